#pragma once
// The driver of the MPM steps over one slab and its particles: the time step size (Algorithm 1,
// step 13), the step itself (mpm_step.hpp), rebalancing the slabs between steps, reporting an
// invalid particle state, and what a restart needs to continue bitwise.
#include <memory>
#include <stdexcept>
#include <vector>

#include "case_config.hpp"
#include "mpm_step.hpp"

namespace mpmflow {

// A particle with a NaN or non-positive density, or a NaN pressure or velocity: the run cannot go on.
struct InvalidStateError : std::runtime_error {
  InvalidStateError(const std::string& message, long step, particle_id_t id, real_t x, real_t y)
      : std::runtime_error(message), step(step), particle_id(id), position_x(x), position_y(y) {}
  long step;
  particle_id_t particle_id;
  real_t position_x, position_y;
};

// One rebalancing of the slabs (Solver::advance, every decomposition/balance_interval steps).
struct BalanceReport {
  long step = 0;
  double imbalance_before = 1;  // max / mean particles per rank
  double imbalance_after = 1;
  SlabDecomposition decomposition;  // the new slabs
};

class Solver {
 public:
  // A single process owning `slab` (the whole grid, or a part of it in tests).
  Solver(const CaseConfig& config, const GridSlab& slab, ParticleState particles);
  // Rank `context.rank()` of a distributed run: the slab `decomposition` gives it, with its
  // particles (any particle outside the slab is sent to its owner at once).
  Solver(const CaseConfig& config, const ParallelContext& context, const SlabDecomposition& decomposition,
         ParticleState particles);
  ~Solver();
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  // dt = cfl h / max_i(|v_i| + c_i) over the nodes (paper eq. 29 with cfl = 0.5, h the smaller
  // cell side) and, where a side is open, the free stream beyond it, from the step's first P2G,
  // which this runs and the next advance() then uses (max_node_signal_speed: the paper takes
  // max_p(|v_p| + c_p) over the particles, which a few light particles with outlying states can
  // set). A pass over the particles checks the state: throws InvalidStateError, naming the first
  // bad particle, if any particle has a NaN or non-positive density or a NaN pressure or velocity.
  real_t stable_time_step();
  // The check alone (before an output, so that a bad state is never written as a good one).
  void check_state() { (void)stable_time_step(); }

  // Advances particles and grid by dt (Algorithm 1, steps 2-12), then rebalances the slabs when
  // decomposition/balance_interval says so.
  void advance(real_t dt);

  // One stable step from time t, shortened so as not to pass `target`; returns the new time
  // (exactly `target` when it is reached, so outputs land on their times). `stop_request` is this
  // rank's reason to stop the run before the step (0: none; the run loop's signals and wall-time
  // limit): the ranks' largest is taken in the reduction that gives the step its signal speed, not
  // in a collective of its own (one a step fewer), and where it is above 0 no step is taken, t is
  // returned and stop_request() gives it, the same on every rank. Collective.
  double step_towards(double t, double target, int stop_request = 0);
  // The ranks' largest stop request, as the last step_towards took it.
  int stop_request() const { return stop_request_; }

  // Rebalances the slabs now if that evens out the particle counts; returns whether it did.
  // Collective.
  bool balance_load();
  // The rebalancings so far.
  const std::vector<BalanceReport>& balance_reports() const { return balance_reports_; }

  // The particles' state, where they are now, on this slab's nodes (GridFields::ProjectionColumn:
  // mass, momentum, and mass times density, pressure and specific energy), summed over the
  // slabs: what grid output shows.
  // Collective. Computed apart: the step's grid fields are left as they are.
  NodeFieldsView grid_projection() const;
  // The mean force on each obstacle (case order) since the last call (or the start, or the
  // restart), summed over the ranks: {x, y} per obstacle, in the order x0, y0, x1, y1, ...; zeros
  // when no step has been taken since. Resets the sums.
  std::vector<double> take_mean_obstacle_forces();
  // The sums behind it: {time, impulse x0, impulse y0, ...}, the same on every rank (checkpoints).
  const std::vector<double>& obstacle_impulse() const { return obstacle_impulse_; }
  void restore_obstacle_impulse(const std::vector<double>& impulse) { obstacle_impulse_ = impulse; }
  // The stable step the last step_towards computed (before any shortening to reach its target).
  double last_stable_time_step() const { return last_stable_time_step_; }
  // "particle <id> at (x, y): |v| + c = S (density, pressure)" of the particle with the largest
  // signal speed of all ranks, on every rank. Collective.
  std::string describe_fastest_particle() const;
  // The case the solver runs (after --set and defaults).
  const CaseConfig& config() const { return config_; }

