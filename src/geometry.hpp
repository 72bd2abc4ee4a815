#pragma once
// Solid obstacles by signed distance (paper eqs. 23-24): host-side input (points files, polygon
// transforms and checks) and a device-side signed distance function over a set of circles and
// closed polygons, with the grid data the boundary conditions and the particle move need.
#include <cmath>
#include <string>
#include <vector>

#include "case_config.hpp"
#include "grid.hpp"
#include "kernels/device_math.hpp"

namespace mpmflow {

// ---- Host-side polygon input ---------------------------------------------------------------------

struct Point {
  double x = 0, y = 0;
};
using Polygon = std::vector<Point>;

// Scale about the origin of the points file, then rotate counter-clockwise about it, then
// translate. An aerofoil at angle of attack alpha (flow along +x) is rotation_degrees = -alpha.
struct PolygonTransform {
  double scale = 1;
  double rotation_degrees = 0;
  double translation_x = 0, translation_y = 0;
};

// Reads a closed polygon from a points file: one "x y" pair per line; blank lines and lines
// starting with '#' are skipped; a first line that is not two numbers is a title (the Selig aerofoil
// format). A last point repeating the first, and repeated consecutive points, are dropped.
// Throws std::runtime_error naming the file and line.
Polygon read_points_file(const std::string& path);

Polygon transformed(const Polygon& polygon, const PolygonTransform& transform);

// Empty when the polygon is simple; otherwise names two edges that cross or touch.
std::string describe_self_intersection(const Polygon& polygon);

// A circle as a polygon of `points` vertices on it, counter-clockwise from (x + r, y).
Polygon circle_outline(double centre_x, double centre_y, double radius, int points);

// The part of `polygon` within the box [x_min, x_max] x [y_min, y_max], clipped against each side
// in turn (Sutherland and Hodgman); the points where it crosses a side lie exactly on it, and
// a point within 1e-12 of the box's size of the one before it is dropped. Empty where nothing of it lies within. A polygon whose
// part within is several pieces comes out as one outline joining them along the box's sides, on
// edges that overlap (describe_self_intersection names them).
Polygon clipped_to_box(const Polygon& polygon, double x_min, double x_max, double y_min, double y_max);

// ---- Device-side signed distance -----------------------------------------------------------------

struct SignedDistance {
  real_t distance;            // negative inside an obstacle (eq. 23)
  real_t normal_x, normal_y;  // unit gradient of the distance: the outward normal (eq. 24)
  index_t obstacle = 0;       // the nearest obstacle, in case order
  // On a convex vertex of a polygon (within round-off; the body's angle there below 180 degrees):
  // its two faces' outward normals (normal_x, _y is their mean there).
  bool on_convex_vertex = false;
  real_t face_normal_x[2] = {0, 0}, face_normal_y[2] = {0, 0};
};

// The round-off of a distance computed from coordinates and lengths of about `scale`: 64 units of
// their last place, some ten times what a node's coordinate (origin + spacing i) and the distance's
// few operations leave. A point within it of a surface is on the surface: a node on a face along a
// grid line is then an obstacle node on the surface (ObstacleGrid), every node of the face alike,
// rather than inside or out as the last bits fall. The band must stay far below any length the
// flow resolves: a particle in it is on the surface, and the particle rules put back only those
// deeper (ParticleBoundaries). With 1024 units (until 2026-12-07), single precision's band was
// 1.2e-4 of the coordinates, up to 2e-4 round the Mach 3 cylinder (half a per cent of a cell at
// 100 x 50 cells), and particles that had entered the body stayed there, 1e-4 to 2e-4 deep.
KOKKOS_INLINE_FUNCTION real_t distance_round_off(real_t scale) { return 64 * real_epsilon * scale; }
KOKKOS_INLINE_FUNCTION real_t snapped_to_surface(real_t distance, real_t scale) {
  return absolute_value(distance) <= distance_round_off(scale) ? real_t(0) : distance;
}

// The union of the case's obstacles. Distance and normal are those of the nearest obstacle.
template <class MemSpace>
struct ObstacleSet {
  using RealColumns = Kokkos::View<real_t**, Kokkos::LayoutLeft, MemSpace>;
  using Offsets = Kokkos::View<index_t*, Kokkos::LayoutLeft, MemSpace>;
  RealColumns circles;      // (circle, {centre x, centre y, radius})
  RealColumns edges;        // (edge, {x0, y0, x1, y1}), counter-clockwise around each polygon
  Offsets polygon_edges;    // polygon k owns edges [polygon_edges(k), polygon_edges(k + 1))
  Offsets case_index;       // of circle c: case_index(c); of polygon k: case_index(num_circles + k)
  index_t num_circles = 0;
  index_t num_polygons = 0;

