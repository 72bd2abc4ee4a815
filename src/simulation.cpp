#include "simulation.hpp"

#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <cmath>
#include <iomanip>
#include <memory>
#include <ostream>
#include <sstream>
#include <streambuf>
#include <type_traits>
#include <vector>

#include "build_commit.hpp"
#include "checkpoint.hpp"
#include "hdf5_io.hpp"
#include "run_files.hpp"
#include "output.hpp"
#include "parallel.hpp"
#include "particles.hpp"
#include "solver.hpp"

namespace mpmflow {
namespace {

std::string format_seconds(double s) {
  std::ostringstream out;
  // A step size that collapses makes the estimate meaningless, never negative or wrapped around.
  if (!(s >= 0) || s > 3600.0 * 1e5) return "more than 100000h";
  if (s < 60) out << std::fixed << std::setprecision(1) << s << "s";
  else if (s < 3600) out << int(s / 60) << "m" << std::setw(2) << std::setfill('0') << int(s) % 60 << "s";
  else out << int(s / 3600) << "h" << std::setw(2) << std::setfill('0') << int(s / 60) % 60 << "m";
  return out.str();
}

// The totals of an output; with open sides, also the mass that crossed them and how well the mass
// balance mass = mass(0) + in - out closes.
void print_totals(std::ostream& log, const char* label, const ConservationTotals& t, const ConservationTotals& t0,
                  const BoundaryFluxes& fluxes, bool open_sides) {
  log << std::setprecision(10) << "  " << label << ": mass " << t.mass << " (rel. change "
      << std::setprecision(3) << (t.mass - t0.mass) / t0.mass << ")" << std::setprecision(10) << ", momentum ("
      << t.momentum_x << ", " << t.momentum_y << "), kinetic " << t.kinetic_energy << ", internal "
      << t.internal_energy << ", total energy drift " << std::setprecision(3)
      << (t.total_energy() - t0.total_energy()) / t0.total_energy() << "\n";
  if (open_sides)
    log << std::setprecision(10) << "    open sides: mass in " << fluxes.entered.mass << ", out " << fluxes.left.mass
        << ", mass balance residual (mass - mass(0) - in + out) / mass(0) " << std::setprecision(3)
        << (t.mass - t0.mass - fluxes.entered.mass + fluxes.left.mass) / t0.mass << "\n";
}

// The time per phase; under MPI the mean over the ranks, with the fastest and the slowest rank
// (collective: every rank calls it).
void print_timer_table(std::ostream& log, const PhaseTimers& timers, long steps, const ParallelContext& context) {
  const bool ranks = context.distributed();
  auto mean_over_ranks = [&](double value) {
    context.sum_in_place(&value, 1);
    return value / context.size();
  };
  const double total = mean_over_ranks(timers.total_seconds());
  log << "\nTime per phase" << (ranks ? " (mean over the ranks, and the fastest and slowest rank)" : "") << "\n";
  if (timers.timing() == PhaseTiming::unfenced)
    log << "  (output/phase_timers = unfenced: the host's time in each phase; on a GPU a phase's kernels may\n"
           "  run on into the next phases and be charged to the first that waits for them)\n";
  log << "  " << std::left << std::setw(28) << "phase" << std::right << std::setw(11)
      << (ranks ? "mean [s]" : "total [s]");
  if (ranks) log << std::setw(10) << "min [s]" << std::setw(10) << "max [s]";
  log << std::setw(8) << "%" << std::setw(10) << "calls" << std::setw(14) << "per step [ms]" << "\n";
  for (const Phase phase : timers.phases()) {
    const auto& e = timers.entry(phase);
    const double mean = mean_over_ranks(e.seconds);
    const double fastest = context.min(e.seconds), slowest = context.max(e.seconds);
    log << "  " << std::left << std::setw(28) << phase_name(phase) << std::right << std::fixed << std::setprecision(3)
        << std::setw(11) << mean;
    if (ranks) log << std::setw(10) << fastest << std::setw(10) << slowest;
    log << std::setprecision(1) << std::setw(8) << 100 * mean / total << std::setw(10) << e.calls
        << std::setprecision(3) << std::setw(14) << (steps > 0 ? 1000 * mean / steps : 0.0) << "\n";
  }
  log << std::defaultfloat;
}

}  // namespace

namespace {
// The version and build; with the execution space's concurrency, which needs Kokkos initialised.
std::string describe_build(bool with_concurrency) {
  std::ostringstream out;
  out << build_identity() << ", "
      << (sizeof(real_t) == 8 ? "double" : "single") << " precision\n"
      << "Kokkos " << kokkos_version() << ", execution space " << ExecutionSpace::name();
  if (with_concurrency) out << ", concurrency " << ExecutionSpace().concurrency();
  if (gpu_code_paths_on_host) out << ", the GPU build's code paths (MPMFLOW_GPU_CODE_PATHS_ON_HOST)";
  out << "\n";
#ifdef MPMFLOW_HAVE_MPI
  out << "MPI: on";
#else
  out << "MPI: off";
#endif
#ifdef MPMFLOW_HAVE_HDF5
  out << ", HDF5: on";
#else
  out << ", HDF5: off";
#endif
  return out.str();
}
}  // namespace

std::string version_description() { return describe_build(false); }
std::string build_description() { return describe_build(true); }

void check_memory(const CaseConfig& config, int num_ranks, double max_bytes) {
  const double particles = double(config.domain.cells_x) * config.domain.cells_y * config.particles.per_cell_x *
                           config.particles.per_cell_y;
  const double nodes = double(config.domain.cells_x + 5) * (config.domain.cells_y + 5);
  // One rank builds each snapshot and checkpoint in memory before writing it (h5::write_file_safely):
  // about 90 B a particle more while it does (the cylinder at 448 x 224 cells, 881,013 particles:
  // heap peaks of 233 B a particle with snapshots, 144 without).
  const bool files_in_memory = num_ranks <= 1 && (config.output.snapshots > 0 || config.output.checkpoint_interval > 0);
  const double per_particle = files_in_memory ? 300 : 200;
  const double needed = (per_particle * particles + 200 * nodes) / std::max(num_ranks, 1);
  const double machine = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGESIZE));
  const double available = max_bytes > 0 ? max_bytes : machine;
  if (available > 0 && needed > available) {
    std::ostringstream msg;
    msg << config.source << ": /domain: " << config.domain.cells_x << " x " << config.domain.cells_y << " cells and "
        << static_cast<long long>(particles) << " particles need about " << std::setprecision(3) << needed / 1e9
        << " GB per rank (" << per_particle << " bytes per particle, 200 per node); "
        << (max_bytes > 0 ? "--max-memory allows " : "this machine has ") << available / 1e9
        << " GB; expected a smaller case, or more ranks";
    throw ConfigError(msg.str());
  }
}

