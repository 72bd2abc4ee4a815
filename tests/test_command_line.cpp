// The mpmflow executable as a user drives it: exit codes, error messages, and what it writes.
#include <gtest/gtest.h>
#include <unistd.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "build_commit.hpp"
#include "kernels/types.hpp"
#ifdef MPMFLOW_HAVE_HDF5
#include "hdf5_io.hpp"
#endif
#include "test_files.hpp"

namespace {

namespace fs = std::filesystem;
using mpmflow::read_text;

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// A shell command's exit code and output (exit code -1 when it could not be started).
CommandResult run_command(const std::string& command) {
  CommandResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return result;
  char buffer[4096];
  while (size_t n = fread(buffer, 1, sizeof buffer, pipe)) result.output.append(buffer, n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

CommandResult run_mpmflow(const std::string& arguments, const fs::path& directory) {
  return run_command("cd '" + directory.string() + "' && '" + std::string(MPMFLOW_BINARY) + "' " + arguments + " 2>&1");
}

// A scratch directory holding a copy of cases/sod.json, edited by the test.
class CommandLine : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(testing::TempDir()) /
           ("mpmflow_cli_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
            std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    sod_text_ = read_text(fs::path(MPMFLOW_SOURCE_DIR) / "cases" / "sod.json");
  }
  void TearDown() override { fs::remove_all(dir_); }

  void write_case(const std::string& name, const std::string& text) { std::ofstream(dir_ / name) << text; }
  std::string sod_with(const std::string& from, const std::string& to) const {
    std::string text = sod_text_;
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return text.replace(at, from.size(), to);
  }
  // A bad case must fail with exit code 2, say `message`, and write nothing.
  void expect_rejected(const std::string& arguments, const std::string& message) {
    const CommandResult r = run_mpmflow(arguments + " --output out", dir_);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos) << "expected: " << message << "\ngot:\n" << r.output;
    EXPECT_FALSE(fs::exists(dir_ / "out")) << "an output directory was created for a rejected run";
    EXPECT_FALSE(fs::exists(dir_ / "output"));
  }

  fs::path dir_;
  std::string sod_text_;
};

TEST_F(CommandLine, VersionNamesKokkosAndExecutionSpace) {
  const CommandResult r = run_mpmflow("--version", dir_);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("mpmflow "), std::string::npos);
  EXPECT_NE(r.output.find("Kokkos "), std::string::npos);
  EXPECT_NE(r.output.find("execution space"), std::string::npos);
}

// The banner names the commit the sources are at now, not the one the build folder was configured
// at: the build rewrites it whenever it changed (cmake/MpmflowBuildCommit.cmake).
TEST_F(CommandLine, VersionNamesTheCommitOfTheSources) {
  const CommandResult git =
      run_command("git -C '" + std::string(MPMFLOW_SOURCE_DIR) + "' describe --always --dirty 2>/dev/null");
  if (git.exit_code != 0 || git.output.empty()) GTEST_SKIP() << "the sources are not a git checkout";
  const std::string commit = git.output.substr(0, git.output.find_last_not_of("\n") + 1);
  EXPECT_EQ(std::string(mpmflow::build_commit()), commit) << "built from other sources: rebuild";
  const CommandResult r = run_mpmflow("--version", dir_);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("mpmflow " MPMFLOW_VERSION " (" + commit + ")"), std::string::npos) << r.output;
}

TEST_F(CommandLine, UnknownKeyIsRejected) {
  write_case("case.json", sod_with("\"cfl\": 0.5", "\"cfl\": 0.5, \"cfll\": 1"));
  expect_rejected("run case.json", "case.json: /time/cfll: unknown key");
}

TEST_F(CommandLine, WrongTypeIsRejected) {
  write_case("case.json", sod_with("\"cells_x\": 100", "\"cells_x\": 100.5"));
  expect_rejected("run case.json", "case.json: /domain/cells_x: expected an integer");
}

TEST_F(CommandLine, OutOfRangeValueIsRejected) {
  write_case("case.json", sod_with("\"pressure\": 0.1", "\"pressure\": 0"));
  expect_rejected("run case.json", "case.json: /initial_state/background/pressure: expected a number > 0; got 0");
}

