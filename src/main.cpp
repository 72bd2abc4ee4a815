// mpmflow command line:
//   [mpirun -np N] mpmflow run CASE.json [--output DIR] [--set json/path=value ...] [--progress-interval S]
//                               [--restart CHECKPOINT.h5] [--gpu-aware-mpi]
//   mpmflow riemann --left RHO,U,P --right RHO,U,P --x0 X --time T [--gamma G] [--x A,B] [--points N]
//   mpmflow --version | --help
// Kokkos options (--kokkos-threads=N / --kokkos-num-threads=N, ...) are passed through to Kokkos.
// Exit codes: 0 success, 1 runtime failure, 2 bad command line or bad case file. Under MPI every
// rank exits with the same code; rank 0 alone prints the error (an error met by one rank only
// aborts the job).
#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#ifdef MPMFLOW_HAVE_MPI
#include <mpi.h>
#endif

#if defined(KOKKOS_ENABLE_CUDA)
#include <cuda_runtime_api.h>
#elif defined(KOKKOS_ENABLE_HIP)
#include <hip/hip_runtime_api.h>
#endif

#include "case_config.hpp"
#include "exact_riemann.hpp"
#include "parallel.hpp"
#include "simulation.hpp"

namespace {

constexpr int kExitRuntimeError = 1;
constexpr int kExitUsage = 2;

const char* kUsage =
    "usage: [mpirun -np N] mpmflow run CASE.json [--output DIR] [--set json/path=value ...]\n"
    "                      [--progress-interval SECONDS] [--restart CHECKPOINT.h5] [--gpu-aware-mpi]\n"
    "       mpmflow riemann --left RHO,U,P --right RHO,U,P --x0 X --time T [--gamma G] [--x A,B] [--points N]\n"
    "       mpmflow --version\n"
    "       mpmflow --help\n"
    "\n"
    "  --output DIR            write outputs to DIR (overrides output/directory)\n"
    "  --set PATH=VALUE        override a case-file value, e.g. --set domain/cells_x=400\n"
    "                          (VALUE is JSON; anything that is not JSON is taken as a string)\n"
    "  --progress-interval S   seconds of wall time between progress lines (default 2)\n"
    "  --restart FILE          continue from a checkpoint (output/checkpoint_interval writes them)\n"
    "  --gpu-aware-mpi         pass GPU buffers to MPI directly (default: staged through host memory)\n"
    "  Under mpirun each rank runs one slab of the grid (case key decomposition) and drives one GPU\n"
    "  of its node (chosen from its node-local rank).\n"
    "  Kokkos options such as --kokkos-threads=N are passed to Kokkos.\n"
    "  riemann prints the exact solution of a 1D Riemann problem (Toro) as CSV x,density,velocity,pressure\n"
    "  (defaults: gamma 1.4, x in [0,1], 1001 points); the plotting tool draws it beside a run.\n";

struct CommandLine {
  std::string command;
  std::vector<std::string> arguments;  // of the riemann command
  std::string case_file;
  std::string output_directory;
  std::vector<std::string> overrides;
  double progress_interval = 2.0;
  std::string restart_file;
  bool gpu_aware_mpi = false;
};

struct UsageError {
  std::string message;
};

CommandLine parse_command_line(const std::vector<std::string>& args) {
  CommandLine cl;
  if (args.empty()) throw UsageError{"no command given"};
  cl.command = args[0];
  if (cl.command == "--help" || cl.command == "-h" || cl.command == "--version") return cl;
  if (cl.command == "riemann") {
    cl.arguments.assign(args.begin() + 1, args.end());
    return cl;
  }
  if (cl.command != "run") throw UsageError{"unknown command '" + cl.command + "'"};
  for (size_t i = 1; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&](const std::string& option) -> std::string {
      if (i + 1 >= args.size()) throw UsageError{option + " needs a value"};
      return args[++i];
    };
    if (a == "--output") cl.output_directory = value(a);
    else if (a == "--restart") cl.restart_file = value(a);
    else if (a == "--gpu-aware-mpi") cl.gpu_aware_mpi = true;
    else if (a == "--set") cl.overrides.push_back(value(a));
    else if (a == "--progress-interval") {
      const std::string v = value(a);
      char* end = nullptr;
      cl.progress_interval = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end != '\0' || !(cl.progress_interval >= 0))
        throw UsageError{"--progress-interval expects a number of seconds >= 0; got '" + v + "'"};
    } else if (a.size() > 1 && a[0] == '-') throw UsageError{"unknown option '" + a + "'"};
    else if (cl.case_file.empty()) cl.case_file = a;
    else throw UsageError{"more than one case file: '" + cl.case_file + "' and '" + a + "'"};
  }
  if (cl.case_file.empty()) throw UsageError{"run needs a case file"};
  return cl;
}

// Numbers separated by commas, exactly `count` of them.
std::vector<double> parse_numbers(const std::string& option, const std::string& text, size_t count) {
  std::vector<double> values;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0') break;
    values.push_back(v);
    start = comma + 1;
  }
  if (values.size() != count)
    throw UsageError{option + " expects " + std::to_string(count) + " comma-separated numbers; got '" + text + "'"};
  return values;
}

