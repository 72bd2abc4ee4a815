#include "particle_migration.hpp"

#include "kernels/particle_compaction.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace mpmflow {

OutsideTheCells::OutsideTheCells(const GridSlab& slab_, int axis_, index_t begin_, index_t end_)
    : slab(slab_), axis(axis_), begin(begin_), end(end_) {
  const GridGeometry& g = slab.geometry;
  const real_t spacing = axis == 0 ? g.spacing_x : g.spacing_y;
  // The faces: the slab's local nodes of the first and the end cell, as GridGeometry places nodes.
  const index_t from_cells = begin - slab.node_offset(axis), to_cells = end - slab.node_offset(axis);
  const real_t from = axis == 0 ? g.node_x(from_cells) : g.node_y(from_cells);
  const real_t to = axis == 0 ? g.node_x(to_cells) : g.node_y(to_cells);
  surely_inside_from = from + face_margin(from, spacing, from_cells);
  surely_inside_to = to - face_margin(to, spacing, to_cells);
}

real_t OutsideTheCells::face_margin(real_t face, real_t spacing, index_t cells) {
  const real_t unit = std::numeric_limits<real_t>::epsilon();
  return real_t(1e-6) * spacing + 8 * unit * (std::abs(face) + spacing * real_t(std::abs(cells) + 1));
}

namespace {

#ifdef MPMFLOW_HAVE_MPI
// The rank a particle belongs to is the owner (SlabDecomposition::owner_of_cell, the same function
// on the device) of its global cell along the decomposition axis, which the slab it was last in
// computes from its position. Whether particle p has left this rank's slab takes its coordinate
// along the axis alone (`along`, OutsideTheCells) and no search of the slabs, which is left to the
// few that leave (slab_owning_cell). (Every particle's rank, written and then read again to select
// those leaving, made migration 1.9 ms a step on each of 2 ranks of one thread, the cylinder at 448
// x 224 cells: docs/performance_history.md, "Migration's test".)
struct LeavesTheSlab {
  RealView along;
  OutsideTheCells outside;
  KOKKOS_INLINE_FUNCTION index_t global_cell(index_t p) const {
    return outside.slab.global_cell_at(outside.axis, along(p));
  }
  KOKKOS_INLINE_FUNCTION bool operator()(index_t p) const { return outside(along(p)); }
};

// The exchange of a migration: rank r gets send[send_offsets[r] ..) (send_counts[r] items of
// `type`) and puts what r sends it at receive + receive_offsets[r]. With `neighbours_only` (no
// count but those of the neighbouring slabs, rank - 1 and rank + 1, is nonzero), point to point
// with those two; otherwise MPI_Alltoallv. The same layout either way.
template <class T>
void exchange(const T* send, const std::vector<int>& send_counts, const std::vector<int>& send_offsets, T* receive,
              const std::vector<int>& receive_counts, const std::vector<int>& receive_offsets, MPI_Datatype type,
              bool neighbours_only, int rank, MPI_Comm comm) {
  const int ranks = static_cast<int>(send_counts.size());
  if (!neighbours_only) {
    MPI_Alltoallv(send, send_counts.data(), send_offsets.data(), type, receive, receive_counts.data(),
                  receive_offsets.data(), type, comm);
    return;
  }
  std::vector<MPI_Request> requests;
  for (const int r : {rank - 1, rank + 1}) {
    if (r < 0 || r >= ranks) continue;
    requests.emplace_back();
    MPI_Irecv(receive + receive_offsets[r], receive_counts[r], type, r, 0, comm, &requests.back());
    requests.emplace_back();
    MPI_Isend(send + send_offsets[r], send_counts[r], type, r, 0, comm, &requests.back());
  }
  MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
}

// What a particle carries to another rank: its real fields, side by side (particle-major, in
// WholeParticles' order: pack and unpack agree on the layout by construction), and its id apart;
// its cell is recomputed on arrival. One launch each way for all the fields (a GPU pays a launch's
// latency however few particles leave, and a slab's leave every step).

// reals(s * R + f) = real field f of particle order(s), ids(s) = its id, for s in [0, count).
void pack_particles(const WholeParticles& whole, const IndexView& order, index_t count, const RealView& reals,
                    const ParticleIdView& ids) {
  if (whole.num_ids != 1)
    throw std::logic_error("migration: a particle has one id field, found " + std::to_string(whole.num_ids));
  Kokkos::parallel_for(
      "migration_pack", Kokkos::RangePolicy<ExecutionSpace>(0, count), KOKKOS_LAMBDA(const index_t s) {
        const index_t p = order(s);
        const size_t row = static_cast<size_t>(s) * whole.num_reals;
        for (int f = 0; f < whole.num_reals; ++f) reals(row + f) = whole.reals[f](p);
        ids(s) = whole.ids[0](p);
      });
}

// The reverse into particles first + s, s in [0, count).
void unpack_particles(const WholeParticles& whole, index_t first, index_t count, const RealView& reals,
                      const ParticleIdView& ids) {
  Kokkos::parallel_for(
      "migration_unpack", Kokkos::RangePolicy<ExecutionSpace>(0, count), KOKKOS_LAMBDA(const index_t s) {
        const index_t p = first + s;
        const size_t row = static_cast<size_t>(s) * whole.num_reals;
        for (int f = 0; f < whole.num_reals; ++f) whole.reals[f](p) = reals(row + f);
        whole.ids[0](p) = ids(s);
      });
}
#endif

}  // namespace