TEST_F(CommandLine, BadEnumIsRejected) {
  write_case("case.json", sod_with("\"left\": { \"type\": \"slip_wall\" }", "\"left\": { \"type\": \"wall\" }"));
  expect_rejected("run case.json", "case.json: /boundaries/left/type: expected one of slip_wall, inflow, outflow, far_field; got \"wall\"");
}

TEST_F(CommandLine, InvalidJsonAndMissingFileAreRejected) {
  write_case("case.json", sod_text_.substr(0, sod_text_.size() / 2));
  expect_rejected("run case.json", "case.json: not valid JSON");
  expect_rejected("run missing.json", "missing.json: cannot open the case file");
}

TEST_F(CommandLine, BadOverrideAndUsageErrorsAreRejected) {
  write_case("case.json", sod_text_);
  expect_rejected("run case.json --set domain/cells_x=-3", "case.json: /domain/cells_x: expected an integer");
  expect_rejected("run case.json --set cells_x", "expected PATH=VALUE");
  expect_rejected("run case.json --frobnicate", "mpmflow: error: The following argument was not expected: --frobnicate");
  expect_rejected("run", "mpmflow: error: run needs a case file (CASE), or --restart CHECKPOINT.h5");
  expect_rejected("run case.json --progress-interval soon", "--progress-interval");
  expect_rejected("run case.json --kokkos-threads=abc", "--kokkos-threads expects a positive integer; got 'abc'");
  expect_rejected("", "A subcommand is required");
  expect_rejected("riemann --left 1,0 --right 0.125,0,0.1 --x0 0.5 --time 0.2", "--left");
}

// Hostile and mistaken input: each refused with exit 2, one line naming the file and what was
// expected, nothing written, and quickly (none of these may grow memory or run for minutes).
TEST_F(CommandLine, HostileInputIsRefusedQuickly) {
  write_case("case.json", sod_text_);
  fs::create_directories(dir_ / "cases");
  expect_rejected("run cases", "cases: is a directory; expected a case file (JSON)");
  write_case("dup.json", sod_with("\"cfl\": 0.5", "\"cfl\": 0.5, \"cfl\": 0.4"));
  expect_rejected("run dup.json", "dup.json: the key \"cfl\" appears twice in one object");
  write_case("big.json", sod_with("\"end\": 0.143", "\"end\": 1e400"));
  expect_rejected("run big.json", "big.json: not valid JSON: [json.exception.out_of_range.406] number overflow");
  write_case("deep.json", std::string(100000, '[') + std::string(100000, ']'));
  expect_rejected("run deep.json", "deep.json: nested deeper than 32 levels");
  expect_rejected("run case.json --restart ''", "--restart expects a checkpoint file; got an empty name");
  expect_rejected("run case.json --set domain/cells_x=1048576 --set domain/cells_y=4096",
                  "case.json: /domain: 1048576 x 4096 cells with 3 x 1 particles per cell make 12884901888 particles; "
                  "expected at most 2^30");
  // 9e8 particles (within 2^30) need about 240 GB: refused before anything is allocated (on a
  // machine that has that much, the case would run, so the check is left out there).
  if (double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGESIZE)) < 200e9)
    expect_rejected("run case.json --set domain/cells_x=20000 --set domain/cells_y=15000",
                    "case.json: /domain: 20000 x 15000 cells and 900000000 particles need about");
  expect_rejected("run case.json --set domain/cells_x=10000 --max-memory 0.001", "--max-memory allows 0.001 GB");
  expect_rejected("run case.json --set 'initial_state/regions/0/x=[2,3]'",
                  "case.json: /initial_state/regions/0: expected a box overlapping the domain");
  expect_rejected("run case.json --set 'obstacles=[{\"type\": \"rectangle\", \"x\": [0, 1], \"y\": [0, 0.01]}]'",
                  "case.json: /obstacles/0 (rectangle): expected an obstacle with a surface inside the domain; "
                  "every edge lies on a side of the domain");
  expect_rejected("run case.json --set 'obstacles=[{\"type\": \"rectangle\", \"x\": [0, 0.5], \"y\": [0, 0.01]}, "
                  "{\"type\": \"rectangle\", \"x\": [0.5, 1], \"y\": [0, 0.01]}]'",
                  "case.json: no gas in the domain");
  expect_rejected("run case.json --set boundaries/left/type=inflow --set "
                  "'free_stream={\"density\": 1, \"pressure\": 1, \"velocity\": [-1, 0]}'",
                  "case.json: /boundaries/left: an inflow side needs the free stream to enter through it");
  expect_rejected("run case.json --set 'obstacles=[{\"type\": \"polygon\", \"file\": \"/dev/zero\"}]'",
                  "case.json: /obstacles/0/file: '/dev/zero' is not a regular file");
}