  bool empty() const { return num_circles == 0 && num_polygons == 0; }

  KOKKOS_INLINE_FUNCTION SignedDistance operator()(real_t x, real_t y) const {
    SignedDistance nearest{real_t(1e30), 1, 0};
    for (index_t c = 0; c < num_circles; ++c) {
      const real_t dx = x - circles(c, 0), dy = y - circles(c, 1);
      const real_t r = square_root(dx * dx + dy * dy);
      const real_t d = snapped_to_surface(r - circles(c, 2), absolute_value(x) + absolute_value(y) + circles(c, 2));
      if (d < nearest.distance)
        nearest = r > 0 ? SignedDistance{d, dx / r, dy / r, case_index(c)} : SignedDistance{d, 1, 0, case_index(c)};
    }
    for (index_t k = 0; k < num_polygons; ++k) {
      SignedDistance d = polygon_distance(k, x, y);
      d.obstacle = case_index(num_circles + k);
      if (d.distance < nearest.distance) nearest = d;
    }
    return nearest;
  }

  // The distance to the nearest edge, negative inside (even-odd rule), 0 within round-off. The
  // normal: where the nearest point lies within the edge, the edge's own outward normal (the exact
  // gradient there, inside or out; from the difference vector it would be round-off for a point on
  // the edge, such as a node on a face along a grid line); at a vertex, the direction from it,
  // and on the vertex the mean of its two edges' normals (a smooth body's normal there, where a
  // polygon's vertex stands for a point of its curve, and between a corner's two faces).
  KOKKOS_INLINE_FUNCTION SignedDistance polygon_distance(index_t k, real_t x, real_t y) const {
    real_t best_squared = real_t(1e30), best_dx = 0, best_dy = 0;
    index_t best_edge = polygon_edges(k);
    real_t best_along = 0;
    bool inside = false;
    for (index_t e = polygon_edges(k); e < polygon_edges(k + 1); ++e) {
      const real_t x0 = edges(e, 0), y0 = edges(e, 1), x1 = edges(e, 2), y1 = edges(e, 3);
      // Nearest point of the edge.
      const real_t ex = x1 - x0, ey = y1 - y0;
      const real_t along = ((x - x0) * ex + (y - y0) * ey) / (ex * ex + ey * ey);
      const real_t s = along < 0 ? real_t(0) : (along > 1 ? real_t(1) : along);
      const real_t dx = x - (x0 + s * ex), dy = y - (y0 + s * ey);
      const real_t squared = dx * dx + dy * dy;
      if (squared < best_squared) {
        best_squared = squared;
        best_dx = dx;
        best_dy = dy;
        best_edge = e;
        best_along = along;
      }
      // Even-odd rule: count the edges a ray towards +x crosses.
      if ((y0 > y) != (y1 > y) && x < x0 + (y - y0) * ex / ey) inside = !inside;
    }
    const real_t sign = inside ? real_t(-1) : real_t(1);
    real_t nx, ny;
    const real_t length = edge_normal(best_edge, nx, ny);
    const real_t d = snapped_to_surface(square_root(best_squared), absolute_value(x) + absolute_value(y) + length);
    const bool at_vertex = best_along <= 0 || best_along >= 1;
    if (!at_vertex) return {sign * d, nx, ny};
    if (d > 0) return {sign * d, sign * best_dx / d, sign * best_dy / d};
    // On the vertex: the edge before it (best_along <= 0: the vertex starts the edge) or after it.
    const index_t first = polygon_edges(k), last = polygon_edges(k + 1) - 1;
    const index_t other = best_along <= 0 ? (best_edge == first ? last : best_edge - 1)
                                          : (best_edge == last ? first : best_edge + 1);
    real_t mx, my;
    edge_normal(other, mx, my);
    const real_t mean = square_root((nx + mx) * (nx + mx) + (ny + my) * (ny + my));
    SignedDistance on_vertex{0, (nx + mx) / mean, (ny + my) / mean};
    // Convex where the edge into the vertex turns left into the edge out of it (counter-clockwise
    // edges): the edge out's normal lies counter-clockwise of the edge in's.
    const real_t in_x = best_along <= 0 ? mx : nx, in_y = best_along <= 0 ? my : ny;
    const real_t out_x = best_along <= 0 ? nx : mx, out_y = best_along <= 0 ? ny : my;
    on_vertex.on_convex_vertex = in_x * out_y - in_y * out_x > 0;
    on_vertex.face_normal_x[0] = nx, on_vertex.face_normal_y[0] = ny;
    on_vertex.face_normal_x[1] = mx, on_vertex.face_normal_y[1] = my;
    return on_vertex;
  }

