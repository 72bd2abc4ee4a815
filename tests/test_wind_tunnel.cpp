// The wind tunnel: signed distance functions, geometry input errors, particle placement, open
// sides (particles entering and leaving, recycling), boundary conditions, and the invariants of a
// run past obstacles.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <type_traits>
#include <vector>

#include <sys/resource.h>

#include "allocation_tracker.hpp"
#include "boundary_conditions.hpp"
#include "case_config.hpp"
#include "counter_random.hpp"
#include "gas_physics.hpp"
#include "geometry.hpp"
#include "host_memory.hpp"
#include "launch_census.hpp"
#include "open_boundaries.hpp"
#include "particle_splitting.hpp"
#include "particles.hpp"
#include "slab_state.hpp"
#include "solver.hpp"
#include "transfers.hpp"
#include "round_off.hpp"

namespace mpmflow {
namespace {

namespace fs = std::filesystem;

// ---- Signed distance ------------------------------------------------------------------------------

ObstacleConfig square_obstacle(real_t lo, real_t hi) {
  ObstacleConfig o;
  o.shape = ObstacleShape::rectangle;
  o.vertices_x = {lo, hi, hi, lo};
  o.vertices_y = {lo, lo, hi, hi};
  return o;
}

TEST(SignedDistance, CircleDistanceAndOutwardNormal) {
  ObstacleConfig circle;
  circle.centre_x = 1;
  circle.centre_y = 2;
  circle.radius = 0.5;
  const HostObstacleSet set = make_host_obstacle_set({circle});
  const SignedDistance outside = set(1, 3);
  EXPECT_DOUBLE_EQ(outside.distance, 0.5);
  EXPECT_DOUBLE_EQ(outside.normal_y, 1);
  const SignedDistance inside = set(1.3, 2);
  EXPECT_NEAR(inside.distance, -0.2, round_off(1e-15));
  EXPECT_DOUBLE_EQ(inside.normal_x, 1);  // the gradient points out of the obstacle everywhere (eq. 24)
}

TEST(SignedDistance, PolygonSignDistanceAndNormalForEitherOrientation) {
  for (bool clockwise : {false, true}) {
    ObstacleConfig square = square_obstacle(0, 1);
    if (clockwise) {
      std::reverse(square.vertices_x.begin(), square.vertices_x.end());
      std::reverse(square.vertices_y.begin(), square.vertices_y.end());
    }
    const HostObstacleSet set = make_host_obstacle_set({square});
    const SignedDistance left_of = set(-0.25, 0.5);
    EXPECT_DOUBLE_EQ(left_of.distance, 0.25);
    EXPECT_DOUBLE_EQ(left_of.normal_x, -1);
    const SignedDistance inside = set(0.9, 0.5);
    EXPECT_NEAR(inside.distance, -0.1, round_off(1e-15));
    EXPECT_NEAR(inside.normal_x, 1, round_off(1e-15));
    const SignedDistance corner = set(2, 2);  // nearest point: the corner (1, 1)
    EXPECT_NEAR(corner.distance, std::sqrt(2.0), round_off(1e-15));
    EXPECT_NEAR(corner.normal_x, std::sqrt(0.5), round_off(1e-15));
    const SignedDistance on_edge = set(0.5, 0);
    EXPECT_EQ(on_edge.distance, 0);
    EXPECT_NEAR(on_edge.normal_y, -1, round_off(1e-15)) << "clockwise input " << clockwise;
  }
}

TEST(SignedDistance, UnionTakesTheNearestObstacle) {
  ObstacleConfig circle;
  circle.centre_x = 3;
  circle.centre_y = 0.5;
  circle.radius = 0.5;
  const HostObstacleSet set = make_host_obstacle_set({square_obstacle(0, 1), circle});
  EXPECT_NEAR(set(1.9, 0.5).distance, 0.6, round_off(1e-15));  // 0.9 from the square, 0.6 from the circle
  EXPECT_NEAR(set(1.2, 0.5).distance, 0.2, round_off(1e-15));
}

TEST(PolygonInput, SeligTitleClosingPointAndTransform) {
  const fs::path path = fs::path(testing::TempDir()) / "mpmflow_selig_test.dat";
  std::ofstream(path) << "MY AEROFOIL\n1.0 0.0\n0.5 0.1\n\n# a comment\n0.0 0.0\n0.5 -0.1\n1.0 0.0\n";
  const Polygon polygon = read_points_file(path.string());
  ASSERT_EQ(polygon.size(), 4u);  // the repeated trailing edge is dropped
  EXPECT_EQ(polygon[2].x, 0.0);
  const Polygon moved = transformed(polygon, {2.0, 90.0, 1.0, 0.0});  // scale 2, rotate 90 degrees, then +x
  EXPECT_NEAR(moved[0].x, 1.0, round_off(1e-12));
  EXPECT_NEAR(moved[0].y, 2.0, round_off(1e-12));
  EXPECT_TRUE(describe_self_intersection(polygon).empty());
  fs::remove(path);
}

TEST(PolygonInput, SelfIntersectionIsNamed) {
  const Polygon bow_tie = {{0, 0}, {1, 1}, {1, 0}, {0, 1}};
  const std::string crossing = describe_self_intersection(bow_tie);
  EXPECT_NE(crossing.find("edge 0 (0, 0)-(1, 1) meets edge 2 (1, 0)-(0, 1)"), std::string::npos) << crossing;
  const Polygon spike = {{0, 0}, {2, 0}, {1, 0}, {1, 1}};  // edge 1 runs back over edge 0
  EXPECT_FALSE(describe_self_intersection(spike).empty());
}

// The part of a polygon within a box: a square half outside comes out as its quarter inside, with
// the points where it crosses the sides on them; one inside as it is; one outside empty; a U whose
// prongs alone reach in as the two prongs joined along the side, which describe_self_intersection
// names.
TEST(PolygonInput, ClippedToABoxIsThePartInside) {
  auto as_pairs = [](const Polygon& polygon) {
    std::vector<std::pair<double, double>> points;
    for (const Point& p : polygon) points.emplace_back(p.x, p.y);
    return points;
  };
  using Points = std::vector<std::pair<double, double>>;
  EXPECT_EQ(as_pairs(clipped_to_box({{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}, 0, 2, 0, 2)),
            (Points{{1, 0}, {1, 1}, {0, 1}, {0, 0}}));
  const Polygon inside = {{0.5, 0.5}, {1.5, 0.5}, {1, 1.5}};
  EXPECT_EQ(as_pairs(clipped_to_box(inside, 0, 2, 0, 2)), as_pairs(inside));
  EXPECT_TRUE(clipped_to_box({{3, 3}, {4, 3}, {4, 4}}, 0, 2, 0, 2).empty());
  const Polygon prongs = {{1, -1}, {3, -1}, {3, 0.5}, {2.5, 0.5}, {2.5, -0.5}, {1.5, -0.5}, {1.5, 0.5}, {1, 0.5}};
  const Polygon joined = clipped_to_box(prongs, 0, 4, 0, 2);
  EXPECT_EQ(as_pairs(joined),
            (Points{{3, 0}, {3, 0.5}, {2.5, 0.5}, {2.5, 0}, {1.5, 0}, {1.5, 0.5}, {1, 0.5}, {1, 0}}));
  EXPECT_FALSE(describe_self_intersection(joined).empty());
}

// ---- Case-file errors for geometry and open boundaries -------------------------------------------

// A small wind tunnel; `extra` is spliced into the top-level object.
std::string tunnel_case(const std::string& boundaries, const std::string& extra) {
  return R"({"name": "tunnel", "domain": {"x": [0, 4], "y": [0, 2], "cells_x": 40, "cells_y": 20},
    "time": {"end": 0.1}, "boundaries": )" + boundaries +
         R"(, "particles": {"placement": "random", "per_cell": [2, 2], "seed": 3})" + extra + "}";
}
const std::string kTunnelSides =
    R"({"left": {"type": "inflow"}, "right": {"type": "outflow"}, "bottom": {"type": "slip_wall"}, "top": {"type": "slip_wall"}})";
const std::string kFreeStream = R"(, "free_stream": {"density": 1.4, "pressure": 1, "velocity": [3, 0]})";

// The gas volume of each node's hat that the volume correction measures the particles' volumes
// against: a cell's area inside the domain, half on a wall or an inflow side, a quarter in a
// corner, none beyond the domain; 0 (unknown) within a cell of a far-field side; within a cell
// diagonal of an obstacle the hat's part outside it, negative (only a shortfall counts there).
// A tunnel with inflow, outflow, a slip wall at the bottom and `top` (a type), and a circle of
// radius 0.25 at (2, 1).
CaseConfig circle_in_tunnel(const std::string& top, const std::string& name) {
  return parse_case(tunnel_case(R"({"left": {"type": "inflow"}, "right": {"type": "outflow"},
                                    "bottom": {"type": "slip_wall"}, "top": {"type": ")" + top + R"("}})",
                                kFreeStream + R"(, "obstacles": [{"type": "circle", "centre": [2, 1], "radius": 0.25}])"),
                    name);
}

TEST(SignedDistance, NodeGasVolumeIsTheHatsShareOfTheGasSpace) {
  const CaseConfig config = circle_in_tunnel("far_field", "gas_volume.json");
  const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
  const ObstacleGrid grid = make_obstacle_grid(config.obstacles, slab, config.boundaries);
  auto volume = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grid.node_gas_volume);
  const GridGeometry& g = slab.geometry;
  const double area = g.spacing_x * g.spacing_y;  // 0.1 x 0.1
  auto at = [&](double x, double y) {
    return volume(g.node_index(static_cast<index_t>(std::lround((x - g.origin_x) / g.spacing_x)),
                               static_cast<index_t>(std::lround((y - g.origin_y) / g.spacing_y))));
  };
  EXPECT_NEAR(at(1.0, 0.5), area, round_off(1e-15));             // inside
  EXPECT_NEAR(at(0.0, 0.5), area / 2, round_off(1e-15));         // on the inflow side
  EXPECT_NEAR(at(4.0, 0.5), area / 2, round_off(1e-15));         // on the outflow side
  EXPECT_NEAR(at(1.0, 0.0), area / 2, round_off(1e-15));         // on the wall
  EXPECT_NEAR(at(0.0, 0.0), area / 4, round_off(1e-15));         // in a corner
  EXPECT_EQ(at(-0.1, 0.5), 0.0);                      // beyond the domain
  EXPECT_EQ(at(1.0, 2.0), 0.0);                       // on the far-field side
  EXPECT_EQ(at(1.0, 1.9), 0.0);                       // a cell inside it
  EXPECT_NEAR(at(1.0, 1.8), area, round_off(1e-15));             // two cells inside it
  EXPECT_EQ(at(2.0, 1.0), 0.0);                       // deep in the obstacle
  EXPECT_NEAR(at(2.0, 1.5), area, round_off(1e-15));             // 0.25 from it, beyond a diagonal (0.141)
  // 0.05 from it: the hat outside the circle, by a finer midpoint rule than the solver's.
  double outside = 0;
  constexpr int n = 400;
  for (int b = 0; b < n; ++b)
    for (int a = 0; a < n; ++a) {
      const double u = -1 + (a + 0.5) * 2 / n, w = -1 + (b + 0.5) * 2 / n;
      if (std::hypot(2.0 + 0.1 * u - 2, 1.3 + 0.1 * w - 1) > 0.25) outside += (1 - std::fabs(u)) * (1 - std::fabs(w));
    }
  outside *= (2.0 / n) * (2.0 / n) * area;
  EXPECT_LT(outside, 0.95 * area);  // the circle takes a part of it
  EXPECT_NEAR(at(2.0, 1.3), -outside, 0.01 * area);
}

// The box the particle rules test before a cell's flag (ObstacleGrid::near_x_min ..) holds every
// flagged cell, and is far smaller than the domain; a grid without obstacles has an empty box.
TEST(SignedDistance, TheNearBoxHoldsEveryCellAnObstacleMayReachInto) {
  const CaseConfig config = circle_in_tunnel("slip_wall", "near_box.json");
  const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
  const ObstacleGrid grid = make_obstacle_grid(config.obstacles, slab, config.boundaries);
  const ParticleBoundaries rules(config, slab, grid);
  auto near = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grid.cell_near_obstacle);
  const GridGeometry& g = slab.geometry;
  index_t flagged = 0;
  for (index_t cj = 0; cj < g.cells_y(); ++cj)
    for (index_t ci = 0; ci < g.cells_x(); ++ci) {
      if (!near(ci + g.cells_x() * cj)) continue;
      ++flagged;
      // Its corners, edge midpoints and centre, the faces where the grid puts them (node_x(ci + 1),
      // not node_x(ci) + spacing_x: without contracted multiply-adds, as in the debug build, the
      // two differ in the last bit, and the second may lie in the next cell).
      const double xs[] = {g.node_x(ci), 0.5 * (g.node_x(ci) + g.node_x(ci + 1)), g.node_x(ci + 1)};
      const double ys[] = {g.node_y(cj), 0.5 * (g.node_y(cj) + g.node_y(cj + 1)), g.node_y(cj + 1)};
      for (const double x : xs)
        for (const double y : ys) EXPECT_TRUE(rules.near_an_obstacle(x, y)) << "cell " << ci << ", " << cj;
    }
  EXPECT_GT(flagged, 0);
  // The circle and a cell diagonal around it, to within a cell: [1.6, 2.4] x [0.6, 1.4].
  EXPECT_LT(grid.near_x_max - grid.near_x_min, 0.8 + 2 * g.spacing_x + round_off(1e-12));
  EXPECT_LT(grid.near_y_max - grid.near_y_min, 0.8 + 2 * g.spacing_y + round_off(1e-12));
  EXPECT_FALSE(rules.near_an_obstacle(0.5, 0.5));
  CaseConfig empty = config;
  empty.obstacles.clear();
  const ObstacleGrid none = make_obstacle_grid(empty.obstacles, slab, empty.boundaries);
  EXPECT_GT(none.near_x_min, none.near_x_max);
  EXPECT_FALSE(ParticleBoundaries(empty, slab, none).near_an_obstacle(2, 1));
}

// A points file of `points` in the test's temporary folder; its path.
std::string points_file(const std::string& name, const std::vector<std::pair<double, double>>& points) {
  const fs::path path = fs::path(testing::TempDir()) / (name + "_" + std::to_string(::getpid()) + ".dat");
  std::ofstream out(path);
  out.precision(17);
  for (const auto& [x, y] : points) out << x << " " << y << "\n";
  return path.string();
}

// A half disc of radius r on the floor (y = 0), centred at x = cx: its arc in n points from
// (cx + r, 0) to (cx - r, 0), its base along the floor, in a points file; its path.
std::string half_disc_points_file(const std::string& name, double cx, double r, int n = 181) {
  std::vector<std::pair<double, double>> arc;
  for (int k = 0; k < n; ++k) {
    const double angle = M_PI * k / (n - 1);
    arc.emplace_back(cx + r * std::cos(angle), r * std::sin(angle));  // (sin(pi) is 1e-16, not 0)
  }
  return points_file(name, arc);
}

// An edge on a side of the domain is no surface: the base of a half disc on the floor. A point
// inside just above the floor, or on the floor under the body (where the clamp to the domain puts
// particles), is inside, and its nearest surface is the arc. (Before, the base was the nearest
// surface: a particle that came in at the stagnation point on the floor was put back below the
// floor, clamped onto it, and slid along it through the body: WindTunnel.
// AHalfCylinderOnASymmetryWallIsHalfTheCylinder.)
TEST(SignedDistance, AnEdgeOnASideOfTheDomainIsNoSurface) {
  const std::string points = half_disc_points_file("half_disc", 2, 0.5);
  const CaseConfig config = parse_case(
      tunnel_case(kTunnelSides, kFreeStream + R"(, "obstacles": [{"type": "polygon", "file": ")" + points + R"("}])"),
      "half_disc.json");
  const ObstacleConfig& disc = config.obstacles[0];
  EXPECT_EQ(std::count(disc.edge_side.begin(), disc.edge_side.end(), int(bottom_side)), 1);  // the base
  EXPECT_EQ(std::count(disc.edge_side.begin(), disc.edge_side.end(), -1), 180);             // the arc
  const HostObstacleSet set = make_host_obstacle_set(config.obstacles);
  for (const double y : {0.0, 0.001}) {
    const SignedDistance sd = set(2.2, y);  // 0.3 from the arc, radially out along +x
    EXPECT_NEAR(sd.distance, -0.3, 1e-3) << "y " << y;
    EXPECT_NEAR(sd.normal_x, 1, 1e-3) << "y " << y;
  }
  EXPECT_NEAR(set(2, 0.2).distance, -0.3, 1e-3);
  EXPECT_GT(set(1.4, 0).distance, 0);  // on the floor before the body
  // The outline the case gives is the body's (the step's end stays on the outflow side).
  const CaseConfig step = load_case_file(std::string(MPMFLOW_SOURCE_DIR) + "/cases/step_mach3.json");
  EXPECT_EQ(step.obstacles[0].vertices_x, (std::vector<real_t>{0.6, 3, 3, 0.6}));
  EXPECT_EQ(step.obstacles[0].vertices_y, (std::vector<real_t>{0, 0, 0.2, 0.2}));
  EXPECT_EQ(step.obstacles[0].edge_side, (std::vector<int>{bottom_side, right_side, -1, -1}));
  fs::remove(points);
}

// The nodes on a face along a grid line are inside the body, with the face's normal, all of them;
// a node on a corner with both faces' normals (one face's normal alone would stop the gas at the
// corner moving along the other: over the step's corner, which left a near-vacuum behind it), its
// gas shared between them (GridConditions.SurfaceNodesKeepTheGasFromEnteringOnly). Before, the
// normal came from the node's difference to its nearest point, round-off for a node on the face
// ((0, 1) or (0, -1) for nodes on the step's front face), and the sign of the distance with it
// (some nodes on the step's top inside, some out).
// Two obstacle sets give the same signed distance (to 1e-12) and normal (to 1e-9) on a lattice of
// spacing `step` over [x0, x1] x [y0, y1].
void expect_same_signed_distance(const HostObstacleSet& first, const HostObstacleSet& second, double x0, double x1,
                                 double y0, double y1, double step) {
  for (double x = x0; x <= x1; x += step)
    for (double y = y0; y <= y1; y += step) {
      const SignedDistance a = first(x, y), b = second(x, y);
      EXPECT_NEAR(a.distance, b.distance, round_off(1e-12)) << x << ", " << y;
      EXPECT_NEAR(a.normal_x, b.normal_x, 1e-9) << x << ", " << y;
      EXPECT_NEAR(a.normal_y, b.normal_y, 1e-9) << x << ", " << y;
    }
}