#ifdef MPMFLOW_HAVE_HDF5
// Files belong to a run: a second run into a folder holding the first run's files refuses (exit 2,
// nothing touched) unless told to remove them (--overwrite); the manifest names the run and lists
// its files.
TEST_F(CommandLine, ARunDoesNotMixWithAnotherRunsFiles) {
  write_case("case.json", sod_text_);
  const std::string run = "run case.json --output out --set domain/cells_x=20 --set output/snapshots=2 "
                          "--set output/checkpoint_interval=5 --set output/checkpoints_kept=0";
  ASSERT_EQ(run_mpmflow(run, dir_).exit_code, 0);
  size_t checkpoints = 0;
  for (const auto& entry : fs::directory_iterator(dir_ / "out"))
    checkpoints += entry.path().filename().string().find("_checkpoint_") != std::string::npos;
  ASSERT_GT(checkpoints, 2u);
  const std::string first_manifest = read_text(dir_ / "out" / "sod_manifest.json");
  EXPECT_NE(first_manifest.find("\"run_id\": \"sod-"), std::string::npos) << first_manifest;
  EXPECT_NE(first_manifest.find("\"sod_000002.h5\""), std::string::npos) << first_manifest;
  const auto first_write = fs::last_write_time(dir_ / "out" / "sod_000002.h5");

  const CommandResult again = run_mpmflow(run, dir_);
  EXPECT_EQ(again.exit_code, 2) << again.output;
  EXPECT_NE(again.output.find("files of another run of sod"), std::string::npos) << again.output;
  EXPECT_NE(again.output.find("give --overwrite"), std::string::npos) << again.output;
  EXPECT_EQ(fs::last_write_time(dir_ / "out" / "sod_000002.h5"), first_write);  // untouched
  EXPECT_EQ(read_text(dir_ / "out" / "sod_manifest.json"), first_manifest);
  size_t checkpoints_after = 0;  // none pruned by the refused run
  for (const auto& entry : fs::directory_iterator(dir_ / "out"))
    checkpoints_after += entry.path().filename().string().find("_checkpoint_") != std::string::npos;
  EXPECT_EQ(checkpoints_after, checkpoints);

  const CommandResult overwritten = run_mpmflow(run + " --overwrite", dir_);
  EXPECT_EQ(overwritten.exit_code, 0) << overwritten.output;
  EXPECT_NE(overwritten.output.find("files of run sod-"), std::string::npos) << overwritten.output;
  EXPECT_NE(read_text(dir_ / "out" / "sod_manifest.json"), first_manifest);  // a new run id
}

// Snapshots and checkpoints name the build that wrote them (attribute mpmflow_build).
TEST_F(CommandLine, FilesNameTheBuildThatWroteThem) {
  write_case("case.json", sod_text_);
  ASSERT_EQ(run_mpmflow("run case.json --output out --set domain/cells_x=20 --set output/snapshots=1 "
                        "--set output/checkpoint_interval=5",
                        dir_)
                .exit_code,
            0);
  std::vector<fs::path> files{dir_ / "out" / "sod_000001.h5"};
  for (const auto& entry : fs::directory_iterator(dir_ / "out"))
    if (entry.path().filename().string().find("_checkpoint_") != std::string::npos) files.push_back(entry.path());
  ASSERT_GE(files.size(), 2u) << "no checkpoint written";
  for (const fs::path& file : files) {
    namespace h5 = mpmflow::h5;
    h5::Handle h(h5::open_file_here(file.string()), H5Fclose, "open " + file.string());
    ASSERT_GT(H5Aexists(h, "mpmflow_build"), 0) << file;
    EXPECT_EQ(h5::read_string_attribute(h, "mpmflow_build"), mpmflow::build_identity()) << file;
  }
}

