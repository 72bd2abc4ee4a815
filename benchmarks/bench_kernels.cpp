// Google Benchmark programs for each kernel of the MPM step and for the whole step, on the Mach 3
// cylinder case (cases/cylinder_mach3.json) at several grid sizes and particles per cell, with
// and without reordering, next to a STREAM-style triad measured in the same run.
//
// Each BM_Kernel row times one phase of real steps (the solver's phase timers, which fence) and
// reports it per call: time, particle-steps per second (Mpps) and effective bandwidth (GBps:
// bytes from the traffic model below divided by the time). BM_Step rows report the whole step (its
// wall time, with the phase timers as the case sets them: output/phase_timers), its share of the
// triad bandwidth, and memory: the peak of all Kokkos allocations (every View,
// ScatterView copy and temporary, seen through the Kokkos Tools allocation callbacks) per
// particle and per node. The share twice: of BM_Triad's bandwidth (triad_fraction, the run's
// first row), and of the triad's in passes right before and right after the row's steps
// (row_triad_fraction): a shared machine's bandwidth changes from minute to minute (20-34 GB/s
// within one session here, 17-80 GB/s across sessions), and the second compares the step with
// what the machine gave at the same time.
//
// With --launch-census, each step row runs its steps once more, untimed, counting what a step
// launches (kernel_launches_per_step, of them reductions_per_step) and copies between Views
// (view_copies_per_step), the Kokkos allocations it makes (allocations_per_step), the fences of
// the phase timers (phase_fences_per_step; output/phase_timers = unfenced: none) and the fills that
// fence before and after (fenced_fills_per_step, launch_census.hpp): on a GPU each
// costs microseconds of latency whatever its size, which at small sizes bounds the step more than
// its bytes do. The counts are the back-end's path (a CPU build takes the sorted P2G and its own
// selections; a GPU build the atomic P2G and scans).
//
// "Without reordering" starts from particles in random order, as after a long run in which
// recycling has scattered them (freshly created particles are in cell order and would hide the
// effect); "with reordering" sorts them by cell every step (numerics/reorder_interval = 1), or every
// 20 steps as the case files do (the target rows).
//
// Traffic model: what each call moves per particle and per node, counted in reals, indices
// (4 bytes: the cell map, the cell order) and ids (8 bytes), so that the bytes follow real_t's size
// (8 bytes; 4 in a single-precision build). Each particle field a kernel reads or writes counts once;
// grid columns count once per node (read, write, or two for read-modify-write), and nodes ~ cells =
// particles / ppc. Stencil weights are computed, not stored, and cost nothing. GIMP kernels also
// read the two stretches (2 reals). In double precision:
//   p2g_mass_momentum_force     reads x y cell m vx vy e q rho               = 68; grid 7 RMW = 112/ppc
//   g2p_p2g_velocity_momentum   reads x y cell m vx vy, writes vx vy         = 60; grid 2 read + 2 RMW = 48/ppc
//   (unfused) g2p_velocity_acceleration  reads x y cell vx vy, writes vx vy  = 52; grid 2 read = 16/ppc
//   (unfused) p2g_momentum_remap         reads x y cell m vx vy              = 44; grid 2 RMW = 32/ppc
//   g2pd_particle_update        reads x y cell rho e q, writes x y rho e q   = 84 (GIMP: stretches also
//                               written, +16); grid 6 read (V-bar, remapped velocity, volume
//                               fraction, mean pressure) = 48/ppc
//   pressure_relaxation (the default) its sums read cell m rho e (28), its update reads cell rho e
//                               x y and writes rho e cell (the cell map, 56) = 84; per cell 5
//                               columns zeroed, 5 RMW, the cell pass's 5 read and 4 written, and
//                               the update's 4 read = 224/ppc
//   splitting                   the candidates' pass reads m rho and the two stretches = 32
//   merging (after a first split) the candidates' pass reads id m rho      = 24
//   particle_move (boundaries)  the rules read x y (and write them where a rule moves the particle)
//                               = 16; without the pressure relaxation, the cells read x y, write
//                               cell: +20
//   time_step                   the particles' check rides on P2G (particles_in_doubt) = 0; grid 4 read
//                               = 32/ppc
//   reorder                     the cell order (a counting sort on CPUs: cell read twice, order
//                               written: 12), then every field (10 reals, cell, id) gathered through
//                               the order into new storage (permuted_particle_field: the order read,
//                               the field read and written, 20 bytes a real, 12 for the cell, 20 for
//                               the id) = 244
//   grid_reset (two calls a step: the 7 state columns, then the 2 momentum columns) 9 columns
//   written a step = 36/ppc a call; grid_momentum_update 5 read + 6 written = 88/ppc;
//   grid_remap_velocity 3 read + 2 written = 40/ppc, and with the volume correction (the default)
//   the volume fraction and mean pressure: 3 read + 2 written = 40/ppc.
// (Until 2026-12-03 the model counted 68 for the fused kernel, one real too many, and 288 for the
// reorder, which had copied each field back from a temporary until 3bbf72c: the step's model bytes
// a particle were then 531.7 with GIMP and 467.0 with linear, against 521.4 and 456.8 now.)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "allocation_tracker.hpp"
#include "build_commit.hpp"
#include "case_config.hpp"
#include "host_memory.hpp"
#include "kernels/particle_sort.hpp"
#include "launch_census.hpp"
#include "particles.hpp"
#include "solver.hpp"

