#include "geometry.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace mpmflow {
namespace {

double cross(const Point& o, const Point& a, const Point& b) {
  return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

// Whether c, known to be collinear with segment ab, lies within its bounding box.
bool on_segment(const Point& a, const Point& b, const Point& c) {
  return std::min(a.x, b.x) <= c.x && c.x <= std::max(a.x, b.x) && std::min(a.y, b.y) <= c.y &&
         c.y <= std::max(a.y, b.y);
}

// Whether the closed segments ab and cd share a point.
bool segments_meet(const Point& a, const Point& b, const Point& c, const Point& d) {
  const double d1 = cross(c, d, a), d2 = cross(c, d, b), d3 = cross(a, b, c), d4 = cross(a, b, d);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return true;
  return (d1 == 0 && on_segment(c, d, a)) || (d2 == 0 && on_segment(c, d, b)) ||
         (d3 == 0 && on_segment(a, b, c)) || (d4 == 0 && on_segment(a, b, d));
}

std::string describe_edge(const Polygon& polygon, size_t i) {
  const Point& a = polygon[i];
  const Point& b = polygon[(i + 1) % polygon.size()];
  std::ostringstream out;
  out << "edge " << i << " (" << a.x << ", " << a.y << ")-(" << b.x << ", " << b.y << ")";
  return out.str();
}

double signed_area(const Polygon& polygon) {
  double area = 0;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const Point& a = polygon[i];
    const Point& b = polygon[(i + 1) % polygon.size()];
    area += a.x * b.y - b.x * a.y;
  }
  return area / 2;
}

}  // namespace

Polygon read_points_file(const std::string& path) {
  // Bounds: an outline is a regular file of lines of two numbers; a device, a pipe or a file of
  // endless lines (/dev/zero) is refused before it fills the memory, and the self-intersection
  // check, quadratic in the points, stays quick.
  constexpr size_t max_line_length = 1024;
  constexpr size_t max_points = 20000;
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw std::runtime_error("cannot open the points file '" + path + "' (no such file)");
  if (!std::filesystem::is_regular_file(path, ec))
    throw std::runtime_error("'" + path + "' is not a regular file; expected a points file of \"x y\" lines");
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open the points file '" + path + "'");
  Polygon polygon;
  std::string line;
  int line_number = 0;
  bool first_content_line = true;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.size() > max_line_length)
      throw std::runtime_error("'" + path + "' line " + std::to_string(line_number) + ": longer than " +
                               std::to_string(max_line_length) + " characters; expected \"x y\"");
    if (polygon.size() >= max_points)
      throw std::runtime_error("'" + path + "': more than " + std::to_string(max_points) + " points");
    const size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    std::istringstream fields(line);
    Point p;
    std::string rest;
    const bool two_numbers = static_cast<bool>(fields >> p.x >> p.y) && !(fields >> rest);
    if (!two_numbers) {
      if (first_content_line) {  // the Selig format's title line
        first_content_line = false;
        continue;
      }
      throw std::runtime_error("'" + path + "' line " + std::to_string(line_number) +
                               ": expected two numbers \"x y\"; got \"" + line + "\"");
    }
    first_content_line = false;
    if (!std::isfinite(p.x) || !std::isfinite(p.y))
      throw std::runtime_error("'" + path + "' line " + std::to_string(line_number) + ": expected finite numbers");
    if (!polygon.empty() && polygon.back().x == p.x && polygon.back().y == p.y) continue;
    polygon.push_back(p);
  }
  if (polygon.size() > 1 && polygon.front().x == polygon.back().x && polygon.front().y == polygon.back().y)
    polygon.pop_back();
  return polygon;
}

Polygon transformed(const Polygon& polygon, const PolygonTransform& transform) {
  const double angle = transform.rotation_degrees * 3.14159265358979323846 / 180;
  const double c = std::cos(angle), s = std::sin(angle);
  Polygon out;
  out.reserve(polygon.size());
  for (const Point& p : polygon) {
    const double x = transform.scale * p.x, y = transform.scale * p.y;
    out.push_back({c * x - s * y + transform.translation_x, s * x + c * y + transform.translation_y});
  }
  return out;
}

