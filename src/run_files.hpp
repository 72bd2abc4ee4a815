#pragma once
// The files of one run in its output folder. Each run has an id (case name, start time, a random
// part), written into every HDF5 file it makes (attribute run_id) and into the manifest
// <case>_manifest.json, which lists the run's files. A run never mixes with another run's files:
// a new run into a folder holding another run's snapshots or checkpoints of the same case stops
// (unless told to remove them first: --overwrite), pruning only removes the run's own
// checkpoints, and the tools read the run's own snapshots (its XDMF). A restart continues the
// checkpoint's run, and its id.
#include <string>
#include <vector>

namespace mpmflow {

// "<case>-<UTC yyyymmddThhmmssZ>-<8 hex digits>": unique for practical purposes.
std::string new_run_id(const std::string& case_name);

// Creates the run's output folder and its parents (rank 0 alone, before its files). Throws
// std::runtime_error naming the folder, the setting it comes from and why it cannot be made (a
// file in the way, a parent that is not a folder or cannot be written).
void create_output_directory(const std::string& directory);

// The run id an HDF5 file of mpmflow carries ("" when it has none or cannot be read).
std::string run_id_of_file(const std::string& path);

// The snapshots (<case>_NNNNNN.h5) and checkpoints (<case>_checkpoint_*.h5) of `case_name` in
// `directory` that belong to another run than `run_id` (another id, or none: an older mpmflow's),
// and the other run's id ("" when unknown). Empty when the folder holds none.
struct OtherRunFiles {
  std::string run_id;
  std::vector<std::string> files;  // names in the directory
};
OtherRunFiles files_of_other_runs(const std::string& directory, const std::string& case_name,
                                  const std::string& run_id);

// Removes `files` and the other files a run of `case_name` leaves in `directory` (its XDMF files,
// grid mesh file, diagnostics.csv and manifest). Throws std::runtime_error naming a file that
// cannot be removed.
void remove_run_files(const std::string& directory, const std::string& case_name,
                      const std::vector<std::string>& files);

// The manifest of a run: rewritten (atomically) as files are added.
class RunManifest {
 public:
  RunManifest() = default;
  RunManifest(std::string directory, std::string case_name, std::string run_id);
  // Records `file` (a name in the directory) and rewrites the manifest; a file already listed
  // stays once.
  void add(const std::string& file);
  void remove(const std::string& file);
  std::string path() const;

 private:
  void write() const;
  std::string directory_, case_name_, run_id_;
  std::vector<std::string> files_;
};

}  // namespace mpmflow