// The datasets `names` of a file that `write` wrote (h5::write_file_safely, in the temporary
// folder, removed after), each read whole as doubles, row after row.
std::map<std::string, std::vector<double>> written_and_read_back(const std::string& stem,
                                                                 const std::vector<std::string>& names,
                                                                 const std::function<void(hid_t)>& write) {
  namespace h5 = mpmflow::h5;
  const fs::path path = fs::temp_directory_path() / ("mpmflow_" + stem + "_" + std::to_string(getpid()) + ".h5");
  h5::write_file_safely(path.string(), mpmflow::ParallelContext::self(), write);
  std::map<std::string, std::vector<double>> read;
  {
    h5::Handle file(h5::open_file_here(path.string()), H5Fclose, "open " + path.string());
    for (const std::string& name : names) {
      h5::Handle set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose, "open " + name);
      h5::Handle space(H5Dget_space(set), H5Sclose, "dataspace of " + name);
      std::vector<double> values(static_cast<size_t>(H5Sget_simple_extent_npoints(space)));
      if (H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0)
        throw std::runtime_error("read " + name + " of " + path.string());
      read[name] = std::move(values);
    }
  }
  fs::remove(path);
  return read;
}

// A table written piece by piece (the snapshots' positions, velocities and vertices) holds each of
// this rank's rows in order at its place: pieces of 4 rows here, a last one of 2; and a table of no
// rows is written empty. (Two ranks of unequal rows write them in Output.XdmfInParaViewAndMeshio and
// Robustness.FullDiskLosesNothing.)
TEST(Hdf5Files, RowsWrittenInPiecesAreTheRowsInOrder) {
  namespace h5 = mpmflow::h5;
  const mpmflow::ParallelContext context = mpmflow::ParallelContext::self();
  const auto row_values = [](hsize_t k, double* row) {
    row[0] = double(k);
    row[1] = 10.0 * k;
    row[2] = 100.0 * k;
  };
  const auto read = written_and_read_back("rows", {"table", "empty"}, [&](hid_t file) {
    h5::write_rows_in_pieces<double>(file, "table", 17, 3, 5, 10, row_values, context, 4);
    h5::write_rows_in_pieces<long long>(file, "empty", 0, 1, 0, 0, [](hsize_t, long long*) {}, context, 4);
  });
  const std::vector<double>& values = read.at("table");
  ASSERT_EQ(values.size(), 17u * 3);
  for (int k = 0; k < 10; ++k)
    for (int c = 0; c < 3; ++c) {
      double expected[3];
      row_values(hsize_t(k), expected);
      EXPECT_EQ(values[size_t((5 + k) * 3 + c)], expected[c]) << "row " << 5 + k << ", column " << c;
    }
  EXPECT_TRUE(read.at("empty").empty());
}

// A rectangle of a 2D array of rows (the grid's nodes a slab owns, x fastest) written in pieces of
// whole runs lands in its own rows, row by row, and nowhere else; a piece shorter than a run still
// writes the run whole.
TEST(Hdf5Files, ARectangleWrittenInPiecesLandsInItsRows) {
  namespace h5 = mpmflow::h5;
  const mpmflow::ParallelContext context = mpmflow::ParallelContext::self();
  // A 6 x 5 array of rows of two values; the rectangle of 4 x 3 from (1, 1): row k of it is
  // (1 + k % 4, 1 + k / 4) of the array.
  const hsize_t width = 6, height = 5, run_length = 4, num_runs = 3, first = 1 + width * 1;
  const auto row_values = [](hsize_t k, double* row) {
    row[0] = 1.0 + double(k);
    row[1] = -1.0 - double(k);
  };
  const hsize_t piece_rows[] = {9, 2};  // two runs a piece, then one (fewer rows than a run)
  const auto read = written_and_read_back("rectangle", {"array0", "array1"}, [&](hid_t file) {
    for (int t = 0; t < 2; ++t)
      h5::write_rectangle_in_pieces<double>(file, ("array" + std::to_string(t)).c_str(), width * height, 2, first,
                                            run_length, num_runs, width, row_values, context, piece_rows[t]);
  });
  for (int t = 0; t < 2; ++t) {
    const std::vector<double>& values = read.at("array" + std::to_string(t));
    ASSERT_EQ(values.size(), width * height * 2);
    for (hsize_t j = 0; j < height; ++j)
      for (hsize_t i = 0; i < width; ++i) {
        const bool inside = i >= 1 && i < 1 + run_length && j >= 1 && j < 1 + num_runs;
        double expected[2] = {0.0, 0.0};  // (HDF5's fill value)
        if (inside) row_values((i - 1) + run_length * (j - 1), expected);
        for (int c = 0; c < 2; ++c)
          EXPECT_EQ(values[(i + width * j) * 2 + c], expected[c])
              << "pieces of " << piece_rows[t] << " rows: node (" << i << ", " << j << "), value " << c;
      }
  }
}
#endif