namespace mpmflow {
namespace {

// ---- Memory: every Kokkos allocation, through the Kokkos Tools callbacks ----------------------

// Installed at its first use, which main makes right after Kokkos is initialised, for the whole
// run (allocation_tracker.hpp).
AllocationTracker& allocations() {
  static AllocationTracker tracker;
  return tracker;
}

// ---- The runs -------------------------------------------------------------------------------

struct RunSpec {
  long target_cells = 100000;
  int ppc_axis = 3;                    // particles per cell: ppc_axis^2
  int reorder_interval = 0;            // 0: random order, never reordered
  std::string shape = "gimp";          // numerics/shape_function
  std::string p2g = "automatic";       // numerics/p2g
  bool fused = true;                   // numerics/fused_kernels
  // The user's --set assignments, the same for every row (checked by check_case_overrides).
  std::vector<std::string> case_overrides;

  std::string key() const {
    return std::to_string(target_cells) + "/" + std::to_string(ppc_axis) + "/" + std::to_string(reorder_interval) +
           "/" + shape + "/" + p2g + "/" + (fused ? "fused" : "unfused");
  }
  std::string label() const {
    const std::string order = reorder_interval == 0   ? std::string("random order")
                              : reorder_interval == 1 ? std::string("reordered every step")
                                                      : "reordered every " + std::to_string(reorder_interval) + " steps";
    return shape + ", " + std::to_string(ppc_axis * ppc_axis) + " ppc, " + order + ", P2G " + p2g +
           (fused ? "" : ", unfused");
  }
};

// The case file the rows run.
std::string cylinder_case_path() { return std::string(MPMFLOW_SOURCE_DIR) + "/cases/cylinder_mach3.json"; }

// What a row sets in the case file itself (one list: cylinder_case applies it, and
// check_case_overrides refuses a --set of any of its keys): the cylinder case at about
// target_cells cells (its 2:1 domain), ppc_axis^2 particles per cell, the spec's numerics.
std::vector<std::string> row_settings(const RunSpec& spec) {
  const long cells_y = std::max(4L, std::lround(std::sqrt(spec.target_cells / 2.0)));
  return {"domain/cells_x=" + std::to_string(2 * cells_y), "domain/cells_y=" + std::to_string(cells_y),
          "particles/per_cell=[" + std::to_string(spec.ppc_axis) + "," + std::to_string(spec.ppc_axis) + "]",
          "numerics/reorder_interval=" + std::to_string(spec.reorder_interval),
          "numerics/shape_function=\"" + spec.shape + "\"", "numerics/p2g=\"" + spec.p2g + "\"",
          std::string("numerics/fused_kernels=") + (spec.fused ? "true" : "false"), "output/snapshots=0"};
}

// The user's assignments first, the row's after them (check_case_overrides keeps the two apart).
CaseConfig cylinder_case(const RunSpec& spec) {
  std::vector<std::string> overrides = spec.case_overrides;
  for (const std::string& setting : row_settings(spec)) overrides.push_back(setting);
  return load_case_file(cylinder_case_path(), overrides);
}

// Puts the particles in a random order (the same for every run).
void shuffle_particles(ParticleState& particles) {
  const index_t n = particles.count;
  std::vector<index_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), std::mt19937(12345));
  IndexView permutation("shuffle_permutation", n);
  auto host = Kokkos::create_mirror_view(permutation);
  for (index_t k = 0; k < n; ++k) host(k) = order[k];
  Kokkos::deep_copy(permutation, host);
  particles.for_each_field_mutable([&](auto& field) { field = permuted_particle_field(field, permutation, n); });
}

// One solver at a time (rows of the same run are adjacent): creating it is timed for memory only.
struct Run {
  RunSpec spec;
  CaseConfig config;
  std::unique_ptr<Solver> solver;
  // Open sides change the particle count: the mean count over the steps of the last row.
  double particles = 0, cells = 0, nodes = 0;
  long long baseline_bytes = 0;  // allocated before the solver was built
  long long peak_bytes = 0;      // all Kokkos allocations while building it and stepping
};