void check_case_supported(const CaseConfig& config) {
  // A duplicated ScatterView holds a copy of the node fields for every thread that may run at
  // once: a few on a CPU, hundreds of thousands on a GPU. On an H200 the Sod tube (800 nodes) took
  // 24 s instead of 0.1 s that way, and a grid of 1e5 cells would need terabytes.
  if (!std::is_same<MemorySpace, Kokkos::HostSpace>::value && config.numerics.p2g == P2GStrategy::duplicated)
    throw ConfigError(config.source + ": /numerics/p2g: \"duplicated\" keeps a copy of the grid for each GPU thread, "
                      "and this mpmflow runs on a GPU; expected \"automatic\" (atomic on GPUs), \"atomic\" or "
                      "\"sorted\"");
#ifndef MPMFLOW_HAVE_HDF5
  if (config.output.snapshots > 0)
    throw ConfigError(config.source + ": /output/snapshots: this mpmflow was built without HDF5, so it cannot "
                      "write output; expected 0 (run with --set output/snapshots=0), or rebuild with "
                      "-DMPMFLOW_ENABLE_HDF5=ON");
#endif
}

namespace {

// Conservation totals over all ranks.
ConservationTotals global_totals(const Solver& solver) {
  ConservationTotals totals = particle_totals(solver.particles());
  std::vector<double> values;
  totals.for_each_total([&](const char*, double value) { values.push_back(value); });
  solver.context().sum_in_place(values.data(), static_cast<int>(values.size()));
  size_t k = 0;
  totals.for_each_total([&](const char*, double& value) { value = values[k++]; });
  return totals;
}

// The fluxes through the open sides over all ranks.
BoundaryFluxes global_fluxes(const Solver& solver) {
  BoundaryFluxes fluxes = solver.open_sides().fluxes();
  std::vector<double> values;
  fluxes.for_each_flux([&](const std::string&, double value) { values.push_back(value); });
  solver.context().sum_in_place(values.data(), static_cast<int>(values.size()));
  size_t k = 0;
  fluxes.for_each_flux([&](const std::string&, double& value) { value = values[k++]; });
  return fluxes;
}

std::string describe_slabs(const SlabDecomposition& d) {
  std::ostringstream out;
  out << (d.axis == 0 ? "x" : "y") << " cells";
  for (int r = 0; r < d.num_ranks(); ++r) out << (r ? ", " : " ") << "[" << d.begin(r) << "," << d.end(r) << ")";
  return out.str();
}

// Where stdout of ranks other than 0 goes.
class NullBuffer : public std::streambuf {
 protected:
  int overflow(int c) override { return c; }
};

}  // namespace