namespace {
// The part of `polygon` on one side of the line where coordinate `axis` (0: x, 1: y) is `bound`:
// at or above it (keep_above) or at or below.
Polygon clipped_to_half_plane(const Polygon& polygon, int axis, double bound, bool keep_above) {
  auto coordinate = [axis](const Point& p) { return axis == 0 ? p.x : p.y; };
  auto kept = [&](const Point& p) { return keep_above ? coordinate(p) >= bound : coordinate(p) <= bound; };
  Polygon out;
  const size_t n = polygon.size();
  for (size_t i = 0; i < n; ++i) {
    const Point& a = polygon[i];
    const Point& b = polygon[(i + 1) % n];
    if (kept(a)) out.push_back(a);
    if (kept(a) != kept(b)) {
      const double t = (bound - coordinate(a)) / (coordinate(b) - coordinate(a));
      Point crossing{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)};
      (axis == 0 ? crossing.x : crossing.y) = bound;  // on the side, not a rounding off it
      out.push_back(crossing);
    }
  }
  return out;
}
}  // namespace

Polygon circle_outline(double centre_x, double centre_y, double radius, int points) {
  Polygon outline;
  outline.reserve(points);
  for (int v = 0; v < points; ++v) {
    const double angle = 2 * 3.14159265358979323846 * v / points;
    outline.push_back({centre_x + radius * std::cos(angle), centre_y + radius * std::sin(angle)});
  }
  return outline;
}

Polygon clipped_to_box(const Polygon& polygon, double x_min, double x_max, double y_min, double y_max) {
  Polygon clipped = clipped_to_half_plane(polygon, 0, x_min, true);
  clipped = clipped_to_half_plane(clipped, 0, x_max, false);
  clipped = clipped_to_half_plane(clipped, 1, y_min, true);
  clipped = clipped_to_half_plane(clipped, 1, y_max, false);
  // A vertex on a side up to round-off (a circle's outline, whose sine at 180 degrees is 1e-16)
  // and the crossing next to it: one point.
  const double tolerance = 1e-12 * std::max(x_max - x_min, y_max - y_min);
  auto same = [tolerance](const Point& a, const Point& b) {
    return std::fabs(a.x - b.x) <= tolerance && std::fabs(a.y - b.y) <= tolerance;
  };
  Polygon out;
  for (const Point& p : clipped)
    if (out.empty() || !same(p, out.back())) out.push_back(p);
  while (out.size() > 1 && same(out.front(), out.back())) out.pop_back();
  return out;
}

std::string describe_self_intersection(const Polygon& polygon) {
  const size_t n = polygon.size();
  for (size_t i = 0; i < n; ++i) {
    const Point& a = polygon[i];
    const Point& b = polygon[(i + 1) % n];
    // The next edge shares vertex b: it may only meet this one there, so it must not fold back.
    const Point& c = polygon[(i + 2) % n];
    if (cross(b, a, c) == 0 && (a.x - b.x) * (c.x - b.x) + (a.y - b.y) * (c.y - b.y) > 0)
      return describe_edge(polygon, i) + " folds back onto " + describe_edge(polygon, (i + 1) % n);
    for (size_t j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;  // adjacent through the closing vertex
      if (segments_meet(a, b, polygon[j], polygon[(j + 1) % n]))
        return describe_edge(polygon, i) + " meets " + describe_edge(polygon, j);
    }
  }
  return "";
}

