// mpmflow command line:
//   mpmflow run CASE.json [--output DIR] [--set json/path=value ...] [--progress-interval S]
//   mpmflow riemann --left RHO,U,P --right RHO,U,P --x0 X --time T [--gamma G] [--x A,B] [--points N]
//   mpmflow --version | --help
// Kokkos options (--kokkos-threads=N / --kokkos-num-threads=N, ...) are passed through to Kokkos.
// Exit codes: 0 success, 1 runtime failure, 2 bad command line or bad case file.
#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#ifdef MPMFLOW_HAVE_MPI
#include <mpi.h>
#endif

#include "case_config.hpp"
#include "exact_riemann.hpp"
#include "simulation.hpp"

namespace {

constexpr int kExitRuntimeError = 1;
constexpr int kExitUsage = 2;

const char* kUsage =
    "usage: mpmflow run CASE.json [--output DIR] [--set json/path=value ...] [--progress-interval SECONDS]\n"
    "       mpmflow riemann --left RHO,U,P --right RHO,U,P --x0 X --time T [--gamma G] [--x A,B] [--points N]\n"
    "       mpmflow --version\n"
    "       mpmflow --help\n"
    "\n"
    "  --output DIR            write outputs to DIR (overrides output/directory)\n"
    "  --set PATH=VALUE        override a case-file value, e.g. --set domain/cells_x=400\n"
    "                          (VALUE is JSON; anything that is not JSON is taken as a string)\n"
    "  --progress-interval S   seconds of wall time between progress lines (default 2)\n"
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

int run(const CommandLine& cl) {
  if (cl.command == "riemann") return print_riemann_solution(cl.arguments);
  if (cl.command == "--help" || cl.command == "-h") {
    std::cout << kUsage;
    return 0;
  }
  if (cl.command == "--version") {
    std::cout << mpmflow::build_description() << "\n";
    return 0;
  }
  mpmflow::CaseConfig config;
  try {
    config = mpmflow::load_case_file(cl.case_file, cl.overrides);
    if (!cl.output_directory.empty()) config.output.directory = cl.output_directory;
    mpmflow::check_case_supported(config);
  } catch (const mpmflow::ConfigError& e) {
    std::cerr << "mpmflow: error: " << e.what() << "\n";
    return kExitUsage;
  }
  mpmflow::RunOptions options;
  options.progress_interval_seconds = cl.progress_interval;
  mpmflow::run_simulation(config, options, std::cout);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
#ifdef MPMFLOW_HAVE_MPI
  MPI_Init(&argc, &argv);
  int num_ranks = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &num_ranks);
#endif
  int status = 0;
  Kokkos::initialize(argc, argv);  // removes the --kokkos-* options it recognises
  {
    std::vector<std::string> args(argv + 1, argv + argc);
    try {
#ifdef MPMFLOW_HAVE_MPI
      if (num_ranks > 1)
        throw std::runtime_error("this mpmflow runs on one MPI rank only (the slab decomposition is not built "
                                 "yet); started on " + std::to_string(num_ranks) + " ranks");
#endif
      status = run(parse_command_line(args));
    } catch (const UsageError& e) {
      std::cerr << "mpmflow: error: " << e.message << "\n" << kUsage;
      status = kExitUsage;
    } catch (const std::exception& e) {
      std::cerr << "mpmflow: error: " << e.what() << "\n";
      status = kExitRuntimeError;
    }
  }
  Kokkos::finalize();
#ifdef MPMFLOW_HAVE_MPI
  MPI_Finalize();
#endif
  return status;
}
