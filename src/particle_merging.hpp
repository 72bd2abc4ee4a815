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
// Determinism. The candidates of a cell are paired in the order of their ids (first with second,
// third with fourth, ...), and the merged particle keeps the smaller id: the same pairs on any
// number of ranks or threads and in any particle order (a cell's particles are on one rank).
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
  // (cell, id, index) with a host copy, the pairs' lists (keep, gone, removed) likewise, and the
  // hole fillers (plan_hole_filling).
  mutable IndexView candidates_;
  mutable KeptBuffer<ParticleIdView> candidate_keys_;
  mutable KeptBuffer<IndexView> pair_lists_;
  mutable IndexView fillers_;
};

}  // namespace mpmflow
