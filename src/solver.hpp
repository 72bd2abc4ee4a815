#pragma once
// One explicit MPM step (the paper's Algorithm 1) over a grid slab and its particles.
#include <memory>
#include <stdexcept>
#include <vector>

#include "boundary_conditions.hpp"
#include "case_config.hpp"
#include "geometry.hpp"
#include "grid.hpp"
#include "halo_exchange.hpp"
#include "parallel.hpp"
#include "particle_migration.hpp"
#include "particles.hpp"
#include "phase_timers.hpp"

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
  // particles (any particle outside the slab is sent to its owner at the first step).
  Solver(const CaseConfig& config, const ParallelContext& context, const SlabDecomposition& decomposition,
         ParticleState particles);
  ~Solver();
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  // dt = cfl h / max_p(|v_p| + c_p), h the smaller cell side (paper eq. 29 with cfl = 0.5).
  // The same pass checks the state: throws InvalidStateError, naming the first bad particle, if
  // any particle has a NaN or non-positive density or a NaN pressure or velocity.
  real_t stable_time_step();
  // The check alone (before an output, so that a bad state is never written as a good one).
  void check_state() { (void)stable_time_step(); }

  // Advances particles and grid by dt: steps 2-12 of Algorithm 1.
  void advance(real_t dt);

  // Total particles over all ranks.
  long long global_particle_count() const { return context_.sum(particles_.count); }
  const ParallelContext& context() const { return context_; }
  const SlabDecomposition& decomposition() const { return decomposition_; }
  // Rebalances the slabs now if that evens out the particle counts; returns whether it did.
  // Collective. advance() calls it every decomposition/balance_interval steps.
  bool balance_load();
  // The rebalancings so far.
  const std::vector<BalanceReport>& balance_reports() const { return balance_reports_; }
  // Sets the step counter (restart from a checkpoint).
  void set_step_count(long steps) { step_count_ = steps; }

  // One stable step from time t, shortened so as not to pass `target`; returns the new time
  // (exactly `target` when it is reached, so outputs land on their times).
  double step_towards(double t, double target);

  // Maps mass and momentum of the particles, where they are now, onto the grid (the first P2G of
  // a step), so that grid output describes the same state as the particles. Steps begin with a
  // grid reset, so this never affects the solution.
  void project_to_grid();

  long step_count() const { return step_count_; }
  const ParticleState& particles() const { return particles_; }
  ParticleState& particles() { return particles_; }
  const GridFields& grid_fields() const { return grid_fields_; }
  const GridSlab& slab() const { return slab_; }
  const ObstacleGrid& obstacle_grid() const { return obstacle_grid_; }
  PhaseTimers& timers() { return timers_; }
  // The P2G ScatterView mode in use, after resolving "automatic" for this execution space.
  P2GStrategy p2g_strategy() const;

  // Bytes of device memory the solver holds, by owner: particle fields, grid fields and the P2G
  // ScatterViews' duplicated copies (zero for atomic ScatterViews, which write in place).
  struct MemoryUse {
    size_t particle_bytes = 0;
    size_t grid_bytes = 0;
    size_t scatter_copy_bytes = 0;
    size_t total() const { return particle_bytes + grid_bytes + scatter_copy_bytes; }
  };
  MemoryUse memory_use() const;

  // Nodal velocity is momentum / mass where the node carries more than this mass; below it a node
  // is treated as empty (no velocity, no acceleration), so nearly empty nodes at the edge of the
  // particle cloud cannot produce huge accelerations.
  real_t node_mass_threshold() const { return node_mass_threshold_; }
  // Restores the threshold of the run a checkpoint came from (it is fixed from the particles at
  // t = 0, and recycling changes particle masses, so recomputing it would change the run).
  void set_node_mass_threshold(real_t threshold) { node_mass_threshold_ = threshold; }

  // The step itself, specialised on the P2G ScatterView duplication mode and the shape function.
  // Public so that device lambdas may be defined in its member functions (a CUDA requirement).
  class Stepper;
  template <class Accumulation, class Shape>
  class ScatterStepper;

  // Throws InvalidStateError on every rank, with the first bad particle of the lowest rank that
  // has one (collective; `local_invalid`: this rank has one). Public for CUDA's device lambdas.
  [[noreturn]] void report_invalid_particle(bool local_invalid) const;
  // Throws InvalidStateError describing this rank's first bad particle (which must exist).
  [[noreturn]] void describe_invalid_particle() const;

 private:
  template <class Accumulation>
  std::unique_ptr<Stepper> make_stepper() const;
  // (Re)builds everything that depends on the slab: grid fields, obstacles on the grid, boundary
  // conditions, halo buffers and the P2G stepper.
  void build_slab_state();

  CaseConfig config_;
  ParallelContext context_;
  SlabDecomposition decomposition_;
  GridSlab slab_;
  ParticleState particles_;
  GridFields grid_fields_;
  PhaseTimers timers_;
  ObstacleGrid obstacle_grid_;
  GridBoundaryConditions grid_boundaries_;
  ParticleBoundaries particle_boundaries_;
  std::unique_ptr<HaloExchange> halo_;
  ParticleMigration migration_;
  std::vector<BalanceReport> balance_reports_;
  real_t node_mass_threshold_ = 0;
  long step_count_ = 0;
  std::unique_ptr<Stepper> stepper_;
};

}  // namespace mpmflow