// A case whose speeds make the time step absurdly small stops at once, naming the particle that
// sets it, instead of running for ever. (A pressure of 1e30, a sound speed of 1e15: within a
// single-precision build's reals too, where 1e300 is refused at the case file.)
TEST_F(CommandLine, CollapsingTimeStepStopsNamingTheParticle) {
  write_case("case.json", sod_with("\"pressure\": 1.0, \"velocity\"", "\"pressure\": 1e30, \"velocity\""));
  const CommandResult r = run_mpmflow("run case.json --output out --set output/snapshots=0", dir_);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("the time step has collapsed"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("it is set by particle "), std::string::npos) << r.output;
}

// Each subcommand has its own --help (exit 0), and neither --help nor --version initialises Kokkos
// (whose own help and OpenMP binding warnings would otherwise come first).
TEST_F(CommandLine, HelpAndVersionExitZeroWithoutKokkos) {
  for (const char* arguments : {"--help", "run --help", "case --help", "riemann --help", "--version"}) {
    const CommandResult r = run_mpmflow(arguments, dir_);
    EXPECT_EQ(r.exit_code, 0) << arguments << "\n" << r.output;
    EXPECT_EQ(r.output.find("Kokkos::OpenMP"), std::string::npos) << arguments << "\n" << r.output;
    EXPECT_EQ(r.output.find("--kokkos-help"), std::string::npos) << arguments << "\n" << r.output;
    EXPECT_EQ(r.output.find("warning"), std::string::npos) << arguments << "\n" << r.output;
  }
  EXPECT_NE(run_mpmflow("run --help", dir_).output.find("--progress-interval"), std::string::npos);
  EXPECT_NE(run_mpmflow("riemann --help", dir_).output.find("--x0"), std::string::npos);
}

// `mpmflow case` prints the case as it would run, with every default, and that text is itself a
// case giving the same text again.
TEST_F(CommandLine, CasePrintsTheEffectiveCase) {
  write_case("case.json", sod_text_);
  const CommandResult r = run_mpmflow("case case.json --set domain/cells_x=37", dir_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("\"cells_x\": 37"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"shape_function\": \"gimp\""), std::string::npos) << r.output;  // a default
  EXPECT_NE(r.output.find("\"cfl\": 0.5"), std::string::npos) << r.output;
  write_case("effective.json", r.output);
  const CommandResult again = run_mpmflow("case effective.json", dir_);
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(again.output, r.output);
  const CommandResult bad = run_mpmflow("case case.json --set time/cfl=3", dir_);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.output.find("case.json: /time/cfl: expected a number in (0, 1]"), std::string::npos) << bad.output;
}

