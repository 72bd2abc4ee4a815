// Case files: valid input parses into the expected structs; every kind of bad input is rejected
// with a message naming the file, the JSON path and what was expected.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "case_config.hpp"

namespace mpmflow {
namespace {

const char* kMinimalCase = R"({
  "name": "t",
  "domain": { "x": [0, 2], "y": [0, 1], "cells_x": 20, "cells_y": 10 },
  "time": { "end": 0.5 },
  "particles": { "per_cell": [2, 2] },
  "initial_state": { "background": { "density": 1.4, "pressure": 1, "velocity": [3, 0] } }
})";

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
  EXPECT_DOUBLE_EQ(c.physics.gamma, 1.4);
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
