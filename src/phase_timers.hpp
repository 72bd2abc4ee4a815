#pragma once
// The phases of a run, and wall-clock time per phase. Each phase is also a Kokkos profiling region
// under the same name, so the standard Kokkos tools (space-time stack, kernel timer, nsys/rocprof
// connectors) see the names the run's phase table prints.
#include <array>
#include <vector>

#include <Kokkos_Core.hpp>

#include "phase_timing.hpp"

namespace mpmflow {

// Every phase of a run, in the order of a step (Algorithm 1); `phase_names` below is the one list
// of their names, which the solver, the phase table, the tests and the benchmarks all use.
enum class Phase : int {
  time_step,                  // 13. CFL condition (and the check of the particle states)
  grid_reset,                 // 2.
  p2g_mass_momentum_force,    // 3.
  halo_exchange,              // sums on the nodes shared with neighbouring slabs
  boundary_conditions,        // 4. and 9.
  grid_momentum_update,       // 5.
  g2p_p2g_velocity_momentum,  // 6.-8. fused
  g2p_velocity_acceleration,  // 6.-7. unfused
  p2g_momentum_remap,         // 8. unfused
  grid_remap_velocity,        // the remapped node velocity, for 10.
  g2pd_particle_update,       // 10. and the move of 11.
  particle_move,              // 11.: walls and obstacles after the move; the cell map
  pressure_relaxation,        // each cell's pressures evened out (numerics/pressure_relaxation); then the cell map
  open_sides,                 // particles removed or recycled at open sides, the free stream's entered
  splitting,                  // particles whose volume has doubled split in two
  migration,                  // particles to the ranks owning their cells
  merging,                    // tiny particles of a cell merged in pairs
  reorder,                    // 12.
  load_balance,               // the slabs moved to even out the particles
  output,
  checkpoint,
  count
};

constexpr std::array<const char*, static_cast<size_t>(Phase::count)> phase_names = {
    "time_step",           "grid_reset",           "p2g_mass_momentum_force",   "halo_exchange",
    "boundary_conditions", "grid_momentum_update", "g2p_p2g_velocity_momentum", "g2p_velocity_acceleration",
    "p2g_momentum_remap",  "grid_remap_velocity",  "g2pd_particle_update",      "particle_move",
    "pressure_relaxation", "open_sides",           "splitting",                 "migration",
    "merging",             "reorder",              "load_balance",              "output",
    "checkpoint"};

constexpr const char* phase_name(Phase phase) { return phase_names[static_cast<size_t>(phase)]; }

class PhaseTimers {
 public:
  struct Entry {
    double seconds = 0;
    long calls = 0;
  };

  explicit PhaseTimers(PhaseTiming timing = PhaseTiming::fenced) : timing_(timing) {}

  // Scoped phase: a profiling region and a timer. Fenced, the fence at the end makes the time
  // belong to this phase even on asynchronous back-ends; unfenced, a GPU's kernels of the phase may
  // still run when the next phase begins (and are charged to the phase that next waits for them).
  class Scope {
   public:
    Scope(PhaseTimers& timers, Phase phase) : timers_(timers), phase_(phase) {
      Kokkos::Profiling::pushRegion(phase_name(phase_));
    }
    ~Scope() {
      if (timers_.timing_ == PhaseTiming::fenced) {
        Kokkos::fence();
        ++timers_.fences_;
      }
      Kokkos::Profiling::popRegion();
      timers_.add(phase_, timer_.seconds());
    }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    PhaseTimers& timers_;
    Phase phase_;
    Kokkos::Timer timer_;
  };

  Scope scope(Phase phase) { return Scope(*this, phase); }

  PhaseTiming timing() const { return timing_; }
  // (The benchmark's kernel rows time one phase each: they need the fences whatever the case says.)
  void set_timing(PhaseTiming timing) { timing_ = timing; }
  // The fences the scopes have made (with `fenced`, one a phase call).
  long fences() const { return fences_; }

  void add(Phase phase, double seconds) {
    Entry& e = entries_[static_cast<size_t>(phase)];
    if (e.calls == 0) order_.push_back(phase);
    e.seconds += seconds;
    e.calls += 1;
  }

  // The phases timed so far, in first-seen order (the order of the step).
  const std::vector<Phase>& phases() const { return order_; }
  bool seen(Phase phase) const { return entry(phase).calls > 0; }
  const Entry& entry(Phase phase) const { return entries_[static_cast<size_t>(phase)]; }
  double total_seconds() const {
    double total = 0;
    for (const Entry& e : entries_) total += e.seconds;
    return total;
  }

 private:
  PhaseTiming timing_;
  long fences_ = 0;
  std::array<Entry, static_cast<size_t>(Phase::count)> entries_{};
  std::vector<Phase> order_;
};

}  // namespace mpmflow
