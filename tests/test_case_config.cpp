// Case files: valid input parses into the expected structs; every kind of bad input is rejected
// with a message naming the file, the JSON path and what was expected.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "case_config.hpp"
#include "simulation.hpp"
#include "test_files.hpp"

namespace mpmflow {
namespace {

// The smallest valid case: only the required keys. One file, which tests/validate_cases.py reads
// too (the schema's defaults against the parser's).
const std::string kMinimalCase = read_text(std::string(MPMFLOW_SOURCE_DIR) + "/tests/data/minimal_case.json");

// The message parse_case throws for `text`, or "" when it parses.
std::string error_of(const std::string& text) {
  try {
    parse_case(text, "case.json");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

// kMinimalCase with `from` replaced by `to` (which must occur).
std::string minimal_with(const std::string& from, const std::string& to) {
  std::string text = kMinimalCase;
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

TEST(CaseConfig, MinimalCaseGetsDocumentedDefaults) {
  const CaseConfig c = parse_case(kMinimalCase, "case.json");
  EXPECT_EQ(c.name, "t");
  EXPECT_DOUBLE_EQ(c.domain.x_max, 2.0);
  EXPECT_EQ(c.domain.cells_x, 20);
  EXPECT_EQ(c.physics.gamma, real_t(1.4));  // (in float, 1.4 rounded once)
  EXPECT_DOUBLE_EQ(c.physics.viscosity_quadratic, 1.0);
  EXPECT_DOUBLE_EQ(c.physics.viscosity_linear, 1.0);
  EXPECT_DOUBLE_EQ(c.time.cfl, 0.5);
  EXPECT_EQ(c.boundaries.left, BoundaryType::slip_wall);
  EXPECT_EQ(c.output.directory, "output/t");
  EXPECT_EQ(c.output.snapshots, 10);
  EXPECT_EQ(c.numerics.shape_function, ShapeFunction::gimp);
  EXPECT_EQ(c.numerics.p2g, P2GStrategy::automatic);
  EXPECT_DOUBLE_EQ(c.initial_state.background.velocity_x, 3.0);
}

// The memory check before a run holds the case against its peak: on one rank each snapshot and
// checkpoint is built in memory before it is written (about 90 B a particle more), which the
// 200 B a particle of the check had left out. Across ranks the files go through MPI-IO instead.
TEST(Limits, MemoryCheckCountsTheFilesOneRankBuildsInMemory) {
  CaseConfig c = parse_case(kMinimalCase, "case.json");
  c.domain.cells_x = 1000;
  c.domain.cells_y = 1000;  // 4e6 particles (2 x 2 a cell) and 1005 x 1005 nodes with the ghosts
  const double particles = 4e6, nodes = 1005.0 * 1005.0;
  const double limit = 0.5 * ((200 + 300) * particles) + 200 * nodes;  // between the two needs
  const auto refusal = [&](int ranks, double bytes) -> std::string {
    try {
      check_memory(c, ranks, bytes);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  };
  c.output.snapshots = 0;
  c.output.checkpoint_interval = 0;
  EXPECT_EQ(refusal(1, limit), "");
  c.output.snapshots = 10;
  EXPECT_NE(refusal(1, limit).find("case.json: /domain: 1000 x 1000 cells and 4000000 particles need about 1.4 GB "
                                   "per rank (300 bytes per particle, 200 per node); --max-memory allows"),
            std::string::npos)
      << refusal(1, limit);
  c.output.snapshots = 0;
  c.output.checkpoint_interval = 100;
  EXPECT_NE(refusal(1, limit), "");
  EXPECT_EQ(refusal(2, limit / 2), "");
}

TEST(CaseConfig, ShippedSodCaseParses) {
  const CaseConfig c = load_case_file(std::string(MPMFLOW_SOURCE_DIR) + "/cases/sod.json");
  EXPECT_EQ(c.domain.cells_x, 100);
  EXPECT_EQ(c.particles.per_cell_x, 3);
  EXPECT_DOUBLE_EQ(c.time.end_time, 0.143);
  ASSERT_EQ(c.initial_state.regions.size(), 1u);
  EXPECT_DOUBLE_EQ(c.initial_state.regions[0].state.density, 1.0);
}

TEST(CaseConfig, UnknownKeyIsRejectedWithItsPath) {
  const std::string e = error_of(minimal_with(R"("end": 0.5)", R"("end": 0.5, "ned": 1)"));
  EXPECT_NE(e.find("case.json: /time/ned: unknown key"), std::string::npos) << e;
  // The hint lists every key looked for there, the optional ones the file leaves out included (the
  // misspelling most likely meant one of those), not only those it has.
  const size_t hint = e.find("(known here:");
  ASSERT_NE(hint, std::string::npos) << e;
  EXPECT_NE(e.find(" cfl", hint), std::string::npos) << e;
  EXPECT_NE(e.find(" end", hint), std::string::npos) << e;
}

TEST(CaseConfig, WrongTypeIsRejectedWithExpectation) {
  const std::string e = error_of(minimal_with(R"("cells_x": 20)", R"("cells_x": "20")"));
  EXPECT_NE(e.find("case.json: /domain/cells_x: expected an integer in [1, 1048576]; got \"20\""), std::string::npos) << e;
}

TEST(CaseConfig, OutOfRangeValueIsRejected) {
  std::string e = error_of(minimal_with(R"("density": 1.4)", R"("density": -1)"));
  EXPECT_NE(e.find("case.json: /initial_state/background/density: expected a number > 0; got -1"), std::string::npos) << e;
  e = error_of(minimal_with(R"("end": 0.5)", R"("end": 0.5, "cfl": 1.5)"));
  EXPECT_NE(e.find("/time/cfl: expected a number in (0, 1]; got 1.5"), std::string::npos) << e;
  e = error_of(minimal_with(R"("x": [0, 2])", R"("x": [2, 0])"));
  EXPECT_NE(e.find("/domain/x: expected an array [lo, hi] of two numbers with lo < hi"), std::string::npos) << e;
}

// A number beyond the build's reals is refused at the case file, naming its key: in single
// precision a pressure of 1e300 had become infinity, and the run stopped only after its first step.
TEST(CaseConfig, ANumberBeyondTheBuildsRealsIsRejected) {
  EXPECT_TRUE(fits_in<float>(3.0e38));
  EXPECT_TRUE(fits_in<float>(-3.0e38));
  EXPECT_FALSE(fits_in<float>(1e300));
  EXPECT_FALSE(fits_in<float>(-4.0e38));
  EXPECT_TRUE(fits_in<double>(1e300));
  // This build's reals, whichever they are: a scalar and an element of an array.
  const std::string pressure = error_of(minimal_with(R"("pressure": 1)", R"("pressure": 1e300)"));
  const std::string velocity = error_of(minimal_with(R"("velocity": [3, 0])", R"("velocity": [3, -1e300])"));
  if (fits_in<real_t>(1e300)) {
    EXPECT_EQ(pressure, "");
    EXPECT_EQ(velocity, "");
  } else {
    EXPECT_NE(pressure.find("case.json: /initial_state/background/pressure: expected a number > 0, at most "),
              std::string::npos) << pressure;
    EXPECT_NE(pressure.find("single precision); got 1e+300"), std::string::npos) << pressure;
    EXPECT_NE(velocity.find("/initial_state/background/velocity: expected an array of two numbers"),
              std::string::npos) << velocity;
  }
}

TEST(CaseConfig, BadEnumNamesTheChoices) {
  const std::string e = error_of(minimal_with(R"("time")", R"("boundaries": { "left": { "type": "inlet" } }, "time")"));
  EXPECT_NE(e.find("case.json: /boundaries/left/type: expected one of slip_wall, inflow, outflow, far_field; got \"inlet\""), std::string::npos) << e;
}

TEST(CaseConfig, MissingRequiredKeyIsNamed) {
  const std::string e = error_of(minimal_with(R"("time": { "end": 0.5 },)", ""));
  EXPECT_NE(e.find("case.json: /time: required key is missing"), std::string::npos) << e;
}

TEST(CaseConfig, InvalidJsonAndMissingFileAreReported) {
  EXPECT_NE(error_of("{ \"name\": ").find("case.json: not valid JSON"), std::string::npos);
  try {
    load_case_file("/nonexistent/case.json");
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/case.json: cannot open"), std::string::npos) << e.what();
  }
}

TEST(CaseConfig, OverridesApplyBeforeValidation) {
  const std::string path = testing::TempDir() + "/override_case.json";
  std::ofstream(path) << kMinimalCase;
  const CaseConfig c = load_case_file(path, {"domain/cells_x=40", "output/directory=elsewhere", "time/cfl=0.25"});
  EXPECT_EQ(c.domain.cells_x, 40);
  EXPECT_EQ(c.output.directory, "elsewhere");
  EXPECT_DOUBLE_EQ(c.time.cfl, 0.25);
  // An override is validated like the file itself...
  EXPECT_THROW(load_case_file(path, {"domain/cells_x=0"}), ConfigError);
  // ...and a misspelt path is an unknown key, not silently added.
  EXPECT_THROW(load_case_file(path, {"domain/cels_x=40"}), ConfigError);
  EXPECT_THROW(load_case_file(path, {"no-equals-sign"}), ConfigError);
}

}  // namespace
}  // namespace mpmflow

namespace mpmflow {

// ---- The JSON Schema of case files ---------------------------------------------------------------

namespace {

// The key paths a JSON Schema describes: every property, nested objects' properties under it,
// array items under "*"; "$ref"s to "#/$defs/NAME" followed.
void schema_paths(const nlohmann::json& root, const nlohmann::json& schema, const std::string& path,
                  std::set<std::string>& paths) {
  if (schema.contains("$ref")) {
    const std::string ref = schema["$ref"];
    const std::string prefix = "#/$defs/";
    ASSERT_EQ(ref.rfind(prefix, 0), 0u) << ref;
    schema_paths(root, root["$defs"][ref.substr(prefix.size())], path, paths);
  }
  if (schema.contains("properties"))
    for (auto it = schema["properties"].begin(); it != schema["properties"].end(); ++it) {
      paths.insert(path + "/" + it.key());
      schema_paths(root, it.value(), path + "/" + it.key(), paths);
    }
  if (schema.contains("items") && schema["items"].is_object()) schema_paths(root, schema["items"], path + "/*", paths);
}

std::set<std::string> difference(const std::set<std::string>& a, const std::set<std::string>& b) {
  std::set<std::string> d;
  std::set_difference(a.begin(), a.end(), b.begin(), b.end(), std::inserter(d, d.end()));
  return d;
}

std::string joined(const std::set<std::string>& keys) {
  std::string text;
  for (const std::string& k : keys) text += " " + k;
  return text;
}

}  // namespace

// cases/mpmflow_case.schema.json names exactly the keys the parser reads: a key added to one and
// not the other fails here. (Scalar array elements, such as per_cell's, are no keys of either.)
TEST(Schema, MatchesTheParsersKeys) {
  std::ifstream in(std::string(MPMFLOW_SOURCE_DIR) + "/cases/mpmflow_case.schema.json");
  ASSERT_TRUE(in) << "cases/mpmflow_case.schema.json";
  const nlohmann::json schema = nlohmann::json::parse(in);
  std::set<std::string> described;
  schema_paths(schema, schema, "", described);
  std::set<std::string> parsed;
  for (const std::string& key : case_file_keys())
    if (key.size() < 2 || key.compare(key.size() - 2, 2, "/*") != 0) parsed.insert(key);  // not "/obstacles/*"
  EXPECT_TRUE(difference(parsed, described).empty()) << "read by the parser, missing from the schema:"
                                                     << joined(difference(parsed, described));
  EXPECT_TRUE(difference(described, parsed).empty()) << "in the schema, not read by the parser:"
                                                     << joined(difference(described, parsed));
  EXPECT_GT(parsed.size(), 50u);
}

// The effective case of every shipped case (what `mpmflow case` prints and every output stores) is
// a case that gives the same effective case again.
TEST(EffectiveCase, RoundTripsForEveryShippedCase) {
  int cases = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(MPMFLOW_SOURCE_DIR) + "/cases")) {
    const std::string path = entry.path().string();
    if (entry.path().extension() != ".json" || entry.path().filename() == "mpmflow_case.schema.json") continue;
    const CaseConfig config = load_case_file(path);
    const std::string effective = effective_case_json(config);
    EXPECT_EQ(effective_case_json(parse_case(effective, path)), effective) << path;
    ++cases;
  }
  EXPECT_GE(cases, 15);
}

// A configured number is written as the case wrote it in either precision: a float's shortest
// decimal, not its value widened to double (the effective case of a single-precision build said
// gamma 1.399999976158142 for 1.4, and so did a restart's refusal quoting it).
TEST(EffectiveCase, NumbersAreWrittenAsTheCaseWroteThemInEitherPrecision) {
  EXPECT_EQ(as_written(1.4f), 1.4);
  EXPECT_EQ(as_written(0.1f), 0.1);
  EXPECT_EQ(as_written(-2.5e-7f), -2.5e-7);
  EXPECT_EQ(as_written(3.0e38f), 3.0e38);
  EXPECT_EQ(as_written(0.0f), 0.0);
  // Any float reads back as itself.
  for (const float f : {std::nextafter(1.4f, 2.0f), 1.0f / 3.0f, 16777217.0f, 1e-30f})
    EXPECT_EQ(static_cast<float>(as_written(f)), f) << f;
  // Doubles are written as they are.
  EXPECT_EQ(as_written(1.3999999761581421), 1.3999999761581421);
  EXPECT_EQ(as_written(0.1), 0.1);
  // This build's effective case, whatever its real_t: the minimal case's numbers as written.
  const nlohmann::json effective = nlohmann::json::parse(effective_case_json(parse_case(kMinimalCase, "case.json")));
  EXPECT_EQ(effective["physics"]["gamma"].get<double>(), 1.4);
  EXPECT_EQ(effective["domain"]["x"][1].get<double>(), 2.0);
  EXPECT_EQ(effective["initial_state"]["background"]["velocity"][0].get<double>(), 3.0);
}

}  // namespace mpmflow