namespace {

// The polygon the signed distance uses for obstacle `o`: counter-clockwise, so that an edge's
// right-hand normal points out of the obstacle, and with its edges on sides of the domain moved
// out beyond them. Such an edge is no surface the gas meets: as the nearest surface, it would put
// a particle that entered the obstacle near it back across the side, where the clamp to the domain
// leaves it inside the obstacle still (a half cylinder on a symmetry wall took in the particles of
// its stagnation streamline, which then slid along the wall through it); nor is a vertex between
// two of them (the step's corner on the outflow side). A run of such edges from a to b becomes
// a, a', the run's inner vertices moved out beyond both their sides, b', b, with a' and b' twice
// the polygon's extent out beyond the side: a-a' and b'-b stand square to the side, so that within
// the domain no point of theirs is nearer than a or b, which are points of the surface; the rest
// is farther from any point of the domain than its nearest surface; and a point on the side
// under the obstacle, where the clamp puts particles, lies strictly inside.
Polygon signed_distance_polygon(const ObstacleConfig& o) {
  const size_t n = o.vertices_x.size();
  auto side_of_edge = [&](size_t v) { return o.edge_side.empty() ? -1 : o.edge_side[v % n]; };
  double x_lo = o.vertices_x[0], x_hi = x_lo, y_lo = o.vertices_y[0], y_hi = y_lo;
  for (size_t v = 0; v < n; ++v) {
    x_lo = std::min(x_lo, double(o.vertices_x[v])), x_hi = std::max(x_hi, double(o.vertices_x[v]));
    y_lo = std::min(y_lo, double(o.vertices_y[v])), y_hi = std::max(y_hi, double(o.vertices_y[v]));
  }
  const double beyond = 2 * std::hypot(x_hi - x_lo, y_hi - y_lo);
  // Point p moved out beyond `side`.
  auto out_beyond = [&](Point p, int side) {
    real_t nx, ny;
    inward_normal(side, nx, ny);
    return Point{p.x - beyond * nx, p.y - beyond * ny};
  };
  // From a vertex that ends a surface edge (case_config refuses a polygon without one), so that
  // no run of edges on sides wraps around the end of the list.
  size_t start = 0;
  while (side_of_edge(start + n - 1) >= 0) ++start;
  Polygon polygon;
  for (size_t k = 0; k < n; ++k) {
    const size_t v = (start + k) % n;
    const Point p{o.vertices_x[v], o.vertices_y[v]};
    const int in = side_of_edge(v + n - 1), out = side_of_edge(v);  // the edges into and out of p
    if (in < 0) polygon.push_back(p);  // a point of the surface
    if (in < 0 && out >= 0) polygon.push_back(out_beyond(p, out));  // a run starts: a'
    if (in >= 0 && out >= 0) polygon.push_back(out == in ? out_beyond(p, in) : out_beyond(out_beyond(p, in), out));
    if (in >= 0 && out < 0) polygon.push_back(out_beyond(p, in)), polygon.push_back(p);  // a run ends: b', b
  }
  if (signed_area(polygon) < 0) std::reverse(polygon.begin(), polygon.end());
  return polygon;
}

}  // namespace

double convex_vertex_face_share(double n0_x, double n0_y, double n1_x, double n1_y) {
  const double pi = std::acos(-1.0);
  const double phi = std::acos(std::clamp(n0_x * n1_x + n0_y * n1_y, -1.0, 1.0));
  return 0.5 * pi / (pi + phi);
}

HostObstacleSet make_host_obstacle_set(const std::vector<ObstacleConfig>& obstacles) {
  HostObstacleSet set;
  index_t num_circles = 0;
  std::vector<Polygon> polygons;
  size_t num_edges = 0;
  for (const ObstacleConfig& o : obstacles) {
    if (o.shape == ObstacleShape::circle) ++num_circles;
    else {
      polygons.push_back(signed_distance_polygon(o));
      num_edges += polygons.back().size();
    }
  }
  const index_t num_polygons = static_cast<index_t>(polygons.size());
  set.circles = HostObstacleSet::RealColumns("obstacle_circles", num_circles, 3);
  set.edges = HostObstacleSet::RealColumns("obstacle_edges", num_edges, 4);
  set.polygon_edges = HostObstacleSet::Offsets("obstacle_polygon_edges", num_polygons + 1);
  set.case_index = HostObstacleSet::Offsets("obstacle_case_index", num_circles + num_polygons);
  index_t edge = 0;
  for (size_t index = 0; index < obstacles.size(); ++index) {
    const ObstacleConfig& o = obstacles[index];
    if (o.shape == ObstacleShape::circle) {
      set.case_index(set.num_circles) = static_cast<index_t>(index);
      set.circles(set.num_circles, 0) = o.centre_x;
      set.circles(set.num_circles, 1) = o.centre_y;
      set.circles(set.num_circles, 2) = o.radius;
      ++set.num_circles;
      continue;
    }
    const Polygon& polygon = polygons[static_cast<size_t>(set.num_polygons)];
    set.polygon_edges(set.num_polygons) = edge;
    set.case_index(num_circles + set.num_polygons) = static_cast<index_t>(index);
    for (size_t v = 0; v < polygon.size(); ++v, ++edge) {
      const Point& a = polygon[v];
      const Point& b = polygon[(v + 1) % polygon.size()];
      set.edges(edge, 0) = a.x;
      set.edges(edge, 1) = a.y;
      set.edges(edge, 2) = b.x;
      set.edges(edge, 3) = b.y;
    }
    ++set.num_polygons;
  }
  set.polygon_edges(set.num_polygons) = edge;
  return set;
}

