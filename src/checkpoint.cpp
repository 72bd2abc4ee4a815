#include "checkpoint.hpp"

#ifdef MPMFLOW_HAVE_HDF5
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <map>
#include <regex>
#include <sstream>
#include <type_traits>
#include <vector>

#include "build_commit.hpp"
#include "hdf5_io.hpp"
#include "run_files.hpp"
#include "open_boundaries.hpp"
#include "solver.hpp"

namespace mpmflow {
namespace {

using h5::Handle;

// A checkpoint's name: <case><checkpoint_infix><step, 9 digits or more>.h5.
constexpr const char* checkpoint_infix = "_checkpoint_";
std::string checkpoint_prefix(const std::string& case_name) { return case_name + checkpoint_infix; }

// A file given to --restart that is not a checkpoint, refused saying what it is. Every checkpoint
// holds next_snapshot (read_checkpoint reads it); a snapshot holds a layout, as no checkpoint does.
void require_checkpoint(hid_t file, const std::string& path) {
  if (H5Aexists(file, "next_snapshot") > 0) return;
  if (H5Aexists(file, "layout") > 0)
    throw ConfigError("--restart " + path + ": a snapshot, not a checkpoint; a run continues from a checkpoint (<case>" +
                      checkpoint_infix + "<step>.h5, written every output/checkpoint_interval steps), or give the "
                      "folder and it takes the newest");
  throw ConfigError("--restart " + path + ": not an mpmflow checkpoint (no attribute next_snapshot)");
}

}  // namespace

std::string write_checkpoint(const std::string& directory, const std::string& case_name, const Solver& solver,
                             const RunClock& clock, int keep) {
  const ParallelContext& context = solver.context();
  h5::require_parallel_if_distributed(context);
  std::ostringstream name;
  name << checkpoint_prefix(case_name) << std::setw(9) << std::setfill('0') << clock.step << ".h5";
  const std::string path = directory + "/" + name.str();
  if (context.is_root()) create_output_directory(directory);
  context.barrier();

  const ParticleState& pt = solver.particles();
  const index_t n = pt.count;
  const std::vector<long long> counts = context.all_gather(n);
  hsize_t offset = 0, total = 0;  // this rank's first row and the rows of all ranks
  for (int r = 0; r < context.size(); ++r) {
    if (r < context.rank()) offset += counts[r];
    total += counts[r];
  }
  // Read back before it replaces anything: a checkpoint that does not open, or whose particle
  // fields are not all there, is not renamed into place, and no older one is pruned for it.
  auto verify = [&](const std::string& written) {
    Handle file(h5::open_file_here(written), H5Fclose, "open " + written + " to check it");
    if (static_cast<long>(h5::read_attribute(file, "step")) != clock.step)
      throw std::runtime_error(written + " reads back another step");
    Handle group(H5Gopen2(file, "particles", H5P_DEFAULT), H5Gclose, "open group particles in " + written);
    pt.for_each_field([&](const auto& field) {
      using View = std::decay_t<decltype(field)>;
      if (std::is_same<View, IndexView>::value) return;
      if (h5::dataset_length(group, field.label().c_str()) != total)
        throw std::runtime_error(written + ": particle field " + field.label() + " reads back short");
    });
  };
  int particle_fields = 0;
  pt.for_each_field([&](const auto&) { ++particle_fields; });
  h5::write_file_safely(path, context, [&](hid_t file) {
    h5::write_string_attribute(file, "case", case_name);
    h5::write_string_attribute(file, "effective_case", effective_case_json(solver.config()));
    h5::write_string_attribute(file, "run_id", clock.run_id);
    h5::write_string_attribute(file, "mpmflow_build", build_identity());
    h5::write_attribute(file, "time", clock.time);
    h5::write_attribute(file, "step", static_cast<double>(clock.step));
    h5::write_attribute(file, "next_snapshot", clock.next_snapshot);
    h5::write_attribute(file, "num_ranks", context.size());
    h5::write_attribute(file, "cells_x", solver.slab().global_cells_x);
    h5::write_attribute(file, "cells_y", solver.slab().global_cells_y);
    h5::write_attribute(file, "decomposition_axis", solver.decomposition().axis);
    clock.initial_totals.for_each_total([&](const char* name, double value) {
      h5::write_attribute(file, (std::string("initial_") + name).c_str(), value);
    });
    h5::write_attribute(file, "node_mass_threshold", solver.node_mass_threshold());
    h5::write_attribute(file, "particle_splits", static_cast<double>(clock.particle_splits));
    {
      std::vector<double> fluxes;
      clock.fluxes.for_each_flux([&](const std::string&, double value) { fluxes.push_back(value); });
      const hsize_t width = fluxes.size();
      h5::write_block(file, "open_side_fluxes", {width * context.size()}, {width * context.rank()}, {width},
                      fluxes.data(), context);
    }
    if (!clock.entry_distance.empty()) h5::write_replicated(file, "entry_distance", clock.entry_distance, context);
    if (!clock.obstacle_impulse.empty())
      h5::write_replicated(file, "obstacle_impulse", clock.obstacle_impulse, context);
    std::vector<long long> slab_begin(solver.decomposition().cell_begin.begin(), solver.decomposition().cell_begin.end());
    h5::write_replicated(file, "slab_begin", slab_begin, context);
    h5::write_replicated(file, "particles_per_rank", counts, context);
    Handle group(H5Gcreate2(file, "particles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                 "create group particles");
    pt.for_each_field([&](const auto& field) {
      using View = std::decay_t<decltype(field)>;
      if (std::is_same<View, IndexView>::value) return;  // the cell map is recomputed on restart
      auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), field);
      h5::write_block(group, field.label().c_str(), {total}, {offset}, {static_cast<hsize_t>(n)}, host.data(), context);
    });
  }, verify, /*expected_bytes=*/8.0 * double(total) * particle_fields);
  if (context.is_root()) {
    if (keep > 0) {
      std::vector<std::string> existing;
      const std::string prefix = checkpoint_prefix(case_name);
      for (const auto& entry : std::filesystem::directory_iterator(directory)) {
        const std::string file = entry.path().filename().string();
        // Only this run's checkpoints: another run's in the same folder are not ours to prune.
        if (file.rfind(prefix, 0) == 0 && file.size() > 3 && file.compare(file.size() - 3, 3, ".h5") == 0 &&
            run_id_of_file(directory + "/" + file) == clock.run_id)
          existing.push_back(file);
      }
      std::sort(existing.begin(), existing.end());  // zero-padded steps: oldest first
      // A checkpoint that cannot be removed stays: pruning is housekeeping, never a failure.
      std::error_code ignored;
      for (size_t k = 0; k + keep < existing.size(); ++k) std::filesystem::remove(directory + "/" + existing[k], ignored);
    }
  }
  context.barrier();
  return path;
}

std::string newest_checkpoint_in(const std::string& folder) {
  // The names write_checkpoint gives: the case's name, then the step (zero-padded to 9 digits, more
  // beyond); at most 18 digits, which a long holds.
  static const std::regex checkpoint_name(std::string("^(.+)") + checkpoint_infix + R"((\d{1,18})\.h5$)");
  struct Newest {
    long step = -1;
    std::string file;
  };
  std::map<std::string, Newest> newest_of_case;
  std::error_code error;
  for (std::filesystem::directory_iterator entry(folder, error), end; !error && entry != end; entry.increment(error)) {
    const std::string file = entry->path().filename().string();
    std::smatch match;
    std::error_code not_a_file;
    if (!std::regex_match(file, match, checkpoint_name) || !entry->is_regular_file(not_a_file)) continue;
    Newest& newest = newest_of_case[match[1].str()];
    const long step = std::stol(match[2].str());
    if (step > newest.step) newest = {step, file};
  }
  if (error) throw ConfigError("--restart " + folder + ": cannot read the folder: " + error.message());
  if (newest_of_case.empty())
    throw ConfigError("--restart " + folder + ": expected a checkpoint file, or a folder holding one "
                      "(<case>_checkpoint_<step>.h5, which output/checkpoint_interval writes); the folder holds none");
  if (newest_of_case.size() > 1) {
    std::string newest_files;
    for (const auto& [name, newest] : newest_of_case) newest_files += (newest_files.empty() ? "" : ", ") + newest.file;
    throw ConfigError("--restart " + folder + ": the folder holds checkpoints of " +
                      std::to_string(newest_of_case.size()) + " cases (the newest of each: " + newest_files +
                      "); give the checkpoint file");
  }
  return (std::filesystem::path(folder) / newest_of_case.begin()->second.file).string();
}

std::string read_checkpoint_case(const std::string& path) {
  h5::silence_error_printing();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw ConfigError("--restart " + path + ": no such checkpoint file");
  try {
    Handle file(h5::open_file_here(path), H5Fclose, "open " + path);
    require_checkpoint(file, path);
    if (H5Aexists(file, "effective_case") <= 0)
      throw ConfigError("--restart " + path + ": the checkpoint holds no case (written by an older mpmflow); "
                        "give the case file too: mpmflow run CASE.json --restart " + path);
    return h5::read_string_attribute(file, "effective_case");
  } catch (const ConfigError&) {
    throw;
  } catch (const std::exception& e) {
    throw ConfigError("--restart " + path + ": not a readable mpmflow checkpoint: " + e.what());
  }
}

RestartState read_checkpoint(const std::string& path, const CaseConfig& config, const ParallelContext& context) {
  h5::require_parallel_if_distributed(context);
  // Every rank opens the file: one that cannot see it (a node without the file system) must stop
  // all of them, not leave the others waiting in the collective open.
  std::error_code ec;
  const bool visible = std::filesystem::is_regular_file(path, ec);
  const int lowest_blind_rank = static_cast<int>(context.min(visible ? context.size() : context.rank()));
  if (lowest_blind_rank < context.size())
    throw CollectiveError("--restart " + path + ": no such checkpoint file" +
                          (context.distributed() ? " (on rank " + std::to_string(lowest_blind_rank) + ")" : std::string()));
  RestartState restart;
  restart.path = path;
  try {
    Handle file(h5::open_file(path, context), H5Fclose, "open " + path);
    require_checkpoint(file, path);  // (every rank reads the same file: all refuse alike)
    const std::string case_name = h5::read_string_attribute(file, "case");
    const long cells_x = static_cast<long>(h5::read_attribute(file, "cells_x"));
    const long cells_y = static_cast<long>(h5::read_attribute(file, "cells_y"));
    if (case_name != config.name || cells_x != config.domain.cells_x || cells_y != config.domain.cells_y)
      throw CollectiveError("--restart " + path + ": the checkpoint is of case '" + case_name + "' on " +
                            std::to_string(cells_x) + " x " + std::to_string(cells_y) + " cells; expected case '" +
                            config.name + "' on " + std::to_string(config.domain.cells_x) + " x " +
                            std::to_string(config.domain.cells_y) + " cells (" + config.source + ")");
    // The case it was written with: only what may change on a restart may differ.
    if (H5Aexists(file, "effective_case") > 0) {
      const std::string difference =
          restart_incompatibility(h5::read_string_attribute(file, "effective_case"), effective_case_json(config));
      if (!difference.empty())
        throw ConfigError("--restart " + path + ": the case differs from the checkpoint's at " + difference +
                          "; a restart may change only the end time, the output schedule and folder, the step "
                          "limit and the description");
    }
    RunClock& clock = restart.clock;
    if (H5Aexists(file, "run_id") > 0) clock.run_id = h5::read_string_attribute(file, "run_id");
    clock.time = h5::read_attribute(file, "time");
    clock.step = static_cast<long>(h5::read_attribute(file, "step"));
    if (!(std::isfinite(clock.time) && clock.time >= 0 && clock.step >= 0))
      throw ConfigError("--restart " + path + ": expected a time >= 0 and a step >= 0; the checkpoint holds t = " +
                        std::to_string(clock.time) + ", step " + std::to_string(clock.step));
    clock.next_snapshot = static_cast<int>(h5::read_attribute(file, "next_snapshot"));
    clock.initial_totals.for_each_total([&](const char* name, double& value) {
      value = h5::read_attribute(file, (std::string("initial_") + name).c_str());
    });
    clock.node_mass_threshold = h5::read_attribute(file, "node_mass_threshold");
    // (Absent from checkpoints written before particles split: none had split.)
    if (H5Aexists(file, "particle_splits") > 0)
      clock.particle_splits = static_cast<long long>(h5::read_attribute(file, "particle_splits"));
    const int written_ranks = static_cast<int>(h5::read_attribute(file, "num_ranks"));
    {
      // Rank-major rows of every flux (BoundaryFluxes::for_each_flux order).
      hsize_t width = 0;
      clock.fluxes.for_each_flux([&](const std::string&, double) { ++width; });
      const bool same_ranks = written_ranks == context.size();
      std::vector<double> rows;
      if (same_ranks) rows = h5::read_rows<double>(file, "open_side_fluxes", width * context.rank(), width, context);
      else rows = h5::read_rows<double>(file, "open_side_fluxes", 0, width * written_ranks, context);
      clock.fluxes = BoundaryFluxes{};
      if (same_ranks || context.is_root()) {
        size_t k = 0;
        clock.fluxes.for_each_flux([&](const std::string&, double& value) {
          for (size_t row = k; row < rows.size(); row += width) value += rows[row];
          ++k;
        });
      }
    }
    if (!config.obstacles.empty() && H5Lexists(file, "obstacle_impulse", H5P_DEFAULT) > 0)
      clock.obstacle_impulse = h5::read_rows<double>(file, "obstacle_impulse", 0, 2 * config.obstacles.size() + 1, context);
    const size_t num_distances = OpenBoundaries::num_entry_cells(config);
    if (num_distances > 0)
      clock.entry_distance = h5::read_rows<double>(file, "entry_distance", 0, num_distances, context);
    const int axis = static_cast<int>(h5::read_attribute(file, "decomposition_axis"));
    const auto counts = h5::read_rows<long long>(file, "particles_per_rank", 0, written_ranks, context);
    const auto slab_begin = h5::read_rows<long long>(file, "slab_begin", 0, written_ranks + 1, context);

    hsize_t offset = 0, count = 0;
    if (written_ranks == context.size() && axis == config.decomposition.axis) {
      // The same slabs and the same particles per rank, in the same order.
      restart.decomposition.axis = axis;
      restart.decomposition.cell_begin.assign(slab_begin.begin(), slab_begin.end());
      for (int r = 0; r < context.rank(); ++r) offset += counts[r];
      count = counts[context.rank()];
    } else {
      restart.decomposition = SlabDecomposition::even(config, context.size());
      long long total = 0;
      for (long long c : counts) total += c;
      const long long share = total / context.size(), extra = total % context.size();
      const int r = context.rank();
      offset = r * share + std::min<long long>(r, extra);
      count = share + (r < extra ? 1 : 0);
    }
    Handle group(H5Gopen2(file, "particles", H5P_DEFAULT), H5Gclose, "open group particles");
    ParticleState particles(static_cast<index_t>(count));
    particles.for_each_field([&](const auto& field) {
      using View = std::decay_t<decltype(field)>;
      if (std::is_same<View, IndexView>::value) return;
      using Value = typename View::non_const_value_type;
      const std::vector<Value> values = h5::read_rows<Value>(group, field.label().c_str(), offset, count, context);
      Kokkos::View<Value*, Kokkos::HostSpace, Kokkos::MemoryTraits<Kokkos::Unmanaged>> host(
          const_cast<Value*>(values.data()), values.size());
      Kokkos::deep_copy(field, host);
    });
    restart.particles = particles;
  } catch (const CollectiveError&) {
    throw;
  } catch (const ConfigError&) {  // too many ranks for the grid
    throw;
  } catch (const std::exception& e) {
    // Every rank opens the same file and fails alike.
    throw CollectiveError("--restart " + path + ": not a readable mpmflow checkpoint: " + e.what());
  }
  return restart;
}

}  // namespace mpmflow
#endif
