#pragma once
// Checkpoints: the whole particle state of every rank, the slabs and the run's clock, in one HDF5
// file written by all ranks together, under a temporary name and renamed when complete (a run
// killed at any moment leaves the previous checkpoint intact).
//
// A restart on the same rank count takes back the same slabs and, on every rank, the same
// particles in the same order, so it continues bitwise as the uninterrupted run would have. On
// another rank count the particles are read in equal chunks and migrated to the owners of their
// cells: the same run up to round-off (sums in another order).
#include <string>
#include <vector>

#include "diagnostics.hpp"
#include "parallel.hpp"
#include "particles.hpp"

namespace mpmflow {

class Solver;

struct RunClock {
  double time = 0;
  long step = 0;
  int next_snapshot = 0;            // index of the next snapshot to write
  ConservationTotals initial_totals;  // of t = 0, for the drift reports
  double node_mass_threshold = 0;     // the solver's, fixed at t = 0 (restored for a bitwise restart)
  long long particle_splits = 0;      // over all ranks since t = 0: they number the split particles' ids
  std::vector<double> entry_distance;  // how far the free stream outside the open sides has moved
  // The obstacles' impulse since the last output: {time, x0, y0, x1, ...}, the same on every rank.
  std::vector<double> obstacle_impulse;
  std::string run_id;  // the run the checkpoint belongs to ("" from an older mpmflow)
  // Through the open sides since t = 0: written, each rank's own; read, this rank's own (same rank
  // count: the sums continue bitwise) or, on another rank count, the global ones on rank 0.
  BoundaryFluxes fluxes;
};

struct RestartState {
  RunClock clock;
  SlabDecomposition decomposition;
  ParticleState particles;  // this rank's share, maybe not yet on their owners
  std::string path;
};

#ifdef MPMFLOW_HAVE_HDF5
// The effective case a checkpoint was written with (this rank alone reads it): what
// `mpmflow run --restart FILE` runs when no case file is given. ConfigError when the file is not
// a readable checkpoint holding one.
std::string read_checkpoint_case(const std::string& path);

// What `--restart FOLDER` continues from: the newest (highest step) <case>_checkpoint_<step>.h5 in
// the folder, so a chain of batch jobs need not know the step its predecessor stopped at.
// ConfigError naming the folder when it holds no checkpoint, or checkpoints of more than one case.
std::string newest_checkpoint_in(const std::string& folder);

// Writes <directory>/<case>_checkpoint_<step>.h5 (collective) and deletes all but the newest
// `keep` checkpoints of the case (0: keeps all). Returns the path.
std::string write_checkpoint(const std::string& directory, const std::string& case_name, const Solver& solver,
                             const RunClock& clock, int keep);

// Reads a checkpoint of `config`'s case (collective). Throws CollectiveError when the file is
// missing, unreadable or was written for another grid.
RestartState read_checkpoint(const std::string& path, const CaseConfig& config, const ParallelContext& context);
#endif

}  // namespace mpmflow