DeviceObstacleSet copy_to_device(const HostObstacleSet& host) {
  DeviceObstacleSet device;
  device.circles = Kokkos::create_mirror_view_and_copy(MemorySpace(), host.circles);
  device.edges = Kokkos::create_mirror_view_and_copy(MemorySpace(), host.edges);
  device.polygon_edges = Kokkos::create_mirror_view_and_copy(MemorySpace(), host.polygon_edges);
  device.case_index = Kokkos::create_mirror_view_and_copy(MemorySpace(), host.case_index);
  device.num_circles = host.num_circles;
  device.num_polygons = host.num_polygons;
  return device;
}

namespace {

// The share of a node's hat function along one axis that lies within the domain, from the node's
// global index g on that axis (the domain's nodes are 0 .. cells): all of it inside, half on a
// side, none beyond.
double hat_share_within(index_t g, index_t cells) {
  if (g < 0 || g > cells) return 0;
  return g == 0 || g == cells ? 0.5 : 1;
}

// ObstacleGrid::node_gas_volume, from each node's signed distance to the obstacles. Within
// `margin` of an obstacle the hat's part outside it is integrated by the midpoint rule on 16 x 16
// points per cell, and the volume stored negative.
RealView node_gas_volumes(const HostObstacleSet& obstacles, const std::vector<real_t>& node_distance,
                          const GridSlab& slab, const BoundaryConfig& sides, double margin) {
  const GridGeometry& geo = slab.geometry;
  const double hx = geo.spacing_x, hy = geo.spacing_y;
  // Within a cell of a far-field side: the side's node line and the one inside it.
  auto near_far_field = [&](index_t gx, index_t gy) {
    return (sides.left == BoundaryType::far_field && gx <= 1) ||
           (sides.right == BoundaryType::far_field && gx >= slab.global_cells_x - 1) ||
           (sides.bottom == BoundaryType::far_field && gy <= 1) ||
           (sides.top == BoundaryType::far_field && gy >= slab.global_cells_y - 1);
  };
  auto inside_domain = [&](double x, double y) {
    return x >= slab.domain_x_min && x <= slab.domain_x_max && y >= slab.domain_y_min && y <= slab.domain_y_max;
  };
  constexpr int samples = 32;  // per axis over the hat's two cells
  RealView volume("node_gas_volume", geo.num_nodes());
  auto host = host_mirror(volume);
  for (index_t j = 0; j < geo.nodes_y; ++j)
    for (index_t i = 0; i < geo.nodes_x; ++i) {
      const index_t gx = i + slab.node_offset_x, gy = j + slab.node_offset_y, node = geo.node_index(i, j);
      double v = hx * hy * hat_share_within(gx, slab.global_cells_x) * hat_share_within(gy, slab.global_cells_y);
      if (v > 0 && near_far_field(gx, gy)) v = 0;
      if (v > 0 && node_distance[node] < margin) {
        const double x = geo.node_x(i), y = geo.node_y(j);
        double sum = 0;
        for (int b = 0; b < samples; ++b)
          for (int a = 0; a < samples; ++a) {
            const double u = -1 + (a + 0.5) * 2 / samples, w = -1 + (b + 0.5) * 2 / samples;
            const double px = x + u * hx, py = y + w * hy;
            if (inside_domain(px, py) && obstacles(px, py).distance > 0) sum += (1 - std::fabs(u)) * (1 - std::fabs(w));
          }
        v = -sum * (2.0 / samples) * (2.0 / samples) * hx * hy;
      }
      host(node) = v;
    }
  Kokkos::deep_copy(volume, host);
  return volume;
}

}  // namespace