// An obstacle that reaches beyond the domain is its part inside: a 30 degree ramp from (0.5, 0) run
// out beyond the top and the right of the tunnel [0, 4] x [0, 2] is the polygon clipped to it, its
// edges on the sides no surface, and its signed distance is that of the same part given by hand;
// a rectangle reaching below the floor is the rectangle inside.
TEST(SignedDistance, AnObstacleReachingBeyondTheDomainIsItsPartInside) {
  const double tan30 = std::tan(3.14159265358979323846 / 6);
  const std::string beyond = points_file("ramp_beyond", {{0.5, 0}, {5, 4.5 * tan30}, {5, -1}, {0.5, -1}});
  const double top_x = 0.5 + 2 / tan30;  // where the ramp's face meets the top side
  const std::string by_hand = points_file("ramp_by_hand", {{0.5, 0}, {top_x, 2}, {4, 2}, {4, 0}});
  auto ramp = [](const std::string& file) {
    return parse_case(tunnel_case(kTunnelSides, kFreeStream + R"(, "obstacles": [{"type": "polygon", "file": ")" +
                                                    file + R"("}])"),
                      "ramp.json");
  };
  const CaseConfig clipped = ramp(beyond), given = ramp(by_hand);
  const ObstacleConfig& o = clipped.obstacles[0];
  ASSERT_EQ(o.vertices_x.size(), 4u);
  // In the file's order, from its first vertex (inside): the face, then along the top, the right
  // side and the floor.
  const std::vector<real_t> expected_x = {0.5, top_x, 4, 4};
  for (size_t v = 0; v < 4; ++v) EXPECT_NEAR(o.vertices_x[v], expected_x[v], round_off(1e-12)) << v;
  EXPECT_EQ(o.vertices_y, (std::vector<real_t>{0, 2, 2, 0}));  // on the sides exactly
  EXPECT_EQ(o.edge_side, (std::vector<int>{-1, top_side, right_side, bottom_side}));
  const HostObstacleSet clipped_set = make_host_obstacle_set(clipped.obstacles);
  const HostObstacleSet given_set = make_host_obstacle_set(given.obstacles);
  expect_same_signed_distance(clipped_set, given_set, 0, 4, 0, 2, 0.1);
  EXPECT_NEAR(clipped_set(2, 0.5).distance, -((2 - 0.5) * tan30 - 0.5) * std::cos(3.14159265358979323846 / 6), round_off(1e-12));
  const CaseConfig block = parse_case(
      tunnel_case(kTunnelSides, kFreeStream + R"(, "obstacles": [{"type": "rectangle", "x": [3, 5], "y": [-1, 0.5]}])"),
      "block.json");
  EXPECT_EQ(block.obstacles[0].vertices_x, (std::vector<real_t>{4, 4, 3, 3}));
  EXPECT_EQ(block.obstacles[0].vertices_y, (std::vector<real_t>{0, 0.5, 0.5, 0}));
  fs::remove(beyond);
  fs::remove(by_hand);
}

// A circle that reaches beyond the domain is a polygon of 360 points clipped to it: centred on the
// floor, the half disc of a points file (half_disc_points_file: 181 points a degree apart, its base
// on the floor), the same signed distance; a circle within the domain stays a circle.
TEST(SignedDistance, ACircleReachingBeyondTheDomainIsThePolygonOfItsPartInside) {
  const std::string points = half_disc_points_file("half_disc_by_file", 2, 0.5);
  auto tunnel_with = [](const std::string& obstacle) {
    return parse_case(tunnel_case(kTunnelSides, kFreeStream + R"(, "obstacles": [)" + obstacle + "]"), "half.json");
  };
  const CaseConfig circle = tunnel_with(R"({"type": "circle", "centre": [2, 0], "radius": 0.5})");
  const CaseConfig file = tunnel_with(R"({"type": "polygon", "file": ")" + points + R"("})");
  const ObstacleConfig& half = circle.obstacles[0];
  EXPECT_EQ(half.shape, ObstacleShape::polygon);
  ASSERT_EQ(half.vertices_x.size(), 181u);  // 0 to 180 degrees; the base closes it
  EXPECT_EQ(std::count(half.edge_side.begin(), half.edge_side.end(), int(bottom_side)), 1);
  EXPECT_NEAR(half.reference_length, 1.0, round_off(1e-12));  // the diameter, along the flow
  const HostObstacleSet from_circle = make_host_obstacle_set(circle.obstacles);
  const HostObstacleSet from_file = make_host_obstacle_set(file.obstacles);
  expect_same_signed_distance(from_circle, from_file, 1, 3, 0, 1, 0.05);
  EXPECT_EQ(tunnel_with(R"({"type": "circle", "centre": [2, 1], "radius": 0.5})").obstacles[0].shape,
            ObstacleShape::circle);
  fs::remove(points);
}

TEST(SignedDistance, NodesOnAFaceAlongAGridLineAreInsideWithTheFacesNormal) {
  const CaseConfig config = parse_case(
      tunnel_case(kTunnelSides, kFreeStream + R"(, "obstacles": [{"type": "rectangle", "x": [0.6, 2.3], "y": [0, 0.7]}])"),
      "block.json");
  const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
  const ObstacleGrid grid = make_obstacle_grid(config.obstacles, slab, config.boundaries);
  auto nodes = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grid.obstacle_nodes);
  auto normals = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grid.obstacle_normals);
  const GridGeometry& g = slab.geometry;  // spacing 0.1
  std::map<std::pair<index_t, index_t>, std::pair<double, double>> normal_at, second_normal_at;
  std::map<std::pair<index_t, index_t>, double> placement_at;
  for (size_t k = 0; k < nodes.extent(0); ++k) {
    const std::pair<index_t, index_t> at{g.node_i_of(nodes(k)), g.node_j_of(nodes(k))};
    normal_at[at] = {normals(k, ObstacleGrid::normal_x_column), normals(k, ObstacleGrid::normal_y_column)};
    second_normal_at[at] = {normals(k, ObstacleGrid::second_normal_x_column), normals(k, ObstacleGrid::second_normal_y_column)};
    placement_at[at] = normals(k, ObstacleGrid::placement_column);
  }
  auto line = [](double at, double origin, double spacing) { return static_cast<index_t>(std::lround((at - origin) / spacing)); };
  const index_t front = line(0.6, g.origin_x, g.spacing_x), back = line(2.3, g.origin_x, g.spacing_x);
  const index_t floor = line(0, g.origin_y, g.spacing_y), top = line(0.7, g.origin_y, g.spacing_y);
  auto expect_normal = [&](index_t i, index_t j, double nx, double ny) {
    const auto it = normal_at.find({i, j});
    ASSERT_NE(it, normal_at.end()) << "node " << i << ", " << j << " is not inside";
    EXPECT_NEAR(it->second.first, nx, round_off(1e-12)) << "node " << i << ", " << j;
    EXPECT_NEAR(it->second.second, ny, round_off(1e-12)) << "node " << i << ", " << j;
  };
  for (index_t j = floor; j < top; ++j) expect_normal(front, j, -1, 0), expect_normal(back, j, 1, 0);
  for (index_t i = front + 1; i < back; ++i) expect_normal(i, top, 0, 1);
  for (index_t i = front + 1; i < back; ++i) EXPECT_EQ(placement_at[std::make_pair(i, top)], ObstacleGrid::on_face) << i;
  // The corners: both faces' normals, in either order.
  for (const auto& [i, side_x] : {std::pair<index_t, double>{front, -1}, {back, 1}}) {
    EXPECT_EQ(placement_at[std::make_pair(i, top)], ObstacleGrid::on_convex_vertex) << i;
    std::set<std::pair<long, long>> faces{
        {std::lround(normal_at[{i, top}].first), std::lround(normal_at[{i, top}].second)},
        {std::lround(second_normal_at[{i, top}].first), std::lround(second_normal_at[{i, top}].second)}};
    EXPECT_EQ(faces, (std::set<std::pair<long, long>>{{std::lround(side_x), 0}, {0, 1}})) << i;
  }
}

class GeometryErrors : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(testing::TempDir()) / ("mpmflow_geometry_" + std::to_string(::getpid()));
    fs::create_directories(dir_ / "shapes");
  }
  void TearDown() override { fs::remove_all(dir_); }
  // Loads the case from a file in dir_, so that points files resolve against dir_.
  std::string error_of(const std::string& text) {
    std::ofstream(dir_ / "case.json") << text;
    try {
      load_case_file((dir_ / "case.json").string());
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "(no error)";
  }
  std::string polygon_case(const std::string& points) {
    std::ofstream(dir_ / "shapes" / "p.dat") << points;
    return tunnel_case(kTunnelSides, kFreeStream + R"(, "obstacles": [{"type": "circle", "centre": [2, 1], "radius": 0.1},
        {"type": "polygon", "file": "shapes/p.dat", "translation": [1, 1]}])");
  }
  fs::path dir_;
};

TEST_F(GeometryErrors, MissingPointsFile) {
  const std::string e = error_of(tunnel_case(
      kTunnelSides, kFreeStream + R"(, "obstacles": [{"type": "polygon", "file": "shapes/none.dat"}])"));
  EXPECT_NE(e.find("case.json: /obstacles/0/file: cannot open the points file '"), std::string::npos) << e;
  EXPECT_NE(e.find("shapes/none.dat'"), std::string::npos) << e;
}

TEST_F(GeometryErrors, FewerThanThreePoints) {
  const std::string e = error_of(polygon_case("0 0\n0.5 0.5\n"));
  EXPECT_NE(e.find("/obstacles/1 (polygon) from"), std::string::npos) << e;
  EXPECT_NE(e.find("expected a polygon of at least 3 points; got 2"), std::string::npos) << e;
}

TEST_F(GeometryErrors, SelfIntersectingPolygon) {
  const std::string e = error_of(polygon_case("0 0\n0.5 0.5\n0.5 0\n0 0.5\n"));
  EXPECT_NE(e.find("expected a simple polygon; it intersects itself: edge 0"), std::string::npos) << e;
}

TEST_F(GeometryErrors, BadLineInPointsFile) {
  const std::string e = error_of(polygon_case("title\n0 0\n0.5 x\n"));
  EXPECT_NE(e.find("p.dat' line 3: expected two numbers \"x y\"; got \"0.5 x\""), std::string::npos) << e;
}

TEST_F(GeometryErrors, ObstacleOutsideTheDomain) {
  const std::string e = error_of(tunnel_case(
      kTunnelSides, kFreeStream + R"(, "obstacles": [{"type": "circle", "centre": [4.5, 1], "radius": 0.25}])"));
  EXPECT_NE(e.find("/obstacles/0 (circle) reaching beyond the domain, as a polygon of 360 points: expected an "
                   "obstacle reaching into the domain [0, 4] x [0, 2]; it lies wholly outside it"),
            std::string::npos)
      << e;
}

// A polygon may reach beyond the domain, not lie wholly outside it, and its part inside must be one
// piece (here two prongs rising through the floor, [1, 1.5] and [2.5, 3] wide: p.dat is moved by
// (1, 1)).
TEST_F(GeometryErrors, APolygonBeyondTheDomainIsOnePieceInsideIt) {
  std::string e = error_of(polygon_case("4 4\n5 4\n5 5\n"));
  EXPECT_NE(e.find("/obstacles/1 (polygon) from"), std::string::npos) << e;
  EXPECT_NE(e.find(": expected an obstacle reaching into the domain [0, 4] x [0, 2]; it lies wholly outside it"),
            std::string::npos)
      << e;
  e = error_of(polygon_case("0 -2\n2 -2\n2 -0.5\n1.5 -0.5\n1.5 -1.5\n0.5 -1.5\n0.5 -0.5\n0 -0.5\n"));
  EXPECT_NE(e.find(": expected an obstacle whose part inside the domain [0, 4] x [0, 2] is one piece; clipped to it, "
                   "edge "),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("(give each piece as an obstacle of its own)"), std::string::npos) << e;
}

TEST_F(GeometryErrors, OpenSidesNeedAFreeStreamAndAnInflow) {
  std::string e = error_of(tunnel_case(kTunnelSides, ""));
  EXPECT_NE(e.find("case.json: /free_stream: required key is missing"), std::string::npos) << e;
  // Recycling needs an inflow to put particles back at, and cannot serve a far field.
  e = error_of(tunnel_case(
      R"({"left": {"type": "outflow"}, "right": {"type": "outflow"}, "particle_supply": "recycle"})", kFreeStream));
  EXPECT_NE(e.find("case.json: /boundaries: expected an inflow side"), std::string::npos) << e;
  e = error_of(tunnel_case(
      R"({"left": {"type": "inflow"}, "right": {"type": "far_field"}, "particle_supply": "recycle"})", kFreeStream));
  EXPECT_NE(e.find("case.json: /boundaries/particle_supply: far_field sides"), std::string::npos) << e;
  e = error_of(tunnel_case(R"({"left": {"type": "inflow"}, "particle_supply": "reuse"})", kFreeStream));
  EXPECT_NE(e.find("case.json: /boundaries/particle_supply: expected one of open, recycle"), std::string::npos) << e;
  // Open sides (the default) need no inflow: gas may only leave, or enter at a far field.
  EXPECT_EQ(error_of(tunnel_case(R"({"left": {"type": "outflow"}, "right": {"type": "far_field"}})", kFreeStream)),
            "(no error)");
}

TEST_F(GeometryErrors, ShippedCasesLoad) {
  for (const char* name : {"cylinder_mach3", "step_mach3", "aerofoil_transonic"}) {
    const CaseConfig c = load_case_file(std::string(MPMFLOW_SOURCE_DIR) + "/cases/" + name + ".json");
    EXPECT_EQ(c.obstacles.size(), 1u) << name;
  }
  const CaseConfig aerofoil = load_case_file(std::string(MPMFLOW_SOURCE_DIR) + "/cases/aerofoil_transonic.json");
  EXPECT_EQ(aerofoil.obstacles[0].vertices_x.size(), 160u);  // NACA 0012, 81 points a side, closed trailing edge
}

// ---- Particles: placement and recycling -----------------------------------------------------------

// The small tunnel, with the top-level keys of `extra_overrides_json` (", \"key\": value, ...")
// replacing the tunnel's own (a case file may not give a key twice).
CaseConfig tunnel_config(const std::string& extra_overrides_json = "") {
  nlohmann::json doc = nlohmann::json::parse(tunnel_case(kTunnelSides, kFreeStream));
  if (!extra_overrides_json.empty())
    doc.update(nlohmann::json::parse("{" + extra_overrides_json.substr(extra_overrides_json.find(',') + 1) + "}"));
  return parse_case(doc.dump(), "tunnel.json");
}

// A View's host copy (a particle field, the sums of a kernel).
template <class View>
auto host_copy(const View& view) {
  return Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), view);
}

using IdPosition = std::map<particle_id_t, std::pair<real_t, real_t>>;

IdPosition positions_by_id(const ParticleState& pt) {
  auto id = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.id);
  auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.position_x);
  auto y = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.position_y);
  IdPosition out;
  for (index_t k = 0; k < pt.count; ++k) out[id(k)] = {x(k), y(k)};
  return out;
}

TEST(ParticlePlacement, RandomPlacementAvoidsObstaclesAndDoesNotDependOnTheSplit) {
  const CaseConfig config =
      tunnel_config(R"(, "obstacles": [{"type": "circle", "centre": [1, 1], "radius": 0.5}])");
  const GridSlab whole = make_grid_slab(config.domain, 0, 40);
  const IdPosition all = positions_by_id(create_initial_particles(config, whole));
  // Fluid area 8 - pi/4 at 4 particles per cell of area 0.01: about 3121 particles.
  EXPECT_NEAR(double(all.size()), 4 * (8 - M_PI * 0.25) / 0.01, 60);
  for (const auto& p : all) EXPECT_GT(std::hypot(p.second.first - 1, p.second.second - 1), 0.5);
  // The same particles, wherever the grid is cut: positions depend on the seed and the id only.
  IdPosition halves = positions_by_id(create_initial_particles(config, make_grid_slab(config.domain, 0, 17)));
  const IdPosition right = positions_by_id(create_initial_particles(config, make_grid_slab(config.domain, 17, 40)));
  halves.insert(right.begin(), right.end());
  EXPECT_EQ(halves, all);
  // Another seed, other positions.
  CaseConfig reseeded = config;
  reseeded.particles.seed = 4;
  EXPECT_NE(positions_by_id(create_initial_particles(reseeded, whole)), all);
}

// Moves every particle of `pt` across the outflow side, applies the particle boundaries and the
// open sides of `open_sides` for a step of dt numbered `step`.
void push_through_outflow(const SlabState& slab, OpenBoundaries& open_sides, ParticleState& pt, real_t dt,
                          long step) {
  // Moved from 3.99 at V-bar = (1, 0): 3.99 + dt > 4, out through the right side.
  Kokkos::deep_copy(pt.position_x, real_t(3.99) + dt);
  apply_particle_boundaries(slab.particle_boundaries(), pt, dt);
  open_sides.exchange(pt, slab, dt, step);
}

// The tunnel with an inflow on the left, an outflow on the right and the paper's recycling.
CaseConfig recycling_tunnel_config() {
  return tunnel_config(R"(, "boundaries": {"left": {"type": "inflow"}, "right": {"type": "outflow"},
      "particle_supply": "recycle"})");
}

// A case on the small tunnel's whole grid (one slab of its 40 cells along x), with its slab's state
// and its initial particles.
struct WholeTunnel {
  explicit WholeTunnel(const CaseConfig& case_config)
      : config(case_config),
        slab(make_grid_slab(config.domain, 0, 40)),
        slab_state(config, slab),
        particles(create_initial_particles(config, slab)) {}
  const CaseConfig config;
  const GridSlab slab;
  const SlabState slab_state;
  ParticleState particles;
};

