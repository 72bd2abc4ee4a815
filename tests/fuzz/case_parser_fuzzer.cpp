// libFuzzer target for the case parser (ctest Fuzz.CaseParser): any text is either a case or a
// ConfigError; nothing else may escape (no crash, no other exception, no sanitizer report), and
// the effective case of an accepted one parses again to the same effective case.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "case_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mpmflow::PointsFiles points;  // the outline "shape.dat" from memory; other names go to the disk
  points.files["shape.dat"] = {{0, 0}, {1, 0}, {0, 1}};
  try {
    const mpmflow::CaseConfig config = mpmflow::parse_case(text, "fuzz.json", &points);
    const std::string effective = mpmflow::effective_case_json(config);
    const std::string again = mpmflow::effective_case_json(mpmflow::parse_case(effective, "fuzz.json", &points));
    if (again != effective) std::abort();  // the effective case must describe the case it came from
  } catch (const mpmflow::ConfigError&) {
  }
  return 0;
}
