#pragma once
// Merging of tiny particles (numerics/merge_particles), the counterpart of splitting.
//
// Split halves that are compressed again (in the Mach 3 cylinder's wake, gas split many times in
// the near-vacuum behind the body is squeezed back by the wake's recompression) end up far smaller
// than the placed particles. A tiny particle hardly weighs in its nodes: its pressure barely pushes
// back on the grid, so its density follows the grid's velocity gradient unchecked and drifts away
// from its neighbours', and its FLIP velocity collects the noise of light nodes. Two tiny particles
// of one cell are merged into one: mass, momentum, total energy (the kinetic energy of their
// velocity difference becomes heat) and volume are conserved exactly; the merged particle sits at
// their centre of mass, which lies in the same cell.
//
// Pairs. The candidates of a cell are paired by the least change to where their mass lies: the
// pair whose merge changes the moment of inertia of the gas least (merge_cost) first, then the
// least of the rest, and so on (with an odd count one is left). The merged particle keeps the
// smaller id. A rule of positions and masses keeps a flow's mirror symmetry: mirror-image cells
// pair mirror-image particles (pairing in the order of their ids, as before 2026-12-06, paired
// them otherwise, ids not being mirror images of each other: a 2D Riemann problem symmetric about
// a diagonal drifted from it).
// Determinism: equal costs are taken in the order of the pairs' ids, so the same pairs on any
// number of ranks or threads and in any particle order (a cell's particles are on one rank).
#include <vector>

#include "boundary_conditions.hpp"
#include "case_config.hpp"
#include "particles.hpp"

namespace mpmflow {

// Whether a particle may merge: a split particle (negative id, particle_splitting.hpp) whose volume
// is under a quarter of a placed particle's (`initial_volume`, a cell over the particles per cell).
// Particles never split are left alone however compressed (the stagnation gas of a Mach 3 body is
// 4.3 times denser than the free stream: merging it too left the nose pressure 6.6 % low instead of
// 2.4 %). A merged pair has at most half a placed particle's volume, far from the doubling that
// splits a particle again.
// (Its volume M / rho is computed only for split particles: most particles need no division.)
KOKKOS_INLINE_FUNCTION bool may_merge(long long id, real_t mass, real_t density, real_t initial_volume) {
  return id < 0 && mass / density < initial_volume / 4;
}

// A candidate for merging as the pairing sees it.
struct MergeCandidate {
  long long cell = 0, id = 0;
  index_t index = 0;  // in the particle arrays
  real_t x = 0, y = 0, mass = 0;
};

// What merging a and b costs: the moment of inertia that merging takes from the gas, m_a m_b /
// (m_a + m_b) |x_a - x_b|^2 (about the pair's centre of mass, where the merged particle goes):
// the nearer and lighter the pair, the less the mass moves.
inline real_t merge_cost(const MergeCandidate& a, const MergeCandidate& b) {
  const real_t dx = a.x - b.x, dy = a.y - b.y;
  return a.mass * b.mass / (a.mass + b.mass) * (dx * dx + dy * dy);
}

// How close two merge costs must be to count as equal: what round-off reaches in mirror images.
inline constexpr real_t merge_tie_tolerance = mirror_tie_tolerance;

// The pairs of `candidates` (any order): per cell the cheapest pair (merge_cost) first, and so on;
// the particle with the smaller id of each pair in `keep`, the other in `gone`.
void pair_candidates(std::vector<MergeCandidate> candidates, std::vector<index_t>& keep, std::vector<index_t>& gone);

class ParticleMerging {
 public:
  ParticleMerging() = default;
  ParticleMerging(const CaseConfig& config, const GridGeometry& geometry);

  // Merges the tiny particles of each cell in pairs; `particles.cell` must be current. Local
  // (no communication). A merged particle lies at the pair's centre of mass, or where that is in
  // one of the obstacles of `boundaries` (the chord between two particles either side of a convex
  // body's surface may cross it), at the kept particle's place. Returns the number of merges on
  // this rank.
  index_t merge(ParticleState& particles, const ParticleBoundaries& boundaries = ParticleBoundaries()) const;
  bool enabled() const { return enabled_; }

 private:
  bool enabled_ = false;
  real_t initial_volume_ = 0;
  // Kept from call to call, scratch, not state: the candidates' list (select_indices), their keys
  // (cell, id, index) and places (x, y, mass) with host copies, the pairs' lists (keep, gone,
  // removed) likewise, and the hole fillers (plan_hole_filling).
  mutable IndexView candidates_;
  mutable KeptBuffer<ParticleIdView> candidate_keys_;
  mutable KeptBuffer<RealView> candidate_places_;
  mutable KeptBuffer<IndexView> pair_lists_;
  mutable IndexView fillers_;
};

}  // namespace mpmflow
