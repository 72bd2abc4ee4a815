#pragma once
// Snapshot output: one HDF5 file per output step (particle fields and grid node fields) and XDMF
// time series that ParaView/VisIt open directly; a CSV of the conservation diagnostics. Every
// file is written under a temporary name and renamed when complete, so a reader (or a crash)
// never sees half a file.
#include <string>
#include <vector>

#include "diagnostics.hpp"
#include "parallel.hpp"
#include "solver.hpp"

namespace mpmflow {

// Writes `text` to `path` through a temporary file in the same directory and a rename.
void write_file_atomically(const std::string& path, const std::string& text);

// The conservation diagnostics of every output so far, as CSV (rewritten whole at each output):
// the totals, the total energy, and what crossed the open sides since t = 0 ("<total>_in",
// "<total>_out").
class DiagnosticsLog {
 public:
  explicit DiagnosticsLog(std::string path) : path_(std::move(path)) {}
  void append(long step, double time, const ConservationTotals& totals, const BoundaryFluxes& fluxes,
              const DiagnosticColumns& extra = {});
  // After a restart at `step`: keeps the rows of the file up to that step.
  void resume(long step);

 private:
  std::string path_;
  std::string text_;
};

#ifdef MPMFLOW_HAVE_HDF5
class SnapshotWriter {
 public:
  // Creates `directory` if needed. Files are named <case_name>_<index>.h5. All ranks of
  // `context` write every snapshot together (collective calls); rank 0 writes the XDMF.
  SnapshotWriter(std::string directory, std::string case_name, const ParallelContext& context,
                 std::string run_id = "");

  // After a restart: takes the snapshots 0 .. num_written - 1 already in the directory into the
  // XDMF time series.
  void resume(int num_written);

  // Writes snapshot `index` and refreshes the XDMF time series; returns the HDF5 path. The grid
  // fields are the particles' mass and momentum projected where the particles are now
  // (Solver::grid_projection); nothing of the solver's state changes.
  std::string write(int index, long step, double time, const Solver& solver, const ConservationTotals& totals,
                    const BoundaryFluxes& fluxes, const DiagnosticColumns& extra = {});

  std::string particles_xdmf_path() const;
  std::string grid_xdmf_path() const;

 private:
  struct Record {
    std::string file;  // relative to the directory
    double time;
    long num_particles;
  };
  // The XDMF time series of the records so far, and the latest snapshot's own XDMF files;
  // `particles` tells the particle fields' types.
  void write_xdmf(const ParticleState& particles) const;
  std::string particles_grid_xml(const Record& record, const ParticleState& particles, bool with_time,
                                 const std::string& indent) const;
  std::string grid_grid_xml(const Record& record, bool explicit_mesh, const std::string& indent) const;
  std::string mesh_file_name() const;
  void write_mesh_file() const;
  std::string file_name(int index) const;

  std::string directory_;
  std::string case_name_;
  std::string run_id_;  // written into every file (run_files.hpp)
  ParallelContext context_;
  std::vector<Record> records_;
  // Owned grid nodes written, and their geometry, for the XDMF topology.
  long grid_nodes_x_ = 0, grid_nodes_y_ = 0;
  double grid_origin_x_ = 0, grid_origin_y_ = 0, grid_spacing_x_ = 0, grid_spacing_y_ = 0;
};
#endif

}  // namespace mpmflow