TEST(Recycling, ReentersWhereItLeftAlongTheSideWithTheFreeStreamStateIndependentOfOrder) {
  WholeTunnel tunnel(recycling_tunnel_config());
  const CaseConfig& config = tunnel.config;
  const GridSlab& slab = tunnel.slab;
  const SlabState& slab_state = tunnel.slab_state;
  ParticleState& forward = tunnel.particles;
  const index_t n = forward.count;
  // A split particle (half a placed particle's mass) keeps its mass through the recycling.
  const real_t placed_mass = real_t(1.4 * 0.01 / 4);
  Kokkos::deep_copy(Kokkos::subview(forward.mass, std::make_pair(index_t(0), index_t(1))), placed_mass / 2);
  const IdPosition exits = positions_by_id(forward);
  ParticleState backward = create_initial_particles(config, slab);
  Kokkos::deep_copy(backward.mass, forward.mass);
  // The same particles in reverse memory order: the threads meet them in another order.
  backward.for_each_field([&](const auto& view) {
    auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), view);
    std::reverse(host.data(), host.data() + backward.count);
    Kokkos::deep_copy(view, host);
  });
  const real_t dt = 0.02;  // the free stream (u = 3) sweeps a strip 0.06 deep: less than a cell (0.1)
  OpenBoundaries open_forward(config, slab), open_backward(config, slab);
  push_through_outflow(slab_state, open_forward, forward, dt, 7);
  push_through_outflow(slab_state, open_backward, backward, dt, 7);
  EXPECT_EQ(forward.count, n);  // recycled, not removed
  const IdPosition a = positions_by_id(forward), b = positions_by_id(backward);
  EXPECT_EQ(a, b);
  // 0.01 beyond the outflow (at x = 4.01): 0.01 inside the inflow, at the height it left at.
  for (const auto& [id, position] : a) {
    EXPECT_NEAR(position.first, 0.01, round_off(1e-12)) << id;
    EXPECT_EQ(position.second, exits.at(id).second) << id;
  }
  auto rho = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), forward.density);
  auto vx = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), forward.velocity_x);
  auto m = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), forward.mass);
  auto id = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), forward.id);
  for (index_t k = 0; k < forward.count; ++k) {
    EXPECT_EQ(rho(k), real_t(1.4));
    EXPECT_EQ(vx(k), real_t(3));
    EXPECT_NEAR(m(k), id(k) == 0 ? placed_mass / 2 : placed_mass, round_off(1e-15)) << id(k);
  }
  // What left and what entered are counted: all the mass, once each way, the split half's half.
  const double total_mass = 8 * 1.4 - placed_mass / 2;
  // (In single precision the particles' masses are float roundings of the placed mass: 3.5e-7 seen.)
  EXPECT_NEAR(open_forward.fluxes().left.mass, total_mass, per_precision(1e-9, 1e-5));
  EXPECT_NEAR(open_forward.fluxes().entered.mass, total_mass, per_precision(1e-9, 1e-5));
}

TEST(Recycling, GasThatWentBeyondMoreThanTheStripIsDeepIsWrappedIntoIt) {
  const CaseConfig config = recycling_tunnel_config();
  const GridSlab slab = make_grid_slab(config.domain, 0, 40);
  const SlabState slab_state(config, slab);
  ParticleState pt = create_initial_particles(config, slab);
  const real_t dt = 0.02;  // a strip 0.06 deep
  // 0.1 beyond the outflow: 0.1 - 0.06 = 0.04 inside the inflow.
  Kokkos::deep_copy(pt.position_x, real_t(4.1));
  apply_particle_boundaries(slab_state.particle_boundaries(), pt, dt);
  OpenBoundaries open_sides(config, slab);
  open_sides.exchange(pt, slab_state, dt, 3);
  for (const auto& [id, position] : positions_by_id(pt)) EXPECT_NEAR(position.first, 0.04, round_off(1e-12)) << id;
}

// ---- Open sides: particles entering and leaving ----------------------------------------------------

// The particles entering through the inflow side of an empty tunnel (no particles inside), step by
// step with uneven steps, on the slabs of `cuts` along y (the inflow side split among "ranks").
struct EnteringRun {
  std::vector<double> mass_per_step;  // entered in each step
  IdPosition particles;               // every particle entered, by id
  double particle_mass = 0;
};
EnteringRun enter_empty_tunnel(const CaseConfig& config, const std::vector<index_t>& cuts, int steps) {
  EnteringRun run;
  run.mass_per_step.assign(steps, 0.0);
  for (size_t k = 0; k + 1 < cuts.size(); ++k) {
    const GridSlab slab = make_grid_slab(config.domain, 1, cuts[k], cuts[k + 1]);
    const SlabState slab_state(config, slab);
    OpenBoundaries open_sides(config, slab);
    for (int step = 1; step <= steps; ++step) {
      ParticleState pt(0);
      const real_t dt = real_t(0.004 + 0.003 * (step % 3));  // 0.4 to 1 of a row spacing (0.05 / 3)
      const double before = open_sides.fluxes().entered.mass;
      open_sides.exchange(pt, slab_state, dt, step);
      run.mass_per_step[step - 1] += open_sides.fluxes().entered.mass - before;
      const IdPosition entered = positions_by_id(pt);
      for (const auto& p : entered) EXPECT_TRUE(run.particles.emplace(p).second) << "id " << p.first << " twice";
      if (pt.count > 0) run.particle_mass = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.mass)(0);
    }
  }
  return run;
}

// A side's depth and distance along it (the far-field strips' measure) undo the point placed at
// them (the entering particles' placement), on every side; a point beyond a side is at a negative
// depth.
TEST(OpenSides, TheDepthAndPlaceAlongASideUndoThePointPlacedThere) {
  DomainBox domain;
  domain.x_min = -1, domain.x_max = 3, domain.y_min = 0.5, domain.y_max = 2;
  for (int side : {left_side, right_side, bottom_side, top_side}) {
    SCOPED_TRACE(side);
    for (const auto& [along, depth] : {std::pair<real_t, real_t>{0.25, 0.125}, {1.0, 0.75}, {0.0, 0.0}}) {
      real_t x, y, depth_back, along_back;
      domain.point_inside_side(side, along, depth, x, y);
      domain.depth_and_along_side(side, x, y, depth_back, along_back);
      EXPECT_EQ(depth_back, depth);
      EXPECT_EQ(along_back, along);
    }
  }
  real_t depth, along;
  domain.depth_and_along_side(left_side, -1.5, 1, depth, along);
  EXPECT_EQ(depth, -0.5);
  domain.depth_and_along_side(top_side, 0, 2.25, depth, along);
  EXPECT_EQ(depth, -0.25);
  EXPECT_EQ(along, 1);
}

TEST(OpenSides, InflowMassPerStepIsTheFreeStreamFluxWithinOneParticleAndIdsAreUnique) {
  for (const char* placement : {"regular", "random"}) {
    CaseConfig config = tunnel_config(R"(, "boundaries": {"left": {"type": "inflow"}, "right": {"type": "outflow"}})");
    config.particles.placement = placement == std::string("regular") ? ParticlePlacement::regular
                                                                     : ParticlePlacement::random;
    config.particles.per_cell_x = 3;  // row spacing 0.1 / 3
    const int steps = 60;
    const EnteringRun run = enter_empty_tunnel(config, {0, 20}, steps);
    const double m = 1.4 * 0.01 / 6;
    EXPECT_NEAR(run.particle_mass, m, round_off(1e-15) * m);
    double total = 0, exact_total = 0, worst = 0;
    for (int step = 1; step <= steps; ++step) {
      const double dt = real_t(0.004 + 0.003 * (step % 3));
      const double exact = 1.4 * 3 * 2 * dt;  // rho_inf (v_inf . n) x side length x dt
      worst = std::max(worst, std::fabs(run.mass_per_step[step - 1] - exact) / m);
      total += run.mass_per_step[step - 1];
      exact_total += exact;
    }
    std::printf("[open sides] %s placement: %zu particles entered in %d steps, mass %.6f (exact %.6f), worst "
                "step off by %.3f particle masses\n", placement, run.particles.size(), steps, total, exact_total, worst);
    EXPECT_LE(worst, 1.0) << placement;
    EXPECT_LE(std::fabs(total - exact_total), m) << placement;
    // Inside the domain, within the depth the free stream travelled in the step (+ half a row
    // spacing of jitter when random), and spread evenly along the side.
    double mean_y = 0;
    for (const auto& p : run.particles) {
      EXPECT_GE(p.second.first, 0);
      EXPECT_LE(p.second.first, 3 * 0.01 + 0.1 / 6 + round_off(1e-12));
      EXPECT_GE(p.second.second, 0);
      EXPECT_LE(p.second.second, 2);
      mean_y += p.second.second / run.particles.size();
      EXPECT_GE(p.first, 40 * 20 * 6) << "an entering id must lie above the initial ids";
    }
    EXPECT_NEAR(mean_y, 1.0, 0.02) << placement;
  }
}

TEST(OpenSides, EnteringParticlesDoNotDependOnHowTheSideIsSplit) {
  for (const char* placement : {"regular", "random"}) {
    CaseConfig config = tunnel_config(R"(, "boundaries": {"left": {"type": "inflow"}, "right": {"type": "outflow"}})");
    config.particles.placement = placement == std::string("regular") ? ParticlePlacement::regular
                                                                     : ParticlePlacement::random;
    const EnteringRun whole = enter_empty_tunnel(config, {0, 20}, 12);
    const EnteringRun split = enter_empty_tunnel(config, {0, 7, 13, 20}, 12);
    EXPECT_FALSE(whole.particles.empty());
    EXPECT_EQ(whole.particles, split.particles) << placement;
  }
}

TEST(OpenSides, ParticlesLeavingAreRemovedAndCounted) {
  const CaseConfig config = tunnel_config(R"(, "boundaries": {"left": {"type": "inflow"}, "right": {"type": "outflow"}})");
  const GridSlab slab = make_grid_slab(config.domain, 0, 40);
  const SlabState slab_state(config, slab);
  ParticleState pt = create_initial_particles(config, slab);
  const index_t n = pt.count;
  // Every other particle (by index) leaves through the outflow side; the others stay.
  auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.position_x);
  auto id = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.id);
  std::set<particle_id_t> staying;
  const real_t dt = 0.02;
  for (index_t k = 0; k < n; ++k) {  // moved by dt V-bar, V-bar = (1, 0)
    x(k) = (k % 2 ? real_t(3.99) : real_t(2)) + dt;
    if (k % 2 == 0) staying.insert(id(k));
  }
  Kokkos::deep_copy(pt.position_x, x);
  OpenBoundaries open_sides(config, slab);
  apply_particle_boundaries(slab_state.particle_boundaries(), pt, dt);
  open_sides.exchange(pt, slab_state, dt, 1);
  // The staying particles, and the free stream that entered in the step: 3 x 0.02 = 0.06 deep, 1.2
  // rows 0.05 apart of 40 particles along the side: 48 particles.
  const IdPosition after = positions_by_id(pt);
  index_t kept = 0, entered = 0;
  for (const auto& p : after) (staying.count(p.first) ? kept : entered) += 1;
  EXPECT_EQ(kept, static_cast<index_t>(staying.size()));
  EXPECT_EQ(entered, 48);
  EXPECT_EQ(pt.count, kept + entered);
  EXPECT_NEAR(open_sides.fluxes().left.mass, (n - staying.size()) * 1.4 * 0.01 / 4, round_off(1e-12));
  EXPECT_NEAR(open_sides.fluxes().left.momentum_x, 3 * open_sides.fluxes().left.mass, round_off(1e-12));
  EXPECT_NEAR(open_sides.fluxes().entered.mass, 48 * 1.4 * 0.01 / 4, round_off(1e-12));
}

// The allocations a tracker counted, by label, for a failure's message.
std::string allocations_by_label(const AllocationTracker& allocations) {
  std::string listed;
  for (const auto& [label, count] : allocations.allocation_count_by_label())
    listed += " " + label + " (" + std::to_string(count) + ")";
  return listed;
}

// The open sides run every step, and the far-field sides' strips are measured through a
// ScatterView they keep (KeptScatterView): once the lists have grown, an exchange of as many
// particles allocates nothing (on a GPU an allocation and its free cost more than the small
// kernels of a side; made for each call, the ScatterView's copies were allocations every step on
// CPUs).
TEST(OpenSides, ASecondExchangeOfAsManyParticlesAllocatesNothing) {
  const CaseConfig config = tunnel_config(R"(, "boundaries": {"left": {"type": "inflow"}, "right": {"type": "outflow"},
      "bottom": {"type": "far_field"}, "top": {"type": "far_field"}})");
  const GridSlab slab = make_grid_slab(config.domain, 0, 40);
  const SlabState slab_state(config, slab);
  OpenBoundaries open_sides(config, slab);
  const real_t dt = 0.02;
  for (int round = 0; round < 2; ++round) {
    ParticleState pt = create_initial_particles(config, slab);  // the same particles each round
    pt.reserve(2 * pt.count);  // room for those entering: the particle Views do not grow
    // Every tenth particle leaves through the right side (and the free stream enters on the left).
    auto x = host_copy(pt.position_x);
    for (index_t k = 0; k < pt.count; k += 10) x(k) = real_t(4.01);
    Kokkos::deep_copy(pt.position_x, x);
    apply_particle_boundaries(slab_state.particle_boundaries(), pt, dt);
    const index_t before = pt.count;
    const AllocationTracker allocations;
    open_sides.exchange(pt, slab_state, dt, round + 1);
    EXPECT_NE(pt.count, before) << "round " << round << ": nothing left or entered, the test covers little";
    if (round == 1)
      EXPECT_EQ(allocations.allocation_count(), 0) << "allocations in the second exchange:"
                                                   << allocations_by_label(allocations);
  }
}

// Field f's entry p of the first n: 1000 f + p (distinct across fields and particles; exact in every
// field type), so that an entry tells which field and particle it came from.
void number_every_field(const ParticleState& pt, index_t n) {
  int f = 0;
  pt.for_each_field([&](const auto& field) {
    auto h = Kokkos::create_mirror_view(field);
    for (index_t p = 0; p < n; ++p) h(p) = 1000 * f + p;
    Kokkos::deep_copy(field, h);
    ++f;
  });
}

// The particle Views grow as the gas entering and splitting need (grow_to_hold): every field of the
// particles in use is kept, entry by entry, and keeps its label (the profiling regions and the
// allocation counts name the fields by it).
TEST(ParticleStorage, GrowingKeepsEveryFieldOfTheParticlesInUse) {
  const index_t n = 1000, in_use = 700;
  ParticleState pt(n);
  pt.count = in_use;
  number_every_field(pt, n);
  std::vector<std::string> labels;
  pt.for_each_field([&](const auto& field) { labels.push_back(field.label()); });

  pt.grow_to_hold(2 * n);
  EXPECT_GE(pt.capacity(), 2 * n);
  EXPECT_EQ(pt.count, in_use);
  int f = 0;
  pt.for_each_field([&](const auto& field) {
    SCOPED_TRACE(field.label());
    EXPECT_EQ(field.label(), labels[static_cast<size_t>(f)]);
    EXPECT_EQ(static_cast<index_t>(field.extent(0)), pt.capacity());
    auto h = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), field);
    index_t wrong = 0;
    for (index_t p = 0; p < in_use; ++p) wrong += h(p) == std::decay_t<decltype(h(p))>(1000 * f + p) ? 0 : 1;
    EXPECT_EQ(wrong, 0);
    ++f;
  });
  EXPECT_EQ(f, static_cast<int>(labels.size()));
}

// copy_particles moves particles whole, every field, in one launch (a GPU pays a launch's latency
// however few particles move): to listed places and to places from `first` on.
TEST(ParticleStorage, CopyParticlesCopiesEveryFieldInOneLaunch) {
  const index_t n = 100;
  ParticleState pt(n);
  pt.count = n;
  number_every_field(pt, n);
  // Particles 3 and 7 to 90 and 95; particles 10, 11 and 12 to 50, 51 and 52.
  const IndexView to = to_device_indices("copy_to", {90, 95}), from = to_device_indices("copy_from", {3, 7});
  const IndexView from_run = to_device_indices("copy_from_run", {10, 11, 12});
  long long copy_launches = 0;
  {
    const LaunchCensus census(/*by_label=*/true);
    copy_particles("test_copy", pt, to, 0, from, 2);
    copy_particles("test_copy", pt, IndexView(), 50, from_run, 3);
    copy_launches = census.by_label().at("test_copy");
  }
  EXPECT_EQ(copy_launches, 2);
  const std::map<index_t, index_t> source_of = {{90, 3}, {95, 7}, {50, 10}, {51, 11}, {52, 12}};
  int f = 0;
  pt.for_each_field([&](const auto& field) {
    SCOPED_TRACE(field.label());
    auto h = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), field);
    index_t wrong = 0;
    for (index_t p = 0; p < n; ++p) {
      const auto it = source_of.find(p);
      const index_t source = it == source_of.end() ? p : it->second;
      wrong += h(p) == std::decay_t<decltype(h(p))>(1000 * f + source) ? 0 : 1;
    }
    EXPECT_EQ(wrong, 0);
    ++f;
  });
}

// A moved ParticleState hands its fields over whole: the source keeps none (with Kokkos 3.4 a View's
// move is a copy, and a defaulted move left the source sharing every field, which stayed allocated
// as long as the source lived), and the target's are the only holders. A copy shares them.
TEST(ParticleStorage, AMoveLeavesTheSourceHoldingNoField) {
  auto expect_sole_holder = [](const ParticleState& target, const ParticleState& source, index_t count) {
    EXPECT_EQ(target.count, count);
    EXPECT_EQ(source.count, 0);
    EXPECT_EQ(source.capacity(), 0);
    target.for_each_field([](const auto& field) {
      SCOPED_TRACE(field.label());
      EXPECT_EQ(field.use_count(), 1);
    });
    source.for_each_field([](const auto& field) {
      SCOPED_TRACE(field.label());
      EXPECT_EQ(field.data(), nullptr);
    });
  };
  ParticleState source(100);
  source.count = 60;
  const ParticleState copy = source;
  EXPECT_EQ(copy.mass.data(), source.mass.data());
  EXPECT_EQ(source.mass.use_count(), 2);
  {
    ParticleState only(100);
    only.count = 60;
    const ParticleState moved(std::move(only));
    expect_sole_holder(moved, only, 60);
  }
  {
    ParticleState only(100), assigned;
    only.count = 60;
    assigned = std::move(only);
    expect_sole_holder(assigned, only, 60);
  }
}

// The reorder's new storage for a field takes the block that the field before it freed
// (reuse_freed_host_memory): a field of 8e6 doubles (64 MB, above glibc's largest mmap threshold)
// allocated, written, freed and allocated again, the second writing faults in (almost) no page.
// Served by mmap, as glibc does by default, each of its 15,625 pages faults again.
TEST(HostMemory, AFreedLargeFieldIsReusedWithoutFaultingItsPagesAgain) {
  if (!std::is_same<MemorySpace, Kokkos::HostSpace>::value) GTEST_SKIP() << "the particle fields are not in host memory";
#if !defined(__GLIBC__)
  GTEST_SKIP() << "not glibc: the C library's allocator is left as it is";
#endif
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's allocator stands in for glibc's, which mallopt sets";
#endif
  ASSERT_TRUE(reuse_freed_host_memory());
  const index_t n = 8'000'000;
  const auto minor_faults = [] {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return static_cast<long>(usage.ru_minflt);
  };
  const auto write_new_field = [&] {
    const Kokkos::View<double*, DeviceType> field(Kokkos::view_alloc(Kokkos::WithoutInitializing, "large_field"), n);
    const long before = minor_faults();
    Kokkos::deep_copy(field, 1.0);
    Kokkos::fence();
    return minor_faults() - before;
  };
  const long first = write_new_field();
  const long again = write_new_field();
  EXPECT_GT(first, 10000);  // the first time, its pages are new (a 4 KiB page each: 15,625)
  EXPECT_LT(again, 200);
}