// A row's label, with the strategy numerics/p2g = automatic took (the solver's choice).
std::string label_of(const Run& run) {
  const std::string label = run.spec.label();
  if (run.spec.p2g != "automatic") return label;
  return label + " (" + to_string(run.solver->p2g_strategy()) + ")";
}

// After a row's steps: the mean particle count over them (from the solver's particle-steps) and
// the allocation peak so far (the particle Views grow as the shock layer fills up).
void observe_steps(Run& run, long long particle_steps_before, long steps) {
  if (steps > 0) run.particles = double(run.solver->particle_steps() - particle_steps_before) / steps;
  run.peak_bytes = std::max(run.peak_bytes, allocations().peak() - run.baseline_bytes);
}

Run& current_run() {
  static Run run;
  return run;
}

Run& run_for(const RunSpec& spec) {
  Run& run = current_run();
  if (run.solver && run.spec.key() == spec.key()) return run;
  run.solver.reset();
  run.baseline_bytes = allocations().current();
  allocations().reset_peak();
  run.spec = spec;
  run.config = cylinder_case(spec);
  const GridSlab slab = make_grid_slab(run.config.domain, 0, run.config.domain.cells_x);
  run.solver = std::make_unique<Solver>(run.config, slab, create_initial_particles(run.config, slab));
  if (spec.reorder_interval == 0) shuffle_particles(run.solver->particles());
  // A few steps outside the timing: first-touch of the ScatterView copies, the bow shock forming.
  for (int k = 0; k < 3; ++k) run.solver->advance(run.solver->stable_time_step());
  run.peak_bytes = allocations().peak() - run.baseline_bytes;
  run.particles = run.solver->particles().count;
  run.cells = double(run.config.domain.cells_x) * run.config.domain.cells_y;
  run.nodes = slab.geometry.num_nodes();
  return run;
}

struct Traffic {
  double particle_reals;    // per particle
  double particle_indices;  // per particle: the cell map, the cell order (index_t)
  double particle_ids;      // per particle (particle_id_t)
  double node_reals;        // per node
  bool stencil;             // GIMP reads the two stretches
};
const std::map<Phase, Traffic>& traffic_model() {
  static const std::map<Phase, Traffic> model = {
      {Phase::p2g_mass_momentum_force, {8, 1, 0, 14, true}},
      {Phase::g2p_p2g_velocity_momentum, {7, 1, 0, 6, true}},
      {Phase::g2p_velocity_acceleration, {6, 1, 0, 2, true}},
      {Phase::p2g_momentum_remap, {5, 1, 0, 4, true}},
      {Phase::g2pd_particle_update, {10, 1, 0, 6, true}},
      {Phase::particle_move, {2, 0, 0, 0, false}},
      {Phase::pressure_relaxation, {9, 3, 0, 28, false}},
      {Phase::time_step, {0, 0, 0, 4, false}},
      {Phase::reorder, {20, 17, 2, 0, false}},
      {Phase::splitting, {4, 0, 0, 0, false}},
      {Phase::merging, {2, 0, 1, 0, false}},
      {Phase::grid_reset, {0, 0, 0, 4.5, false}},
      {Phase::grid_momentum_update, {0, 0, 0, 11, false}},
      {Phase::grid_remap_velocity, {0, 0, 0, 5, false}}};
  return model;
}

// Model bytes of one call of `phase` on this run.
double phase_bytes(Phase phase, const Run& run) {
  const auto it = traffic_model().find(phase);
  if (it == traffic_model().end()) return 0;
  Traffic t = it->second;
  if (run.spec.shape == "gimp" && t.stencil) t.particle_reals += 2;
  if (run.spec.shape == "gimp" && phase == Phase::g2pd_particle_update) t.particle_reals += 2;
  if (!run.config.numerics.pressure_relaxation && phase == Phase::particle_move) {
    t.particle_reals += 2;
    t.particle_indices += 1;
  }
  if (run.config.numerics.volume_correction && phase == Phase::grid_remap_velocity) t.node_reals += 5;
  const double per_particle = t.particle_reals * sizeof(real_t) + t.particle_indices * sizeof(index_t) +
                              t.particle_ids * sizeof(particle_id_t);
  return per_particle * run.particles + t.node_reals * sizeof(real_t) * run.nodes;
}

double& measured_triad_GBps() {
  static double value = 0;
  return value;
}

