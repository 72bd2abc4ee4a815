#pragma once
// One explicit MPM step, the paper's Algorithm 1 (steps 2-12; the driver, Solver, takes the
// time step size of step 13 and rebalances the slabs between steps).
#include "open_boundaries.hpp"
#include "particle_migration.hpp"
#include "particle_merging.hpp"
#include "particle_splitting.hpp"
#include "particles.hpp"
#include "phase_timers.hpp"
#include "slab_state.hpp"
#include "transfers.hpp"

namespace mpmflow {

// What a step reads and writes; the Solver owns all of it.
struct StepState {
  SlabState& slab;
  ParticleState& particles;
  TransferKernels& transfers;
  ParticleMigration& migration;
  OpenBoundaries& open_sides;
  ParticleSplitting& splitting;
  const ParticleMerging& merging;
  PhaseTimers& timers;
  ObstacleForces& obstacle_forces;  // of the step, on this slab's nodes
  CellOrder& reorder_order;         // step 12's, kept from reordering to reordering
};

// What a step needs to know besides the state: fixed for a run. The Solver sets every field from
// the case; the defaults of those that mirror a case key are that key's (NumericsConfig), so that
// a StepSettings made anywhere else cannot disagree with the case file's reference.
struct StepSettings {
  // G2P of velocity and acceleration fused with the momentum remap P2G (numerics/fused_kernels).
  bool fused_kernels = NumericsConfig{}.fused_kernels;
  // Step 12 on every step divisible by it; 0: never (numerics/reorder_interval).
  int reorder_interval = NumericsConfig{}.reorder_interval;
  // Nodes with no more mass than this count as empty (no velocity, no acceleration), so that
  // nearly empty nodes at the edge of the particle cloud cannot produce huge accelerations.
  real_t node_mass_threshold = 0;
  ThermodynamicConstants thermodynamics;
};

// A step in two parts. Steps 2-3 (grid reset; P2G of mass, momentum and pressure x volume, P2GD
// of the force; the sums over the slabs sharing a node) do not depend on dt, and the time step
// is taken from what they put on the nodes (max_node_signal_speed); then the rest advances the
// particles and the grid by dt. `step` numbers the step being taken (1 for the first): it keys
// recycling's random numbers and the reordering interval.
void project_particles_to_grid(const StepState& state);
void finish_step(const StepState& state, const StepSettings& settings, real_t dt, long step);

}  // namespace mpmflow