// ---- Grid boundary conditions --------------------------------------------------------------------

// The energy budget sums the conditions' work over GridBoundaryConditions::conditioned_nodes
// alone: every node of the slab's share (its owned nodes and the ghost nodes beyond the domain)
// whose momentum or force a condition changes must be in that list. Every side type, an obstacle,
// and the tunnel whole and cut into slabs along x and along y.
TEST(GridConditions, ChangeOnlyTheNodesTheEnergyBudgetSumsOver) {
  const CaseConfig config = tunnel_config(
      R"(, "boundaries": {"left": {"type": "inflow"}, "right": {"type": "outflow"}, "bottom": {"type": "slip_wall"},
          "top": {"type": "far_field"}}, "obstacles": [{"type": "circle", "centre": [2, 1], "radius": 0.25}])");
  const std::vector<GridSlab> slabs = {make_grid_slab(config.domain, 0, 0, 40), make_grid_slab(config.domain, 0, 0, 19),
                                       make_grid_slab(config.domain, 0, 19, 40), make_grid_slab(config.domain, 1, 0, 9),
                                       make_grid_slab(config.domain, 1, 9, 20)};
  for (const GridSlab& slab : slabs) {
    const SlabState slab_state(config, slab);
    const NodeFieldsView state = slab_state.fields().state;
    const auto listed = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), slab_state.fields().conditioned_node);
    const std::set<index_t> in_list(listed.data(), listed.data() + listed.extent(0));
    EXPECT_EQ(in_list.size(), listed.extent(0));
    EXPECT_TRUE(std::is_sorted(listed.data(), listed.data() + listed.extent(0)));
    // Every node carries mass, momentum and force (no condition is idle for want of them).
    // (Copies, not mirror views: on the host those would be `state` itself.)
    const auto initial = Kokkos::create_mirror(state);
    for (size_t node = 0; node < state.extent(0); ++node)
      for (size_t c = 0; c < state.extent(1); ++c)
        initial(node, c) = c == GridFields::mass ? 1 + 0.001 * (node % 7) : 0.3 + 0.01 * ((node * (c + 3)) % 11);
    const IndexRange2D share = slab.owned_nodes_with_outer_ghosts();
    const auto changed_nodes = [&](const auto& apply) {
      Kokkos::deep_copy(state, initial);
      apply();
      const auto after = Kokkos::create_mirror(state);
      Kokkos::deep_copy(after, state);
      std::set<index_t> changed;
      for (index_t j = share.begin_y; j < share.end_y; ++j)
        for (index_t i = share.begin_x; i < share.end_x; ++i) {
          const index_t node = slab.geometry.node_index(i, j);
          for (size_t c = 0; c < state.extent(1); ++c)
            if (after(node, c) != initial(node, c)) changed.insert(node);
        }
      return changed;
    };
    const GridBoundaryConditions& conditions = slab_state.grid_boundaries();
    const std::set<index_t> by_step_4 = changed_nodes([&] { conditions.apply_to_momentum_and_force(state); });
    const std::set<index_t> by_step_9 =
        changed_nodes([&] { conditions.apply_to_momentum(state, GridFields::momentum_x, state); });
    EXPECT_FALSE(by_step_4.empty());
    EXPECT_FALSE(by_step_9.empty());
    for (const std::set<index_t>* changed : {&by_step_4, &by_step_9})
      for (const index_t node : *changed)
        EXPECT_TRUE(in_list.count(node)) << "node " << slab.geometry.node_i_of(node) << ", "
                                         << slab.geometry.node_j_of(node) << " of the slab from cell "
                                         << slab.owned_cell_begin_x << ", " << slab.owned_cell_begin_y;
  }
}

// A node under two sides' conditions takes both, in the order pressure sides, inflow sides, slip
// walls: in the corners of an inflow side and a slip wall (ghost nodes included) the free stream's
// momentum along the wall and none across it; at the inflow side's end on a far-field side the
// inflow's zero force, not the traction; on the slip wall at the outflow side, where the gas leaves
// (the side's line and the ghost line beyond), the gas outside's force and inertia along it and no
// force across it. The free stream crosses the slip wall (velocity [3, 1]), so that the
// inflow's momentum across it is not zero already. The tunnel whole and cut into slabs.
TEST(GridConditions, ANodeUnderTwoSidesTakesBothConditionsInTheSidesOrder) {
  const CaseConfig config = tunnel_config(
      R"(, "boundaries": {"left": {"type": "inflow"}, "right": {"type": "outflow"}, "bottom": {"type": "slip_wall"},
          "top": {"type": "far_field"}}, "free_stream": {"density": 1.4, "pressure": 1, "velocity": [3, 1]})");
  const std::vector<GridSlab> slabs = {make_grid_slab(config.domain, 0, 0, 40), make_grid_slab(config.domain, 0, 0, 19),
                                       make_grid_slab(config.domain, 0, 19, 40), make_grid_slab(config.domain, 1, 0, 9),
                                       make_grid_slab(config.domain, 1, 9, 20)};
  const index_t last_i = config.domain.cells_x, last_j = config.domain.cells_y;
  int corners_seen = 0;
  for (const GridSlab& slab : slabs) {
    const SlabState slab_state(config, slab);
    const NodeFieldsView state = slab_state.fields().state;
    const auto initial = Kokkos::create_mirror(state);
    for (size_t node = 0; node < state.extent(0); ++node)
      for (size_t c = 0; c < state.extent(1); ++c)
        initial(node, c) = c == GridFields::mass ? 1 + 0.001 * (node % 7) : 0.3 + 0.01 * ((node * (c + 3)) % 11);
    const GridBoundaryConditions& conditions = slab_state.grid_boundaries();
    for (const bool with_force : {true, false}) {
      Kokkos::deep_copy(state, initial);
      if (with_force)
        conditions.apply_to_momentum_and_force(state);
      else
        conditions.apply_to_momentum(state, GridFields::momentum_x, state);
      const auto after = Kokkos::create_mirror(state);
      Kokkos::deep_copy(after, state);
      for (index_t j = 0; j < slab.geometry.nodes_y; ++j)
        for (index_t i = 0; i < slab.geometry.nodes_x; ++i) {
          const index_t node = slab.geometry.node_index(i, j);
          const index_t gi = i - slab.local_node_x(0), gj = j - slab.local_node_y(0);
          const double m = initial(node, GridFields::mass);
          const auto value = [&](int column) { return after(node, column); };
          const auto was = [&](int column) { return initial(node, column); };
          const std::string where = "global node " + std::to_string(gi) + ", " + std::to_string(gj) +
                                    (with_force ? ", momentum and force" : ", momentum");
          const bool inflow = gi <= 0, slip = gj <= 0;
          if (inflow) {
            EXPECT_DOUBLE_EQ(value(GridFields::momentum_x), real_t(3 * m)) << where;  // (3 m in the build's reals)
            EXPECT_DOUBLE_EQ(value(GridFields::momentum_y), slip ? 0.0 : m) << where;
            if (with_force) {
              EXPECT_EQ(value(GridFields::force_x), 0.0) << where;  // at gj = last_j: after the traction
              EXPECT_EQ(value(GridFields::force_y), 0.0) << where;
            }
            corners_seen += slip || gj == last_j;
          } else if (slip) {
            EXPECT_EQ(value(GridFields::momentum_y), 0.0) << where;
            EXPECT_EQ(value(GridFields::momentum_x), was(GridFields::momentum_x)) << where;
            if (with_force) {
              EXPECT_EQ(value(GridFields::force_y), 0.0) << where;
              // The gas outside acts along the wall on the outflow's line (gi = last_i, gj = 0) and
              // the ghost line beyond; the line inside keeps its force (no particles: g = 0).
              if (gi >= last_i && gj == 0)
                EXPECT_NE(value(GridFields::force_x), was(GridFields::force_x)) << where;
              else
                EXPECT_EQ(value(GridFields::force_x), was(GridFields::force_x)) << where;
            }
          }
        }
    }
  }
  EXPECT_GT(corners_seen, 0);
}

// Step 4 computes the stencils of the particles of the cells BoundaryVolumeGradients marks, for
// the volume gradients on the crossed pressure sides' nodes and the obstacles' pressure nodes: the
// sums are those of every particle, bit for bit (integers), for each shape; an outflow side and a
// far-field side the free stream leaves through, a circle and a square; the tunnel whole and cut
// into slabs along x and along y. And the marks stand where a stencil may reach such a node, not
// far from them. The sides' entries are looked up by node: each node's is the one its (i, j) give.
TEST(GridConditions, TheCellsMarkedForTheVolumeGradientsHoldEveryParticleThatAddsToThem) {
  for (const char* shape : {"linear", "gimp", "bspline"}) {
    const CaseConfig config = tunnel_config(
        std::string(R"(, "boundaries": {"left": {"type": "inflow"}, "right": {"type": "outflow"},
            "bottom": {"type": "slip_wall"}, "top": {"type": "far_field"}},
            "free_stream": {"density": 1.4, "pressure": 1, "velocity": [3, 0.5]},
            "particles": {"placement": "random", "per_cell": [3, 3], "seed": 11},
            "obstacles": [{"type": "circle", "centre": [1.5, 1], "radius": 0.3},
                          {"type": "rectangle", "x": [2.55, 3.05], "y": [0.35, 0.75]}],
            "numerics": {"shape_function": ")") +
        shape + R"("})");
    const std::vector<GridSlab> slabs = {make_grid_slab(config.domain, 0, 0, 40), make_grid_slab(config.domain, 0, 0, 23),
                                         make_grid_slab(config.domain, 0, 23, 40), make_grid_slab(config.domain, 1, 0, 12),
                                         make_grid_slab(config.domain, 1, 12, 20)};
    for (const GridSlab& slab : slabs) {
      const std::string where = std::string(shape) + ", the slab from cell " + std::to_string(slab.owned_cell_begin_x) +
                                ", " + std::to_string(slab.owned_cell_begin_y);
      const SlabState slab_state(config, slab);
      const ParticleState pt = create_initial_particles(config, slab);
      GridFields fields(slab.geometry);
      const auto transfers = make_transfer_kernels(config, slab.geometry, fields);
      const BoundaryVolumeGradients marked = slab_state.grid_boundaries().volume_gradients();
      ASSERT_TRUE(marked.side_nodes.any_crossed) << where;
      // The entry each node's stencils look up (PressureSideNodes::entry_of) is its (i, j)'s.
      const auto node_entry = host_copy(marked.side_nodes.node_entry);
      ASSERT_EQ(node_entry.extent(0), static_cast<size_t>(slab.geometry.num_nodes())) << where;
      for (index_t n = 0; n < slab.geometry.num_nodes(); ++n)
        ASSERT_EQ(node_entry(n), marked.side_nodes.entry(slab.geometry.node_i_of(n), slab.geometry.node_j_of(n)))
            << where << ", node " << n;
      // The same sums with every cell marked for both.
      BoundaryVolumeGradients every = marked;
      const Kokkos::View<unsigned char*, DeviceType> all_cells("all_cells", marked.cell_reach.extent(0));
      Kokkos::deep_copy(all_cells, BoundaryVolumeGradients::reaches_side | BoundaryVolumeGradients::reaches_obstacle);
      every.cell_reach = all_cells;
      every.side_gradients = Kokkos::View<long long*, DeviceType>("side", marked.side_gradients.extent(0));
      every.obstacle_gradients = Kokkos::View<long long*, DeviceType>("obstacle", marked.obstacle_gradients.extent(0));
      Kokkos::deep_copy(marked.side_gradients, 0);
      Kokkos::deep_copy(marked.obstacle_gradients, 0);
      transfers->add_boundary_volume_gradients(pt, marked);
      transfers->add_boundary_volume_gradients(pt, every);
      const auto side = host_copy(marked.side_gradients), side_every = host_copy(every.side_gradients);
      const auto obstacle = host_copy(marked.obstacle_gradients), obstacle_every = host_copy(every.obstacle_gradients);
      int side_sums = 0, obstacle_sums = 0;
      for (size_t e = 0; e < side.extent(0); ++e) {
        EXPECT_EQ(side(e), side_every(e)) << where << ", side entry " << e;
        side_sums += side(e) != 0;
      }
      for (size_t e = 0; e < obstacle.extent(0); ++e) {
        EXPECT_EQ(obstacle(e), obstacle_every(e)) << where << ", obstacle entry " << e;
        obstacle_sums += obstacle(e) != 0;
      }
      EXPECT_GT(side_sums, 10) << where;
      EXPECT_GT(obstacle_sums, 10) << where;  // (each slab holds a body, or a part of one)
      // Marked where a stencil may reach such a node, and only there, among the slab's own cells:
      // none with its centre in [0, 0.6] x [0, 1.5], well away from both bodies and both crossed
      // sides; the outlet's last column for its side; the cells the circle's surface cuts for it.
      const auto marks = host_copy(marked.cell_reach);
      const GridGeometry& g = slab.geometry;
      int far = 0, by_outlet = 0, by_circle = 0;
      for (index_t c = 0; c < g.num_cells(); ++c) {
        const index_t gi = g.cell_i_of(c) + slab.node_offset_x, gj = g.cell_j_of(c) + slab.node_offset_y;
        if (gi < slab.owned_cell_begin_x || gi >= slab.owned_cell_end_x || gj < slab.owned_cell_begin_y ||
            gj >= slab.owned_cell_end_y)
          continue;
        const double x = (gi + 0.5) * g.spacing_x, y = (gj + 0.5) * g.spacing_y;
        const std::string cell = where + ", the cell at " + std::to_string(x) + ", " + std::to_string(y);
        if (x < 0.6 && y < 1.5) {
          ++far;
          EXPECT_EQ(marks(c), 0) << cell;
        }
        if (gi == config.domain.cells_x - 1) {
          ++by_outlet;
          EXPECT_TRUE(marks(c) & BoundaryVolumeGradients::reaches_side) << cell;
        }
        if (std::abs(std::hypot(x - 1.5, y - 1) - 0.3) < 0.5 * g.spacing_x) {
          ++by_circle;
          EXPECT_TRUE(marks(c) & BoundaryVolumeGradients::reaches_obstacle) << cell;
        }
      }
      EXPECT_GT(far + by_outlet + by_circle, 0) << where;
    }
  }
}

// Step 4 adds into the volume gradients every step through ScatterViews the transfers keep
// (KeptScatterView): a second addition allocates nothing (made for each call, a duplicated
// ScatterView's copies were two allocations a step on CPUs), and its sums are the first's: the
// kept copies start from zero each time. Other Views of sums (as a slab rebuilt by a rebalance
// holds) take a ScatterView of their own: the same sums there too.
TEST(GridConditions, ASecondAdditionOfTheVolumeGradientsAllocatesNothingAndSumsTheSame) {
  const CaseConfig config =
      tunnel_config(R"(, "boundaries": {"left": {"type": "inflow"}, "right": {"type": "outflow"},
          "bottom": {"type": "slip_wall"}, "top": {"type": "slip_wall"}},
          "obstacles": [{"type": "circle", "centre": [3.2, 1], "radius": 0.3}])");
  const GridSlab slab = make_grid_slab(config.domain, 0, 0, 40);
  const SlabState slab_state(config, slab);
  const ParticleState pt = create_initial_particles(config, slab);
  GridFields fields(slab.geometry);
  const auto transfers = make_transfer_kernels(config, slab.geometry, fields);
  const BoundaryVolumeGradients sums = slab_state.grid_boundaries().volume_gradients();
  BoundaryVolumeGradients elsewhere = sums;  // the same marks, other Views of sums
  elsewhere.side_gradients = Kokkos::View<long long*, DeviceType>("side", sums.side_gradients.extent(0));
  elsewhere.obstacle_gradients = Kokkos::View<long long*, DeviceType>("obstacle", sums.obstacle_gradients.extent(0));
  std::vector<long long> first;
  for (int round = 0; round < 4; ++round) {
    const BoundaryVolumeGradients& into = round < 3 ? sums : elsewhere;
    Kokkos::deep_copy(into.side_gradients, 0);
    Kokkos::deep_copy(into.obstacle_gradients, 0);
    const AllocationTracker allocations;
    transfers->add_boundary_volume_gradients(pt, into);
    if (round > 0 && round < 3)
      EXPECT_EQ(allocations.allocation_count(), 0) << "round " << round << ":" << allocations_by_label(allocations);
    std::vector<long long> added;
    for (const auto& view : {into.side_gradients, into.obstacle_gradients}) {
      const auto host = host_copy(view);
      added.insert(added.end(), host.data(), host.data() + host.extent(0));
    }
    if (round == 0) {
      first = added;
      EXPECT_GT(std::count_if(first.begin(), first.end(), [](long long g) { return g != 0; }), 20);
    } else {
      EXPECT_EQ(added, first) << "round " << round;
    }
  }
}