// STREAM triad a = b + s c on Views far larger than the caches (3 x 256 MiB): the bandwidth the
// machine gives. The arrays are made once, at their first use, and kept until the end (main),
// outside the allocation count (the peaks are the solver's).
constexpr index_t triad_length = index_t(1) << 25;
struct TriadArrays {
  RealView a, b, c;
};
TriadArrays& triad_storage() {
  static TriadArrays arrays;
  return arrays;
}
const TriadArrays& triad_arrays() {
  TriadArrays& arrays = triad_storage();
  if (arrays.a.extent(0) == 0) {
    allocations().paused = true;
    arrays = {RealView("triad_a", triad_length), RealView("triad_b", triad_length), RealView("triad_c", triad_length)};
    allocations().paused = false;
    Kokkos::deep_copy(arrays.b, 1.0);
    Kokkos::deep_copy(arrays.c, 2.0);
  }
  return arrays;
}
// The seconds of one triad pass.
double triad_pass_seconds() {
  const TriadArrays& arrays = triad_arrays();
  const RealView a = arrays.a, b = arrays.b, c = arrays.c;
  const real_t s = 3;
  Kokkos::Timer timer;
  Kokkos::parallel_for(
      "triad", Kokkos::RangePolicy<ExecutionSpace>(0, triad_length),
      KOKKOS_LAMBDA(const index_t i) { a(i) = b(i) + s * c(i); });
  Kokkos::fence();
  return timer.seconds();
}
// Three arrays of triad_length reals pass through memory once a pass (write-allocate not counted).
double triad_GBps(long passes, double seconds) {
  return 3.0 * sizeof(real_t) * triad_length * static_cast<double>(passes) / seconds / 1e9;
}

void BM_Triad(benchmark::State& state) {
  double seconds = 0;
  for (auto _ : state) seconds += triad_pass_seconds();
  const double GBps = triad_GBps(state.iterations(), seconds);
  measured_triad_GBps() = GBps;
  state.counters["GBps"] = GBps;
}

// One phase, per call, in real steps. Manual time: only that phase's time counts.
void BM_Kernel(benchmark::State& state, RunSpec spec, Phase phase) {
  Run& run = run_for(spec);
  Solver& solver = *run.solver;
  solver.timers().set_timing(PhaseTiming::fenced);  // (one phase's own time, whatever the case says)
  double seconds = 0;
  long calls = 0, steps = 0;
  const long long particle_steps_before = solver.particle_steps();
  for (auto _ : state) {
    ++steps;
    const PhaseTimers& timers = solver.timers();
    const double before = timers.entry(phase).seconds;
    const long calls_before = timers.entry(phase).calls;
    solver.advance(solver.stable_time_step());
    if (!timers.seen(phase)) {
      state.SkipWithError((std::string("no phase ") + phase_name(phase) + " in this run").c_str());
      return;
    }
    const double dt = timers.entry(phase).seconds - before;
    seconds += dt;
    calls += timers.entry(phase).calls - calls_before;
    state.SetIterationTime(dt);
  }
  observe_steps(run, particle_steps_before, steps);
  const double per_call = seconds / std::max(1L, calls);
  state.counters["Mpps"] = run.particles / per_call / 1e6;
  state.counters["GBps"] = phase_bytes(phase, run) / per_call / 1e9;
  state.counters["model_B_per_particle"] = phase_bytes(phase, run) / run.particles;
  state.counters["particles"] = run.particles;
  state.counters["cells"] = run.cells;
  state.SetLabel(label_of(run));
}

// The allocations live at the run's peak, by label, in bytes a particle, largest first (on stderr,
// beside the row's line): where peak_alloc_B_per_particle goes.
void print_peak_by_label(const Run& run, double particles) {
  std::vector<std::pair<long long, std::string>> entries;
  long long total = 0;
  for (const auto& [label, bytes] : allocations().peak_by_label()) {
    entries.emplace_back(bytes, label);
    total += bytes;
  }
  std::sort(entries.rbegin(), entries.rend());
  std::fprintf(stderr, "peak allocations of BM_Step/%s: %.1f B a particle (live before the run: %.1f)\n",
               run.spec.key().c_str(), double(total) / particles, double(run.baseline_bytes) / particles);
  int small = 0;  // under 0.01 B a particle: counted, not listed
  for (const auto& [bytes, label] : entries) {
    if (std::fabs(double(bytes)) / particles < 0.01) ++small;
    else std::fprintf(stderr, "  %10.2f  %s\n", double(bytes) / particles, label.c_str());
  }
  if (small > 0) std::fprintf(stderr, "  (%d more labels under 0.01 B a particle each)\n", small);
}