namespace {
// The signal that asked the run to stop (0: none). A signal handler can do nothing but set a flag
// of this type, so it is the one variable of the program at namespace scope.
volatile std::sig_atomic_t stop_signal = 0;
extern "C" void request_stop(int signal_number) { stop_signal = signal_number; }

// SIGTERM and SIGINT set stop_signal while a run is in progress; the previous handlers return after.
class StopSignals {
 public:
  StopSignals() {
    stop_signal = 0;
    previous_term_ = std::signal(SIGTERM, request_stop);
    previous_int_ = std::signal(SIGINT, request_stop);
  }
  ~StopSignals() {
    std::signal(SIGTERM, previous_term_);
    std::signal(SIGINT, previous_int_);
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  void (*previous_term_)(int) = SIG_DFL;
  void (*previous_int_)(int) = SIG_DFL;
};

// Why a rank asks the run to stop early, as Solver::step_towards takes it: the ranks' largest
// request wins (a signal over the wall-time limit).
enum StopReason : int { no_stop = 0, wall_time_limit = 1, terminated = 2, interrupted = 3 };
StopReason stop_reason(bool near_wall_time_limit) {
  return stop_signal == SIGTERM ? terminated
         : stop_signal == SIGINT ? interrupted
         : near_wall_time_limit  ? wall_time_limit
                                 : no_stop;
}
const char* stop_reason_name(int reason) {
  return reason == terminated ? "SIGTERM" : reason == interrupted ? "SIGINT" : "the wall-time limit";
}
}  // namespace

RunSummary run_simulation(const CaseConfig& config, const RunOptions& options, std::ostream& root_log) {
  const StopSignals stop_signals;
  check_case_supported(config);
  ParallelContext context;
  context.gpu_aware = options.gpu_aware_mpi;
#ifdef MPMFLOW_HAVE_HDF5
  h5::silence_error_printing();  // its reasons go into mpmflow's own one-line errors
#endif
  NullBuffer null_buffer;
  std::ostream null_log(&null_buffer);
  std::ostream& log = context.is_root() ? root_log : null_log;

  // Where to start: t = 0 with equal slabs, or a checkpoint.
  RestartState restart;
  const bool restarting = !options.restart_file.empty();
  if (restarting) {
#ifdef MPMFLOW_HAVE_HDF5
    restart = read_checkpoint(options.restart_file, config, context);
#else
    throw CollectiveError("--restart needs HDF5, and this mpmflow was built without it");
#endif
  } else {
    restart.decomposition = SlabDecomposition::even(config, context.size());
    const SlabDecomposition& d = restart.decomposition;
    restart.particles = create_initial_particles(
        config, make_grid_slab(config.domain, d.axis, d.begin(context.rank()), d.end(context.rank())));
  }
  // The run's id: the checkpoint's on a restart (the same run goes on), a new one otherwise. Its
  // folder must not hold another run's files of the case (they would mix with its own, and
  // pruning or the tools would take one for the other).
  std::string run_id = restarting ? restart.clock.run_id : (context.is_root() ? new_run_id(config.name) : "");
  context.broadcast(run_id);
  {
    std::string conflict;
    if (context.is_root()) {
      try {
        const OtherRunFiles other = files_of_other_runs(config.output.directory, config.name, run_id);
        if (!other.files.empty() && options.overwrite) {
          remove_run_files(config.output.directory, config.name, other.files);
          log << "removed " << other.files.size() << " files of run " << (other.run_id.empty() ? "(unknown)" : other.run_id)
              << " from " << config.output.directory << " (--overwrite)\n";
        } else if (!other.files.empty()) {
          conflict = config.output.directory + " holds " + std::to_string(other.files.size()) + " files of another run of " +
                     config.name + " (run " + (other.run_id.empty() ? "of an older mpmflow" : other.run_id) + ", e.g. " +
                     other.files.front() + "); expected a folder without them: give --overwrite to remove them " +
                     "first, or another --output";
        }
      } catch (const std::exception& e) {
        conflict = e.what();
      }
    }
    context.broadcast(conflict);
    if (!conflict.empty()) throw ConfigError(conflict);
  }
  // (The move leaves `restart.particles` empty: the initial particles are the solver's alone.)
  Solver solver(config, context, restart.decomposition, std::move(restart.particles));
  solver.set_step_count(restart.clock.step);
  if (restarting) {
    solver.set_node_mass_threshold(static_cast<real_t>(restart.clock.node_mass_threshold));
    solver.open_sides().restore(restart.clock.entry_distance, restart.clock.fluxes);
    solver.restore_obstacle_impulse(restart.clock.obstacle_impulse);
    solver.splitting().restore(restart.clock.particle_splits);
  }
  const bool open_sides = config.boundaries.any_open();
  const long long n = solver.global_particle_count();
  if (n == 0)
    throw ConfigError(config.source + ": no gas in the domain: the obstacles (/obstacles) cover every particle's " +
                      "place; expected obstacles that leave room for the flow");
  const double end_time = config.time.end_time;

  if (options.print_banner) {
    log << build_description() << "\n";
    if (context.distributed())
      log << "MPI ranks " << context.size() << ", slabs along " << describe_slabs(solver.decomposition())
          << (config.decomposition.balance_interval > 0
                  ? ", rebalanced every " + std::to_string(config.decomposition.balance_interval) + " steps"
                  : std::string(", never rebalanced"))
          << (context.gpu_aware ? ", GPU-aware MPI" : "") << "\n";
    if (!options.device_description.empty()) log << options.device_description << "\n";
    log << "case " << config.name << " (" << config.source << "): " << config.domain.cells_x << " x "
        << config.domain.cells_y << " cells, " << n << " particles, t_end " << end_time << ", cfl "
        << config.time.cfl << "\n"
        << "numerics: shape function " << to_string(config.numerics.shape_function) << ", P2G "
        << to_string(solver.p2g_strategy()) << ", reorder every " << config.numerics.reorder_interval
        << " steps (0: never), kernels "
        << (!config.numerics.fused_kernels            ? "unfused"
            : solver.fuses_g2p_with_remap()             ? "fused (G2P + momentum remap P2G in one pass)"
                                                        : "fused, but G2P and the momentum remap P2G in two passes "
                                                          "(the sorted P2G gathers by blocks of nodes)")
        << "\n";
    if (restarting)
      log << "restart from " << restart.path << ": step " << restart.clock.step << ", t = " << restart.clock.time
          << "\n";
  }

  RunSummary summary;
  summary.num_particles = static_cast<long>(n);
  // The particle count at the last output (open sides change it), for the progress line's rate.
  long long current_particles = n;
  const int snapshots = config.output.snapshots;
#ifdef MPMFLOW_HAVE_HDF5
  // The run's files, listed as they are written (rank 0).
  std::unique_ptr<RunManifest> manifest;
  if (context.is_root() && (config.output.snapshots > 0 || config.output.checkpoint_interval > 0)) {
    create_output_directory(config.output.directory);
    manifest = std::make_unique<RunManifest>(config.output.directory, config.name, run_id);
  }
  std::unique_ptr<SnapshotWriter> writer;
  std::unique_ptr<DiagnosticsLog> diagnostics_log;
  if (snapshots > 0) {
    writer = std::make_unique<SnapshotWriter>(config.output.directory, config.name, context, run_id);
    if (context.is_root()) {
      diagnostics_log = std::make_unique<DiagnosticsLog>(config.output.directory + "/diagnostics.csv");
      if (restarting) diagnostics_log->resume(restart.clock.step);
    }
    summary.output_directory = config.output.directory;
  }
  const long checkpoint_interval = config.output.checkpoint_interval;
#endif
  auto snapshot_time = [&](int k) { return end_time * k / snapshots; };
  // The schedule is the case's (end time and snapshot count, which a restart may change): the
  // next snapshot is the first one scheduled after the checkpoint's time.
  int next_snapshot = restart.clock.next_snapshot;
  if (restarting && snapshots > 0) {
    next_snapshot = 1;
    while (next_snapshot < snapshots && snapshot_time(next_snapshot) <= restart.clock.time * (1 + 1e-12))
      ++next_snapshot;
  }
#ifdef MPMFLOW_HAVE_HDF5
  if (restarting && writer) writer->resume(next_snapshot);
#endif
  auto write_output = [&](double t, const ConservationTotals& totals, const BoundaryFluxes& fluxes) {
#ifdef MPMFLOW_HAVE_HDF5
    if (!writer) return;
    auto scope = solver.timers().scope(Phase::output);
    // The mean force on each obstacle since the previous output (collective: every rank takes it).
    const DiagnosticColumns forces = obstacle_force_columns(config, solver.take_mean_obstacle_forces());
    const std::string path = writer->write(next_snapshot, solver.step_count(), t, solver, totals, fluxes, forces);
    if (diagnostics_log) diagnostics_log->append(solver.step_count(), t, totals, fluxes, forces);
    if (manifest) {
      for (const std::string& name : {std::filesystem::path(path).filename().string(), config.name + "_particles.xmf",
                                      config.name + "_grid.xmf", config.name + "_grid_mesh.h5", std::string("diagnostics.csv")})
        manifest->add(name);
    }
    log << "  output " << next_snapshot << " at t = " << t << ": " << path << std::endl;
#else
    (void)t;
    (void)totals;
    (void)fluxes;
#endif
  };
  double t = restart.clock.time;
#ifdef MPMFLOW_HAVE_HDF5
  long last_checkpoint_step = -1;
#endif
  std::string last_checkpoint_path;
  double checkpoint_seconds = 0;  // how long the last checkpoint took to write
  auto write_checkpoint_now = [&](bool even_without_interval = false) {
#ifdef MPMFLOW_HAVE_HDF5
    if ((checkpoint_interval <= 0 && !even_without_interval) || last_checkpoint_step == solver.step_count()) return;
    Kokkos::Timer checkpoint_timer;
    auto scope = solver.timers().scope(Phase::checkpoint);
    RunClock clock{t, solver.step_count(), next_snapshot, summary.initial_totals, solver.node_mass_threshold()};
    clock.run_id = run_id;
    clock.entry_distance = solver.open_sides().entry_distance();
    clock.obstacle_impulse = solver.obstacle_impulse();
    clock.fluxes = solver.open_sides().fluxes();
    clock.particle_splits = solver.splitting().splits();
    const std::string path =
        write_checkpoint(config.output.directory, config.name, solver, clock, config.output.checkpoints_kept);
    last_checkpoint_step = solver.step_count();
    last_checkpoint_path = path;
    if (manifest) manifest->add(std::filesystem::path(path).filename().string());
    checkpoint_seconds = checkpoint_timer.seconds();
    log << "  checkpoint at step " << solver.step_count() << ", t = " << t << ": " << path << std::endl;
#endif
  };

  const ConservationTotals start_totals = global_totals(solver);
  summary.initial_totals = restarting ? restart.clock.initial_totals : start_totals;
  print_totals(log, restarting ? "restart" : "t = 0", start_totals, summary.initial_totals, global_fluxes(solver),
               open_sides);
  bool last_state_written = false;
  if (snapshots > 0 && !restarting) {
    write_output(0.0, summary.initial_totals, BoundaryFluxes{});
    next_snapshot = 1;
    last_state_written = true;
  }

  Kokkos::Timer wall;
  double last_report = 0;
  const long max_steps = config.time.max_steps;
  const long first_step = solver.step_count();
  size_t balance_reports_printed = 0;
  double first_stable_dt = 0;
  // This rank's reason to stop, from the end of the last step (a signal, or the wall-time limit
  // within reach): the next step's time step takes the ranks' largest in its own reduction, so that
  // every rank stops after the same step without a collective of its own. (A run whose last step
  // ends it, at t_end or max_steps, ends as asked.)
  StopReason stop_request = no_stop;
  while (t < end_time && (max_steps == 0 || solver.step_count() < max_steps)) {
    const double target = snapshots > 0 ? snapshot_time(next_snapshot) : end_time;
    const double t_before = t;
    try {
      t = solver.step_towards(t, target, stop_request);
      if (solver.stop_request() != no_stop) {
        summary.stopped_by = stop_reason_name(solver.stop_request());
        break;
      }
      last_state_written = false;
      if (snapshots > 0 && t == target) solver.check_state();
    } catch (const InvalidStateError& e) {
      // The outputs so far hold the last good state; the failed state is written after them, so
      // that it can be inspected (the bad particle shows where it happened), and the run stops.
      std::ostringstream msg;
      msg << e.what() << " (t = " << t << ")";
      if (snapshots > 0) {
        msg << "; the last good state is output " << next_snapshot - 1 << ", the failed state output "
            << next_snapshot << " in " << config.output.directory;
        write_output(t, global_totals(solver), global_fluxes(solver));
      }
      throw CollectiveError(msg.str());
    }
    // A step size that collapses (a blow-up in the making, or a case whose speeds are absurd:
    // a pressure of 1e300) would run forever: stop, naming the fastest particle (the nodes that set
    // the step are those it dominates, as a rule). The stable step is the same on every rank, and
    // so is the decision.
    const double stable_dt = solver.last_stable_time_step();
    if (first_stable_dt == 0) first_stable_dt = stable_dt;
    const double steps_left = (end_time - t) / stable_dt;
    if (!(stable_dt >= 1e-9 * first_stable_dt) || steps_left > 1e12) {
      std::ostringstream msg;
      msg << "the time step has collapsed: " << stable_dt << " after step " << solver.step_count() << " (t = " << t
          << "; the first step's was " << first_stable_dt << "), " << steps_left
          << " more steps to t_end; it is set by " << solver.describe_fastest_particle();
      throw CollectiveError(msg.str());
    }

    for (; balance_reports_printed < solver.balance_reports().size(); ++balance_reports_printed) {
      const BalanceReport& b = solver.balance_reports()[balance_reports_printed];
      log << "  load balance at step " << b.step << ": imbalance (max/mean particles per rank) "
          << std::setprecision(3) << b.imbalance_before << " -> " << b.imbalance_after << ", slabs along "
          << describe_slabs(b.decomposition) << std::setprecision(6) << std::endl;
    }
    if (snapshots > 0 && t == target) {
      const ConservationTotals totals = global_totals(solver);
      const BoundaryFluxes fluxes = global_fluxes(solver);
      print_totals(log, ("t = " + std::to_string(t)).c_str(), totals, summary.initial_totals, fluxes, open_sides);
      write_output(t, totals, fluxes);
      current_particles = solver.global_particle_count();
      ++next_snapshot;
      last_state_written = true;
    }
#ifdef MPMFLOW_HAVE_HDF5
    if (checkpoint_interval > 0 && solver.step_count() % checkpoint_interval == 0) write_checkpoint_now();
#endif
    const double elapsed = wall.seconds();
    // A signal, or the wall-time limit within reach (two more steps at the mean pace so far and a
    // checkpoint): every rank stops after the same step (the decision is taken together, by the
    // next step_towards).
    {
      const double seconds_per_step = elapsed / double(solver.step_count() - first_step);
      const bool near_limit = options.wall_time_seconds > 0 &&
                              elapsed + 2 * seconds_per_step + 2 * checkpoint_seconds + 1 > options.wall_time_seconds;
      stop_request = stop_reason(near_limit);
    }
    if (elapsed - last_report >= options.progress_interval_seconds) {
      last_report = elapsed;
      const double rate = double(current_particles) * (solver.step_count() - first_step) / elapsed;
      const double fraction = t / end_time;
      const double start_fraction = restart.clock.time / end_time;
      const double done = fraction - start_fraction;
      log << "step " << solver.step_count() << "  t " << std::setprecision(6) << t << "  dt " << std::setprecision(3)
          << t - t_before << "  " << std::fixed << std::setprecision(1) << 100 * fraction << "%  " << std::scientific
          << std::setprecision(2) << rate << " particle-steps/s  ETA "
          << format_seconds(done > 0 ? elapsed * (1 - fraction) / done : 0) << std::defaultfloat << std::endl;  // flushed: batch jobs log to files
    }
  }

  summary.final_totals = global_totals(solver);
  summary.final_fluxes = global_fluxes(solver);
  if (!summary.stopped_by.empty()) {
    // Stopped early: a checkpoint to continue from, and no snapshot off the schedule.
#ifdef MPMFLOW_HAVE_HDF5
    write_checkpoint_now(/*even_without_interval=*/true);
    summary.stop_checkpoint = last_checkpoint_path;
#endif
    log << "stopped by " << summary.stopped_by << " after step " << solver.step_count() << " (t = " << t
        << "); continue with: mpmflow run --restart " << summary.stop_checkpoint << "\n";
  } else if (!last_state_written && snapshots > 0) {
    write_output(t, summary.final_totals, summary.final_fluxes);
    ++next_snapshot;
  }
  write_checkpoint_now();
  summary.steps = solver.step_count();
  summary.end_time = t;
  summary.wall_seconds = wall.seconds();
  const long steps_run = summary.steps - first_step;
  const double particle_steps = double(solver.context().sum(solver.particle_steps()));
  summary.particle_steps_per_second = summary.wall_seconds > 0 ? particle_steps / summary.wall_seconds : 0;

  log << "done: " << summary.steps << " steps to t = " << t << " in " << format_seconds(summary.wall_seconds)
      << ", " << std::scientific << std::setprecision(3) << summary.particle_steps_per_second << std::defaultfloat
      << " particle-steps/s";
  if (context.distributed()) log << " on " << context.size() << " ranks";
  log << "\n";
  print_totals(log, "final", summary.final_totals, summary.initial_totals, summary.final_fluxes, open_sides);
  print_timer_table(log, solver.timers(), steps_run, context);
  if (!summary.output_directory.empty()) {
#ifdef MPMFLOW_HAVE_HDF5
    log << "output written to " << summary.output_directory << " (open " << writer->particles_xdmf_path()
        << " or " << writer->grid_xdmf_path() << " in ParaView)\n";
#endif
  }
  return summary;
}

}  // namespace mpmflow