int print_riemann_solution(const std::vector<std::string>& args) {
  std::vector<double> left, right, x_range = {0, 1};
  double x0 = 0, time = 0, gamma = 1.4, points = 1001;
  bool has_x0 = false, has_time = false;
  for (size_t i = 0; i < args.size(); ++i) {
    if (i + 1 >= args.size()) throw UsageError{args[i] + " needs a value"};
    const std::string& option = args[i];
    const std::string& value = args[++i];
    if (option == "--left") left = parse_numbers(option, value, 3);
    else if (option == "--right") right = parse_numbers(option, value, 3);
    else if (option == "--x") x_range = parse_numbers(option, value, 2);
    else if (option == "--x0") x0 = parse_numbers(option, value, 1)[0], has_x0 = true;
    else if (option == "--time") time = parse_numbers(option, value, 1)[0], has_time = true;
    else if (option == "--gamma") gamma = parse_numbers(option, value, 1)[0];
    else if (option == "--points") points = parse_numbers(option, value, 1)[0];
    else throw UsageError{"riemann: unknown option '" + option + "'"};
  }
  if (left.empty() || right.empty() || !has_x0 || !has_time)
    throw UsageError{"riemann needs --left, --right, --x0 and --time"};
  if (!(left[0] > 0 && left[2] > 0 && right[0] > 0 && right[2] > 0 && gamma > 1 && time >= 0 && points >= 2))
    throw UsageError{"riemann expects positive densities and pressures, gamma > 1, time >= 0 and points >= 2"};
  const mpmflow::ExactRiemannSolver exact({left[0], left[1], left[2]}, {right[0], right[1], right[2]}, gamma);
  std::cout << "x,density,velocity,pressure\n";
  std::cout.precision(10);
  const int n = static_cast<int>(points);
  for (int k = 0; k < n; ++k) {
    const double x = x_range[0] + (x_range[1] - x_range[0]) * k / (n - 1);
    const mpmflow::PrimitiveState1D s = exact.solution(x, time, x0);
    std::cout << x << "," << s.density << "," << s.velocity << "," << s.pressure << "\n";
  }
  return 0;
}

// Rank 0 reads the case file (and any points file it names) and hands the text to the other
// ranks, which parse the same text: a bad input is reported once, by rank 0, and every rank
// then stops with a ConfigError.
mpmflow::CaseConfig load_case_on_root(const CommandLine& cl, const mpmflow::ParallelContext& context) {
  std::string error, text, files;
  mpmflow::CaseConfig config;
  if (context.is_root()) {
    try {
      text = mpmflow::load_case_document(cl.case_file, cl.overrides);
      mpmflow::PointsFiles points;
      config = mpmflow::parse_case(text, cl.case_file, &points);
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
    config = mpmflow::parse_case(text, cl.case_file, &points);
  }
  if (!cl.output_directory.empty()) config.output.directory = cl.output_directory;
  mpmflow::check_case_supported(config);
  return config;
}

int run(const CommandLine& cl, const mpmflow::ParallelContext& context, const std::string& device) {
  if (cl.command == "riemann") return print_riemann_solution(cl.arguments);
  if (cl.command == "--help" || cl.command == "-h") {
    if (context.is_root()) std::cout << kUsage;
    return 0;
  }
  if (cl.command == "--version") {
    if (context.is_root()) std::cout << mpmflow::build_description() << "\n";
    return 0;
  }
  const mpmflow::CaseConfig config = load_case_on_root(cl, context);
  mpmflow::RunOptions options;
  options.progress_interval_seconds = cl.progress_interval;
  options.restart_file = cl.restart_file;
  options.gpu_aware_mpi = cl.gpu_aware_mpi;
  options.device_description = device;
  mpmflow::run_simulation(config, options, std::cout);
  return 0;
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
#ifdef MPMFLOW_HAVE_MPI
  MPI_Init(&argc, &argv);
#endif
  int status = 0;
  {
    const mpmflow::ParallelContext context;
    std::vector<std::string> kokkos_args(argv, argv + argc);
    const std::string device = choose_device(kokkos_args, context);
    std::vector<char*> kokkos_argv;
    for (std::string& a : kokkos_args) kokkos_argv.push_back(&a[0]);
    int kokkos_argc = static_cast<int>(kokkos_argv.size());
    Kokkos::initialize(kokkos_argc, kokkos_argv.data());  // removes the --kokkos-* options it recognises
    {
      std::vector<std::string> args(kokkos_argv.begin() + 1, kokkos_argv.begin() + kokkos_argc);
      const bool root = context.is_root();
      try {
        status = run(parse_command_line(args), context, device);
      } catch (const UsageError& e) {
        if (root) std::cerr << "mpmflow: error: " << e.message << "\n" << kUsage;
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
    }
    Kokkos::finalize();
  }
#ifdef MPMFLOW_HAVE_MPI
  MPI_Finalize();
#endif
  return status;
}