// What a step row reports besides its figures (options of this program).
struct StepRowExtras {
  bool memory_breakdown = false;  // --memory-breakdown
  bool launch_census = false;     // --launch-census
  bool launch_breakdown = false;  // --launch-breakdown
};

// After a step row's timed steps, as many again under a launch census (launch_census.hpp): the
// kernel launches, reductions, View copies and allocations a step makes. Not timed: Kokkos fences
// before each launch while a census is installed (its tools' default), which would take a GPU's
// launches out of the queue they overlap in.
void count_launches(benchmark::State& state, const Run& run, Solver& solver, long steps, bool by_label) {
  const LaunchCensus census(by_label);
  const long long allocations_before = allocations().allocation_count();
  const std::map<std::string, long long> allocations_by_label_before = allocations().allocation_count_by_label();
  const long fences_before = solver.timers().fences();
  for (long k = 0; k < steps; ++k) solver.advance(solver.stable_time_step());
  const double allocations_per_step = double(allocations().allocation_count() - allocations_before) / steps;
  const double phase_fences_per_step = double(solver.timers().fences() - fences_before) / steps;
  state.counters["kernel_launches_per_step"] = double(census.launches()) / steps;
  state.counters["reductions_per_step"] = double(census.reductions()) / steps;
  state.counters["view_copies_per_step"] = double(census.view_copies()) / steps;
  state.counters["allocations_per_step"] = allocations_per_step;
  state.counters["phase_fences_per_step"] = phase_fences_per_step;
  state.counters["fenced_fills_per_step"] = double(census.fenced_fills()) / steps;
  if (!by_label) return;
  std::fprintf(stderr,
               "launches of BM_Step/%s a step: %.2f (%.2f reductions), %.2f View copies, %.2f allocations, "
               "%.2f phase timers' fences, %.2f fenced fills\n",
               run.spec.key().c_str(), double(census.launches()) / steps, double(census.reductions()) / steps,
               double(census.view_copies()) / steps, allocations_per_step, phase_fences_per_step,
               double(census.fenced_fills()) / steps);
  for (const auto& [label, count] : census.by_label())
    std::fprintf(stderr, "  %8.2f  %s\n", double(count) / steps, label.c_str());
  std::fprintf(stderr, "allocations of BM_Step/%s a step, by label:\n", run.spec.key().c_str());
  for (const auto& [label, count] : allocations().allocation_count_by_label()) {
    const auto before = allocations_by_label_before.find(label);
    const long long made = count - (before == allocations_by_label_before.end() ? 0 : before->second);
    if (made > 0) std::fprintf(stderr, "  %8.2f  %s\n", double(made) / steps, label.c_str());
  }
}

// The whole step (time step, all phases, reordering when due).
void BM_Step(benchmark::State& state, RunSpec spec, StepRowExtras extras) {
  Run& run = run_for(spec);
  Solver& solver = *run.solver;
  solver.timers() = PhaseTimers(run.config.output.phase_timers);
  long steps = 0;
  const long long particle_steps_before = solver.particle_steps();
  // The triad just before and just after the steps (outside the loop: not in the row's time).
  constexpr int triad_passes = 3;
  double triad_seconds = 0;
  for (int k = 0; k < triad_passes; ++k) triad_seconds += triad_pass_seconds();
  // The steps' wall time, up to the end of their last kernel: with output/phase_timers = unfenced
  // a GPU's last phases are still running when the host leaves the last step.
  Kokkos::Timer step_timer;
  for (auto _ : state) {
    solver.advance(solver.stable_time_step());
    ++steps;
  }
  Kokkos::fence();
  const double steps_seconds = step_timer.seconds();
  for (int k = 0; k < triad_passes; ++k) triad_seconds += triad_pass_seconds();
  const double row_triad_GBps = triad_GBps(2 * triad_passes, triad_seconds);
  observe_steps(run, particle_steps_before, steps);
  const PhaseTimers& timers = solver.timers();
  const double step_seconds = steps_seconds / std::max(1L, steps);
  double step_bytes = 0;
  for (const Phase phase : timers.phases()) step_bytes += phase_bytes(phase, run) * timers.entry(phase).calls / steps;
  const Solver::MemoryUse memory = solver.memory_use();
  state.counters["particles"] = run.particles;
  state.counters["cells"] = run.cells;
  state.counters["particle_steps_per_s"] = run.particles / step_seconds;
  state.counters["GBps"] = step_bytes / step_seconds / 1e9;
  if (measured_triad_GBps() > 0) state.counters["triad_fraction"] = step_bytes / step_seconds / 1e9 / measured_triad_GBps();
  state.counters["row_triad_GBps"] = row_triad_GBps;
  state.counters["row_triad_fraction"] = step_bytes / step_seconds / 1e9 / row_triad_GBps;
  state.counters["model_B_per_particle"] = step_bytes / run.particles;
  // The rate at which the step would run if it moved its model bytes at the row's triad speed: an
  // upper bound, as far as the model holds, for a step bound by memory on this machine at this
  // minute, to hold a target against (a step bound by its core's work runs below it).
  state.counters["row_triad_bound_particle_steps_per_s"] = row_triad_GBps * 1e9 / (step_bytes / run.particles);
  state.counters["peak_alloc_B_per_particle"] = double(run.peak_bytes) / solver.particles().count;
  // The particle Views' capacity (spare room included) per particle in use.
  state.counters["particle_B_per_particle"] = double(memory.particle_bytes) / solver.particles().count;
  state.counters["grid_B_per_node"] = double(memory.grid_bytes + memory.scatter_copy_bytes) / run.nodes;
  state.SetLabel(label_of(run));
  if (extras.memory_breakdown) print_peak_by_label(run, solver.particles().count);
  if (extras.launch_census && steps > 0) count_launches(state, run, solver, steps, extras.launch_breakdown);
}

