// mpmflow command line (CLI11): subcommands run, case and riemann, each with its own --help;
// `mpmflow --help` and `mpmflow --version` need no case. Options starting with --kokkos- are
// taken out before parsing and passed to Kokkos, which is initialised only for `run`, after the
// command line has been parsed (so --help and --version print nothing of Kokkos).
// Exit codes: 0 success, 1 runtime failure, 2 bad command line or bad case file, 3 stopped early
// (SIGTERM, SIGINT, --wall-time) with a checkpoint to continue from. Under MPI every
// rank exits with the same code; rank 0 alone prints the error (an error met by one rank only
// aborts the job).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#ifdef MPMFLOW_HAVE_MPI
#include <mpi.h>
#endif

#if defined(KOKKOS_ENABLE_CUDA)
#include <cuda_runtime_api.h>
#elif defined(KOKKOS_ENABLE_HIP)
#include <hip/hip_runtime_api.h>
#endif

#include "case_config.hpp"
#include "checkpoint.hpp"
#include "exact_riemann.hpp"
#include "host_memory.hpp"
#include "parallel.hpp"
#include "simulation.hpp"

namespace {

constexpr int kExitRuntimeError = 1;
constexpr int kExitUsage = 2;
// Stopped before the end by SIGTERM, SIGINT or --wall-time, after writing a checkpoint: the job
// is to be continued with --restart (a batch script can test for it).
constexpr int kExitStoppedEarly = 3;

struct CommandLine {
  std::string case_file;
  std::string output_directory;
  std::vector<std::string> overrides;
  double progress_interval = 2.0;
  std::string restart_file;
  bool gpu_aware_mpi = false;
  bool overwrite = false;
  double wall_time_seconds = 0;
  double max_memory_gb = 0;
  // riemann
  std::vector<double> left, right, x_range = {0, 1};
  double x0 = 0, time = 0, gamma = 1.4;
  int points = 1001;
};

struct UsageError {
  std::string message;
};

// The exact solution of the riemann command's problem, as CSV.
int print_riemann_solution(const CommandLine& cl) {
  const std::vector<double>& left = cl.left;
  const std::vector<double>& right = cl.right;
  if (!(left[0] > 0 && left[2] > 0 && right[0] > 0 && right[2] > 0))
    throw UsageError{"riemann expects positive densities and pressures in --left and --right RHO,U,P"};
  if (!(cl.x_range[0] < cl.x_range[1])) throw UsageError{"riemann --x expects A,B with A < B"};
  const mpmflow::ExactRiemannSolver exact({left[0], left[1], left[2]}, {right[0], right[1], right[2]}, cl.gamma);
  std::cout << "x,density,velocity,pressure\n";
  std::cout.precision(10);
  for (int k = 0; k < cl.points; ++k) {
    const double x = cl.x_range[0] + (cl.x_range[1] - cl.x_range[0]) * k / (cl.points - 1);
    const mpmflow::PrimitiveState1D s = exact.solution(x, cl.time, cl.x0);
    std::cout << x << "," << s.density << "," << s.velocity << "," << s.pressure << "\n";
  }
  return 0;
}

// Rank 0 reads the case file (and any points file it names) and hands the text to the other
// ranks, which parse the same text: a bad input is reported once, by rank 0, and every rank
// then stops with a ConfigError.
// What a case came from, for messages: its file, or the checkpoint it was taken from.
std::string source_of(const CommandLine& cl) { return cl.case_file.empty() ? cl.restart_file : cl.case_file; }

// Under mpirun every rank must be given the same command line (a rank given another --output
// would wait for the others in a collective write for ever): compared with rank 0's, and a
// difference stops every rank, naming the first rank that differs.
void check_same_command_line(const CommandLine& cl, const mpmflow::ParallelContext& context) {
  if (!context.distributed()) return;
  std::string mine = cl.case_file + '\n' + cl.output_directory + '\n' + cl.restart_file + '\n' +
                     std::to_string(cl.wall_time_seconds) + '\n' + std::to_string(cl.max_memory_gb) + '\n' +
                     (cl.overwrite ? "overwrite" : "") + '\n';
  for (const std::string& o : cl.overrides) mine += o + '\n';
  std::string root = mine;
  context.broadcast(root);
  const int first_different = static_cast<int>(context.min(root == mine ? context.size() : context.rank()));
  if (first_different < context.size())
    throw mpmflow::ConfigError("rank " + std::to_string(first_different) +
                               " was given another command line than rank 0 (case file, --output, --restart, --set, "
                               "--wall-time or --overwrite); expected the same on every rank");
}

// --restart FOLDER: the newest checkpoint in it (newest_checkpoint_in), chosen by rank 0 for every
// rank. After check_same_command_line, which compares what the ranks were given.
void resolve_restart_folder(CommandLine& cl, const mpmflow::ParallelContext& context) {
#ifdef MPMFLOW_HAVE_HDF5
  std::string error, path = cl.restart_file;
  std::error_code not_a_folder;
  if (context.is_root() && !path.empty() && std::filesystem::is_directory(path, not_a_folder)) {
    try {
      path = mpmflow::newest_checkpoint_in(path);
    } catch (const mpmflow::ConfigError& e) {
      error = e.what();
    }
  }
  context.broadcast(error);
  if (!error.empty()) throw mpmflow::ConfigError(error);
  context.broadcast(path);
  cl.restart_file = path;
#else
  (void)cl;
  (void)context;
#endif
}

mpmflow::CaseConfig load_case_on_root(const CommandLine& cl, const mpmflow::ParallelContext& context) {
  std::string error, text, files;
  mpmflow::CaseConfig config;
  if (context.is_root()) {
    try {
#ifdef MPMFLOW_HAVE_HDF5
      // No case file with --restart: the case the checkpoint was written with.
      if (cl.case_file.empty() && !cl.restart_file.empty())
        text = mpmflow::apply_overrides(mpmflow::read_checkpoint_case(cl.restart_file), cl.restart_file, cl.overrides);
      else
#endif
        text = mpmflow::load_case_document(cl.case_file, cl.overrides);
      mpmflow::PointsFiles points;
      config = mpmflow::parse_case(text, source_of(cl), &points);
      files = points.serialise();
    } catch (const mpmflow::ConfigError& e) {
      error = e.what();
    }
  }
  context.broadcast(error);
  if (!error.empty()) throw mpmflow::ConfigError(error);
  context.broadcast(text);
  context.broadcast(files);
  if (!context.is_root()) {
    mpmflow::PointsFiles points = mpmflow::PointsFiles::deserialise(files);
    config = mpmflow::parse_case(text, source_of(cl), &points);
  }
  if (!cl.output_directory.empty()) config.output.directory = cl.output_directory;
  mpmflow::check_case_supported(config);
  mpmflow::check_memory(config, context.size(), cl.max_memory_gb * 1e9);
  return config;
}

int run_case(const CommandLine& cl, const mpmflow::CaseConfig& config, const std::string& device) {
  mpmflow::RunOptions options;
  options.progress_interval_seconds = cl.progress_interval;
  options.restart_file = cl.restart_file;
  options.gpu_aware_mpi = cl.gpu_aware_mpi;
  options.device_description = device;
  options.wall_time_seconds = cl.wall_time_seconds;
  options.overwrite = cl.overwrite;
  const mpmflow::RunSummary summary = mpmflow::run_simulation(config, options, std::cout);
  return summary.stopped_by.empty() ? 0 : kExitStoppedEarly;
}

// The subcommands and their options, bound to `cl`.
void define_command_line(CLI::App& app, CommandLine& cl) {
  app.require_subcommand(1);
  app.set_version_flag("--version", mpmflow::version_description(), "print the version and build, then exit");
  app.footer(
      "Kokkos options (--kokkos-threads=N, --kokkos-device-id=N, ...; see the Kokkos documentation) are passed to\n"
      "Kokkos. Exit codes: 0 success, 1 runtime failure, 2 bad command line or case file, 3 stopped early\n"
      "(SIGTERM, SIGINT, --wall-time) with a checkpoint to continue from.");

  CLI::App* run = app.add_subcommand("run", "run a case: [mpirun -np N] mpmflow run CASE.json [options]");
  run->add_option("CASE", cl.case_file, "the case file (JSON); with --restart, by default the checkpoint's own case");
  run->add_option("--output", cl.output_directory, "write outputs to DIR (overrides output/directory)")
      ->type_name("DIR");
  run->add_option("--set", cl.overrides,
                  "override a case-file value, e.g. --set domain/cells_x=400 (VALUE is JSON; anything that is "
                  "not JSON is taken as a string); repeatable")
      ->type_name("PATH=VALUE")
      ->take_all()
      ->expected(1);
  run->add_option("--progress-interval", cl.progress_interval, "seconds of wall time between progress lines")
      ->type_name("SECONDS")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  run->add_option("--restart", cl.restart_file,
                  "continue from a checkpoint (output/checkpoint_interval writes them), or from the newest "
                  "checkpoint in a folder")
      ->type_name("CHECKPOINT.h5|FOLDER");
  run->add_option_function<std::string>(
         "--wall-time",
         [&cl](const std::string& text) {
           int h = 0, m = 0, s = 0;
           char extra = 0;
           if (std::sscanf(text.c_str(), "%d:%d:%d%c", &h, &m, &s, &extra) != 3 || h < 0 || m < 0 || m > 59 || s < 0 ||
               s > 59 || h * 3600 + m * 60 + s == 0)
             throw CLI::ValidationError("--wall-time", "expected HH:MM:SS (more than zero); got '" + text + "'");
           cl.wall_time_seconds = h * 3600.0 + m * 60.0 + s;
         },
         "stop before this much wall time, with a checkpoint to continue from (exit code 3); as the batch "
         "job's limit, minus a margin")
      ->type_name("HH:MM:SS");
  run->add_option("--max-memory", cl.max_memory_gb,
                  "refuse a case needing more than this many GB per rank (default: the machine's memory)")
      ->type_name("GB")
      ->check(CLI::PositiveNumber);
  run->add_flag("--overwrite", cl.overwrite,
                "remove another run's files of the case from the output folder first (a run refuses to mix "
                "with them otherwise)");
  run->add_flag("--gpu-aware-mpi", cl.gpu_aware_mpi,
                "pass GPU buffers to MPI directly (default: staged through host memory)");
  run->footer(
      "Under mpirun each rank runs one slab of the grid (case key decomposition) and drives one GPU of its node\n"
      "(chosen from its node-local rank). SIGTERM, SIGINT or --wall-time stop the run after the current step with a\n"
      "checkpoint (exit code 3); mpmflow run --restart CHECKPOINT.h5 continues it.");

  CLI::App* show = app.add_subcommand(
      "case", "print the effective case (after --set, with every default) as JSON: mpmflow case CASE.json [--set ...]");
  show->add_option("CASE", cl.case_file, "the case file (JSON)")->required();
  show->add_option("--set", cl.overrides, "override a case-file value, as for run; repeatable")
      ->type_name("PATH=VALUE")
      ->take_all()
      ->expected(1);

  CLI::App* riemann = app.add_subcommand(
      "riemann", "print the exact solution of a 1D Riemann problem (Toro) as CSV x,density,velocity,pressure");
  riemann->add_option("--left", cl.left, "left state")->type_name("RHO,U,P")->delimiter(',')->expected(3)->required();
  riemann->add_option("--right", cl.right, "right state")->type_name("RHO,U,P")->delimiter(',')->expected(3)->required();
  riemann->add_option("--x0", cl.x0, "position of the initial discontinuity")->type_name("X")->required();
  riemann->add_option("--time", cl.time, "time of the solution")->type_name("T")->check(CLI::NonNegativeNumber)->required();
  riemann->add_option("--gamma", cl.gamma, "ratio of specific heats")->check(CLI::Range(1.0 + 1e-12, 1e6))
      ->capture_default_str();
  riemann->add_option("--x", cl.x_range, "interval sampled")->type_name("A,B")->delimiter(',')->expected(2)
      ->capture_default_str();
  riemann->add_option("--points", cl.points, "points sampled")->check(CLI::Range(2, 100000000))->capture_default_str();
  riemann->footer("The plotting tool (tools/mpmflow_plot.py sod) draws it beside a run.");
}

// --kokkos-threads and --kokkos-num-threads take a positive integer; Kokkos aborts on anything else.
void check_kokkos_arguments(const std::vector<std::string>& kokkos_args) {
  for (const std::string& a : kokkos_args) {
    for (const char* option : {"--kokkos-threads=", "--kokkos-num-threads="}) {
      if (a.rfind(option, 0) != 0) continue;
      const std::string value = a.substr(std::strlen(option));
      char* end = nullptr;
      const long n = std::strtol(value.c_str(), &end, 10);
      if (value.empty() || *end != '\0' || n < 1 || n > 1000000)
        throw UsageError{std::string(option, std::strlen(option) - 1) + " expects a positive integer; got '" + value + "'"};
    }
  }
}

// On a GPU build, each rank of a node drives its own GPU: the node-local rank (from a
// shared-memory communicator) modulo the GPUs the node has, unless the user chose with
// --kokkos-device-id. Returns the banner line.
std::string choose_device(std::vector<std::string>& kokkos_args, const mpmflow::ParallelContext& context) {
#if defined(KOKKOS_ENABLE_CUDA) || defined(KOKKOS_ENABLE_HIP)
  int local_rank = 0;
#ifdef MPMFLOW_HAVE_MPI
  if (context.distributed()) {
    MPI_Comm node;
    MPI_Comm_split_type(context.comm(), MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
    MPI_Comm_rank(node, &local_rank);
    MPI_Comm_free(&node);
  }
#endif
  int devices = 0;
#if defined(KOKKOS_ENABLE_CUDA)
  if (cudaGetDeviceCount(&devices) != cudaSuccess) devices = 0;
#else
  if (hipGetDeviceCount(&devices) != hipSuccess) devices = 0;
#endif
  for (const std::string& a : kokkos_args)
    if (a.rfind("--kokkos-device-id", 0) == 0 || a.rfind("--kokkos-map-device-id-by", 0) == 0)
      return "rank " + std::to_string(context.rank()) + ": GPU chosen on the command line (" + a + ")";
  if (devices <= 0) return "rank " + std::to_string(context.rank()) + ": no GPU visible";
  const int device = local_rank % devices;
  kokkos_args.push_back("--kokkos-device-id=" + std::to_string(device));
  return "rank " + std::to_string(context.rank()) + " (node-local rank " + std::to_string(local_rank) +
         ") drives GPU " + std::to_string(device) + " of " + std::to_string(devices);
#else
  (void)kokkos_args;
  (void)context;
  return "";
#endif
}

}  // namespace

int main(int argc, char** argv) {
  mpmflow::reuse_freed_host_memory();  // before any large allocation (host_memory.hpp)
#ifdef MPMFLOW_HAVE_MPI
  MPI_Init(&argc, &argv);
#endif
  int status = 0;
  {
    const mpmflow::ParallelContext context;
    const bool root = context.is_root();
    // The --kokkos-* options go to Kokkos; the rest to the command line.
    std::vector<std::string> kokkos_args = {argc > 0 ? argv[0] : "mpmflow"}, args;
    for (int i = 1; i < argc; ++i)
      (std::strncmp(argv[i], "--kokkos-", 9) == 0 ? kokkos_args : args).push_back(argv[i]);
    CommandLine cl;
    CLI::App app{"mpmflow: a Material Point Method solver for 2D compressible gas dynamics (Kokkos)", "mpmflow"};
    define_command_line(app, cl);
    bool parsed = false;
    try {
      std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes them in reverse
      app.parse(reversed);
      check_kokkos_arguments(kokkos_args);
      parsed = true;
    } catch (const CLI::ParseError& e) {
      // --help and --version arrive here too, with exit code 0.
      std::ostringstream out, err;
      status = app.exit(e, out, err) == 0 ? 0 : kExitUsage;
      if (root) {
        std::cout << out.str();
        if (status != 0) std::cerr << "mpmflow: error: " << err.str();
      }
    } catch (const UsageError& e) {
      if (root) std::cerr << "mpmflow: error: " << e.message << "\n";
      status = kExitUsage;
    }
    if (parsed) {
      const bool run = app.got_subcommand("run");
      bool kokkos_initialized = false;
      try {
        if (run) {
          // The case is read and checked first: a bad case is reported before Kokkos says anything.
          if (app.get_subcommand("run")->count("--restart") > 0 && cl.restart_file.empty())
            throw UsageError{"--restart expects a checkpoint file; got an empty name"};
          if (cl.case_file.empty() && cl.restart_file.empty())
            throw UsageError{"run needs a case file (CASE), or --restart CHECKPOINT.h5 (or a folder holding "
                             "checkpoints) to continue a run"};
          check_same_command_line(cl, context);
          resolve_restart_folder(cl, context);
          const mpmflow::CaseConfig config = load_case_on_root(cl, context);
          const std::string device = choose_device(kokkos_args, context);
          std::vector<char*> kokkos_argv;
          for (std::string& a : kokkos_args) kokkos_argv.push_back(&a[0]);
          int kokkos_argc = static_cast<int>(kokkos_argv.size());
          Kokkos::initialize(kokkos_argc, kokkos_argv.data());
          kokkos_initialized = true;
          status = run_case(cl, config, device);
        } else if (app.got_subcommand("case")) {
          check_same_command_line(cl, context);
          const mpmflow::CaseConfig config = load_case_on_root(cl, context);
          if (root) std::cout << mpmflow::effective_case_json(config) << "\n";
        } else {
          if (root) status = print_riemann_solution(cl);
        }
      } catch (const UsageError& e) {
        if (root) std::cerr << "mpmflow: error: " << e.message << "\n";
        status = kExitUsage;
      } catch (const mpmflow::ConfigError& e) {
        if (root) std::cerr << "mpmflow: error: " << e.what() << "\n";
        status = kExitUsage;
      } catch (const mpmflow::CollectiveError& e) {
        if (root) std::cerr << "mpmflow: error: " << e.what() << "\n";
        status = kExitRuntimeError;
      } catch (const std::exception& e) {
        std::cerr << "mpmflow: error";
        if (context.distributed()) std::cerr << " on rank " << context.rank();
        std::cerr << ": " << e.what() << "\n";
        status = kExitRuntimeError;
#ifdef MPMFLOW_HAVE_MPI
        // The other ranks may be waiting in a collective call: only an abort ends them.
        if (context.distributed()) MPI_Abort(context.comm(), status);
#endif
      }
      if (kokkos_initialized) Kokkos::finalize();
    }
  }
#ifdef MPMFLOW_HAVE_MPI
  MPI_Finalize();
#endif
  return status;
}