// The grid conditions on the obstacle nodes of the small tunnel with `obstacles` (a JSON list),
// with momentum and force in every direction, so that about half the nodes' normal parts point
// out: on a node inside, no normal momentum or force is left, outward as well as inward (the
// paper's eqs. 21-22 keep the outward part); on a node on a face, only the inward part goes
// (eqs. 21-22); the tangential parts stay as they were; on a node on a convex vertex, each face's
// inward part of the share of the node's gas beside it; the force on the body is what was removed
// of the force, summed over its nodes. What it saw: the obstacle nodes, those on a face and on a
// convex vertex, the normal parts that pointed out on a face, and those kept.
struct ObstacleNodesSeen {
  index_t nodes = 0;
  int on_face = 0, on_convex_vertex = 0, outward = 0, kept_outward = 0;
};
ObstacleNodesSeen expect_obstacle_conditions(const std::string& obstacles) {
  const CaseConfig config = tunnel_config(R"(, "obstacles": )" + obstacles);
  const GridSlab slab = make_grid_slab(config.domain, 0, 0, 40);
  const SlabState slab_state(config, slab);
  const NodeFieldsView state = slab_state.fields().state;
  const ObstacleGrid& grid = slab_state.obstacles();
  ObstacleNodesSeen seen;
  seen.nodes = grid.num_obstacle_nodes();
  const auto initial = Kokkos::create_mirror(state);
  for (size_t node = 0; node < state.extent(0); ++node)
    for (size_t c = 0; c < state.extent(1); ++c)
      initial(node, c) = c == GridFields::mass ? 1.0 : std::sin(1.7 * double(node) + 0.9 * double(c));
  Kokkos::deep_copy(state, initial);
  ObstacleForces forces;
  slab_state.grid_boundaries().apply_to_momentum_and_force(state, &forces);
  const auto after = Kokkos::create_mirror(state);
  Kokkos::deep_copy(after, state);
  const auto nodes = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grid.obstacle_nodes);
  const auto normals = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grid.obstacle_normals);
  double removed_x = 0, removed_y = 0;
  for (index_t k = 0; k < seen.nodes; ++k) {
    const index_t node = nodes(k);
    const double nx = normals(k, ObstacleGrid::normal_x_column), ny = normals(k, ObstacleGrid::normal_y_column);
    const double placement = normals(k, ObstacleGrid::placement_column);
    seen.on_face += placement == ObstacleGrid::on_face;
    seen.on_convex_vertex += placement == ObstacleGrid::on_convex_vertex;
    for (const int column : {int(GridFields::momentum_x), int(GridFields::force_x)}) {
      const double before_x = initial(node, column), before_y = initial(node, column + 1);
      double expected_x = before_x, expected_y = before_y;
      if (placement == ObstacleGrid::on_convex_vertex) {
        const double share = normals(k, ObstacleGrid::face_share_column);
        const double mx = normals(k, ObstacleGrid::second_normal_x_column);
        const double my = normals(k, ObstacleGrid::second_normal_y_column);
        for (const auto& [fx, fy] : {std::pair<double, double>{nx, ny}, std::pair<double, double>{mx, my}}) {
          const double before_f = before_x * fx + before_y * fy;
          if (before_f < 0) expected_x -= share * before_f * fx, expected_y -= share * before_f * fy;
        }
      } else {
        const double before_n = before_x * nx + before_y * ny;
        const bool kept = placement == ObstacleGrid::on_face && before_n > 0;
        if (placement == ObstacleGrid::on_face) seen.outward += before_n > 0, seen.kept_outward += kept;
        if (!kept) expected_x -= before_n * nx, expected_y -= before_n * ny;
      }
      EXPECT_NEAR(after(node, column), expected_x, round_off(1e-14)) << "node " << node << ", column " << column;
      EXPECT_NEAR(after(node, column + 1), expected_y, round_off(1e-14)) << "node " << node << ", column " << column;
      if (column == GridFields::force_x) removed_x += before_x - expected_x, removed_y += before_y - expected_y;
    }
  }
  EXPECT_EQ(forces.x.size(), 1u);
  if (forces.x.size() == 1) {
    EXPECT_NEAR(forces.x[0], removed_x, round_off(1e-12));
    EXPECT_NEAR(forces.y[0], removed_y, round_off(1e-12));
  }
  return seen;
}

// A circle whose surface passes through no node: every obstacle node is inside.
TEST(GridConditions, ObstacleNodesKeepNoNormalMomentumOrForceAndTheBodyTakesTheForceRemoved) {
  const ObstacleNodesSeen seen = expect_obstacle_conditions(R"([{"type": "circle", "centre": [2, 1], "radius": 0.25}])");
  ASSERT_GT(seen.nodes, 20);
  EXPECT_EQ(seen.on_face + seen.on_convex_vertex, 0);
}

// A rectangle with its faces along grid lines: on its faces' nodes only the inward part goes; on
// its corners, each face's inward part of a third of the node's gas (a right angle: the quarter
// turn beside each face of the three quarters around the corner).
TEST(GridConditions, SurfaceNodesKeepTheGasFromEnteringOnly) {
  const ObstacleNodesSeen seen = expect_obstacle_conditions(R"([{"type": "rectangle", "x": [1, 2.5], "y": [0.5, 1.2]}])");
  // The faces' nodes (x from 1 to 2.5, y from 0.5 to 1.2, spacing 0.1): 14 + 14 + 6 + 6 between
  // the 4 corners.
  EXPECT_EQ(seen.on_face, 40);
  EXPECT_EQ(seen.on_convex_vertex, 4);
  EXPECT_GT(seen.kept_outward, 10);
}

// A diamond aerofoil (half-angle 10 degrees) whose leading and trailing edges are nodes, in a
// stream along +x: the leading edge's node lets the gas part along its faces, losing only the
// inward parts of the two shares beside the faces (2 x 90/340 x sin^2 10 deg of its x momentum),
// where the faces' mean normal, (-1, 0), stopped it; a concave vertex keeps the mean normal.
TEST(GridConditions, ALeadingEdgeNodeLetsTheGasPartAlongItsFaces) {
  const double t = std::tan(10 * std::acos(-1.0) / 180);
  const std::string diamond = R"([{"type": "polygon", "file": ")" +
                              points_file("diamond", {{1, 1}, {1.5, 1 - 0.5 * t}, {2, 1}, {1.5, 1 + 0.5 * t}}) + R"("}])";
  const ObstacleNodesSeen seen = expect_obstacle_conditions(diamond);
  EXPECT_EQ(seen.on_convex_vertex, 2);  // the edges; the crests are no nodes
  const CaseConfig config = tunnel_config(R"(, "obstacles": )" + diamond);
  const GridSlab slab = make_grid_slab(config.domain, 0, 0, 40);
  const SlabState slab_state(config, slab);
  const ObstacleGrid& grid = slab_state.obstacles();
  const auto nodes = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grid.obstacle_nodes);
  const auto normals = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grid.obstacle_normals);
  const GridGeometry& g = slab.geometry;  // spacing 0.1
  const index_t leading = g.node_index(static_cast<index_t>(std::lround((1 - g.origin_x) / g.spacing_x)),
                                       static_cast<index_t>(std::lround((1 - g.origin_y) / g.spacing_y)));
  index_t k = 0;
  while (k < grid.num_obstacle_nodes() && nodes(k) != leading) ++k;
  ASSERT_LT(k, grid.num_obstacle_nodes());
  ASSERT_EQ(normals(k, ObstacleGrid::placement_column), ObstacleGrid::on_convex_vertex);
  EXPECT_NEAR(normals(k, ObstacleGrid::face_share_column), 90.0 / 340.0, round_off(1e-12));
  const NodeFieldsView state = slab_state.fields().state;
  const auto values = Kokkos::create_mirror(state);
  Kokkos::deep_copy(values, 0.0);
  values(leading, GridFields::mass) = 1;
  values(leading, GridFields::momentum_x) = 1;
  Kokkos::deep_copy(state, values);
  slab_state.grid_boundaries().apply_to_momentum_and_force(state, nullptr);
  Kokkos::deep_copy(values, state);
  const double s = std::sin(10 * std::acos(-1.0) / 180);
  EXPECT_NEAR(values(leading, GridFields::momentum_x), 1 - 2 * 90.0 / 340.0 * s * s, round_off(1e-12));
  EXPECT_NEAR(values(leading, GridFields::momentum_y), 0, round_off(1e-12));
}

// A chevron's reflex vertex (the body's angle there above 180 degrees) on a node is on a face
// with the mean of its faces' normals; its convex vertices are convex vertices.
TEST(SignedDistance, OnlyConvexVerticesSplitTheirNodesGas) {
  const CaseConfig config = tunnel_config(R"(, "obstacles": [{"type": "polygon", "file": ")" +
                                          points_file("chevron", {{1, 0.5}, {2, 0.5}, {1.5, 1}, {2, 1.5}, {1, 1.5}}) +
                                          R"("}])");
  const GridSlab slab = make_grid_slab(config.domain, 0, 0, 40);
  const ObstacleGrid grid = make_obstacle_grid(config.obstacles, slab, config.boundaries);
  const auto nodes = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grid.obstacle_nodes);
  const auto normals = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grid.obstacle_normals);
  const GridGeometry& g = slab.geometry;
  auto placement_at = [&](double x, double y) {
    const index_t node = g.node_index(static_cast<index_t>(std::lround((x - g.origin_x) / g.spacing_x)),
                                      static_cast<index_t>(std::lround((y - g.origin_y) / g.spacing_y)));
    for (index_t k = 0; k < grid.num_obstacle_nodes(); ++k)
      if (nodes(k) == node) return std::make_tuple(double(normals(k, ObstacleGrid::placement_column)), double(normals(k, 0)), double(normals(k, 1)));
    return std::make_tuple(-1.0, 0.0, 0.0);
  };
  for (const auto& [x, y] : {std::pair<double, double>{1, 0.5}, {2, 0.5}, {2, 1.5}, {1, 1.5}})
    EXPECT_EQ(std::get<0>(placement_at(x, y)), ObstacleGrid::on_convex_vertex) << x << ", " << y;
  const auto [reflex, nx, ny] = placement_at(1.5, 1);
  EXPECT_EQ(reflex, ObstacleGrid::on_face);
  EXPECT_NEAR(nx, 1, round_off(1e-12));  // the mean of (1, -1) / sqrt 2 and (1, 1) / sqrt 2
  EXPECT_NEAR(ny, 0, round_off(1e-12));
}

// A slab cut through an obstacle holds the obstacle's nodes on the far side of the cut as ghost
// nodes, whose force another slab's rank counts: each slab's force on the body is the normal force
// removed on the nodes it owns, no more, and the slabs' forces add up to the whole tunnel's. Cut
// along x and along y, each slab with the same node values as the whole. (Where the terms of the
// others go is not seen here: added outside the reduction's totals, as they were before 28044b0,
// they changed nothing a CPU reads back.)
TEST(GridConditions, ASlabCutThroughAnObstacleCountsTheForceOnTheNodesItOwns) {
  const CaseConfig config = tunnel_config(R"(, "obstacles": [{"type": "circle", "centre": [2, 1], "radius": 0.25}])");
  const auto force_on_body = [&](const GridSlab& slab, double removed[2]) {
    const SlabState slab_state(config, slab);
    const NodeFieldsView state = slab_state.fields().state;
    const auto initial = Kokkos::create_mirror(state);
    for (index_t j = 0; j < slab.geometry.nodes_y; ++j)
      for (index_t i = 0; i < slab.geometry.nodes_x; ++i) {
        const double global_node = double(i - slab.local_node_x(0) + 100 * (j - slab.local_node_y(0)));
        const index_t node = slab.geometry.node_index(i, j);
        for (size_t c = 0; c < state.extent(1); ++c)
          initial(node, c) = c == GridFields::mass ? 1.0 : std::sin(1.7 * global_node + 0.9 * double(c));
      }
    Kokkos::deep_copy(state, initial);
    const ObstacleGrid& obstacles = slab_state.obstacles();
    const auto nodes = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), obstacles.obstacle_nodes);
    const auto normals = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), obstacles.obstacle_normals);
    const IndexRange2D owned = slab.index_space(Ownership::owned, Entity::node, Indexing::local);
    removed[0] = removed[1] = 0;
    int ghosts = 0;
    for (index_t k = 0; k < obstacles.num_obstacle_nodes(); ++k) {
      const index_t i = slab.geometry.node_i_of(nodes(k)), j = slab.geometry.node_j_of(nodes(k));
      if (!owned.contains(i, j)) {
        ++ghosts;
        continue;
      }
      const double nx = normals(k, 0), ny = normals(k, 1);
      const double f_n = initial(nodes(k), GridFields::force_x) * nx + initial(nodes(k), GridFields::force_y) * ny;
      removed[0] += f_n * nx;
      removed[1] += f_n * ny;
    }
    ObstacleForces forces;
    slab_state.grid_boundaries().apply_to_momentum_and_force(state, &forces);
    EXPECT_EQ(forces.x.size(), 1u);
    return std::make_tuple(forces.x.at(0), forces.y.at(0), ghosts);
  };
  double whole_removed[2];
  const auto whole = force_on_body(make_grid_slab(config.domain, 0, 0, 40), whole_removed);
  EXPECT_EQ(std::get<2>(whole), 0);
  EXPECT_NEAR(std::get<0>(whole), whole_removed[0], round_off(1e-12));
  EXPECT_NEAR(std::get<1>(whole), whole_removed[1], round_off(1e-12));
  for (const std::array<index_t, 3>& cut : {std::array<index_t, 3>{0, 19, 40}, std::array<index_t, 3>{1, 9, 20}}) {
    const int axis = static_cast<int>(cut[0]);
    double removed_low[2], removed_high[2];
    const auto low = force_on_body(make_grid_slab(config.domain, axis, 0, cut[1]), removed_low);
    const auto high = force_on_body(make_grid_slab(config.domain, axis, cut[1], cut[2]), removed_high);
    EXPECT_GT(std::get<2>(low) + std::get<2>(high), 0) << "axis " << axis;  // the cut goes through the body
    EXPECT_NEAR(std::get<0>(low), removed_low[0], round_off(1e-12)) << "axis " << axis;
    EXPECT_NEAR(std::get<1>(low), removed_low[1], round_off(1e-12)) << "axis " << axis;
    EXPECT_NEAR(std::get<0>(high), removed_high[0], round_off(1e-12)) << "axis " << axis;
    EXPECT_NEAR(std::get<1>(high), removed_high[1], round_off(1e-12)) << "axis " << axis;
    EXPECT_NEAR(std::get<0>(low) + std::get<0>(high), std::get<0>(whole), round_off(1e-12)) << "axis " << axis;
    EXPECT_NEAR(std::get<1>(low) + std::get<1>(high), std::get<1>(whole), round_off(1e-12)) << "axis " << axis;
  }
}

// The particle rules after a move (Algorithm 1, step 11), with two obstacles: a particle that moved
// into one with an inward normal velocity loses that velocity, and the body it entered takes its
// impulse over dt (the other body none of it); one moving out of an obstacle is put back on its
// surface but keeps its velocity and gives no impulse; one through a slip wall is mirrored and
// loses its outward velocity; the kinetic energy taken is what they lost. All the others, placed in
// the gas, are left alone.
TEST(ParticleRules, ObstaclesTakeTheInwardVelocityAndEachBodyItsOwnImpulse) {
  const CaseConfig config = tunnel_config(R"(, "obstacles": [{"type": "circle", "centre": [1, 1], "radius": 0.25},
      {"type": "circle", "centre": [3, 1], "radius": 0.25}])");
  const GridSlab slab = make_grid_slab(config.domain, 0, 0, 40);
  const SlabState slab_state(config, slab);
  ParticleState pt = create_initial_particles(config, slab);
  ASSERT_GT(pt.count, 100);
  // (x, y, vx, vy) of the first four particles: into obstacle 0 from its right (outward normal
  // (1, 0)), into obstacle 1 from below (normal (0, -1)), out of obstacle 1 upwards, and below the
  // bottom wall moving down.
  const double moved[4][4] = {
      {1.1, 1.0, -2.0, 0.5}, {3.0, 0.85, 0.3, 1.5}, {3.0, 1.1, 0.0, 1.0}, {2.0, -0.01, 0.4, -0.7}};
  auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.position_x);
  auto y = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.position_y);
  auto vx = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.velocity_x);
  auto vy = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.velocity_y);
  const auto m = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.mass);
  for (int k = 0; k < 4; ++k) x(k) = moved[k][0], y(k) = moved[k][1], vx(k) = moved[k][2], vy(k) = moved[k][3];
  Kokkos::deep_copy(pt.position_x, x);
  Kokkos::deep_copy(pt.position_y, y);
  Kokkos::deep_copy(pt.velocity_x, vx);
  Kokkos::deep_copy(pt.velocity_y, vy);
  const auto vx_before = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.velocity_x);
  const auto vy_before = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.velocity_y);
  const real_t dt = real_t(0.01);
  ObstacleForces forces;
  forces.x = {0.5, -0.25};  // what the grid's condition gave in the same step: added to
  forces.y = {0.125, 0.0};
  const double stopped = apply_particle_rules(slab_state.particle_boundaries(), pt, dt, &forces);
  Kokkos::deep_copy(vx, pt.velocity_x);
  Kokkos::deep_copy(vy, pt.velocity_y);
  Kokkos::deep_copy(x, pt.position_x);
  Kokkos::deep_copy(y, pt.position_y);
  const double tolerance = round_off(1e-12);
  EXPECT_NEAR(forces.x[0], 0.5 + m(0) * -2.0 / dt, tolerance);
  EXPECT_NEAR(forces.y[0], 0.125, tolerance);
  EXPECT_NEAR(forces.x[1], -0.25, tolerance);
  EXPECT_NEAR(forces.y[1], m(1) * 1.5 / dt, tolerance);
  EXPECT_NEAR(stopped, 0.5 * m(0) * 4.0 + 0.5 * m(1) * 2.25 + 0.5 * m(3) * 0.49, tolerance);
  const double velocity_after[4][2] = {{0.0, 0.5}, {0.3, 0.0}, {0.0, 1.0}, {0.4, 0.0}};
  for (int k = 0; k < 4; ++k) {
    EXPECT_NEAR(vx(k), velocity_after[k][0], tolerance) << "particle " << k;
    EXPECT_NEAR(vy(k), velocity_after[k][1], tolerance) << "particle " << k;
  }
  EXPECT_GE(std::hypot(x(0) - 1, y(0) - 1), 0.25);  // on (just off) the surfaces it entered
  EXPECT_GE(std::hypot(x(1) - 3, y(1) - 1), 0.25);
  EXPECT_GE(std::hypot(x(2) - 3, y(2) - 1), 0.25);
  EXPECT_NEAR(y(3), 0.01, tolerance);  // mirrored
  index_t changed = 0;
  for (index_t p = 4; p < pt.count; ++p) changed += vx(p) != vx_before(p) || vy(p) != vy_before(p);
  EXPECT_EQ(changed, 0);
}