// The items of a comma-separated list.
std::vector<std::string> split_list(const std::string& list) {
  std::vector<std::string> items;
  size_t start = 0;
  while (start < list.size()) {
    const size_t end = std::min(list.find(',', start), list.size());
    items.push_back(list.substr(start, end - start));
    start = end + 1;
  }
  return items;
}

// A number that is the whole of an option's text, in [least, most] (and whole where asked); an
// error naming the option and what it expects otherwise.
double parse_number(const std::string& text, const char* option, const char* expected, double least, double most,
                    bool whole) {
  size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || !(value >= least && value <= most) || (whole && value != std::floor(value)))
    throw std::invalid_argument(std::string("mpmflow_benchmarks: ") + option + ": \"" + text + "\" is not " + expected);
  return value;
}

std::vector<long> parse_cells(const std::string& list) {
  std::vector<long> cells;
  for (const std::string& item : split_list(list))
    cells.push_back(std::lround(parse_number(item, "--cells", "a number of cells (expected e.g. 1e5)", 1, 1e12, false)));
  return cells;
}

// Steps a row: a whole positive number.
int parse_steps(const std::string& text) {
  return static_cast<int>(parse_number(text, "--steps", "a number of steps (expected 1 to 1000000)", 1, 1e6, true));
}

// Shape functions by their case-file names (numerics/shape_function); an unknown name is an error
// here, before any row runs, not one thrown by the case loader inside a row.
std::vector<std::string> parse_shapes(const std::string& list) {
  std::vector<std::string> shapes;
  for (const std::string& item : split_list(list)) {
    bool known = false;
    std::string names;
    for (const EnumName<ShapeFunction>& entry : EnumNames<ShapeFunction>::table) {
      known = known || item == entry.name;
      names += std::string(names.empty() ? "" : ", ") + entry.name;
    }
    if (!known)
      throw std::invalid_argument("mpmflow_benchmarks: --shapes: unknown shape function \"" + item + "\" (expected " +
                                  names + ")");
    shapes.push_back(item);
  }
  return shapes;
}

// The user's --set assignments: a key a row sets itself (row_settings), or one above or below it,
// is refused, naming it (--cells and --shapes choose those); the rest must make a valid case,
// checked here, before any row runs, with the case loader's own error naming the key otherwise.
// Returns that case (with a row's settings, which leave the physics alone), for register_benchmarks.
CaseConfig check_case_overrides(const std::vector<std::string>& overrides) {
  auto path_of = [](const std::string& assignment) {
    std::string path = assignment.substr(0, assignment.find('='));
    return path.empty() || path.front() != '/' ? path : path.substr(1);
  };
  // `a` is `b` or holds it: "numerics" holds "numerics/p2g"; "numerics/p" does not.
  auto holds = [](const std::string& a, const std::string& b) {
    return b.compare(0, a.size(), a) == 0 && (a.size() == b.size() || a.empty() || b[a.size()] == '/');
  };
  std::vector<std::string> row_paths;
  std::string row_keys;
  for (const std::string& setting : row_settings(RunSpec{})) {
    row_paths.push_back(path_of(setting));
    row_keys += (row_keys.empty() ? "" : ", ") + row_paths.back();
  }
  for (const std::string& assignment : overrides) {
    const size_t equals = assignment.find('=');
    if (equals == std::string::npos || equals == 0) continue;  // the loader names it
    const std::string path = path_of(assignment);
    for (const std::string& row_path : row_paths)
      if (holds(path, row_path) || holds(row_path, path))
        throw std::invalid_argument("mpmflow_benchmarks: --set " + assignment + ": \"" + path +
                                    "\" is set by the rows themselves (expected a key other than " + row_keys +
                                    "; --cells and --shapes choose the grid sizes and shapes)");
  }
  RunSpec spec;
  spec.case_overrides = overrides;
  try {
    return cylinder_case(spec);
  } catch (const ConfigError& e) {
    throw std::invalid_argument(std::string("mpmflow_benchmarks: --set: ") + e.what());
  }
}

