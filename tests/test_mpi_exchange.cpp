// HaloExchange and ParticleMigration on their own, run under mpirun at 2 and 4 ranks (ctest
// MpiUnit.*): the sums on shared nodes, and particles reaching the ranks that own their cells
// with every field, none lost or duplicated, in the documented order.
#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "allocation_tracker.hpp"
#include "counter_random.hpp"
#include "grid.hpp"
#include "halo_exchange.hpp"
#include "parallel.hpp"
#include "particle_migration.hpp"
#include "particles.hpp"

namespace mpmflow {
namespace {

CaseConfig config_for(int cells_x, int cells_y, int axis) {
  CaseConfig config;
  config.source = "test.json";
  config.domain = {0.0, 2.0, 0.0, 1.0, cells_x, cells_y};
  config.decomposition.axis = axis;
  return config;
}

// Whether global node (gi, gj) is one of the nodes rank r holds (ghosts included).
bool holds(const DomainConfig& domain, const SlabDecomposition& d, int r, index_t gi, index_t gj) {
  const IndexRange2D nodes =
      make_grid_slab(domain, d.axis, d.begin(r), d.end(r)).index_space(Ownership::ghosted, Entity::node, Indexing::global);
  return nodes.contains(gi, gj);
}

// What rank r contributes to component c of global node (gi, gj): whole numbers, so that every
// sum is exact whatever its order.
double contribution(int r, index_t gi, index_t gj, int c) { return (r + 1) * (1.0 + gi + 100.0 * gj + 10000.0 * c); }

void check_halo_sums(int axis) {
  const ParallelContext context;
  const int ranks = context.size(), rank = context.rank();
  const CaseConfig config = config_for(4 * ranks + 1, 3 * ranks + 2, axis);  // slabs 3 to 5 cells wide
  const SlabDecomposition d = SlabDecomposition::even(config, ranks);
  const GridSlab slab = make_grid_slab(config.domain, axis, d.begin(rank), d.end(rank));
  const GridGeometry& geo = slab.geometry;
  const int components = 3;
  NodeFieldsView fields("fields", geo.num_nodes(), components);
  auto host = Kokkos::create_mirror_view(fields);
  for (index_t j = 0; j < geo.nodes_y; ++j)
    for (index_t i = 0; i < geo.nodes_x; ++i)
      for (int c = 0; c < components; ++c)
        host(geo.node_index(i, j), c) = contribution(rank, i + slab.node_offset_x, j + slab.node_offset_y, c);
  Kokkos::deep_copy(fields, host);

  const HaloExchange halo(slab, context, components);
  EXPECT_EQ(halo.active(), ranks > 1);
  halo.sum_shared_nodes(fields, 1, 2);  // components 1 and 2; component 0 must stay as it was
  Kokkos::deep_copy(host, fields);

  long wrong = 0, shared = 0;
  for (index_t j = 0; j < geo.nodes_y; ++j)
    for (index_t i = 0; i < geo.nodes_x; ++i) {
      const index_t gi = i + slab.node_offset_x, gj = j + slab.node_offset_y;
      int holders = 0;
      for (int r = 0; r < ranks; ++r) holders += holds(config.domain, d, r, gi, gj) ? 1 : 0;
      shared += holders > 1 ? 1 : 0;
      for (int c = 0; c < components; ++c) {
        double expected = contribution(rank, gi, gj, c);
        if (c > 0) {
          expected = 0;
          for (int r = 0; r < ranks; ++r)
            if (holds(config.domain, d, r, gi, gj)) expected += contribution(r, gi, gj, c);
        }
        if (host(geo.node_index(i, j), c) != expected) ++wrong;
      }
    }
  EXPECT_EQ(wrong, 0) << "rank " << rank << ", slabs along " << (axis == 0 ? "x" : "y");
  // Interior slabs share 3 node lines with each neighbour, edge slabs with one.
  const index_t line = axis == 0 ? geo.nodes_y : geo.nodes_x;
  const int neighbours = (rank > 0 ? 1 : 0) + (rank + 1 < ranks ? 1 : 0);
  EXPECT_EQ(shared, neighbours * GridSlab::shared_lines * line) << "rank " << rank;
}

TEST(HaloExchange, SharedNodesHoldTheSumOfEveryRankHoldingThemAlongX) { check_halo_sums(0); }
TEST(HaloExchange, SharedNodesHoldTheSumOfEveryRankHoldingThemAlongY) { check_halo_sums(1); }

// The value of every real field of the particle with id `id`, field k (distinct per field).
real_t field_value(particle_id_t id, int k) { return real_t(id) + real_t(0.125) * k; }

// f(k, field) for the real particle fields other than the positions, k numbering them.
template <class F>
void for_each_tagged_field(const ParticleState& pt, F&& f) {
  int k = 0;
  pt.for_each_field([&](const auto& field) {
    using View = std::decay_t<decltype(field)>;
    if constexpr (std::is_same<typename View::value_type, real_t>::value) {
      ++k;
      if (field.data() != pt.position_x.data() && field.data() != pt.position_y.data()) f(k, field);
    }
  });
}

// Where the particle `id` was made along x: anywhere in the domain, or, with `near` (slabs along
// x), within half a cell of the slab of the rank that made it (id / 1000), as after a step.
real_t made_x(const CaseConfig& config, particle_id_t id, const SlabDecomposition* near) {
  const DomainConfig& domain = config.domain;
  double low = domain.x_min, high = domain.x_max;
  if (near) {
    const double h = (domain.x_max - domain.x_min) / domain.cells_x;
    const int r = static_cast<int>(id / 1000);
    low = std::max<double>(domain.x_min, domain.x_min + h * (near->begin(r) - 0.5));
    high = std::min<double>(domain.x_max, domain.x_min + h * (near->end(r) + 0.5));
  }
  return real_t(low + (high - low) * counter_uniform(7, id, 0, 0));
}

// Particles of this rank anywhere in the domain (most belong to other ranks), or near its slab
// (made_x), their fields functions of their ids; ids are rank * 1000 + index.
ParticleState scattered_particles(const CaseConfig& config, int rank, index_t n, const SlabDecomposition* near) {
  ParticleState pt(n);
  auto x = Kokkos::create_mirror_view(pt.position_x);
  auto y = Kokkos::create_mirror_view(pt.position_y);
  auto id = Kokkos::create_mirror_view(pt.id);
  for (index_t k = 0; k < n; ++k) {
    id(k) = rank * 1000 + k;
    x(k) = made_x(config, id(k), near);
    y(k) = config.domain.y_min + (config.domain.y_max - config.domain.y_min) * counter_uniform(7, id(k), 0, 1);
  }
  Kokkos::deep_copy(pt.position_x, x);
  Kokkos::deep_copy(pt.position_y, y);
  Kokkos::deep_copy(pt.id, id);
  for_each_tagged_field(pt, [&](int k, const RealView& field) {
    auto h = Kokkos::create_mirror_view(field);
    for (index_t p = 0; p < n; ++p) h(p) = field_value(id(p), k);
    Kokkos::deep_copy(field, h);
  });
  return pt;
}

// Migrates particles made on the slabs of `from` (anywhere, or with `near` within half a cell of
// their rank's slab) to the slabs of `to`, and checks the result.
void check_migration(const CaseConfig& config, const SlabDecomposition& from, const SlabDecomposition& to,
                     bool near = false) {
  const ParallelContext context;
  const int rank = context.rank(), ranks = context.size();
  const index_t made = 40 + 7 * rank;
  ParticleState pt = scattered_particles(config, rank, made, near ? &from : nullptr);
  const GridSlab slab = make_grid_slab(config.domain, from.axis, from.begin(rank), from.end(rank));
  update_cell_map(slab.geometry, pt);  // as a step leaves them
  ParticleMigration migration;
  const long sent = migration.migrate(pt, slab, to, context);
  if (ranks > 1) EXPECT_GT(context.sum(sent), 0) << "nothing to check: no particle moved";
  // Near their slabs, the particles go to the neighbouring ones, point to point; scattered over
  // more than 2 slabs, some go further, and every rank exchanges with every other.
  if (ranks > 1)
    EXPECT_EQ(migration.last_exchange_neighbours_only(), near || ranks == 2) << "rank " << rank;

  // Every particle is on the rank owning its cell under `to`, with the fields it left with.
  const GridSlab new_slab = make_grid_slab(config.domain, to.axis, to.begin(rank), to.end(rank));
  auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.position_x);
  auto y = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.position_y);
  auto id = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.id);
  // Within one decomposition (every step) each particle is in the cell of its position, the arrivals
  // too. (After a rebalance the caller recomputes every cell on the new slab.)
  if (from == to) {
    auto cell = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.cell);
    long stale = 0;
    for (index_t p = 0; p < pt.count; ++p) stale += cell(p) != new_slab.geometry.cell_of(x(p), y(p)) ? 1 : 0;
    EXPECT_EQ(stale, 0) << "particles not in the cell of their position";
  }
  long misplaced = 0, wrong_fields = 0;
  for (index_t p = 0; p < pt.count; ++p) {
    if (to.owner_of_cell(new_slab.global_cell_along(to.axis, x(p), y(p))) != rank) ++misplaced;
    if (x(p) != made_x(config, id(p), near ? &from : nullptr)) ++wrong_fields;
  }
  for_each_tagged_field(pt, [&](int k, const RealView& field) {
    auto h = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), field);
    for (index_t p = 0; p < pt.count; ++p) wrong_fields += h(p) != field_value(id(p), k) ? 1 : 0;
  });
  EXPECT_EQ(misplaced, 0) << "rank " << rank;
  EXPECT_EQ(wrong_fields, 0) << "rank " << rank;

  // Arrivals come after the particles that stayed, in (source rank, source order): ids increase.
  long out_of_order = 0;
  for (index_t p = 1; p < pt.count; ++p)
    if (id(p - 1) / 1000 != rank && id(p) / 1000 != rank && id(p) < id(p - 1)) ++out_of_order;
  EXPECT_EQ(out_of_order, 0) << "rank " << rank;

  // Each particle made anywhere is on exactly one rank.
  const std::vector<long long> counts = context.all_gather(pt.count);
  std::vector<int> receive_counts(ranks), offsets(ranks + 1, 0);
  for (int r = 0; r < ranks; ++r) receive_counts[r] = static_cast<int>(counts[r]), offsets[r + 1] = offsets[r] + receive_counts[r];
  std::vector<long long> local(id.data(), id.data() + pt.count), all(offsets[ranks]);
  MPI_Allgatherv(local.data(), pt.count, MPI_LONG_LONG, all.data(), receive_counts.data(), offsets.data(),
                 MPI_LONG_LONG, context.comm());
  std::vector<long long> expected;
  for (int r = 0; r < ranks; ++r)
    for (index_t k2 = 0; k2 < 40 + 7 * r; ++k2) expected.push_back(r * 1000 + k2);
  std::sort(all.begin(), all.end());
  EXPECT_EQ(all, expected);
}