// A particle that moved a thousandth of a cell into a body is put back on its surface and loses
// its inward velocity, in either precision: the band within which a point counts as on a surface
// (distance_round_off, geometry.hpp) is round-off, far below a length the flow resolves. With 1024
// units of the last place (until 2026-12-07) it was 2.4e-4 here in single precision (2.4e-3 of
// this tunnel's cell): such particles were on the surface to the rules and stayed in the body
// (WindTunnel.AHalfCylinderOnASymmetryWallIsHalfTheCylinder found them 1e-4 to 2e-4 deep).
TEST(ParticleRules, AParticleAThousandthOfACellInsideABodyIsPutBack) {
  const CaseConfig config = tunnel_config(R"(, "obstacles": [{"type": "circle", "centre": [1, 1], "radius": 0.25}])");
  const GridSlab slab = make_grid_slab(config.domain, 0, 0, 40);
  ASSERT_NEAR(slab.cell_size(), 0.1, round_off(1e-15));
  const SlabState slab_state(config, slab);
  ParticleState pt = create_initial_particles(config, slab);
  // Particle 0 1e-4 inside the circle's left face (outward normal (-1, 0)), moving in.
  const double depth = 1e-4;
  auto x = host_copy(pt.position_x), y = host_copy(pt.position_y);
  auto vx = host_copy(pt.velocity_x), vy = host_copy(pt.velocity_y);
  x(0) = real_t(0.75 + depth), y(0) = 1, vx(0) = 2, vy(0) = real_t(0.5);
  ASSERT_LT(make_host_obstacle_set(config.obstacles)(x(0), y(0)).distance, -depth / 2);
  Kokkos::deep_copy(pt.position_x, x);
  Kokkos::deep_copy(pt.position_y, y);
  Kokkos::deep_copy(pt.velocity_x, vx);
  Kokkos::deep_copy(pt.velocity_y, vy);
  apply_particle_rules(slab_state.particle_boundaries(), pt, real_t(0.01));
  Kokkos::deep_copy(x, pt.position_x);
  Kokkos::deep_copy(vx, pt.velocity_x);
  Kokkos::deep_copy(vy, pt.velocity_y);
  EXPECT_LE(x(0), 0.75 + 1e-6);  // on the surface, to its coordinate's round-off
  EXPECT_EQ(vx(0), 0);
  EXPECT_EQ(vy(0), real_t(0.5));
}

// ---- Splitting ----------------------------------------------------------------------------------

TEST(ParticleSplitting, AlongTheAxisStretchedMoreOrBothWhereTheStretchesAgree) {
  EXPECT_EQ(split_axis(2.0, 1.0, 1.0, 1.0), -1);  // not yet doubled
  EXPECT_EQ(split_axis(2.5, 1.0, 1.3, 1.0), 0);
  EXPECT_EQ(split_axis(2.5, 1.0, 1.0, 1.3), 1);
  EXPECT_EQ(split_axis(2.5, 1.0, 1.0, 1.0), split_both_axes);
  // Round-off apart: still alike (a particle on a mirror line whose sums ran in another order): a
  // part in 1e12, or in single precision 64 units of the last place (7.6e-6; with a tolerance of
  // 1e-9 there, below float's epsilon, these split in two).
  const real_t apart = real_t(1.3 * (1 + std::max(1e-12, 64.0 * real_epsilon)));
  ASSERT_NE(apart, real_t(1.3));
  EXPECT_EQ(split_axis(2.5, 1.0, apart, 1.3), split_both_axes);
  EXPECT_EQ(split_axis(2.5, 1.0, 1.3, apart), split_both_axes);
  EXPECT_EQ(split_axis(2.5, 1.0, 1.3 * (1 + 1e-3), 1.3), 0);
  EXPECT_EQ(split_pieces(0), 2);
  EXPECT_EQ(split_pieces(split_both_axes), 4);
}

// The first `count` particles within [x0, x1] x [0.5, 1.5], well inside the tunnel (no piece
// clamped to its sides), for the splitting tests.
std::vector<index_t> particles_inside(const ParticleState& particles, real_t x0, real_t x1, size_t count) {
  const auto x = host_copy(particles.position_x), y = host_copy(particles.position_y);
  std::vector<index_t> chosen;
  for (index_t k = 0; k < particles.count && chosen.size() < count; ++k)
    if (x(k) > x0 && x(k) < x1 && y(k) > 0.5 && y(k) < 1.5) chosen.push_back(k);
  return chosen;
}

// A particle stretched alike along both axes splits in four quarters, the mirror image of itself
// about its own diagonals; one stretched more along x in two halves along x. Ids: the parents in
// id order, a split in four taking two split numbers.
TEST(ParticleSplitting, AParticleStretchedAlikeAlongBothAxesSplitsInFourQuarters) {
  WholeTunnel tunnel(tunnel_config());
  ParticleState& particles = tunnel.particles;
  const index_t n = particles.count;
  auto x = host_copy(particles.position_x), y = host_copy(particles.position_y), density = host_copy(particles.density);
  auto stretch_x = host_copy(particles.domain_stretch_x), mass = host_copy(particles.mass);
  const auto id = host_copy(particles.id);
  const std::vector<index_t> chosen = particles_inside(particles, 1, 3, 2);
  ASSERT_EQ(chosen.size(), 2u);
  const index_t four = chosen[0], two = chosen[1];
  density(four) /= 3, density(two) /= 3;
  stretch_x(two) = 1.5;
  Kokkos::deep_copy(particles.density, density);
  Kokkos::deep_copy(particles.domain_stretch_x, stretch_x);
  const real_t x4 = x(four), y4 = y(four), m4 = mass(four), x2 = x(two), y2 = y(two), m2 = mass(two);

  ParticleSplitting splitting(tunnel.config, tunnel.slab);
  EXPECT_EQ(splitting.split(particles, tunnel.slab_state.particle_boundaries(), tunnel.slab_state.context()), 3);
  EXPECT_EQ(splitting.splits(), 3);
  ASSERT_EQ(particles.count, n + 4);
  // The ids: the parent with the smaller id numbers first.
  const bool four_first = id(four) < id(two);
  const long long first_of_four = four_first ? -1 : -3, first_of_two = four_first ? -5 : -1;
  const auto after_id = host_copy(particles.id);
  const auto after_x = host_copy(particles.position_x), after_y = host_copy(particles.position_y);
  auto after_mass = host_copy(particles.mass), after_sx = host_copy(particles.domain_stretch_x);
  auto after_sy = host_copy(particles.domain_stretch_y);
  std::map<long long, index_t> index_of;
  for (index_t k = 0; k < particles.count; ++k) index_of[after_id(k)] = k;
  // A placed particle's domain is half of a cell over 2 particles: 0.025; a quarter's centre lies
  // half of that from the parent's along each axis.
  const real_t q = 0.0125;
  const real_t quarter_x[4] = {x4 - q, x4 + q, x4 - q, x4 + q}, quarter_y[4] = {y4 - q, y4 - q, y4 + q, y4 + q};
  for (int j = 0; j < 4; ++j) {
    ASSERT_EQ(index_of.count(first_of_four - j), 1u) << first_of_four - j;
    const index_t k = index_of.at(first_of_four - j);
    EXPECT_NEAR(after_x(k), quarter_x[j], round_off(1e-15)) << j;
    EXPECT_NEAR(after_y(k), quarter_y[j], round_off(1e-15)) << j;
    EXPECT_DOUBLE_EQ(after_mass(k), m4 / 4);
    EXPECT_DOUBLE_EQ(after_sx(k), 0.5);
    EXPECT_DOUBLE_EQ(after_sy(k), 0.5);
  }
  const real_t half_x[2] = {real_t(x2 - 1.5 * q), real_t(x2 + 1.5 * q)};
  for (int j = 0; j < 2; ++j) {
    ASSERT_EQ(index_of.count(first_of_two - j), 1u) << first_of_two - j;
    const index_t k = index_of.at(first_of_two - j);
    EXPECT_NEAR(after_x(k), half_x[j], round_off(1e-15)) << j;
    EXPECT_DOUBLE_EQ(after_y(k), y2);
    EXPECT_DOUBLE_EQ(after_mass(k), m2 / 2);
    EXPECT_DOUBLE_EQ(after_sx(k), 0.75);
    EXPECT_DOUBLE_EQ(after_sy(k), 1.0);
  }
}

// A particle whose domain the gas has drawn into a needle (40 times its placed length along x, as
// gas sheared along a body draws them) splits into halves at most a cell from its centre, not at
// the centres of the needle's halves, 5 cells away: such halves of wake particles had landed ahead
// of the Mach 3 cylinder and on its nose (particle_splitting.cpp, SplitRule::pieces). The halves
// still take half the domain each.
TEST(ParticleSplitting, ANeedleSplitsIntoHalvesAtMostACellApartFromItsCentre) {
  WholeTunnel tunnel(tunnel_config());
  ParticleState& particles = tunnel.particles;
  const index_t n = particles.count;
  // (Within [1.5, 2.5]: the needle's quarter length, 0.25, stays inside the tunnel.)
  const std::vector<index_t> inside = particles_inside(particles, 1.5, 2.5, 1);
  ASSERT_EQ(inside.size(), 1u);
  const index_t needle = inside[0];
  auto x = host_copy(particles.position_x), y = host_copy(particles.position_y);
  auto density = host_copy(particles.density), stretch_x = host_copy(particles.domain_stretch_x);
  density(needle) /= 3;
  stretch_x(needle) = 40;
  Kokkos::deep_copy(particles.density, density);
  Kokkos::deep_copy(particles.domain_stretch_x, stretch_x);
  const real_t x0 = x(needle), y0 = y(needle);
  ParticleSplitting splitting(tunnel.config, tunnel.slab);
  EXPECT_EQ(splitting.split(particles, tunnel.slab_state.particle_boundaries(), tunnel.slab_state.context()), 1);
  ASSERT_EQ(particles.count, n + 1);
  const auto after_id = host_copy(particles.id);
  const auto after_x = host_copy(particles.position_x), after_y = host_copy(particles.position_y);
  const auto after_sx = host_copy(particles.domain_stretch_x);
  const real_t cell = tunnel.slab.geometry.spacing_x;  // 0.05; the needle's quarter length 0.25
  std::vector<real_t> offsets;
  for (index_t k = 0; k < particles.count; ++k)
    if (after_id(k) < 0) {
      offsets.push_back(after_x(k) - x0);
      EXPECT_DOUBLE_EQ(after_y(k), y0);
      EXPECT_DOUBLE_EQ(after_sx(k), 20.0);
    }
  ASSERT_EQ(offsets.size(), 2u);
  std::sort(offsets.begin(), offsets.end());
  EXPECT_NEAR(offsets[0], -cell, round_off(1e-15));
  EXPECT_NEAR(offsets[1], cell, round_off(1e-15));
}

// ---- Memory at a growth ------------------------------------------------------------------------

// When splitting makes the particle Views grow, each field's old storage goes as its new storage
// comes: at no moment are all the fields held twice. (The splitting's selection kept a copy of
// every View until the end of the split; the benchmark's GIMP cylinder then peaked at 215 B a
// particle instead of 138.)
TEST(ParticleSplitting, GrowingForTheHalvesHoldsNoFieldTwiceButTheOneBeingMoved) {
  WholeTunnel tunnel(tunnel_config());
  ParticleState& particles = tunnel.particles;
  const index_t n = particles.count;
  ASSERT_EQ(particles.capacity(), n);  // no spare: the halves must grow the Views
  {
    // Every other particle at three times its placed volume, stretched along x: it splits in two.
    auto density = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), particles.density);
    auto stretch_x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), particles.domain_stretch_x);
    for (index_t k = 0; k < n; k += 2) density(k) /= 3, stretch_x(k) = 1.5;
    Kokkos::deep_copy(particles.density, density);
    Kokkos::deep_copy(particles.domain_stretch_x, stretch_x);
  }
  const auto bytes_of_fields = [&](long long& total, long long& largest) {
    total = largest = 0;
    particles.for_each_field([&](const auto& field) {
      const long long bytes = static_cast<long long>(field.span() * sizeof(field(0)));
      total += bytes;
      largest = std::max(largest, bytes);
    });
  };
  long long old_total = 0, old_largest = 0;
  bytes_of_fields(old_total, old_largest);
  ParticleSplitting splitting(tunnel.config, tunnel.slab);
  long long peak = 0;
  {
    const AllocationTracker allocations;
    EXPECT_EQ(splitting.split(particles, tunnel.slab_state.particle_boundaries(), tunnel.slab_state.context()),
              (n + 1) / 2);
    peak = allocations.peak();
  }
  ASSERT_GT(particles.capacity(), n);
  long long grown = 0, grown_largest = 0;
  bytes_of_fields(grown, grown_largest);
  // The tracker saw the old fields go but not come, so it counts from the start: at its peak the
  // grown fields less the old ones, one field held twice while it moves, and the split's lists (a
  // second field's worth allowed for them). All the old fields held to the end: the grown ones.
  std::printf("[splitting] growth for %d halves: peak %lld bytes beyond the start; fields %lld -> %lld bytes\n",
              (n + 1) / 2, peak, old_total, grown);
  EXPECT_LT(peak, grown - old_total + 2 * grown_largest);
}

TEST(CounterRandom, UniformInUnitIntervalWithTheRightMean) {
  double sum = 0;
  for (int id = 0; id < 100000; ++id) {
    const double u = counter_uniform(42, id, 3, 1);
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    sum += u;
  }
  EXPECT_NEAR(sum / 100000, 0.5, 0.005);
  EXPECT_NE(counter_uniform(42, 1, 3, 0), counter_uniform(42, 1, 3, 1));
  EXPECT_NE(counter_uniform(42, 1, 3, 0), counter_uniform(42, 1, 4, 0));
  EXPECT_NE(counter_uniform(42, 1, 3, 0), counter_uniform(43, 1, 3, 0));
}

// ---- Runs --------------------------------------------------------------------------------------

struct HostParticles {
  std::vector<real_t> x, y, rho, p, vx, vy;
};
HostParticles to_host(const Solver& solver) {
  const ParticleState& pt = solver.particles();
  HostParticles h;
  auto copy = [&](const RealView& v, std::vector<real_t>& out) {
    auto m = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), v);
    out.assign(m.data(), m.data() + pt.count);
  };
  copy(pt.position_x, h.x);
  copy(pt.position_y, h.y);
  copy(pt.density, h.rho);
  std::vector<real_t> e;
  copy(pt.specific_energy, e);
  for (size_t k = 0; k < e.size(); ++k)
    h.p.push_back(perfect_gas_pressure(solver.config().physics.gamma, h.rho[k], e[k]));
  copy(pt.velocity_x, h.vx);
  copy(pt.velocity_y, h.vy);
  return h;
}

// Runs `solver` from t = 0 to t_end; the mass it started with.
double run_until(Solver& solver, double t_end) {
  const double initial_mass = particle_totals(solver.particles()).mass;
  double t = 0;
  while (t < t_end) t = solver.step_towards(t, t_end);
  return initial_mass;
}

// A case run on one slab from its initial particles to t_end: its mass then and at the start, and
// its particles.
struct RunEnd {
  double initial_mass, mass;
  HostParticles particles;
};
RunEnd run_on_one_slab(const CaseConfig& config, double t_end) {
  const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
  Solver solver(config, slab, create_initial_particles(config, slab));
  const double initial_mass = run_until(solver, t_end);
  return {initial_mass, particle_totals(solver.particles()).mass, to_host(solver)};
}

// An empty tunnel at Mach 3 stays the free stream in every band along the flow: the gas entering
// at the inflow, leaving at the outflow and the outflow's pressure neither push, drain nor starve
// it. Over t = 2 (the gas crosses the tunnel 1.5 times) the particle count stays within 1 % of
// the initial one, and so does the mass per unit area of the tunnel. Band by band (0.5 wide, 400
// particles each), within 1 % with regular placement; with random placement the particles'
// random-arrangement noise moves mass along the flow (seen: bands 1.2 % light to 2.5 % heavy), so
// 4 % there.
TEST(WindTunnel, EmptyTunnelKeepsTheFreeStream) {
  for (const char* placement : {"regular", "random"}) {
    CaseConfig config = tunnel_config();
    config.particles.placement = placement == std::string("regular") ? ParticlePlacement::regular
                                                                     : ParticlePlacement::random;
    const GridSlab slab = make_grid_slab(config.domain, 0, 40);
    Solver solver(config, slab, create_initial_particles(config, slab));
    const index_t n = solver.particles().count;
    double t = 0;
    index_t fewest = n, most = n;
    for (int k = 1; k <= 8; ++k) {
      while (t < 0.25 * k) t = solver.step_towards(t, 0.25 * k);
      fewest = std::min(fewest, solver.particles().count);
      most = std::max(most, solver.particles().count);
    }
    std::printf("[tunnel] empty tunnel, %s placement: %d particles at t = 0, between %d and %d at t = 0.25 ... 2\n",
                placement, n, fewest, most);
    EXPECT_LE(most - n, n / 100) << placement;
    EXPECT_LE(n - fewest, n / 100) << placement;
    const HostParticles h = to_host(solver);
    auto mass = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), solver.particles().mass);
    constexpr int bands = 8;  // 0.5 x 2 each
    std::vector<double> count(bands), band_mass(bands), rho(bands), vx(bands), p(bands);
    for (index_t k = 0; k < solver.particles().count; ++k) {
      const int b = std::min(bands - 1, static_cast<int>(h.x[k] / 0.5));
      count[b] += 1;
      band_mass[b] += mass(k);
      rho[b] += h.rho[k];
      vx[b] += h.vx[k];
      p[b] += h.p[k];
    }
    double total_mass = 0;
    for (double m : band_mass) total_mass += m;
    std::printf("[tunnel]   mass per area of the tunnel %.5f\n", total_mass / 8);
    EXPECT_NEAR(total_mass / 8, 1.4, 0.014) << placement;
    const double band_tolerance = placement == std::string("regular") ? 0.01 : 0.04;
    for (int b = 0; b < bands; ++b) {
      std::printf("[tunnel]   x in [%.1f, %.1f): %4.0f particles, mass per area %.4f, mean particle density %.3f, "
                  "velocity %.4f, pressure %.3f\n", 0.5 * b, 0.5 * (b + 1), count[b], band_mass[b] / 1.0,
                  rho[b] / count[b], vx[b] / count[b], p[b] / count[b]);
      EXPECT_NEAR(band_mass[b] / 1.0, 1.4, 1.4 * band_tolerance) << placement << ", band " << b;
      EXPECT_NEAR(vx[b] / count[b], 3.0, 0.06) << placement << ", band " << b;
      EXPECT_NEAR(p[b] / count[b], 1.0, 0.06) << placement << ", band " << b;
    }
  }
}