  // Total particles over all ranks.
  long long global_particle_count() const { return context().sum(particles_.count); }
  const ParallelContext& context() const { return slab_->context(); }
  const SlabDecomposition& decomposition() const { return slab_->decomposition(); }
  const GridSlab& slab() const { return slab_->slab(); }
  const ParticleState& particles() const { return particles_; }
  // (Changing the particles through it discards the grid stable_time_step prepared.)
  ParticleState& particles() {
    grid_holds_particles_ = false;
    return particles_;
  }
  PhaseTimers& timers() { return timers_; }
  const PhaseTimers& timers() const { return timers_; }
  // The P2G accumulation in use, after resolving "automatic" for this execution space.
  P2GStrategy p2g_strategy() const { return transfers_->strategy(); }
  // Whether numerics/fused_kernels makes steps 6-8 one pass (TransferKernels::fuses_g2p_with_remap).
  bool fuses_g2p_with_remap() const { return transfers_->fuses_g2p_with_remap(); }

  // Particle splitting: the splits so far (checkpoints carry them: they number the new ids).
  const ParticleSplitting& splitting() const { return splitting_; }
  ParticleSplitting& splitting() { return splitting_; }

  // The open sides: what entered and left through them, and the state of the free stream outside.
  const OpenBoundaries& open_sides() const { return open_sides_; }
  OpenBoundaries& open_sides() { return open_sides_; }

  // Restart state: the steps taken, and the node-mass threshold (fixed from the particles at
  // t = 0; open sides change the particles, so recomputing it on restart would change the run).
  long step_count() const { return step_count_; }
  // The particles this rank advanced, summed over the steps taken since this Solver was made.
  long long particle_steps() const { return particle_steps_; }
  void set_step_count(long steps) {
    step_count_ = steps;
    grid_holds_particles_ = false;
  }
  real_t node_mass_threshold() const { return settings_.node_mass_threshold; }
  void set_node_mass_threshold(real_t threshold) { settings_.node_mass_threshold = threshold; }

  // Bytes of device memory the solver holds, by owner: particle fields, grid fields, the P2G
  // scratch (duplicated ScatterView copies, or the cell order of the sorted strategy) and the
  // reordering's cell order (step 12, kept between reorderings).
  struct MemoryUse {
    size_t particle_bytes = 0;
    size_t grid_bytes = 0;
    size_t scatter_copy_bytes = 0;
    size_t reorder_bytes = 0;
    size_t total() const { return particle_bytes + grid_bytes + scatter_copy_bytes + reorder_bytes; }
  };
  MemoryUse memory_use() const;

 private:
  Solver(const CaseConfig& config, std::unique_ptr<SlabState> slab_state, ParticleState particles);
  // The slab state and the transfers bound to its grid fields, for `decomposition`.
  void build_slab(const SlabDecomposition& decomposition);
  // The state a step works on, and steps 2-3 of the next step unless the grid holds them already.
  StepState step_state();
  void prepare_grid();
  // stable_time_step, with this rank's stop request taken in its reduction (stop_request_).
  real_t stable_time_step_and_stop_request(int local_request);
  // Throws InvalidStateError on every rank, with the first bad particle of the lowest rank that
  // has one (collective; `local_invalid`: this rank has one).
  [[noreturn]] void report_invalid_particle(bool local_invalid) const;

  CaseConfig config_;
  std::unique_ptr<SlabState> slab_;
  ParticleState particles_;
  std::unique_ptr<TransferKernels> transfers_;
  ParticleMigration migration_;
  OpenBoundaries open_sides_;
  ParticleSplitting splitting_;
  ParticleMerging merging_;
  PhaseTimers timers_;
  StepSettings settings_;
  std::vector<BalanceReport> balance_reports_;
  long step_count_ = 0;
  long long particle_steps_ = 0;
  ObstacleForces step_forces_;
  CellOrder reorder_order_;  // step 12's cell order, its arrays kept between reorderings
  double last_stable_time_step_ = 0;
  int stop_request_ = 0;
  // Whether the grid holds steps 2-3 (project_particles_to_grid) of the particles as they are.
  bool grid_holds_particles_ = false;
  std::vector<double> obstacle_impulse_;  // since the last take_mean_obstacle_forces
};

}  // namespace mpmflow