TEST(ParticleMigration, ParticlesReachTheOwnersOfTheirCellsAlongX) {
  const int ranks = ParallelContext().size();
  const CaseConfig config = config_for(5 * ranks, 4, 0);
  const SlabDecomposition d = SlabDecomposition::even(config, ranks);
  check_migration(config, d, d);
}

TEST(ParticleMigration, ParticlesReachTheOwnersOfTheirCellsAlongY) {
  const int ranks = ParallelContext().size();
  const CaseConfig config = config_for(4, 4 * ranks, 1);
  const SlabDecomposition d = SlabDecomposition::even(config, ranks);
  check_migration(config, d, d);
}

TEST(ParticleMigration, ParticlesNearTheirSlabsGoToTheNeighboursPointToPoint) {
  const int ranks = ParallelContext().size();
  const CaseConfig config = config_for(4 * ranks, 3, 0);
  const SlabDecomposition d = SlabDecomposition::even(config, ranks);
  check_migration(config, d, d, /*near=*/true);
}

TEST(ParticleMigration, ParticlesFollowTheSlabsWhenTheyMove) {
  // As after a rebalance: particles of the even slabs go to uneven ones.
  const int ranks = ParallelContext().size();
  const CaseConfig config = config_for(6 * ranks, 5, 0);
  const SlabDecomposition even = SlabDecomposition::even(config, ranks);
  std::vector<long long> per_column(config.domain.cells_x, 1);
  for (index_t c = 0; c < config.domain.cells_x / 3; ++c) per_column[c] = 50;  // crowded on the left
  const SlabDecomposition moved = SlabDecomposition::balanced(0, per_column, ranks);
  EXPECT_TRUE(ranks == 1 || moved != even);
  check_migration(config, even, moved);
}