  // The outward unit normal of edge e (edges run counter-clockwise: the right-hand normal points
  // out); returns the edge's length.
  KOKKOS_INLINE_FUNCTION real_t edge_normal(index_t e, real_t& nx, real_t& ny) const {
    const real_t ex = edges(e, 2) - edges(e, 0), ey = edges(e, 3) - edges(e, 1);
    const real_t length = square_root(ex * ex + ey * ey);
    nx = ey / length;
    ny = -ex / length;
    return length;
  }
};

// The share of a node's gas beside each face of a convex vertex it lies on, from the faces'
// outward normals: of the gas around the vertex (the full turn less the body's angle there,
// pi + phi, phi the angle between the normals), the quarter turn beside each face is held off
// the body by that face; the rest, beyond the vertex, by neither (the gas ahead of a sharp
// leading edge parts along the faces, not stopped by the edge). 1/2 between two faces in a line,
// where the two shares add up to the face's whole condition; 1/3 at a right angle.
double convex_vertex_face_share(double n0_x, double n0_y, double n1_x, double n1_y);

using HostObstacleSet = ObstacleSet<Kokkos::HostSpace>;
using DeviceObstacleSet = ObstacleSet<MemorySpace>;

HostObstacleSet make_host_obstacle_set(const std::vector<ObstacleConfig>& obstacles);
DeviceObstacleSet copy_to_device(const HostObstacleSet& host);

// What the grid needs of the obstacles, computed once at start: the nodes inside an obstacle or
// on its surface (signed distance <= 0) with their outward normals, where the grid conditions
// remove the normal momentum and force; and a flag per cell that an obstacle may reach into it, so
// that only particles in flagged cells evaluate the exact distance after their move.
struct ObstacleGrid {
  DeviceObstacleSet obstacles;
  IndexView obstacle_nodes;
  // (k, column) of obstacle_nodes(k): its outward normal (normal_x_column, normal_y_column), where
  // it lies (placement_column: inside, on_face or on_convex_vertex, within round-off: a node on a
  // face along a grid line, or on a polygon's vertex), and on a convex vertex the second face's
  // normal (second_normal_x_column, _y) with the share of the node's gas beside each face
  // (face_share_column; the first normal is then the first face's).
  NodeFieldsView obstacle_normals;
  enum Column { normal_x_column, normal_y_column, placement_column, second_normal_x_column, second_normal_y_column,
                face_share_column, num_columns };
  enum Placement { inside, on_face, on_convex_vertex };
  IndexView cell_near_obstacle;     // 1 where a corner of the cell lies within a cell diagonal of an obstacle
  // The box around the flagged cells (empty, min > max, where none is; unbounded on a side where
  // a flagged cell lies at the edge of the local grid): a particle outside it needs no look-up of
  // its cell's flag.
  real_t near_x_min = 1, near_x_max = 0, near_y_min = 1, near_y_max = 0;
  // Of every local node: the volume its hat function N_i covers within the domain and outside the
  // obstacles, \int N_i over the gas's space (a cell's area inside, half of it on a side, a quarter
  // in a corner, none beyond the domain): what the particles' volumes on the node sum to where
  // they fill the space (the volume correction, node_volume_fraction). Negative within a cell
  // diagonal of an obstacle, where only a shortfall counts: particles pressed against a body
  // overlap it with their domains, so their volumes seem to over-fill a space they do fill. 0,
  // unknown, within a cell of a far-field side, where the gas outside moves in and out as the
  // particles' volumes leave it room (far_field in boundary_conditions.hpp).
  RealView node_gas_volume;
  // Of obstacle_nodes(k): the obstacle (case order) whose surface is nearest, or -1 where this
  // slab does not own the node (each node's reaction is counted by one rank).
  IndexView obstacle_of_node;
  // The nodes within reach of an obstacle's surface, inside or out: those whose basis functions
  // (the bilinear hat, whose averages over a particle's domain are GIMP's weights, or the quadratic
  // B-spline) reach to within half a cell of it, where the particles beside it end; in increasing
  // order, and of each the obstacle whose surface is nearest, or -1 where this slab does not own
  // the node. The bodies press on the gas there with its pressure (boundary_conditions.cpp,
  // ObstaclePressure).
  IndexView body_nodes;
  IndexView body_node_obstacle;
  int num_obstacles = 0;

  index_t num_obstacle_nodes() const { return static_cast<index_t>(obstacle_nodes.extent(0)); }
};

// `sides`: the boundaries of the domain's sides (node_gas_volume leaves far-field sides out).
// `shape`: the case's shape function (body_nodes).
ObstacleGrid make_obstacle_grid(const std::vector<ObstacleConfig>& obstacles, const GridSlab& slab,
                                const BoundaryConfig& sides, ShapeFunction shape = ShapeFunction::gimp);

}  // namespace mpmflow
