#pragma once
// Splitting of particles whose volume has doubled (numerics/split_particles).
//
// In a strong expansion the particles move apart; once a particle's domain (its initial share of
// a cell, stretched with the gas) is wider than a cell, GIMP's stencil cannot follow it (the
// domain is clamped to one cell), the nodes between particles lose their mass, the particles stop
// feeling the pressure gradient and coast with a frozen state, and gaps with no gas open (Toro's
// test 2). A particle whose volume has doubled is split in two well before that (splitting only
// once the domain outgrows a cell lets the particles of a near-vacuum drift apart first, each alone
// in its stencil, which then sees no velocity gradient and no longer expands), along the axis its
// domain has stretched more along: each half takes half the mass and half the domain, centred on
// its half of the parent's domain but at most a cell from the parent's centre, with the parent's
// velocity, density, specific energy and pressure. A particle whose domain has stretched alike
// along both axes (to round-off: split_tie_tolerance) splits along both, in four quarters: a
// particle on a diagonal of a flow symmetric about it (a blast in a square box, a 2D Riemann
// problem) is its own mirror image, and halves along x, or y, broke the symmetry, a rule that picks
// x on a tie favouring one side (the quarter plane Sedov blast at 120 x 120 cells: its density
// field had differed from its own transpose by 21 % of the peak by t = 1). Mass, momentum and
// energy are conserved exactly.
//
// Ids. Both halves get new ids, -1 - 2 n and -2 - 2 n, n counting every split of the run, in the
// order of their parents' ids over all ranks: independent of the ranks, the threads and the particle
// order, and never reused (the count is carried in checkpoints). A split in four counts as two
// splits, n and n + 1: its quarters take -1 - 2 n to -4 - 2 n. Negative ids cannot meet the ids of
// initial or entering particles, which are >= 0, so a negative id marks a split particle (only
// split particles merge, particle_merging.hpp).
#include "boundary_conditions.hpp"
#include "case_config.hpp"
#include "parallel.hpp"
#include "particles.hpp"

namespace mpmflow {

// How close a particle's two stretches must be to split it in four: a relative difference that
// round-off reaches (a node's sums add a cell's particles in an order that mirror images do not
// share) and that physics does not care about.
inline constexpr real_t split_tie_tolerance = mirror_tie_tolerance;

// The axes split_axis names besides x (0) and y (1): both, in four quarters.
inline constexpr int split_both_axes = 2;

// Whether a particle of volume `volume` splits, and along which axis: -1 while its volume is at most
// twice `initial_volume` (the volume of a particle as placed: a cell over the particles per cell);
// else 0 (x) or 1 (y), the axis its domain has stretched more along (stretch_x, stretch_y), or
// split_both_axes where the two stretches agree within split_tie_tolerance.
// The volume M / rho, not the domain, decides: the domain follows only the diagonal of the
// deformation, and gas sheared along a body stretches domains along the flow and squeezes them
// across it without changing their volume (splitting on a domain's width split such particles
// again and again).
KOKKOS_INLINE_FUNCTION int split_axis(real_t volume, real_t initial_volume, real_t stretch_x, real_t stretch_y) {
  if (!(volume > 2 * initial_volume)) return -1;
  const real_t difference = stretch_x - stretch_y, larger = stretch_x >= stretch_y ? stretch_x : stretch_y;
  if (difference <= split_tie_tolerance * larger && -difference <= split_tie_tolerance * larger)
    return split_both_axes;
  return stretch_x >= stretch_y ? 0 : 1;
}

// How many particles a split along `axis` (split_axis) makes of one: two, or four on both axes.
KOKKOS_INLINE_FUNCTION int split_pieces(int axis) { return axis == split_both_axes ? 4 : 2; }

class ParticleSplitting {
 public:
  ParticleSplitting() = default;
  ParticleSplitting(const CaseConfig& config, const GridSlab& slab);

  // Splits every particle whose volume has doubled (once per step: one that has grown more splits
  // again in the next steps). New particles are appended. Collective.
  // Returns the number of splits over all ranks (a split in four counting two).
  long long split(ParticleState& particles, const ParticleBoundaries& boundaries, const ParallelContext& context);

  // Splits so far over all ranks, a split in four counting two (the next new ids are -1 - 2 splits()
  // and below);
  // restored on restart.
  long long splits() const { return splits_; }
  void restore(long long splits) { splits_ = splits; }
  bool enabled() const { return enabled_; }

 private:
  bool enabled_ = false;
  real_t initial_half_x_ = 0, initial_half_y_ = 0;  // a particle's domain at stretch 1
  real_t initial_volume_ = 0;                       // a cell over the particles per cell
  real_t cell_x_ = 0, cell_y_ = 0;                  // the farthest a piece lies from its parent
  long long splits_ = 0;
  IndexView parent_;  // this step's splitting particles, in index order
  KeptBuffer<ParticleIdView> new_id_;  // their pieces' ids (the first of each parent's)
  KeptBuffer<IndexView> first_new_;    // where each parent's new pieces start among the appended
};

}  // namespace mpmflow