// A slab's particles leave every step: once its buffers have grown, a migration of as many
// particles allocates nothing (on a GPU an allocation costs more than the migration's kernels, and
// a free may wait for the device).
TEST(ParticleMigration, ASecondMigrationOfAsManyParticlesAllocatesNothing) {
  const ParallelContext context;
  const int ranks = context.size(), rank = context.rank();
  const CaseConfig config = config_for(4 * ranks, 3, 0);
  const SlabDecomposition d = SlabDecomposition::even(config, ranks);
  const GridSlab slab = make_grid_slab(config.domain, d.axis, d.begin(rank), d.end(rank));
  const index_t made = 40 + 7 * rank;
  ParticleMigration migration;
  long long allocated = -1;
  long sent = 0;
  for (int round = 0; round < 2; ++round) {
    ParticleState pt = scattered_particles(config, rank, made, &d);  // the same particles each round
    pt.reserve(4 * made);  // room for the arrivals: the particle Views do not grow
    update_cell_map(slab.geometry, pt);
    const AllocationTracker allocations;
    sent = migration.migrate(pt, slab, d, context);
    allocated = allocations.allocation_count();
  }
  if (ranks > 1) EXPECT_GT(context.sum(sent), 0) << "nothing moved: the test covers nothing";
  EXPECT_EQ(allocated, 0) << "rank " << rank << ": allocations in the second migration";
}

}  // namespace
}  // namespace mpmflow