// A subsonic empty tunnel (Mach 0.5, the flow 0.1 upwards) with far-field sides on the right, top
// and bottom: gas leaves through the right and the top and enters through the bottom as the flow
// needs, the mass balance closes, and the tunnel keeps its mass (seen: -0.03 % at t = 2, mean
// particle pressure 0.999, since 2026-12-06: the gas outside acts on what the entering particles
// leave uncovered along the bottom, at the pressure of the Riemann invariants, and no strip fill
// there. Before, with the free-stream pressure as a traction there and the fill: -0.3 % and 0.953,
// the first two cell rows along the bottom holding 6 % more mass at pressures of 0.67 and 0.79;
// earlier -1.6 %, and -8 % with the traction scaled by the side nodes' share of a full node's
// mass, the model before the gas outside gave the side nodes its inertia).
TEST(WindTunnel, SubsonicFarFieldLetsGasInAndOut) {
  const CaseConfig config = parse_case(
      tunnel_case(R"({"left": {"type": "inflow"}, "right": {"type": "far_field"}, "bottom": {"type": "far_field"},
                     "top": {"type": "far_field"}})",
                  R"(, "free_stream": {"density": 1.4, "pressure": 1, "velocity": [0.5, 0.1]})"),
      "far_field.json");
  const GridSlab slab = make_grid_slab(config.domain, 0, 40);
  Solver solver(config, slab, create_initial_particles(config, slab));
  const index_t n = solver.particles().count;
  const double initial_mass = run_until(solver, 2);
  const double mass = particle_totals(solver.particles()).mass;
  const BoundaryFluxes& fluxes = solver.open_sides().fluxes();
  const HostParticles h = to_host(solver);
  double p = 0, vx = 0, y_min = 2;
  for (index_t k = 0; k < solver.particles().count; ++k) {
    p += h.p[k] / h.p.size(), vx += h.vx[k] / h.vx.size();
    y_min = std::min<double>(y_min, h.y[k]);
  }
  std::printf("[tunnel] subsonic far field: %d particles at t = 0, %d at t = 2; mass %.5f -> %.5f (in %.4f, out "
              "%.4f); mean pressure %.4f, velocity %.4f\n", n, solver.particles().count, initial_mass, mass,
              fluxes.entered.mass, fluxes.left.mass, p, vx);
  EXPECT_NEAR(mass - initial_mass - fluxes.entered.mass + fluxes.left.mass, 0, round_off(1e-12) * initial_mass);
  // The inflow side alone lets in 1.4 x 0.5 x 2 x 2 = 2.8 over t = 2; the bottom far field adds gas,
  // and its particles fill the tunnel down to the bottom side (the flow would otherwise leave a
  // gap 0.2 high there by t = 2).
  EXPECT_GT(fluxes.entered.mass, 2.8 + 0.1);
  EXPECT_LT(y_min, 0.05);
  EXPECT_GT(fluxes.left.mass, 0.25 * initial_mass);  // the gas has been through the right and top sides
  EXPECT_NEAR(mass, initial_mass, 0.02 * initial_mass);
  EXPECT_NEAR(p, 1.0, 0.12);
  EXPECT_NEAR(vx, 0.5, 0.025);
}

// A uniform subsonic stream (Mach 0.42, regular placement, 2 x 2 particles per cell) through a
// channel of 100 x 4 cells: inflow on the left, slip walls along it, an outflow or a far-field
// side on the right. The exact solution is the stream itself. Where the gas leaves, the gas outside
// acts on what the last particles leave uncovered near the side (SidePressure): the channel keeps
// its mass and its pressure, the outlet included (seen at t = 2: the far-field outlet 1600
// particles, the mass to round-off, mean pressure 1.0001; the outflow side, which lets no gas in,
// 1595, -0.31 %, 0.9954). With the free-stream pressure as a traction on the side alone (before
// 2026-12-06) the outlet drew a rarefaction: by t = 2 the far-field outlet had 1546 particles of
// 1600, 3.4 % of the mass gone, mean pressure 0.953, 0.962 within 0.1 of the outlet (the outflow
// side -3.4 % too).
TEST(WindTunnel, ASubsonicStreamLeavesThroughItsOutletUndisturbed) {
  for (const std::string outlet : {"outflow", "far_field"}) {
    const CaseConfig config = parse_case(
        R"({"name": "channel", "domain": {"x": [0, 1], "y": [0, 0.04], "cells_x": 100, "cells_y": 4},
            "time": {"end": 2}, "boundaries": {"left": {"type": "inflow"}, "right": {"type": ")" +
            outlet + R"("}, "bottom": {"type": "slip_wall"}, "top": {"type": "slip_wall"}},
            "free_stream": {"density": 1, "pressure": 1, "velocity": [0.5, 0]},
            "particles": {"placement": "regular", "per_cell": [2, 2]}})",
        "channel.json");
    const auto [initial_mass, mass, h] = run_on_one_slab(config, 2);
    double sum_p = 0, sum_p_outlet = 0, n_outlet = 0;
    for (size_t k = 0; k < h.p.size(); ++k) {
      sum_p += h.p[k];
      if (h.x[k] > 0.9) sum_p_outlet += h.p[k], n_outlet += 1;
    }
    const double mean_p = sum_p / h.p.size(), outlet_p = sum_p_outlet / n_outlet;
    std::printf("[tunnel] subsonic channel, %s outlet: %zu particles of 1600 at t = 2; mass %.6f -> %.6f; mean "
                "pressure %.4f, within 0.1 of the outlet %.4f\n",
                outlet.c_str(), h.p.size(), initial_mass, mass, mean_p, outlet_p);
    EXPECT_NEAR(mass, initial_mass, 5e-3 * initial_mass) << outlet;
    EXPECT_NEAR(mean_p, 1.0, 0.01) << outlet;
    EXPECT_NEAR(outlet_p, 1.0, 0.01) << outlet;
  }
}

// Gas at rest (density 1.4, pressure 1) round a body in a box of slip walls (100 x 100 cells on
// [0, 2]^2, 2 x 2 particles a cell placed regularly) stays at rest, and the body feels no net
// force: a cylinder of radius 0.25, a square on the grid's lines, and a rectangle off them (its
// sides 0.1 to 0.35 of a cell off the lines, so that the particles, placed on sub-cell centres, end
// short of two faces and over the other two). Checked at t = 0.1, 0.2, 0.3: the particles' speeds
// below 0.15 and pressures within 0.9 to 1.1; the mean force on the body over the run within 1 %
// of the pressure's push on one face. Seen: speeds at most 0.097, 3e-14 and 0.069, pressures 0.964
// to 1.097, 1 and 0.972 to 1.023, forces 6e-14, 3e-16 and 2.3e-3. Before 2026-12-06, without the
// bodies' pressure on the nodes within their reach (ObstaclePressure, boundary_conditions.cpp),
// the gas ran along the walls from the corners and the curve: 0.81, 1.39 and 1.55 by t = 0.3,
// pressures 0.31 to 5.07, and the rectangle felt about 1.3e-2.
TEST(Obstacles, GasAtRestRoundABodyStaysAtRest) {
  for (const char* obstacle : {R"({"type": "circle", "centre": [1, 1], "radius": 0.25})",
                               R"({"type": "rectangle", "x": [0.8, 1.2], "y": [0.8, 1.2]})",
                               R"({"type": "rectangle", "x": [0.811, 1.213], "y": [0.807, 1.209]})"}) {
    const CaseConfig config = parse_case(
        R"({"name": "at_rest", "domain": {"x": [0, 2], "y": [0, 2], "cells_x": 100, "cells_y": 100},
            "time": {"end": 0.3}, "obstacles": [)" + std::string(obstacle) + R"(],
            "initial_state": {"background": {"density": 1.4, "pressure": 1}},
            "particles": {"placement": "regular", "per_cell": [2, 2]}})",
        "at_rest.json");
    const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
    Solver solver(config, slab, create_initial_particles(config, slab));
    double t = 0, fastest = 0, lowest = 1, highest = 1;
    for (const double end : {0.1, 0.2, 0.3}) {
      while (t < end) t = solver.step_towards(t, end);
      const HostParticles h = to_host(solver);
      for (size_t p = 0; p < h.x.size(); ++p) {
        fastest = std::max(fastest, double(std::hypot(h.vx[p], h.vy[p])));
        lowest = std::min(lowest, double(h.p[p]));
        highest = std::max(highest, double(h.p[p]));
      }
    }
    const std::vector<double> force = solver.take_mean_obstacle_forces();
    std::printf("[tunnel] gas at rest round %s: fastest particle %.3g, pressures %.4f to %.4f, mean force on the body "
                "(%.2e, %.2e)\n",
                obstacle, fastest, lowest, highest, force[0], force[1]);
    EXPECT_LT(fastest, 0.15) << obstacle;
    EXPECT_GT(lowest, 0.9) << obstacle;
    EXPECT_LT(highest, 1.1) << obstacle;
    EXPECT_LT(std::hypot(force[0], force[1]), 0.01 * 0.4) << obstacle;  // a face 0.4 long, pressure 1
  }
}

// A channel of 100 x 1 cells on [0, 1] (regular placement, 2 x 2 particles per cell) holding gas at
// rest, density 1.4 and pressure 1 (sound speed 1), whose right side is `right_side` with the free
// stream (density 1.4) at `pressure` moving at `velocity` along x.
CaseConfig channel_at_rest(const std::string& right_side, double pressure, double velocity) {
  return parse_case(
      R"({"name": "channel", "domain": {"x": [0, 1], "y": [0, 0.01], "cells_x": 100, "cells_y": 1},
          "time": {"end": 0.1}, "boundaries": {"left": {"type": "slip_wall"}, "right": {"type": ")" +
          right_side + R"("}, "bottom": {"type": "slip_wall"}, "top": {"type": "slip_wall"}},
          "free_stream": {"density": 1.4, "pressure": )" + std::to_string(pressure) + R"(, "velocity": [)" +
          std::to_string(velocity) + R"(, 0]},
          "initial_state": {"background": {"density": 1.4, "pressure": 1}},
          "particles": {"placement": "regular", "per_cell": [2, 2]}})",
      "channel.json");
}

// The time step holds for the gas beyond the open sides, the free stream, as well as for the gas
// inside: the channel at rest (sound speed 1) whose right side is a far field the free stream
// enters at 2 (pressure 1.5: |v| + c = 3.035) takes steps of cfl h / 3.035 and runs to t = 0.1,
// letting the gas in (seen: mass 0.0140 -> 0.0168). With steps of cfl h / 1, from the gas inside
// alone (before 2026-12-06), its first step left a particle with a density of -7e16. Where no side
// is open the free stream plays no part: the same channel closed by a slip wall steps cfl h / 1.
TEST(WindTunnel, TheTimeStepHoldsForTheFreeStreamBeyondTheOpenSides) {
  const double free_stream_speed = 2 + std::sqrt(1.4 * 1.5 / 1.4);
  for (const std::string right : {"far_field", "slip_wall"}) {
    const CaseConfig config = channel_at_rest(right, 1.5, -2);
    const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
    Solver solver(config, slab, create_initial_particles(config, slab));
    const double expected = 0.5 * 0.01 / (right == "far_field" ? free_stream_speed : 1.0);
    EXPECT_NEAR(solver.stable_time_step(), expected, per_precision(1e-9, 1e-6) * expected) << right;  // float: 2.3e-8
  }
  const CaseConfig config = channel_at_rest("far_field", 1.5, -2);
  const auto [initial_mass, mass, h] = run_on_one_slab(config, 0.1);
  std::printf("[tunnel] channel at rest, the free stream entering at 2 through a far-field side: mass %.5f -> %.5f\n",
              initial_mass, mass);
  for (size_t k = 0; k < h.rho.size(); ++k) ASSERT_GT(h.rho[k], 0) << k;
  EXPECT_GT(mass, 1.1 * initial_mass);  // the free stream moved 0.2 in: 0.28 more mass a unit height
}

// The gas outside an outflow side acts on the gas inside where that ends, wherever the gas at the
// side moves: the channel at rest (pressure 1) with gas outside at 1.5 beyond an outflow side sends a
// compression in, and the last particles, which fall short of the side as the gas moves in, keep
// near the outside pressure (seen at t = 0.1: particles' pressures 0.845 to 1.585). Before 2026-12-06,
// with the outside pressure a traction on the side's nodes wherever the gas there did not move out,
// the traction stayed whole on the side's nodes as the particles fell short of them, and crushed
// the last particle to a pressure of 5.33 while the gas next to it fell to 0.70.
TEST(WindTunnel, TheGasOutsideAnOutflowSidePressesWhereTheGasEnds) {
  const auto [initial_mass, mass, h] = run_on_one_slab(channel_at_rest("outflow", 1.5, 0), 0.1);
  const auto [lowest, highest] = std::minmax_element(h.p.begin(), h.p.end());
  std::printf("[tunnel] channel at rest, gas outside its outflow side at 1.5: pressures %.3f to %.3f at t = 0.1\n",
              *lowest, *highest);
  EXPECT_NEAR(mass, initial_mass, round_off(1e-12) * initial_mass);  // nothing left
  EXPECT_GT(*lowest, 0.8);
  EXPECT_LT(*highest, 1.8);
  EXPECT_GT(*highest, 1.3);  // the compression came in
}

// A uniform stream through far-field sides that it crosses (regular placement, 2 x 2 particles per
// cell, 40 x 40 cells on the unit square, density and pressure 1, t = 3; the exact solution is the
// stream itself): Mach 0.42 along x through far-field left and right sides (slip walls along it);
// Mach 0.49 at (0.5, 0.3) through four far-field sides, in at the left and the bottom, out at the
// right and the top; Mach 2 along x through far-field left and right sides, which acts as an inflow
// where the stream enters faster than sound (acting_boundaries). Checked: the mass, and the mean
// velocity and pressure of the particles within [0.2, 0.8]^2. Seen: mass +0.03 %, +0.19 % and +1.1 %;
// (0.4991, -0.0004), (0.5018, 0.3021) and 2.3741; pressure 1.0009, 0.9986 and 1.0154 (the Mach 2
// stream as through an inflow side, as the empty Mach 3 tunnel). Before 2026-12-06, with the free-stream
// pressure on every far-field side, a traction where the gas entered and the strip fill there
// (SidePressure, OpenBoundaries), the first had slowed to 0.22 with 4.8 % more mass, the second to
// (0.33, 0.22) with 9.4 % more, and the third to 0.93 with 22 % less.
TEST(WindTunnel, AStreamCrossingFarFieldSidesKeepsItsState) {
  struct Crossing {
    const char* sides;
    double vx, vy, mass_tolerance, velocity_tolerance, pressure_tolerance;
  };
  const char* along_x = R"("left": {"type": "far_field"}, "right": {"type": "far_field"},
                           "bottom": {"type": "slip_wall"}, "top": {"type": "slip_wall"})";
  const char* all_four = R"("left": {"type": "far_field"}, "right": {"type": "far_field"},
                            "bottom": {"type": "far_field"}, "top": {"type": "far_field"})";
  for (const Crossing& c : {Crossing{along_x, 0.5, 0, 0.005, 0.01, 0.01}, Crossing{all_four, 0.5, 0.3, 0.005, 0.01, 0.01},
                            Crossing{along_x, 2.4, 0, 0.02, 0.03, 0.03}}) {
    const CaseConfig config = parse_case(
        R"({"name": "box", "domain": {"x": [0, 1], "y": [0, 1], "cells_x": 40, "cells_y": 40}, "time": {"end": 3},
            "boundaries": {)" + std::string(c.sides) + R"(}, "free_stream": {"density": 1, "pressure": 1, "velocity": [)" +
            std::to_string(c.vx) + ", " + std::to_string(c.vy) +
            R"(]}, "particles": {"placement": "regular", "per_cell": [2, 2]}})",
        "box.json");
    const auto [initial_mass, mass, h] = run_on_one_slab(config, 3);
    double vx = 0, vy = 0, p = 0, n = 0;
    for (size_t k = 0; k < h.p.size(); ++k)
      if (h.x[k] > 0.2 && h.x[k] < 0.8 && h.y[k] > 0.2 && h.y[k] < 0.8) vx += h.vx[k], vy += h.vy[k], p += h.p[k], n += 1;
    vx /= n, vy /= n, p /= n;
    std::printf("[tunnel] stream (%.1f, %.1f) crossing far-field sides: mass %.6f -> %.6f; within [0.2, 0.8]^2 "
                "velocity (%.4f, %.4f), pressure %.4f\n",
                c.vx, c.vy, initial_mass, mass, vx, vy, p);
    EXPECT_NEAR(mass, initial_mass, c.mass_tolerance * initial_mass) << c.vx << ", " << c.vy;
    EXPECT_NEAR(vx, c.vx, c.velocity_tolerance * c.vx) << c.vx << ", " << c.vy;
    EXPECT_NEAR(vy, c.vy, c.velocity_tolerance * c.vx) << c.vx << ", " << c.vy;
    EXPECT_NEAR(p, 1.0, c.pressure_tolerance) << c.vx << ", " << c.vy;
  }
}