#ifdef MPMFLOW_HAVE_HDF5
TEST_F(CommandLine, RunWritesHdf5SnapshotsXdmfAndDiagnostics) {
  write_case("case.json", sod_text_);
  const CommandResult r =
      run_mpmflow("run case.json --output out --set domain/cells_x=20 --set output/snapshots=2", dir_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("particle-steps/s"), std::string::npos);
  EXPECT_NE(r.output.find("Time per phase"), std::string::npos);
  for (const char* name : {"sod_000000.h5", "sod_000001.h5", "sod_000002.h5", "sod_particles.xmf", "sod_grid.xmf",
                           "sod_000002_particles.xmf", "sod_000002_grid.xmf", "sod_grid_mesh.h5", "diagnostics.csv"})
    EXPECT_TRUE(fs::exists(dir_ / "out" / name)) << name;
  EXPECT_FALSE(fs::exists(dir_ / "out" / "sod_000003.h5"));
  for (const auto& entry : fs::directory_iterator(dir_ / "out"))
    EXPECT_NE(entry.path().extension(), ".tmp") << "temporary file left behind: " << entry.path();

  const std::string xdmf = read_text(dir_ / "out" / "sod_particles.xmf");
  EXPECT_NE(xdmf.find("<Time Value=\"0\"/>"), std::string::npos) << xdmf;
  EXPECT_NE(xdmf.find("<Time Value=\"0.0715\"/>"), std::string::npos) << xdmf;
  EXPECT_NE(xdmf.find("<Time Value=\"0.143\"/>"), std::string::npos) << xdmf;
  EXPECT_NE(xdmf.find("sod_000002.h5:/particles/density"), std::string::npos);
  // XDMF 3; vertex cells (a Polyvertex without connectivity shows nothing in ParaView); the grid
  // one node thick in z, so that readers put it in the XY plane.
  EXPECT_NE(xdmf.find("<Xdmf Version=\"3.0\">"), std::string::npos);
  EXPECT_NE(xdmf.find("sod_000002.h5:/particles/vertices"), std::string::npos);
  EXPECT_NE(read_text(dir_ / "out" / "sod_grid.xmf").find("TopologyType=\"3DCoRectMesh\" Dimensions=\"1 2 21\""),
            std::string::npos);

  // diagnostics.csv: a header and one line per output; the mass column never changes (to round-off:
  // particles that split are summed as two halves in another order).
  std::istringstream csv(read_text(dir_ / "out" / "diagnostics.csv"));
  std::string line, first_mass;
  int rows = -1;
  while (std::getline(csv, line)) {
    if (++rows == 0) continue;
    std::istringstream fields(line);
    std::string step, time, mass;
    std::getline(fields, step, ',');
    std::getline(fields, time, ',');
    std::getline(fields, mass, ',');
    if (first_mass.empty()) first_mass = mass;
    EXPECT_NEAR(std::stod(mass), std::stod(first_mass), 1e-14 * std::stod(first_mass));
  }
  EXPECT_EQ(rows, 3);
}
// Two streams colliding at 50 times the sound speed, at CFL 1: a particle's density turns negative
// in the first step. The run stops with exit 1, names the step, the particle and its position,
// and leaves the last good output and the failed state on disk, both listed in the XDMF.
TEST_F(CommandLine, InvalidStateStopsTheRunNamingTheParticle) {
  std::string text = sod_with("\"cfl\": 0.5", "\"cfl\": 1.0");
  for (const auto& swap : {std::make_pair(std::string("\"pressure\": 0.1, \"velocity\": [0.0, 0.0]"),
                                          std::string("\"pressure\": 0.1, \"velocity\": [-50.0, 0.0]")),
                           std::make_pair(std::string("\"pressure\": 1.0, \"velocity\": [0.0, 0.0]"),
                                          std::string("\"pressure\": 1.0, \"velocity\": [50.0, 0.0]"))}) {
    const auto at = text.find(swap.first);
    ASSERT_NE(at, std::string::npos) << swap.first;
    text.replace(at, swap.first.size(), swap.second);
  }
  write_case("crash.json", text);
  const CommandResult r = run_mpmflow("run crash.json --output out", dir_);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("mpmflow: error: invalid state after step 1: particle "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(" at (0.5"), std::string::npos) << r.output;  // where the streams meet
  EXPECT_NE(r.output.find("has density -"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("the last good state is output 0, the failed state output 1"), std::string::npos)
      << r.output;
  EXPECT_TRUE(fs::exists(dir_ / "out" / "sod_000000.h5"));
  EXPECT_TRUE(fs::exists(dir_ / "out" / "sod_000001.h5"));
  EXPECT_NE(read_text(dir_ / "out" / "sod_particles.xmf").find("sod_000001.h5"), std::string::npos);
}

// An output folder that cannot be made (here a file stands where it or its parent would go) stops
// the run before any step with an error naming the folder, the setting and the reason; the file in
// the way is left as it was.
TEST_F(CommandLine, AnOutputFolderThatCannotBeMadeIsNamed) {
  write_case("case.json", sod_text_);
  write_case("in_the_way", "not a folder\n");
  for (const std::string folder : {"in_the_way", "in_the_way/out"}) {
    const CommandResult r = run_mpmflow("run case.json --output " + folder, dir_);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_NE(r.output.find("mpmflow: error: cannot create the output folder " + folder +
                            " (output/directory, or --output): Not a directory"),
              std::string::npos)
        << r.output;
    EXPECT_EQ(r.output.find("step 1"), std::string::npos) << r.output;
    EXPECT_EQ(read_text(dir_ / "in_the_way"), "not a folder\n");
  }
}

#else
TEST_F(CommandLine, OutputRequestWithoutHdf5IsRefused) {
  write_case("case.json", sod_text_);
  expect_rejected("run case.json", "built without HDF5");
  const CommandResult r = run_mpmflow("run case.json --set output/snapshots=0", dir_);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("final: mass"), std::string::npos);
}
#endif

