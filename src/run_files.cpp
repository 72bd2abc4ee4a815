#include "run_files.hpp"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <random>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include <nlohmann/json.hpp>

#include "output.hpp"
#ifdef MPMFLOW_HAVE_HDF5
#include "hdf5_io.hpp"
#endif

namespace mpmflow {
namespace fs = std::filesystem;

std::string new_run_id(const std::string& case_name) {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm utc{};
  gmtime_r(&now, &utc);
  std::random_device entropy;  // the one non-deterministic value of a run: its name, not its physics
  std::ostringstream id;
  id << case_name << '-' << std::put_time(&utc, "%Y%m%dT%H%M%SZ") << '-' << std::hex << std::setw(8)
     << std::setfill('0') << (entropy() & 0xffffffffu);
  return id.str();
}

void create_output_directory(const std::string& directory) {
  std::error_code error;
  fs::create_directories(directory, error);
  // create_directories reports no error when the path is already there as something other than a
  // folder in some library versions: ask.
  if (!error && !fs::is_directory(directory, error) && !error) error = std::make_error_code(std::errc::not_a_directory);
  if (error)
    throw std::runtime_error("cannot create the output folder " + directory +
                             " (output/directory, or --output): " + error.message());
}

std::string run_id_of_file(const std::string& path) {
  const fs::path file(path);
#ifdef MPMFLOW_HAVE_HDF5
  try {
    h5::Handle h(h5::open_file_here(file.string()), H5Fclose, "open " + file.string());
    if (H5Aexists(h, "run_id") <= 0) return "";
    return h5::read_string_attribute(h, "run_id");
  } catch (const std::exception&) {
    return "";
  }
#else
  (void)file;
  return "";
#endif
}

OtherRunFiles files_of_other_runs(const std::string& directory, const std::string& case_name,
                                  const std::string& run_id) {
  OtherRunFiles other;
  std::error_code ec;
  if (!fs::is_directory(directory, ec)) return other;
  const std::regex ours("^" + std::regex_replace(case_name, std::regex(R"([-])"), R"(\-)") +
                        R"(_(\d{6}|checkpoint_\d+)\.h5$)");
  for (const auto& entry : fs::directory_iterator(directory, ec)) {
    const std::string name = entry.path().filename().string();
    if (!std::regex_match(name, ours)) continue;
    const std::string id = run_id_of_file(entry.path().string());
    if (id == run_id) continue;
    if (other.files.empty()) other.run_id = id;
    other.files.push_back(name);
  }
  std::sort(other.files.begin(), other.files.end());
  return other;
}

void remove_run_files(const std::string& directory, const std::string& case_name,
                      const std::vector<std::string>& files) {
  std::vector<std::string> names = files;
  for (const char* suffix : {"_particles.xmf", "_grid.xmf", "_grid_mesh.h5", "_manifest.json"})
    names.push_back(case_name + suffix);
  names.push_back("diagnostics.csv");
  const std::regex per_snapshot_xdmf("^" + case_name + R"(_\d{6}_(particles|grid)\.xmf$)");
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(directory, ec)) {
    const std::string name = entry.path().filename().string();
    if (std::regex_match(name, per_snapshot_xdmf)) names.push_back(name);
  }
  for (const std::string& name : names) {
    std::error_code error;
    fs::remove(fs::path(directory) / name, error);
    if (error) throw std::runtime_error("cannot remove " + (fs::path(directory) / name).string() + ": " + error.message());
  }
}

RunManifest::RunManifest(std::string directory, std::string case_name, std::string run_id)
    : directory_(std::move(directory)), case_name_(std::move(case_name)), run_id_(std::move(run_id)) {
  // A restart continues the manifest its run left.
  std::ifstream in(path());
  if (!in) return;
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  if (doc.is_discarded() || doc.value("run_id", "") != run_id_ || !doc.contains("files")) return;
  for (const auto& f : doc["files"])
    if (f.is_string()) files_.push_back(f.get<std::string>());
}

std::string RunManifest::path() const { return (fs::path(directory_) / (case_name_ + "_manifest.json")).string(); }

void RunManifest::add(const std::string& file) {
  if (std::find(files_.begin(), files_.end(), file) == files_.end()) files_.push_back(file);
  write();
}

void RunManifest::remove(const std::string& file) {
  files_.erase(std::remove(files_.begin(), files_.end(), file), files_.end());
  write();
}

void RunManifest::write() const {
  // The files the run still has (pruned checkpoints go).
  std::vector<std::string> present;
  std::error_code ec;
  for (const std::string& f : files_)
    if (fs::exists(fs::path(directory_) / f, ec)) present.push_back(f);
  const nlohmann::json doc = {{"run_id", run_id_}, {"case", case_name_}, {"files", present}};
  write_file_atomically(path(), doc.dump(2) + "\n");
}

}  // namespace mpmflow