// The sides as they act: a far-field side the free stream enters faster than sound is an inflow;
// one it enters slower than sound, leaves or runs along stays a far field.
TEST(WindTunnel, AFarFieldSideEnteredFasterThanSoundActsAsAnInflow) {
  const auto acting = [](double vx, double vy) {
    return acting_boundaries(parse_case(
        R"({"name": "box", "domain": {"x": [0, 1], "y": [0, 1], "cells_x": 4, "cells_y": 4}, "time": {"end": 1},
            "particles": {"placement": "regular", "per_cell": [2, 2]},
            "boundaries": {"left": {"type": "far_field"}, "right": {"type": "far_field"},
                           "bottom": {"type": "far_field"}, "top": {"type": "slip_wall"}},
            "free_stream": {"density": 1.4, "pressure": 1, "velocity": [)" + std::to_string(vx) + ", " +
            std::to_string(vy) + "]}}",
        "box.json"));  // (sound speed 1)
  };
  const BoundaryConfig supersonic = acting(3, 0.5);
  EXPECT_EQ(supersonic.left, BoundaryType::inflow);      // entered at Mach 3
  EXPECT_EQ(supersonic.right, BoundaryType::far_field);  // left through
  EXPECT_EQ(supersonic.bottom, BoundaryType::far_field);  // entered at Mach 0.5
  EXPECT_EQ(supersonic.top, BoundaryType::slip_wall);
  const BoundaryConfig subsonic = acting(0.9, 1.5);
  EXPECT_EQ(subsonic.left, BoundaryType::far_field);
  EXPECT_EQ(subsonic.bottom, BoundaryType::inflow);
  EXPECT_EQ(acting(-3, 0).right, BoundaryType::inflow);
  EXPECT_EQ(acting(-3, 0).left, BoundaryType::far_field);
}

// Far-field sides along the flow (Mach 0.5, regular placement): the gas at the top and bottom
// sides neither drains out nor piles up. Particles that wander across a side leave, and the
// free stream outside fills what they leave empty; before it did, and before the side nodes had
// the inertia of the gas outside, the tunnel lost 3.4 % of its mass by t = 2 through a gap that
// opened along both sides, held open by particles compressed to a pressure of 1.5 to 2.5 there.
// The rows along the sides fluctuate (the top row's mass per area between 1.41 and 1.58 at
// t = 1.5, 2, 2.5 and 3, with the paper's energy update as with the energy-consistent one): the
// rows are averaged over those four times. The mass drifts up after t = 2, with either update
// (+1 to +2 % at t = 3, +2 to +2.4 % at t = 3.5, depending on the time steps the outputs make): an
// open problem of far-field sides (README); 2.5 % is allowed until t = 3.
TEST(WindTunnel, FarFieldAlongTheFlowKeepsTheFreeStream) {
  const CaseConfig config = parse_case(
      tunnel_case(R"({"left": {"type": "inflow"}, "right": {"type": "far_field"}, "bottom": {"type": "far_field"},
                     "top": {"type": "far_field"}})",
                  R"(, "free_stream": {"density": 1.4, "pressure": 1, "velocity": [0.5, 0]})"),
      "far_field_along.json");
  CaseConfig regular = config;
  regular.particles.placement = ParticlePlacement::regular;
  const GridSlab slab = make_grid_slab(regular.domain, 0, 40);
  Solver solver(regular, slab, create_initial_particles(regular, slab));
  const double initial_mass = particle_totals(solver.particles()).mass;
  // Mass per unit area and mean pressure in the cell rows along the sides and in the middle.
  constexpr int rows = 20;  // 0.1 high each
  const std::vector<double> times = {1.5, 2.0, 2.5, 3.0};
  std::vector<double> row_mass(rows), row_p(rows);
  double t = 0, p = 0, mass = 0;
  for (double target : times) {
    while (t < target) t = solver.step_towards(t, target);
    mass = particle_totals(solver.particles()).mass;
    const HostParticles h = to_host(solver);
    auto particle_mass = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), solver.particles().mass);
    std::vector<double> sum_p(rows), count(rows);
    for (index_t k = 0; k < solver.particles().count; ++k) {
      const int r = std::min(rows - 1, static_cast<int>(h.y[k] / 0.1));
      row_mass[r] += particle_mass(k) / (4 * 0.1) / times.size();
      sum_p[r] += h.p[k];
      count[r] += 1;
      p += h.p[k] / solver.particles().count / times.size();
    }
    for (int r = 0; r < rows; ++r) row_p[r] += sum_p[r] / count[r] / times.size();
    EXPECT_NEAR(mass, initial_mass, 0.025 * initial_mass) << "t = " << t;
  }
  std::printf("[tunnel] far field along the flow: mass %.5f -> %.5f; mean pressure %.4f; mass per area and pressure "
              "in the rows along the bottom %.4f %.3f, %.4f %.3f, and the top %.4f %.3f, %.4f %.3f (means over t = 1.5 "
              "to 3)\n",
              initial_mass, mass, p, row_mass[0], row_p[0], row_mass[1], row_p[1], row_mass[rows - 2], row_p[rows - 2],
              row_mass[rows - 1], row_p[rows - 1]);
  EXPECT_NEAR(p, 1.0, 0.03);
  for (int r : {0, 1, rows - 2, rows - 1}) {
    EXPECT_NEAR(row_mass[r], 1.4, 0.12) << "row " << r;
    EXPECT_NEAR(row_p[r], 1.0, 0.15) << "row " << r;
  }
}

// The particles whose cell is not the cell of their position: the cell map that the particle
// boundaries, the open sides, splitting and migration keep between them.
long stale_cells(const Solver& solver) {
  const ParticleState& pt = solver.particles();
  const auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.position_x);
  const auto y = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.position_y);
  const auto cell = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.cell);
  const GridGeometry& geometry = solver.slab().geometry;
  long stale = 0;
  for (index_t k = 0; k < pt.count; ++k) stale += cell(k) != geometry.cell_of(x(k), y(k)) ? 1 : 0;
  return stale;
}

// After every step each particle is in the cell of its position, in a coarse cylinder where the
// free stream enters, particles leave, split in the wake and merge: the step keeps no cell map of
// its own, each stage that moves or adds particles sets their cells.
TEST(WindTunnel, EveryParticleIsInTheCellOfItsPosition) {
  CaseConfig config = load_case_file(std::string(MPMFLOW_SOURCE_DIR) + "/cases/cylinder_mach3.json",
                                     {"domain/cells_x=60", "domain/cells_y=30", "particles/per_cell=[2,2]",
                                      "output/snapshots=0", "numerics/split_particles=true"});
  const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
  Solver solver(config, slab, create_initial_particles(config, slab));
  ASSERT_EQ(stale_cells(solver), 0) << "at the start";
  double t = 0;
  while (t < 1.5) {
    t = solver.step_towards(t, 1.5);
    ASSERT_EQ(stale_cells(solver), 0) << "after step " << solver.step_count();
  }
  EXPECT_GT(solver.splitting().splits(), 0) << "nothing split: the test does not cover splitting";
  EXPECT_GT(solver.open_sides().fluxes().left.mass, 0);
}

// A coarse Mach 3 cylinder: after every step no particle is inside the cylinder or outside the
// domain and nothing is NaN; the mass balance with the open sides closes to round-off; the bow
// shock stands in front of the cylinder.
TEST(WindTunnel, CoarseCylinderInvariantsAndBowShock) {
  CaseConfig config = load_case_file(std::string(MPMFLOW_SOURCE_DIR) + "/cases/cylinder_mach3.json",
                                     {"domain/cells_x=80", "domain/cells_y=40", "particles/per_cell=[2,2]",
                                      "output/snapshots=0"});
  const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
  Solver solver(config, slab, create_initial_particles(config, slab));
  const HostObstacleSet cylinder = make_host_obstacle_set(config.obstacles);
  const double initial_mass = particle_totals(solver.particles()).mass;
  double t = 0;
  const double end = 2.0;
  long violations = 0;
  double worst_balance = 0;
  while (t < end) {
    t = solver.step_towards(t, end);
    if (solver.step_count() % 10 != 0 && t < end) continue;  // checked every 10 steps and at the end
    const BoundaryFluxes& fluxes = solver.open_sides().fluxes();
    const double balance = particle_totals(solver.particles()).mass - initial_mass - fluxes.entered.mass +
                           fluxes.left.mass;
    worst_balance = std::max(worst_balance, std::fabs(balance) / initial_mass);
    const HostParticles h = to_host(solver);
    for (index_t k = 0; k < solver.particles().count; ++k) {
      const bool inside_domain = h.x[k] >= 0 && h.x[k] <= 4 && h.y[k] >= 0 && h.y[k] <= 2;
      const bool in_cylinder = cylinder(h.x[k], h.y[k]).distance < 0;
      const bool finite = std::isfinite(h.rho[k]) && std::isfinite(h.p[k]) && h.rho[k] > 0;
      if (!inside_domain || in_cylinder || !finite) ++violations;
    }
    ASSERT_EQ(violations, 0) << "at step " << solver.step_count();
  }
  // Bow shock: on the symmetry line, the pressure rises past the normal-shock midpoint (5.67)
  // between the inflow and the nose (x = 0.35); upstream of x = 0.1 it is still the free stream.
  EXPECT_LT(worst_balance, round_off(1e-12));
  EXPECT_GT(solver.open_sides().fluxes().left.mass, 0.5 * initial_mass);  // the gas has been through the tunnel
  const HostParticles h = to_host(solver);
  const index_t n = solver.particles().count;
  double upstream_max = 0, shock_layer_max = 0;
  for (index_t k = 0; k < n; ++k) {
    if (std::fabs(h.y[k] - 1) > 0.05) continue;
    if (h.x[k] < 0.1) upstream_max = std::max<double>(upstream_max, h.p[k]);
    if (h.x[k] > 0.2 && h.x[k] < 0.35) shock_layer_max = std::max<double>(shock_layer_max, h.p[k]);
  }
  std::printf("[tunnel] coarse cylinder: %d particles, %ld steps, mass balance residual %.2e, max pressure upstream "
              "%.3f, in the shock layer %.3f\n", n, solver.step_count(), worst_balance, upstream_max, shock_layer_max);
  EXPECT_LT(upstream_max, 1.5);
  EXPECT_GT(shock_layer_max, 5.67);
}

// A half cylinder on a slip wall (a symmetry plane) is half the cylinder in the middle of the
// tunnel: the gas keeps out of it, and it takes half the drag. (Before, the particles of the
// stagnation streamline came in where the arc meets the floor and slid along the floor through the
// body: 131 found inside over the checks below; and with 6 snapshots to t = 3, nodes inside with
// their states set the time step, 1248 steps against the whole cylinder's 774.)
TEST(WindTunnel, AHalfCylinderOnASymmetryWallIsHalfTheCylinder) {
  const std::string file = std::string(MPMFLOW_SOURCE_DIR) + "/cases/cylinder_mach3.json";
  const std::string points = half_disc_points_file("half_cylinder", 0.6, 0.25);
  const CaseConfig whole = load_case_file(file, {"domain/cells_x=100", "domain/cells_y=50", "output/snapshots=0"});
  const CaseConfig half = load_case_file(
      file, {"domain/cells_x=100", "domain/cells_y=25", "domain/y=[0,1]", "output/snapshots=0",
             R"(obstacles=[{"type": "polygon", "file": ")" + points + R"("}])"});
  const double end = 1.0;
  double drag[2];
  for (int k = 0; k < 2; ++k) {
    const CaseConfig& config = k == 0 ? whole : half;
    const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
    Solver solver(config, slab, create_initial_particles(config, slab));
    const double centre_y = k == 0 ? 1 : 0;
    double t = 0;
    long inside = 0;
    while (t < end) {
      t = solver.step_towards(t, end);
      if (solver.step_count() % 10 != 0 && t < end) continue;  // checked every 10 steps and at the end
      const HostParticles h = to_host(solver);
      // Inside the circle by more than the points' chords leave out (1e-5).
      for (size_t p = 0; p < h.x.size(); ++p) inside += std::hypot(h.x[p] - 0.6, h.y[p] - centre_y) < 0.25 - 1e-4;
    }
    EXPECT_EQ(inside, 0) << (k == 0 ? "whole" : "half");
    drag[k] = solver.take_mean_obstacle_forces()[0];
  }
  std::printf("[tunnel] Mach 3 cylinder to t = 1: mean drag %.4f, on the half on the floor %.4f (ratio %.4f)\n",
              drag[0], drag[1], drag[1] / drag[0]);
  EXPECT_NEAR(drag[1] / drag[0], 0.5, 0.015);
  fs::remove(points);
}

// The transonic aerofoil, coarse (100 x 68 cells, t = 0.3): the gas keeps to the aerofoil. Where
// the grid conditions kept the outward part of the normal momentum and force (the paper's eqs.
// 21-22), it left the aft upper surface and the trailing edge, and splitting filled the gaps with
// ever thinner particles: with seeds 1 to 4, 473-615 particles below a quarter of the free
// stream's density and 89-212 below a twentieth (down to 0.001 of it). Now 18-61 (of 61,000) and
// none (seen: at least 0.116 / 1.4). And no particle is compressed beyond what the flow does
// (stagnation 1.8, behind the shock on the upper surface about 2.7): where thin gas shared the
// nodes with dense gas along the aft lower surface, the volume correction compressed the dense
// particles again and again (seeds 1 to 4: 3 to 7 particles above 5, the densest 5.6-8.2; since
// 2026-12-03, the correction weighing the particles by their pressure, none, the densest 3.7-4.7).
TEST(WindTunnel, TheGasKeepsToATransonicAerofoil) {
  const CaseConfig config = load_case_file(std::string(MPMFLOW_SOURCE_DIR) + "/cases/aerofoil_transonic.json",
                                           {"domain/cells_x=100", "domain/cells_y=68", "output/snapshots=0"});
  const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
  Solver solver(config, slab, create_initial_particles(config, slab));
  double t = 0;
  while (t < 0.3) t = solver.step_towards(t, 0.3);
  const HostParticles h = to_host(solver);
  const double free_stream = config.boundaries.free_stream.density;
  long below_a_quarter = 0, below_a_twentieth = 0;
  double least = free_stream, densest = 0;
  for (const real_t rho : h.rho) {
    below_a_quarter += rho < free_stream / 4;
    below_a_twentieth += rho < free_stream / 20;
    least = std::min<double>(least, rho);
    densest = std::max<double>(densest, rho);
  }
  std::printf("[tunnel] coarse aerofoil at t = 0.3: %zu particles, %ld below a quarter of the free stream's density, "
              "%ld below a twentieth, least %.3f, densest %.3f, %ld steps\n",
              h.rho.size(), below_a_quarter, below_a_twentieth, least, densest, solver.step_count());
  EXPECT_LT(below_a_quarter, long(0.002 * h.rho.size()));
  EXPECT_EQ(below_a_twentieth, 0);
  EXPECT_LT(densest, 3.5 * free_stream);
}

TEST(WindTunnel, InvalidStateNamesTheParticle) {
  const CaseConfig config = tunnel_config();
  const GridSlab slab = make_grid_slab(config.domain, 0, 40);
  Solver solver(config, slab, create_initial_particles(config, slab));
  const index_t victim = 123;
  auto rho = Kokkos::subview(solver.particles().density, std::make_pair(victim, victim + 1));
  Kokkos::deep_copy(rho, real_t(-1));
  auto id = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), solver.particles().id);
  auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), solver.particles().position_x);
  try {
    solver.stable_time_step();
    FAIL() << "a negative density went unnoticed";
  } catch (const InvalidStateError& e) {
    EXPECT_EQ(e.particle_id, id(victim));
    EXPECT_EQ(e.position_x, x(victim));
    EXPECT_NE(std::string(e.what()).find("has density -1"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mpmflow

namespace mpmflow {
namespace {

// An empty Mach 3 tunnel with random placement, 40 x 20 cells, 9 particles per cell, to t = 1.5,
// over x in [0.5, 3.5]: the scatter (standard deviation over mean) of the particles' density and
// pressure, their means, the density the particles' volumes give (their mass over the sum of
// their volumes, which must fill the tunnel: the mass per area), and the energy balance, which the pressure
// relaxation, the volume correction and the cell-averaged work must keep to round-off.
struct FreeStreamNoise {
  double density_scatter, pressure_scatter, mean_density, mean_pressure, volume_density, mass_per_area,
      energy_residual;
};
FreeStreamNoise free_stream_noise(bool remedies, bool cell_averaged_strain, P2GStrategy p2g) {
  CaseConfig config = parse_case(tunnel_case(kTunnelSides, kFreeStream), "free_stream.json");
  config.particles.per_cell_x = config.particles.per_cell_y = 3;
  config.numerics.pressure_relaxation = config.numerics.volume_correction = remedies;
  config.numerics.cell_averaged_strain = cell_averaged_strain;
  config.numerics.p2g = p2g;
  const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
  Solver solver(config, slab, create_initial_particles(config, slab));
  const ConservationTotals initial = particle_totals(solver.particles());
  double t = 0;
  while (t < 1.5) t = solver.step_towards(t, 1.5);
  const ConservationTotals now = particle_totals(solver.particles());
  const BoundaryFluxes& f = solver.open_sides().fluxes();
  const double residual = now.total_energy() - initial.total_energy() - f.entered.total_energy() +
                          f.left.total_energy() - f.boundary_work + f.kinetic_energy_stopped;
  const HostParticles h = to_host(solver);
  auto mass = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), solver.particles().mass);
  double sum_rho = 0, sum_rho2 = 0, sum_p = 0, sum_p2 = 0, n = 0, sum_mass = 0, sum_volume = 0;
  for (size_t k = 0; k < h.x.size(); ++k) {
    if (h.x[k] < 0.5 || h.x[k] > 3.5) continue;
    sum_rho += h.rho[k], sum_rho2 += h.rho[k] * h.rho[k], sum_p += h.p[k], sum_p2 += h.p[k] * h.p[k], n += 1;
    sum_mass += mass(k), sum_volume += mass(k) / h.rho[k];
  }
  const double mean_rho = sum_rho / n, mean_p = sum_p / n;
  return {std::sqrt(sum_rho2 / n - mean_rho * mean_rho) / mean_rho,
          std::sqrt(sum_p2 / n - mean_p * mean_p) / mean_p,
          mean_rho,
          mean_p,
          sum_mass / sum_volume,
          sum_mass / (3.0 * 2.0),
          residual / initial.total_energy()};
}

// The issue's bounds for a free stream of random particles (density scatter at most 5 %, pressure
// 7 %, means within 1 %) with the defaults; without the pressure relaxation and the volume
// correction the particles scatter more than twice as much (seen: 0.094 / 0.133 against
// 0.041 / 0.054) and their volumes hold 1.0 % more than the space they fill (0.07 % with them).
TEST(WindTunnel, PressureRelaxationAndVolumeCorrectionQuietAFreeStreamAndKeepTheEnergyBalance) {
  const FreeStreamNoise plain = free_stream_noise(false, false, P2GStrategy::automatic);
  const FreeStreamNoise quiet = free_stream_noise(true, false, P2GStrategy::automatic);
  const FreeStreamNoise sorted = free_stream_noise(true, false, P2GStrategy::sorted);
  const FreeStreamNoise averaged = free_stream_noise(true, true, P2GStrategy::automatic);
  for (const auto& [name, r] : {std::pair{"without", plain}, {"defaults", quiet}, {"sorted P2G", sorted},
                                {"cell-averaged strain", averaged}})
    std::printf("[tunnel] free Mach 3 stream, %s: density / pressure scatter %.4f / %.4f, means %.4f / %.4f, mass "
                "over the particles' volume %.4f (mass per area %.4f), energy balance residual %.1e\n",
                name, r.density_scatter, r.pressure_scatter, r.mean_density, r.mean_pressure, r.volume_density,
                r.mass_per_area, r.energy_residual);
  EXPECT_LT(quiet.density_scatter, 0.05);
  EXPECT_LT(quiet.pressure_scatter, 0.07);
  EXPECT_NEAR(quiet.mean_density, 1.4, 0.014);
  EXPECT_NEAR(quiet.mean_pressure, 1.0, 0.01);
  // The particles' volumes fill their space: mass over volume is the mass per area.
  const auto volume_error = [](const FreeStreamNoise& r) { return std::fabs(r.volume_density / r.mass_per_area - 1); };
  EXPECT_LT(volume_error(quiet), 0.005);
  EXPECT_GT(volume_error(plain), 2 * volume_error(quiet));
  EXPECT_GT(plain.density_scatter, 2 * quiet.density_scatter);
  EXPECT_NEAR(sorted.density_scatter, quiet.density_scatter, 0.01);
  for (double residual : {plain.energy_residual, quiet.energy_residual, sorted.energy_residual, averaged.energy_residual})
    EXPECT_LT(std::fabs(residual), round_off(1e-11));
}

}  // namespace
}  // namespace mpmflow
