#pragma once
// Reading files in the test programs.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace mpmflow {

// The whole text of the file at `path`. Throws if it cannot be opened, so that a missing file
// fails the test that reads it instead of reading as empty.
inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace mpmflow
