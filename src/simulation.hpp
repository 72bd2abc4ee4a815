#pragma once
// The time loop around the solver: output schedule, progress report, diagnostics, timer table.
#include <iosfwd>
#include <string>

#include "case_config.hpp"
#include "diagnostics.hpp"

namespace mpmflow {

struct RunOptions {
  double progress_interval_seconds = 2.0;  // wall time between progress lines
  bool print_banner = true;
  std::string restart_file;  // continue from this checkpoint; empty: start at t = 0
  std::string device_description;  // the GPU this rank drives, for the banner (empty on CPUs)
  bool gpu_aware_mpi = false;      // hand device buffers to MPI directly (else staged through the host)
  // Stop (checkpoint and return, RunSummary::stopped_by) before this much wall time has passed;
  // 0: no limit. SIGTERM and SIGINT stop the run the same way.
  double wall_time_seconds = 0;
  // Remove another run's files of the case from the output folder first, instead of refusing to
  // run there (run_files.hpp).
  bool overwrite = false;
};

struct RunSummary {
  long steps = 0;
  double end_time = 0;
  double wall_seconds = 0;
  double particle_steps_per_second = 0;
  long num_particles = 0;
  ConservationTotals initial_totals;
  ConservationTotals final_totals;
  BoundaryFluxes final_fluxes;  // through the open sides since t = 0
  std::string output_directory;  // empty when nothing was written
  // Why the run stopped before its end ("SIGTERM", "SIGINT", "the wall-time limit"), empty when it
  // ran to the end; and the checkpoint it wrote then, to continue from.
  std::string stopped_by;
  std::string stop_checkpoint;
};

// Throws ConfigError when the case asks for something this build cannot do (output without HDF5;
// the duplicated P2G on a GPU).
void check_case_supported(const CaseConfig& config);

// Runs the case to its end time (or max_steps), writing outputs as configured. Reports go to `log`
// on rank 0. Collective over MPI_COMM_WORLD when MPI is initialised: every rank calls it, each
// running its slab. Errors that every rank meets together are CollectiveError.
RunSummary run_simulation(const CaseConfig& config, const RunOptions& options, std::ostream& log);

// Banner lines: version, Kokkos version and execution space, threads, ranks.
// The version and build (Kokkos version and execution space, MPI, HDF5), without touching Kokkos:
// what --version prints.
std::string version_description();

// Refuses (ConfigError, naming /domain and both figures) a case whose particles and grid would
// need more memory per rank than this machine has: about 200 bytes per particle (the peak the
// benchmark measures, spare capacity included) and 200 per grid node; or than `max_bytes` per
// rank when that is given (> 0; mpmflow run --max-memory).
void check_memory(const CaseConfig& config, int num_ranks, double max_bytes = 0);
std::string build_description();

}  // namespace mpmflow