long ParticleMigration::migrate(ParticleState& pt, const GridSlab& slab, const SlabDecomposition& d,
                                const ParallelContext& context) {
  if (!context.distributed()) return 0;
#ifdef MPMFLOW_HAVE_MPI
  const int rank = context.rank(), ranks = context.size();
  const index_t n = pt.count;
  if (!owners_.cell_begin.data() || owners_of_ != d) {  // (made again only where the slabs changed)
    owners_ = d.device_owners();
    owners_of_ = d;
  }
  const SlabDecomposition::DeviceOwners owners = owners_;
  LeavesTheSlab leaves{d.axis == 0 ? pt.position_x : pt.position_y,
                       OutsideTheCells(slab, d.axis, d.begin(rank), d.end(rank))};
  const IndexView leaving = select_indices("migration_leaving", 0, n, leaves, leaving_);
  const index_t num_leaving = static_cast<index_t>(leaving.extent(0));
  const size_t leaving_count = static_cast<size_t>(num_leaving);

  // Leaving particles grouped by destination, in index order within each group (a counting sort
  // of the few leaving particles on the host: their destinations are gathered first, so that only
  // they cross to the host, not every particle's).
  leaving_destination_.hold(leaving_count, "migration_leaving_destination");
  const IndexView leaving_destination = leaving_destination_.part(leaving_count);
  Kokkos::parallel_for(
      "migration_leaving_destination", Kokkos::RangePolicy<ExecutionSpace>(0, num_leaving),
      KOKKOS_LAMBDA(const index_t k) {
        leaving_destination(k) = owners.owner_of_cell(leaves.global_cell(leaving(k)));
      });
  leaving_on_host_.hold(leaving_count, "migration_leaving_on_host");
  const auto leaving_host = leaving_on_host_.part(leaving_count);
  const auto destination_host = leaving_destination_.host_part(leaving_count);
  Kokkos::deep_copy(leaving_host, leaving);
  Kokkos::deep_copy(destination_host, leaving_destination);
  std::vector<int> send_counts(ranks, 0), send_offsets(ranks + 1, 0);
  for (index_t k = 0; k < num_leaving; ++k) ++send_counts[destination_host(k)];
  for (int r = 0; r < ranks; ++r) send_offsets[r + 1] = send_offsets[r] + send_counts[r];
  send_order_.hold(leaving_count, "migration_send_order");
  const auto send_order_host = send_order_.host_part(leaving_count);
  {
    std::vector<int> next(send_offsets.begin(), send_offsets.end() - 1);
    for (index_t k = 0; k < num_leaving; ++k) send_order_host(next[destination_host(k)]++) = leaving_host(k);
  }
  const IndexView send_order = send_order_.part(leaving_count);
  Kokkos::deep_copy(send_order, send_order_host);

  // Pack: particle-major, the real fields of one particle side by side; ids apart. (WholeParticles
  // as temporaries: one kept to the end of the call would hold the old fields' Views beside their
  // grown copies where the arrivals make the particle Views grow below.)
  const int F = WholeParticles(pt).num_reals;
  send_reals_.hold(leaving_count * F, "migration_send_reals");
  send_ids_.hold(leaving_count, "migration_send_ids");
  const RealView send_reals = send_reals_.part(leaving_count * F);
  const ParticleIdView send_ids = send_ids_.part(leaving_count);
  pack_particles(WholeParticles(pt), send_order, num_leaving, send_reals, send_ids);

  // Counts, then data: with the neighbouring slabs alone where every rank sends only to them (as
  // in a step, where no particle moves more than a cell), with every rank otherwise (recycling
  // along a side cut into slabs, rebalancing). One reduction decides, in place of an all-to-all of
  // the counts.
  bool local_neighbours_only = true;
  for (int r = 0; r < ranks; ++r)
    if (send_counts[r] > 0 && r != rank - 1 && r != rank + 1) local_neighbours_only = false;
  last_exchange_neighbours_only_ = context.min(local_neighbours_only ? 1.0 : 0.0) > 0;
  std::vector<int> receive_counts(ranks, 0), receive_offsets(ranks + 1, 0);
  {
    std::vector<int> one(ranks, 1), at(ranks + 1);
    for (int r = 0; r <= ranks; ++r) at[r] = r;
    exchange(send_counts.data(), one, at, receive_counts.data(), one, at, MPI_INT, last_exchange_neighbours_only_,
             rank, context.comm());
  }
  for (int r = 0; r < ranks; ++r) receive_offsets[r + 1] = receive_offsets[r] + receive_counts[r];
  const index_t num_arriving = receive_offsets[ranks];
  const size_t arriving_count = static_cast<size_t>(num_arriving);
  receive_reals_.hold(arriving_count * F, "migration_receive_reals");
  receive_ids_.hold(arriving_count, "migration_receive_ids");
  const RealView receive_reals = receive_reals_.part(arriving_count * F);
  const ParticleIdView receive_ids = receive_ids_.part(arriving_count);
  {
    const bool direct =
        context.gpu_aware || host_uses_views_directly;
    const auto send_reals_host = send_reals_.host_part(leaving_count * F);
    const auto send_ids_host = send_ids_.host_part(leaving_count);
    const auto receive_reals_host = receive_reals_.host_part(arriving_count * F);
    const auto receive_ids_host = receive_ids_.host_part(arriving_count);
    if (!direct) {
      Kokkos::deep_copy(send_reals_host, send_reals);
      Kokkos::deep_copy(send_ids_host, send_ids);
    } else {
      Kokkos::fence();
    }
    auto scaled = [](const std::vector<int>& v, int factor) {
      std::vector<int> out(v.size());
      for (size_t k = 0; k < v.size(); ++k) out[k] = v[k] * factor;
      return out;
    };
    const MPI_Datatype real_type = sizeof(real_t) == 8 ? MPI_DOUBLE : MPI_FLOAT;
    const bool neighbours = last_exchange_neighbours_only_;
    exchange(direct ? send_reals.data() : send_reals_host.data(), scaled(send_counts, F), scaled(send_offsets, F),
             direct ? receive_reals.data() : receive_reals_host.data(), scaled(receive_counts, F),
             scaled(receive_offsets, F), real_type, neighbours, rank, context.comm());
    exchange(direct ? send_ids.data() : send_ids_host.data(), send_counts, send_offsets,
             direct ? receive_ids.data() : receive_ids_host.data(), receive_counts, receive_offsets, MPI_INT64_T,
             neighbours, rank, context.comm());
    if (!direct) {
      Kokkos::deep_copy(receive_reals, receive_reals_host);
      Kokkos::deep_copy(receive_ids, receive_ids_host);
    }
  }

  // Close the holes: the leaving particles below the new count take the staying particles
  // above it, both in index order.
  const HoleFilling plan = plan_hole_filling(n, leaving, leaves, fillers_);
  copy_particles("particle_fill_holes", pt, plan.holes, 0, plan.fillers, plan.count);
  const index_t staying = plan.staying;
  leaves.along = RealView();  // (let go of before the growth below, as the packing's Views)

  // Append the arrivals.
  const index_t new_count = staying + num_arriving;
  pt.grow_to_hold(new_count);
  pt.count = new_count;
  // (After the growth: WholeParticles holds the grown Views.)
  unpack_particles(WholeParticles(pt), staying, num_arriving, receive_reals, receive_ids);
  update_cell_map(slab.geometry, pt, staying);  // (cells do not travel: they are local)
  return num_leaving;
#else
  (void)pt;
  (void)slab;
  (void)d;
  return 0;
#endif
}

}  // namespace mpmflow