// The rows: every kernel and the step, per shape function, grid size, ppc and ordering; then at the
// target size (1e5 cells, 9 ppc) the P2G strategies, the unfused kernels and the linear shape.
// Each row runs a fixed number of whole steps (a kernel row times its phase within them), so a
// row costs the same whatever share of the step its kernel takes.
void register_benchmarks(const std::vector<std::string>& shapes, const std::vector<long>& cell_counts,
                         bool matrix_only, const StepRowExtras& extras, int steps_per_row,
                         const std::vector<std::string>& case_overrides, bool relaxes) {
  benchmark::RegisterBenchmark("BM_Triad", BM_Triad)->Arg(triad_length)->Unit(benchmark::kMillisecond)->UseRealTime();
  const std::vector<Phase> kernels = {Phase::p2g_mass_momentum_force, Phase::g2p_p2g_velocity_momentum,
                                      Phase::g2pd_particle_update,    Phase::particle_move,
                                      Phase::pressure_relaxation,     Phase::time_step};
  // No row for the relaxation where the case (a --set) turns it off (`relaxes`, the case as
  // check_case_overrides loaded it): it has no phase to time. The rows' own settings leave it alone,
  // so one look at the case serves them all.
  auto add_run = [&](const RunSpec& spec, const std::vector<Phase>& phases) {
    const std::string suffix = "/" + spec.key();
    for (const Phase phase : phases) {
      if (phase == Phase::pressure_relaxation && !relaxes) continue;
      benchmark::RegisterBenchmark((std::string("BM_Kernel/") + phase_name(phase) + suffix).c_str(), BM_Kernel, spec,
                                   phase)
          ->Unit(benchmark::kMillisecond)
          ->UseManualTime()
          ->Iterations(steps_per_row);
    }
    benchmark::RegisterBenchmark(("BM_Step" + suffix).c_str(), BM_Step, spec, extras)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime()
        ->Iterations(steps_per_row);
  };
  for (const std::string& shape : shapes)
    for (long cells : cell_counts)
      for (int ppc_axis : {2, 3, 4})
        for (int reorder : {0, 1}) {
          RunSpec spec;
          spec.case_overrides = case_overrides;
          spec.shape = shape;
          spec.target_cells = cells;
          spec.ppc_axis = ppc_axis;
          spec.reorder_interval = reorder;
          std::vector<Phase> phases = kernels;
          if (reorder) phases.push_back(Phase::reorder);
          add_run(spec, phases);
        }
  if (matrix_only) return;
  RunSpec target;  // 1e5 cells, 9 ppc
  target.case_overrides = case_overrides;
  target.reorder_interval = 20;  // the case file's setting
  for (const char* p2g : {"duplicated", "atomic", "sorted"}) {
    // Not the duplicated one on a GPU: a copy of the grid per GPU thread (check_case_supported).
    if (!std::is_same<MemorySpace, Kokkos::HostSpace>::value && std::string(p2g) == "duplicated") continue;
    RunSpec s = target;
    s.p2g = p2g;
    add_run(s, {Phase::p2g_mass_momentum_force, Phase::g2p_p2g_velocity_momentum});
  }
  RunSpec unfused = target;
  unfused.fused = false;
  add_run(unfused, {Phase::g2p_velocity_acceleration, Phase::p2g_momentum_remap});
  RunSpec linear = target;
  linear.shape = "linear";
  add_run(linear, kernels);
}

}  // namespace
}  // namespace mpmflow

