#pragma once
// Moves particles to the rank whose slab holds them: after every particle move (Algorithm 1,
// step 11, including recycling, which may put a particle anywhere on the inflow side) and after
// the slabs change (load balancing, restart on another rank count).
//
// Pack, exchange counts, exchange data, unpack, all on Kokkos Views; MPI sees host copies unless
// the context asks for GPU-aware MPI. Deterministic: the particles leaving go in index order per
// destination, the holes they leave are filled by the last staying particles in index order, and
// arrivals are appended in (source rank, source order). A run therefore repeats bitwise.
#include "grid.hpp"
#include "parallel.hpp"
#include "particles.hpp"

namespace mpmflow {

// Whether a coordinate along the slabs' axis lies outside the global cells [begin, end) along it, as
// `slab`'s cell arithmetic (GridSlab::global_cell_at, clamped to the domain) tells: migration's
// test of a particle. A coordinate inside the cells' faces by more than that arithmetic's
// round-off can reach (face_margin) is told by two comparisons, as almost every particle is; the
// rest by the arithmetic itself, so that the answer is the arithmetic's for every coordinate.
struct OutsideTheCells {
  GridSlab slab;
  int axis = 0;
  index_t begin = 0, end = 0;
  real_t surely_inside_from = 0, surely_inside_to = 0;  // coordinates along the axis

  OutsideTheCells(const GridSlab& slab, int axis, index_t begin, index_t end);
  KOKKOS_INLINE_FUNCTION bool operator()(real_t coordinate) const {
    if (coordinate > surely_inside_from && coordinate < surely_inside_to) return false;
    const index_t cell = slab.global_cell_at(axis, coordinate);
    return cell < begin || cell >= end;
  }
  // How far inside the face at coordinate `face` (`cells` cells from the slab's first node) a
  // coordinate is surely in the cell beside it as cell_along computes it, (x - origin) / spacing
  // rounded down: 8 times what rounding the face's coordinate and that quotient can take (a few
  // units of the last place of each), and a millionth of a cell more.
  static real_t face_margin(real_t face, real_t spacing, index_t cells);
};

class ParticleMigration {
 public:
  // Sends every particle of `particles` whose cell belongs to another rank under `decomposition`
  // to that rank and appends those received. `slab` is the slab the particles were last in (its
  // geometry turns positions into global cells). Returns the number of particles this rank sent.
  // The arrivals' cells are those of `slab`: right where the decomposition is the one `slab` was
  // cut by (every step); where it changes (rebalancing), the caller recomputes every cell on the
  // new slab.
  long migrate(ParticleState& particles, const GridSlab& slab, const SlabDecomposition& decomposition,
               const ParallelContext& context);
  // Whether the last migrate() exchanged with the neighbouring slabs alone (every rank sent only
  // to rank - 1 and rank + 1), not with every rank.
  bool last_exchange_neighbours_only() const { return last_exchange_neighbours_only_; }

 private:
  bool last_exchange_neighbours_only_ = false;
  SlabDecomposition owners_of_;               // the slabs owners_ was made for
  SlabDecomposition::DeviceOwners owners_;    // their first cells on the device
  // Kept from call to call (KeptBuffer; the selections' lists grow only, select_indices).
  IndexView leaving_, fillers_;
  KeptBuffer<IndexView> leaving_destination_, send_order_;
  KeptBuffer<Kokkos::View<index_t*, Kokkos::HostSpace>> leaving_on_host_;  // (host memory alone)
  KeptBuffer<RealView> send_reals_, receive_reals_;
  KeptBuffer<ParticleIdView> send_ids_, receive_ids_;
};

}  // namespace mpmflow