ObstacleGrid make_obstacle_grid(const std::vector<ObstacleConfig>& obstacles, const GridSlab& slab,
                                const BoundaryConfig& sides, ShapeFunction shape) {
  ObstacleGrid grid;
  const HostObstacleSet host = make_host_obstacle_set(obstacles);
  grid.obstacles = copy_to_device(host);
  const GridGeometry& geo = slab.geometry;
  grid.cell_near_obstacle = IndexView("cell_near_obstacle", geo.num_cells());
  grid.num_obstacles = static_cast<int>(obstacles.size());
  // Evaluated once on the host at start-up (the obstacles are at rest); 1e30 without obstacles.
  // With each node's nearest obstacle (case order), which the forces on each count by.
  std::vector<real_t> node_distance(geo.num_nodes());
  std::vector<index_t> node_obstacle(geo.num_nodes());
  std::vector<index_t> nodes;
  std::vector<std::array<real_t, ObstacleGrid::num_columns>> rows;
  for (index_t j = 0; j < geo.nodes_y; ++j)
    for (index_t i = 0; i < geo.nodes_x; ++i) {
      const SignedDistance sd = host(geo.node_x(i), geo.node_y(j));
      const index_t node = geo.node_index(i, j);
      node_distance[node] = sd.distance;
      node_obstacle[node] = sd.obstacle;
      if (sd.distance > 0) continue;
      nodes.push_back(node);
      std::array<real_t, ObstacleGrid::num_columns> row{};
      row[ObstacleGrid::normal_x_column] = sd.normal_x;
      row[ObstacleGrid::normal_y_column] = sd.normal_y;
      row[ObstacleGrid::placement_column] = sd.distance < 0 ? ObstacleGrid::inside : ObstacleGrid::on_face;
      // A node on a domain side keeps the mean normal: there the polygon's faces may include the
      // edge continued beyond the side (signed_distance_polygon), where no gas is.
      const index_t gx = i + slab.node_offset_x, gy = j + slab.node_offset_y;
      const bool on_a_side = gx <= 0 || gx >= slab.global_cells_x || gy <= 0 || gy >= slab.global_cells_y;
      if (sd.on_convex_vertex && !on_a_side) {
        row[ObstacleGrid::placement_column] = ObstacleGrid::on_convex_vertex;
        row[ObstacleGrid::normal_x_column] = sd.face_normal_x[0];
        row[ObstacleGrid::normal_y_column] = sd.face_normal_y[0];
        row[ObstacleGrid::second_normal_x_column] = sd.face_normal_x[1];
        row[ObstacleGrid::second_normal_y_column] = sd.face_normal_y[1];
        row[ObstacleGrid::face_share_column] = static_cast<real_t>(
            convex_vertex_face_share(sd.face_normal_x[0], sd.face_normal_y[0], sd.face_normal_x[1], sd.face_normal_y[1]));
      }
      rows.push_back(row);
    }
  grid.node_gas_volume =
      node_gas_volumes(host, node_distance, slab, sides, std::hypot(geo.spacing_x, geo.spacing_y));
  if (host.empty()) {
    grid.obstacle_nodes = IndexView("obstacle_nodes", 0);
    grid.obstacle_normals = NodeFieldsView("obstacle_normals", 0, ObstacleGrid::num_columns);
    grid.obstacle_of_node = IndexView("obstacle_of_node", 0);
    grid.body_nodes = IndexView("body_nodes", 0);
    grid.body_node_obstacle = IndexView("body_node_obstacle", 0);
    return grid;
  }
  grid.obstacle_nodes = IndexView("obstacle_nodes", nodes.size());
  grid.obstacle_normals = NodeFieldsView("obstacle_normals", nodes.size(), ObstacleGrid::num_columns);
  auto nodes_host = host_mirror(grid.obstacle_nodes);
  auto normals_host = host_mirror(grid.obstacle_normals);
  for (size_t k = 0; k < nodes.size(); ++k) {
    nodes_host(k) = nodes[k];
    for (int c = 0; c < ObstacleGrid::num_columns; ++c) normals_host(k, c) = rows[k][static_cast<size_t>(c)];
  }
  Kokkos::deep_copy(grid.obstacle_nodes, nodes_host);
  Kokkos::deep_copy(grid.obstacle_normals, normals_host);

  // Which obstacle each node belongs to (the nearest surface), for the forces on each; -1 on nodes
  // another slab owns.
  const IndexRange2D owned = slab.index_space(Ownership::owned, Entity::node, Indexing::local);
  grid.obstacle_of_node = IndexView("obstacle_of_node", nodes.size());
  auto of_node_host = host_mirror(grid.obstacle_of_node);
  for (size_t k = 0; k < nodes.size(); ++k) {
    of_node_host(k) = owned.contains(geo.node_i_of(nodes[k]), geo.node_j_of(nodes[k])) ? node_obstacle[nodes[k]] : -1;
  }
  Kokkos::deep_copy(grid.obstacle_of_node, of_node_host);

  {
    // The basis function's reach (the hat's cell, the B-spline's cell and a half) and half a cell
    // beyond, where the particles beside a body end, along each axis.
    const real_t reach = (shape == ShapeFunction::bspline ? real_t(2) : real_t(1.5)) *
                         std::sqrt(geo.spacing_x * geo.spacing_x + geo.spacing_y * geo.spacing_y);
    std::vector<index_t> band_nodes, band_obstacle;
    for (index_t node = 0; node < geo.num_nodes(); ++node) {
      if (!(std::abs(node_distance[node]) < reach)) continue;
      band_nodes.push_back(node);
      band_obstacle.push_back(owned.contains(geo.node_i_of(node), geo.node_j_of(node)) ? node_obstacle[node] : -1);
    }
    grid.body_nodes = to_device_indices("body_nodes", band_nodes);
    grid.body_node_obstacle = to_device_indices("body_node_obstacle", band_obstacle);
  }

  // The signed distance is 1-Lipschitz, so inside a cell it differs from a corner value by at most
  // the cell diagonal: a cell whose corners are all farther than that holds no obstacle point.
  const real_t diagonal = std::sqrt(geo.spacing_x * geo.spacing_x + geo.spacing_y * geo.spacing_y);
  auto near_host = host_mirror(grid.cell_near_obstacle);
  for (index_t cj = 0; cj < geo.cells_y(); ++cj)
    for (index_t ci = 0; ci < geo.cells_x(); ++ci) {
      const real_t closest = std::min(std::min(node_distance[geo.node_index(ci, cj)], node_distance[geo.node_index(ci + 1, cj)]),
                                      std::min(node_distance[geo.node_index(ci, cj + 1)],
                                               node_distance[geo.node_index(ci + 1, cj + 1)]));
      near_host(ci + geo.cells_x() * cj) = closest < diagonal ? 1 : 0;
      if (closest >= diagonal) continue;
      // (A flagged cell at the edge of the local grid: the look-up clamps a point beyond it to it.)
      const real_t beyond = std::numeric_limits<real_t>::max();
      const real_t x0 = ci == 0 ? -beyond : geo.node_x(ci), x1 = ci + 1 == geo.cells_x() ? beyond : geo.node_x(ci + 1);
      const real_t y0 = cj == 0 ? -beyond : geo.node_y(cj), y1 = cj + 1 == geo.cells_y() ? beyond : geo.node_y(cj + 1);
      const bool first = grid.near_x_min > grid.near_x_max;
      grid.near_x_min = first ? x0 : std::min(grid.near_x_min, x0);
      grid.near_x_max = first ? x1 : std::max(grid.near_x_max, x1);
      grid.near_y_min = first ? y0 : std::min(grid.near_y_min, y0);
      grid.near_y_max = first ? y1 : std::max(grid.near_y_max, y1);
    }
  Kokkos::deep_copy(grid.cell_near_obstacle, near_host);
  return grid;
}

}  // namespace mpmflow