// Options of this program, before Google Benchmark's own (--benchmark_filter, --benchmark_format,
// --benchmark_out, ...):
//   --cells=LIST    grid sizes of the kernel matrix, e.g. --cells=1e4,3e4,1e5 (default 1e4,1e5)
//   --shapes=LIST   shape functions of the kernel matrix, e.g. --shapes=gimp,linear (default gimp)
//   --matrix-only   only the matrix (grid sizes x ppc x ordering), not the target-size variants
//   --memory-breakdown  after each step row, the allocations at its peak by label (on stderr)
//   --launch-census after each step row's timing, its steps again (untimed) with the kernel launches,
//                   reductions, View copies and allocations counted: kernel_launches_per_step, ...
//   --launch-breakdown  the same, and the counts by kernel label (on stderr)
//   --steps=N       steps per row (default 20)
//   --set PATH=VALUE  (or --set=PATH=VALUE; repeatable) a case-file setting for every row, as
//                   `mpmflow run --set` takes it, e.g. --set numerics/pressure_relaxation=false
int main(int argc, char** argv) {
  mpmflow::reuse_freed_host_memory();  // as the solver's executable does (host_memory.hpp)
  std::string cells = "1e4,1e5", shapes = "gimp", steps_text = "20";
  bool matrix_only = false;
  mpmflow::StepRowExtras extras;
  std::vector<std::string> case_overrides;
  std::vector<char*> rest;
  for (int k = 0; k < argc; ++k) {
    const std::string arg = argv[k];
    if (arg == "--set") {
      if (k + 1 == argc || std::string(argv[k + 1]).rfind("--", 0) == 0) {
        std::cerr << "mpmflow_benchmarks: --set: expected PATH=VALUE after it, e.g. --set "
                     "numerics/pressure_relaxation=false\n";
        return 2;
      }
      case_overrides.push_back(argv[++k]);
      continue;
    }
    if (arg.rfind("--set=", 0) == 0) {
      case_overrides.push_back(arg.substr(6));
      continue;
    }
    if (arg.rfind("--cells=", 0) == 0) cells = arg.substr(8);
    else if (arg.rfind("--shapes=", 0) == 0) shapes = arg.substr(9);
    else if (arg == "--matrix-only") matrix_only = true;
    else if (arg == "--memory-breakdown") extras.memory_breakdown = true;
    else if (arg == "--launch-census") extras.launch_census = true;
    else if (arg == "--launch-breakdown") extras.launch_census = extras.launch_breakdown = true;
    else if (arg.rfind("--steps=", 0) == 0) steps_text = arg.substr(8);
    else rest.push_back(argv[k]);
  }
  std::vector<long> cell_counts;
  std::vector<std::string> shape_list;
  int steps = 0;
  bool relaxes = false;  // whether the case, --set applied, relaxes its pressures
  try {
    steps = mpmflow::parse_steps(steps_text);
    cell_counts = mpmflow::parse_cells(cells);
    shape_list = mpmflow::parse_shapes(shapes);
    relaxes = mpmflow::check_case_overrides(case_overrides).numerics.pressure_relaxation;
  } catch (const std::invalid_argument& e) {
    std::cerr << e.what() << "\n";
    return 2;
  }
  int rest_count = static_cast<int>(rest.size());
  Kokkos::ScopeGuard kokkos(rest_count, rest.data());
  mpmflow::allocations();  // counting from here
  mpmflow::register_benchmarks(shape_list, cell_counts, matrix_only, extras, steps, case_overrides,
                               relaxes);
  // The context lines above the rows name the build that made the figures (its commit, "-dirty"
  // with uncommitted changes), its options, the compiler and the Kokkos: the same case runs at
  // another pace with another of any of them. (Google Benchmark's own warning that the "Library
  // was built as DEBUG" is about the Google Benchmark library, Debian's build of it: its
  // bookkeeping, not these rows' steps.)
  benchmark::AddCustomContext("mpmflow_build", mpmflow::build_identity());
  benchmark::AddCustomContext("mpmflow_build_options", MPMFLOW_BUILD_OPTIONS);
  benchmark::AddCustomContext("host_compiler", mpmflow::host_compiler());
  benchmark::AddCustomContext("kokkos_version", mpmflow::kokkos_version());
  // And the precision: the traffic model's bytes follow it.
  benchmark::AddCustomContext("real_t", sizeof(mpmflow::real_t) == sizeof(double) ? "double" : "float");
  // And the back-end and how many threads it runs at once (benchmarks/scaling_study.py's title).
  benchmark::AddCustomContext("execution_space", mpmflow::ExecutionSpace::name());
  benchmark::AddCustomContext("concurrency", std::to_string(mpmflow::ExecutionSpace().concurrency()));
  // And what --set changed in the case file, for every row ("none": the case file as it is).
  std::string settings;
  for (const std::string& assignment : case_overrides) settings += (settings.empty() ? "" : " ") + assignment;
  benchmark::AddCustomContext("case_overrides", settings.empty() ? "none" : settings);
  benchmark::Initialize(&rest_count, rest.data());
  if (benchmark::ReportUnrecognizedArguments(rest_count, rest.data())) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  mpmflow::current_run() = mpmflow::Run();  // its Views go before Kokkos is finalized
  mpmflow::triad_storage() = mpmflow::TriadArrays();
  return 0;
}