// The duplicated P2G keeps a copy of the grid for every thread that may run at once: refused on a
// GPU build, naming the key and what it takes instead; run on a CPU build.
TEST_F(CommandLine, TheDuplicatedP2GIsRefusedOnGpusOnly) {
  write_case("case.json", sod_text_);
  const std::string arguments = "run case.json --set numerics/p2g=duplicated --set output/snapshots=0";
  if (!std::is_same<mpmflow::MemorySpace, Kokkos::HostSpace>::value) {
    expect_rejected(arguments, "case.json: /numerics/p2g: \"duplicated\" keeps a copy of the grid for each GPU "
                               "thread, and this mpmflow runs on a GPU; expected \"automatic\"");
  } else {
    const CommandResult r = run_mpmflow(arguments + " --output out", dir_);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("final: mass"), std::string::npos) << r.output;
  }
}

// output/phase_timers = unfenced: the phase table says what its times are (the host's); the run's
// results are the fenced run's (through the sorted P2G, whose sums' order does not change from run
// to run as the atomic one's does on a GPU).
TEST_F(CommandLine, UnfencedPhaseTimersSayWhatTheTableTimes) {
  write_case("case.json", sod_text_);
  expect_rejected("run case.json --set output/phase_timers=later",
                  "case.json: /output/phase_timers: expected one of fenced, unfenced; got \"later\"");
  const std::string arguments = "run case.json --set domain/cells_x=20 --set output/snapshots=0 "
                                "--set numerics/p2g=sorted --overwrite --output out";
  const CommandResult fenced = run_mpmflow(arguments, dir_);
  ASSERT_EQ(fenced.exit_code, 0) << fenced.output;
  EXPECT_EQ(fenced.output.find("unfenced"), std::string::npos) << fenced.output;
  const auto final_line = [](const std::string& output) { return output.substr(output.find("final: mass")); };
  const std::string fenced_final = final_line(fenced.output);
  const CommandResult unfenced = run_mpmflow(arguments + " --set output/phase_timers=unfenced", dir_);
  ASSERT_EQ(unfenced.exit_code, 0) << unfenced.output;
  EXPECT_NE(unfenced.output.find("Time per phase\n  (output/phase_timers = unfenced: the host's time in each phase"),
            std::string::npos)
      << unfenced.output;
  EXPECT_EQ(final_line(unfenced.output).substr(0, fenced_final.find('\n')),
            fenced_final.substr(0, fenced_final.find('\n')));
}

// A geometry error is a case-file error: exit 2, the message, nothing written.
TEST_F(CommandLine, BadGeometryIsRejectedBeforeAnythingIsWritten) {
  std::ofstream(dir_ / "wing.dat") << "WING\n0 0\n1 1\n1 0\n0 1\n";
  write_case("case.json", R"({"name": "wing", "domain": {"x": [0, 4], "y": [0, 2], "cells_x": 40, "cells_y": 20},
    "time": {"end": 0.1}, "particles": {"per_cell": [2, 2]},
    "boundaries": {"left": {"type": "inflow"}, "right": {"type": "outflow"}},
    "free_stream": {"density": 1, "pressure": 1, "velocity": [1, 0]},
    "obstacles": [{"type": "polygon", "file": "wing.dat", "translation": [1, 0.5]}]})");
  expect_rejected("run case.json", "case.json: /obstacles/0 (polygon) from ");
  expect_rejected("run case.json", "expected a simple polygon; it intersects itself: edge 0 (1, 0.5)-(2, 1.5) meets");
}

}  // namespace
