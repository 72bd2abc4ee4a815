#pragma once
// The open sides of the domain (inflow, outflow, far field) and the particles that cross them,
// after the move (Algorithm 1, step 11), in one of two ways (boundaries/particle_supply):
//
// - `open` (the default): a particle that has left the domain through an open side is removed;
//   free-stream particles enter through inflow and far-field sides. The particle count varies.
// - `recycle` (the paper's): a particle that has left is put back at a random point of the inflow
//   strip the free stream swept clean during the step, with the free-stream state. The count is
//   fixed, so the mass a body's shock layer stores is taken from the free stream ahead of it.
//
// Entering particles. Outside each entering side lies a lattice of free-stream particles, the
// continuation of the case's particles per cell: `columns` = cells along the side x particles per
// cell along it, each column `row_spacing` = cell depth / particles per cell across it between
// rows, each particle the case's free-stream particle mass. The lattice moves towards the side at
// the inward normal speed: the free stream's on an inflow side; on a far-field side, in each cell
// along it, that of the gas at the side (the grid velocity V-bar of the step on its two side
// nodes) where it points inwards, and nothing where it points outwards. entry_distance(cell)
// accumulates how far the lattice has moved. Row r of column i lies (r + phase_i) row spacings
// outside, phase_i = (i + 1/2) / columns, and enters once entry_distance passes it: placed that
// far inside (regular placement), or jittered uniformly within its own row spacing and column
// width, reflected at the side (random placement), with the free-stream density, pressure and
// internal energy, and the free-stream velocity (on a far-field side: the free stream's
// tangential velocity and the gas's inward normal speed). The phases are those of Hermite's
// identity, sum_i floor(x + i / N) = floor(N x): on a side with one inward speed, the particles
// entered up to any step number round(columns x entry_distance / row_spacing), so the mass entered
// in every step is rho_inf (v_inf . n) x side length x dt to within one particle's mass.
//
// Ids and random numbers. A particle entering row r of column i of side s gets the id
//   cells_x cells_y ppc + (r num_sides + s) max_columns + i,
// above every initial id and never reused; its random numbers are a function of the seed and that
// id. Both are independent of the step size, the threads, the ranks and the particle order; each
// rank creates the entering particles whose cells it owns, in (side, row, column) order.
#include <string>
#include <vector>

#include "case_config.hpp"
#include "diagnostics.hpp"
#include "particles.hpp"
#include "slab_state.hpp"

namespace mpmflow {

// A side through which particles enter, as the kernels see it.
struct EntrySide {
  int side = 0;
  bool far_field = false;
  index_t cells = 0;            // cells along the side
  index_t first_cell = 0;       // offset of its cells in the entry-distance arrays
  index_t columns = 0;          // cells x particles per cell along the side
  int per_cell_along = 1;       // particles per cell along the side
  double row_spacing = 0;       // cell depth / particles per cell across the side
  double column_width = 0;      // cell width along the side / particles per cell along it
  double free_stream_inward = 0;  // v_inf . (inward normal)
};

class OpenBoundaries {
 public:
  OpenBoundaries() = default;
  explicit OpenBoundaries(const CaseConfig& config);

  // After the move: the particles outside the domain are removed (or recycled), and those that
  // the lattice outside the entering sides brought in during the step of size dt are created on
  // this rank where it owns their cells. `step` numbers the step (recycling's random numbers).
  // Collective when a side is a far field (the inward speeds along it are summed over the ranks).
  void exchange(ParticleState& particles, const SlabState& slab, real_t dt, long step);

  // This rank's fluxes since the start of the run (or of the restart; see restore).
  const BoundaryFluxes& fluxes() const { return fluxes_; }
  // How far the lattice outside each entering side has moved, per cell along it (the sides in
  // the order left, right, bottom, top): the same on every rank.
  const std::vector<double>& entry_distance() const { return entry_distance_; }
  // A restart: the entry distances and this rank's share of the fluxes.
  void restore(const std::vector<double>& entry_distance, const BoundaryFluxes& fluxes);

 private:
  CaseConfig config_;
  std::vector<EntrySide> sides_;
  std::vector<double> entry_distance_;
  BoundaryFluxes fluxes_;
};

// The conservation totals of `count` particles: those listed in `list`, or, with an empty
// list, those from index `first` on.
ConservationTotals totals_of_particles(const ParticleState& particles, const IndexView& list, index_t first,
                                       index_t count);

}  // namespace mpmflow
