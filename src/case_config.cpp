#include "case_config.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <utility>

#include <nlohmann/json.hpp>

#include "geometry.hpp"

namespace mpmflow {
namespace {

using nlohmann::json;

// An interval a number must lie in, with the phrase used in error messages.
struct Bounds {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;
  std::string phrase = "a number";

  bool contains(double v) const {
    return (min_open ? v > min : v >= min) && v <= max && v == v;
  }
  static Bounds positive() { return {0, std::numeric_limits<double>::infinity(), true, "a number > 0"}; }
  static Bounds non_negative() { return {0, std::numeric_limits<double>::infinity(), false, "a number >= 0"}; }
  static Bounds any() { return {}; }
  static Bounds at_least(double lo, const std::string& phrase) {
    return {lo, std::numeric_limits<double>::infinity(), false, phrase};
  }
  static Bounds between(double lo, double hi, bool lo_open, const std::string& phrase) {
    return {lo, hi, lo_open, phrase};
  }
};

// Reads one JSON object, remembering which keys were used so that leftovers can be rejected.
class ObjectReader {
 public:
  // `keys`, when given, collects every path looked up (array indices as "*"): the parser's table
  // of keys (case_file_keys).
  ObjectReader(const json& object, std::string source, std::string path, std::set<std::string>* keys = nullptr)
      : object_(object), source_(std::move(source)), path_(std::move(path)), keys_(keys) {
    if (!object_.is_object()) fail(path_.empty() ? "/" : path_, "an object", object_);
  }

  bool has(const std::string& key) const {
    record(key);
    asked_.insert(key);
    return object_.contains(key);
  }

  double number(const std::string& key, const Bounds& bounds) {
    const json& v = require(key);
    if (!v.is_number()) fail(at(key), bounds.phrase, v);
    const double d = v.get<double>();
    if (!bounds.contains(d)) fail(at(key), bounds.phrase, v);
    check_fits_real(at(key), bounds.phrase, v);
    return d;
  }
  // Every number of `v` (a number or an array of them) fits the build's reals (fits_in), else the
  // error names `where` and what was expected, with the largest real.
  void check_fits_real(const std::string& where, const std::string& expected, const json& v) const {
    const auto fits = [](const json& x) { return !x.is_number() || fits_in<real_t>(x.get<double>()); };
    if (v.is_array() ? std::all_of(v.begin(), v.end(), fits) : fits(v)) return;
    std::ostringstream largest;
    largest << std::numeric_limits<real_t>::max();
    fail(where, expected + ", at most " + largest.str() + " in magnitude (this mpmflow computes in " +
                    (sizeof(real_t) == sizeof(double) ? "double" : "single") + " precision)",
         v);
  }
  // Reads `key` into `target` when present; otherwise `target` keeps its value: the default of
  // the config struct's initialiser, the one place defaults are written.
  template <class T>
  void optional_number(const std::string& key, T& target, const Bounds& bounds) {
    if (has(key)) target = static_cast<T>(number(key, bounds));
  }

  long integer(const std::string& key, long min, long max) {
    const json& v = require(key);
    const std::string phrase = "an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]";
    if (!v.is_number_integer()) fail(at(key), phrase, v);
    const long i = v.get<long>();
    if (i < min || i > max) fail(at(key), phrase, v);
    return i;
  }
  template <class T>
  void optional_integer(const std::string& key, T& target, long min, long max) {
    if (has(key)) target = static_cast<T>(integer(key, min, max));
  }

  void optional_boolean(const std::string& key, bool& target) {
    if (!has(key)) return;
    const json& v = require(key);
    if (!v.is_boolean()) fail(at(key), "true or false", v);
    target = v.get<bool>();
  }

  std::string string(const std::string& key) {
    const json& v = require(key);
    if (!v.is_string()) fail(at(key), "a string", v);
    return v.get<std::string>();
  }

  // One of the names of `table` (an enum's EnumNames table, or a table of its own).
  template <class T, size_t N>
  T choice(const std::string& key, const EnumName<T> (&table)[N]) {
    const json& v = require(key);
    std::string phrase = "one of";
    for (size_t i = 0; i < N; ++i) phrase += (i ? ", " : " ") + std::string(table[i].name);
    if (v.is_string())
      for (const EnumName<T>& entry : table)
        if (v.get<std::string>() == entry.name) return entry.value;
    fail(at(key), phrase, v);
  }
  template <class Enum>
  Enum choice(const std::string& key) {
    return choice(key, EnumNames<Enum>::table);
  }
  template <class T, size_t N>
  void optional_choice(const std::string& key, T& target, const EnumName<T> (&table)[N]) {
    if (has(key)) target = choice(key, table);
  }
  template <class Enum>
  void optional_choice(const std::string& key, Enum& target) {
    optional_choice(key, target, EnumNames<Enum>::table);
  }

  ObjectReader object(const std::string& key) { return ObjectReader(require(key), source_, at(key), keys_); }
  // A reader for element `index` of the array at `key` (already read with array()).
  ObjectReader element(const std::string& key, size_t index) {
    return ObjectReader(object_.at(key).at(index), source_, at(key) + "/" + std::to_string(index), keys_);
  }

  const json& array(const std::string& key) {
    const json& v = require(key);
    if (!v.is_array()) fail(at(key), "an array", v);
    return v;
  }

  std::string at(const std::string& key) const { return path_ + "/" + key; }
  const std::string& source() const { return source_; }

  // Every key must have been read: a misspelt key is an error, never silently ignored.
  void finish() const {
    for (auto it = object_.begin(); it != object_.end(); ++it)
      if (!used_.count(it.key()))
        throw ConfigError(source_ + ": " + at(it.key()) + ": unknown key" + known_keys_hint());
  }

  [[noreturn]] void fail(const std::string& where, const std::string& expected, const json& got) const {
    throw ConfigError(source_ + ": " + where + ": expected " + expected + "; got " + got.dump());
  }

 private:
  const json& require(const std::string& key) {
    record(key);
    used_.insert(key);
    asked_.insert(key);
    if (!object_.contains(key))
      throw ConfigError(source_ + ": " + at(key) + ": required key is missing");
    return object_.at(key);
  }
  // Every key looked for here, present or not: the optional ones a misspelling most likely meant.
  std::string known_keys_hint() const {
    if (asked_.empty()) return "";
    std::string hint = " (known here:";
    for (const auto& k : asked_) hint += " " + k;
    return hint + ")";
  }

  void record(const std::string& key) const {
    if (!keys_) return;
    std::string path;  // at(key) with each array index as "*"
    std::istringstream segments(at(key));
    for (std::string segment; std::getline(segments, segment, '/');)
      if (!segment.empty())
        path += "/" + (segment.find_first_not_of("0123456789") == std::string::npos ? std::string("*") : segment);
    keys_->insert(path);
  }

  const json& object_;
  std::string source_;
  std::string path_;
  std::set<std::string>* keys_;
  std::set<std::string> used_;
  // Every key looked for (has or require): the hint's list. Mutable: has() is a const question.
  mutable std::set<std::string> asked_;
};

GasState read_gas_state(ObjectReader& r) {
  GasState s;
  s.density = r.number("density", Bounds::positive());
  s.pressure = r.number("pressure", Bounds::positive());
  if (r.has("velocity")) {
    const json& v = r.array("velocity");
    if (v.size() != 2 || !v[0].is_number() || !v[1].is_number())
      r.fail(r.at("velocity"), "an array of two numbers [vx, vy]", v);
    r.check_fits_real(r.at("velocity"), "an array of two numbers [vx, vy]", v);
    s.velocity_x = v[0].get<double>();
    s.velocity_y = v[1].get<double>();
  }  // no velocity: at rest
  return s;
}

// Reads a [lo, hi] pair of numbers with lo < hi.
std::pair<double, double> read_range(ObjectReader& r, const std::string& key) {
  const json& v = r.array(key);
  if (v.size() != 2 || !v[0].is_number() || !v[1].is_number() || !(v[0].get<double>() < v[1].get<double>()))
    r.fail(r.at(key), "an array [lo, hi] of two numbers with lo < hi", v);
  r.check_fits_real(r.at(key), "an array [lo, hi] of two numbers with lo < hi", v);
  return {v[0].get<double>(), v[1].get<double>()};
}

// Reads an array of two numbers [a, b].
std::pair<double, double> read_pair(ObjectReader& r, const std::string& key, const std::string& phrase) {
  const json& v = r.array(key);
  if (v.size() != 2 || !v[0].is_number() || !v[1].is_number()) r.fail(r.at(key), phrase, v);
  r.check_fits_real(r.at(key), phrase, v);
  return {v[0].get<double>(), v[1].get<double>()};
}

// One obstacle of /obstacles, resolved into a circle or a closed polygon and checked: a points
// file must exist and hold at least three points of a simple (not self-intersecting) polygon, and
// the obstacle must lie inside the domain.
// A points file from the cache when it holds it; else from disk, and then into the cache.
Polygon read_points_file_through(const std::string& path, PointsFiles* points_files) {
  if (points_files) {
    const auto it = points_files->files.find(path);
    if (it != points_files->files.end()) {
      Polygon polygon;
      for (const auto& p : it->second) polygon.push_back({p.first, p.second});
      return polygon;
    }
  }
  Polygon polygon = read_points_file(path);
  if (points_files) {
    auto& stored = points_files->files[path];
    for (const Point& p : polygon) stored.emplace_back(p.x, p.y);
  }
  return polygon;
}

// How far a point may lie beyond the domain and count as on its side: round-off of its extent.
double domain_tolerance(const DomainConfig& domain) {
  return 1e-9 * std::max(domain.x_max - domain.x_min, domain.y_max - domain.y_min);
}

// "[x_lo, x_hi] x [y_lo, y_hi]", as the error messages name a box.
std::string describe_box(double x_lo, double x_hi, double y_lo, double y_hi) {
  std::ostringstream text;
  text << "[" << x_lo << ", " << x_hi << "] x [" << y_lo << ", " << y_hi << "]";
  return text.str();
}

// Whether a vertex of `polygon` lies beyond the domain by more than round-off.
bool reaches_beyond(const Polygon& polygon, const DomainConfig& domain) {
  const double tolerance = domain_tolerance(domain);
  return std::any_of(polygon.begin(), polygon.end(), [&](const Point& v) {
    return v.x < domain.x_min - tolerance || v.x > domain.x_max + tolerance || v.y < domain.y_min - tolerance ||
           v.y > domain.y_max + tolerance;
  });
}

ObstacleConfig read_obstacle(ObjectReader& r, const std::string& where, const DomainConfig& domain,
                             const std::pair<double, double>& flow_direction,
                             const std::filesystem::path& case_directory, PointsFiles* points_files) {
  ObstacleConfig obstacle;
  obstacle.shape = r.choice<ObstacleShape>("type");
  obstacle.description = where + " (" + to_string(obstacle.shape) + ")";
  r.optional_number("reference_length", obstacle.reference_length, Bounds::positive());
  Polygon polygon;  // the outline of any but a circle within the domain
  if (obstacle.shape == ObstacleShape::circle) {
    const auto centre = read_pair(r, "centre", "an array [x, y] of two numbers");
    obstacle.centre_x = centre.first;
    obstacle.centre_y = centre.second;
    obstacle.radius = r.number("radius", Bounds::positive());
    const double x_lo = centre.first - obstacle.radius, x_hi = centre.first + obstacle.radius;
    const double y_lo = centre.second - obstacle.radius, y_hi = centre.second + obstacle.radius;
    // A circle that reaches beyond the domain (a half cylinder on a symmetry wall, a bump in a
    // floor) is a polygon, clipped to the domain below, whose edges on the sides are no surface:
    // the signed distance of a whole circle knows no side. (Tried with the circle's own distance:
    // a 10 % circular-arc bump in a Mach 0.5 channel, 150 x 50 cells, t = 15, had a fast spot at
    // its trailing junction, the nodes' Mach number up to 2.33; as a polygon 1.11 to 1.31, against
    // 0.6 to 0.8 over the crest.) 360 vertices: the chords stray from the arc by 3.8e-5 of the
    // radius.
    if (reaches_beyond({{x_lo, y_lo}, {x_hi, y_hi}}, domain)) {
      polygon = circle_outline(centre.first, centre.second, obstacle.radius, 360);
      obstacle.shape = ObstacleShape::polygon;
      obstacle.description += " reaching beyond the domain, as a polygon of 360 points";
    }
  } else if (obstacle.shape == ObstacleShape::rectangle) {
    const auto xr = read_range(r, "x");
    const auto yr = read_range(r, "y");
    polygon = {{xr.first, yr.first}, {xr.second, yr.first}, {xr.second, yr.second}, {xr.first, yr.second}};
  } else {
    const std::string file = r.string("file");
    const std::filesystem::path path = std::filesystem::path(file).is_absolute() ? std::filesystem::path(file) : case_directory / file;
    try {
      polygon = read_points_file_through(path.string(), points_files);
    } catch (const std::runtime_error& e) {
      throw ConfigError(r.source() + ": " + r.at("file") + ": " + e.what());
    }
    PolygonTransform transform;
    r.optional_number("scale", transform.scale, Bounds::positive());
    r.optional_number("rotation_degrees", transform.rotation_degrees, Bounds::any());
    if (r.has("angle_of_attack_degrees")) {  // the aerodynamicist's name: nose up is a clockwise rotation
      if (r.has("rotation_degrees"))
        throw ConfigError(r.source() + ": " + r.at("angle_of_attack_degrees") +
                          ": expected either rotation_degrees or angle_of_attack_degrees, not both");
      transform.rotation_degrees = -r.number("angle_of_attack_degrees", Bounds::any());
    }
    if (r.has("translation")) {
      const auto t = read_pair(r, "translation", "an array [dx, dy] of two numbers");
      transform.translation_x = t.first;
      transform.translation_y = t.second;
    }
    polygon = transformed(polygon, transform);
    obstacle.description += " from " + path.string();
  }
  if (obstacle.shape != ObstacleShape::circle) {
    if (polygon.size() < 3)
      throw ConfigError(r.source() + ": " + obstacle.description + ": expected a polygon of at least 3 points; got " +
                        std::to_string(polygon.size()));
    const std::string crossing = describe_self_intersection(polygon);
    if (!crossing.empty())
      throw ConfigError(r.source() + ": " + obstacle.description +
                        ": expected a simple polygon; it intersects itself: " + crossing);
    // A polygon that reaches beyond the domain (a ramp or a floor run out through a side) is its
    // part inside; its edges on the sides are no surface (below).
    if (reaches_beyond(polygon, domain)) {
      const Polygon inside = clipped_to_box(polygon, domain.x_min, domain.x_max, domain.y_min, domain.y_max);
      if (inside.size() < 3)
        throw ConfigError(r.source() + ": " + obstacle.description + ": expected an obstacle reaching into the domain " +
                          describe_box(domain.x_min, domain.x_max, domain.y_min, domain.y_max) +
                          "; it lies wholly outside it");
      const std::string pieces = describe_self_intersection(inside);
      if (!pieces.empty())
        throw ConfigError(r.source() + ": " + obstacle.description + ": expected an obstacle whose part inside the domain " +
                          describe_box(domain.x_min, domain.x_max, domain.y_min, domain.y_max) +
                          " is one piece; clipped to it, " + pieces + " (give each piece as an obstacle of its own)");
      polygon = inside;
    }
    for (const Point& v : polygon) {
      obstacle.vertices_x.push_back(v.x);
      obstacle.vertices_y.push_back(v.y);
    }
  }
  r.finish();
  // (Every obstacle now lies within the domain, up to round-off: one reaching beyond it is clipped.)
  const double tolerance = domain_tolerance(domain);
  // The coefficients' length, of the obstacle as the case gives it (its part inside the domain).
  obstacle.reference_length = obstacle_reference_length(obstacle, flow_direction.first, flow_direction.second);
  // An edge on a side of the domain is not a surface the gas meets (the signed distance puts the
  // obstacle beyond it: make_host_obstacle_set).
  if (obstacle.shape != ObstacleShape::circle) {
    const size_t n = obstacle.vertices_x.size();
    // The side both ends of an edge lie on, or -1.
    auto side_of_edge = [&](size_t a, size_t b) -> int {
      const real_t xa = obstacle.vertices_x[a], xb = obstacle.vertices_x[b];
      const real_t ya = obstacle.vertices_y[a], yb = obstacle.vertices_y[b];
      if (xa <= domain.x_min + tolerance && xb <= domain.x_min + tolerance) return left_side;
      if (xa >= domain.x_max - tolerance && xb >= domain.x_max - tolerance) return right_side;
      if (ya <= domain.y_min + tolerance && yb <= domain.y_min + tolerance) return bottom_side;
      if (ya >= domain.y_max - tolerance && yb >= domain.y_max - tolerance) return top_side;
      return -1;
    };
    obstacle.edge_side.resize(n);
    size_t surfaces = 0;
    for (size_t v = 0; v < n; ++v) {
      obstacle.edge_side[v] = side_of_edge(v, (v + 1) % n);
      if (obstacle.edge_side[v] < 0) ++surfaces;
    }
    if (surfaces == 0)
      throw ConfigError(r.source() + ": " + obstacle.description +
                        ": expected an obstacle with a surface inside the domain; every edge lies on a side of the domain");
  }
  return obstacle;
}

// The unit vector along the free stream's velocity; +x without a moving free stream.
std::pair<double, double> free_stream_direction(const BoundaryConfig& b) {
  const double vx = b.free_stream.velocity_x, vy = b.free_stream.velocity_y, speed = std::hypot(vx, vy);
  if (!b.has_free_stream || !(speed > 0)) return {1.0, 0.0};
  return {vx / speed, vy / speed};
}

// A side's boundary type into `type`, when the case names one.
void read_boundary(ObjectReader& boundaries, const std::string& side, BoundaryType& type) {
  if (!boundaries.has(side)) return;
  ObjectReader r = boundaries.object(side);
  type = r.choice<BoundaryType>("type");
  r.finish();
}

CaseConfig parse_document(const json& doc, const std::string& source, PointsFiles* points_files,
                          std::set<std::string>* keys = nullptr) {
  const std::filesystem::path case_directory = std::filesystem::path(source).parent_path();
  CaseConfig cfg;
  cfg.source = source;
  ObjectReader root(doc, source, "", keys);

  cfg.name = root.string("name");
  if (root.has("description")) cfg.description = root.string("description");  // free text, echoed in the banner
  if (cfg.name.empty() || cfg.name.find_first_not_of(
                              "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-") !=
                              std::string::npos)
    root.fail("/name", "a non-empty name of letters, digits, '_' and '-' (it names output files)",
              doc["name"]);

  {
    ObjectReader r = root.object("domain");
    const auto xr = read_range(r, "x");
    const auto yr = read_range(r, "y");
    cfg.domain.x_min = xr.first;
    cfg.domain.x_max = xr.second;
    cfg.domain.y_min = yr.first;
    cfg.domain.y_max = yr.second;
    cfg.domain.cells_x = static_cast<int>(r.integer("cells_x", 1, 1 << 20));
    cfg.domain.cells_y = static_cast<int>(r.integer("cells_y", 1, 1 << 20));
    r.finish();
  }

  if (root.has("physics")) {
    ObjectReader r = root.object("physics");
    r.optional_number("gamma", cfg.physics.gamma, Bounds::at_least(1.0 + 1e-12, "a number > 1"));
    if (r.has("artificial_viscosity")) {
      ObjectReader av = r.object("artificial_viscosity");
      av.optional_number("c0", cfg.physics.viscosity_quadratic, Bounds::non_negative());
      av.optional_number("c1", cfg.physics.viscosity_linear, Bounds::non_negative());
      av.finish();
    }
    r.finish();
  }

  {
    ObjectReader r = root.object("time");
    cfg.time.end_time = r.number("end", Bounds::positive());
    r.optional_number("cfl", cfg.time.cfl, Bounds::between(0, 1, true, "a number in (0, 1]"));
    r.optional_integer("max_steps", cfg.time.max_steps, 0, std::numeric_limits<long>::max());
    r.finish();
  }

  if (root.has("boundaries")) {
    ObjectReader r = root.object("boundaries");
    read_boundary(r, "left", cfg.boundaries.left);
    read_boundary(r, "right", cfg.boundaries.right);
    read_boundary(r, "bottom", cfg.boundaries.bottom);
    read_boundary(r, "top", cfg.boundaries.top);
    r.optional_choice("particle_supply", cfg.boundaries.particle_supply);
    r.finish();
  }
  const bool open_sides = cfg.boundaries.any_open();
  if (root.has("free_stream")) {
    ObjectReader r = root.object("free_stream");
    cfg.boundaries.free_stream = read_gas_state(r);
    cfg.boundaries.has_free_stream = true;
    r.finish();
  } else if (open_sides) {
    throw ConfigError(source + ": /free_stream: required key is missing (a side is an inflow, an outflow or a "
                      "far field, so the free-stream density, velocity and pressure are needed)");
  }
  // An inflow side lets the free stream in: its velocity must point into the domain there.
  if (cfg.boundaries.has_free_stream) {
    const GasState& inf = cfg.boundaries.free_stream;
    const std::pair<const char*, double> inward[] = {{"left", inf.velocity_x}, {"right", -inf.velocity_x},
                                                     {"bottom", inf.velocity_y}, {"top", -inf.velocity_y}};
    const auto types = cfg.boundaries.side_types();
    for (int side = 0; side < 4; ++side)
      if (types[side] == BoundaryType::inflow && !(inward[side].second > 0))
        throw ConfigError(source + ": /boundaries/" + inward[side].first +
                          ": an inflow side needs the free stream to enter through it; /free_stream/velocity [" +
                          std::to_string(inf.velocity_x) + ", " + std::to_string(inf.velocity_y) +
                          "] does not point into the domain there (make the side an outflow or a far field)");
  }
  if (cfg.boundaries.particle_supply == ParticleSupply::recycle) {
    if (cfg.boundaries.any(BoundaryType::far_field))
      throw ConfigError(source + ": /boundaries/particle_supply: far_field sides create and remove particles as "
                        "the flow needs; expected \"open\" with far_field sides, got \"recycle\"");
    if (cfg.boundaries.any(BoundaryType::outflow) && !cfg.boundaries.any(BoundaryType::inflow))
      throw ConfigError(source + ": /boundaries: expected an inflow side where particles leaving through an "
                        "outflow side re-enter (particle_supply \"recycle\"); got outflow sides and no inflow");
  }

  if (root.has("obstacles")) {
    const json& obstacles = root.array("obstacles");
    for (size_t i = 0; i < obstacles.size(); ++i) {
      const std::string where = "/obstacles/" + std::to_string(i);
      ObjectReader r = root.element("obstacles", i);
      cfg.obstacles.push_back(
          read_obstacle(r, where, cfg.domain, free_stream_direction(cfg.boundaries), case_directory, points_files));
    }
  }

  {
    ObjectReader r = root.object("particles");
    r.optional_choice("placement", cfg.particles.placement);
    r.optional_integer("seed", cfg.particles.seed, 0, std::numeric_limits<long>::max());
    const json& per_cell = r.array("per_cell");
    if (per_cell.size() != 2 || !per_cell[0].is_number_integer() || !per_cell[1].is_number_integer() ||
        per_cell[0].get<long>() < 1 || per_cell[1].get<long>() < 1 || per_cell[0].get<long>() > 64 ||
        per_cell[1].get<long>() > 64)
      r.fail(r.at("per_cell"), "an array [nx, ny] of two integers in [1, 64]", per_cell);
    cfg.particles.per_cell_x = per_cell[0].get<int>();
    cfg.particles.per_cell_y = per_cell[1].get<int>();
    r.finish();
    // Particle and node indices are 32-bit: the particles (with the storage's spare eighth) and the
    // nodes must stay well below 2^31.
    const double particles = double(cfg.domain.cells_x) * cfg.domain.cells_y * cfg.particles.per_cell_x *
                             cfg.particles.per_cell_y;
    const double limit = 1 << 30;
    if (particles > limit || double(cfg.domain.cells_x + 5) * (cfg.domain.cells_y + 5) > limit)
      throw ConfigError(source + ": /domain: " + std::to_string(cfg.domain.cells_x) + " x " +
                        std::to_string(cfg.domain.cells_y) + " cells with " + std::to_string(cfg.particles.per_cell_x) +
                        " x " + std::to_string(cfg.particles.per_cell_y) + " particles per cell make " +
                        std::to_string(static_cast<long long>(particles)) +
                        " particles; expected at most 2^30 particles and nodes (32-bit indices)");
  }

  // Without an initial_state, the domain starts filled with the free stream (the wind tunnel).
  if (!root.has("initial_state") && cfg.boundaries.has_free_stream) {
    cfg.initial_state.background = cfg.boundaries.free_stream;
  } else {
    ObjectReader r = root.object("initial_state");
    ObjectReader background = r.object("background");
    cfg.initial_state.background = read_gas_state(background);
    background.finish();
    if (r.has("regions")) {
      const json& regions = r.array("regions");
      for (size_t i = 0; i < regions.size(); ++i) {
        ObjectReader region = r.element("regions", i);
        Region reg;
        const auto xr = read_range(region, "x");
        const auto yr = read_range(region, "y");
        reg.x_min = xr.first;
        reg.x_max = xr.second;
        reg.y_min = yr.first;
        reg.y_max = yr.second;
        reg.state = read_gas_state(region);
        region.finish();
        if (reg.x_max <= cfg.domain.x_min || reg.x_min >= cfg.domain.x_max || reg.y_max <= cfg.domain.y_min ||
            reg.y_min >= cfg.domain.y_max) {
          std::ostringstream msg;
          msg << source << ": " << r.at("regions") << "/" << i << ": expected a box overlapping the domain [" << cfg.domain.x_min
              << ", " << cfg.domain.x_max << "] x [" << cfg.domain.y_min << ", " << cfg.domain.y_max << "]; got ["
              << reg.x_min << ", " << reg.x_max << "] x [" << reg.y_min << ", " << reg.y_max << "]";
          throw ConfigError(msg.str());
        }
        cfg.initial_state.regions.push_back(reg);
      }
    }
    r.finish();
  }

  cfg.output.directory = "output/" + cfg.name;
  if (root.has("output")) {
    ObjectReader r = root.object("output");
    if (r.has("directory")) {
      cfg.output.directory = r.string("directory");
      if (cfg.output.directory.empty()) r.fail("/output/directory", "a non-empty path", doc["output"]["directory"]);
    }
    r.optional_integer("snapshots", cfg.output.snapshots, 0, 100000);
    r.optional_integer("checkpoint_interval", cfg.output.checkpoint_interval, 0, 1L << 40);
    r.optional_integer("checkpoints_kept", cfg.output.checkpoints_kept, 0, 1 << 20);
    r.optional_choice("phase_timers", cfg.output.phase_timers);
    r.finish();
  }

  if (root.has("decomposition")) {
    ObjectReader r = root.object("decomposition");
    static constexpr EnumName<int> axes[] = {{"x", 0}, {"y", 1}};
    r.optional_choice("axis", cfg.decomposition.axis, axes);
    r.optional_integer("balance_interval", cfg.decomposition.balance_interval, 0, 1 << 30);
    r.finish();
  }

  if (root.has("numerics")) {
    ObjectReader r = root.object("numerics");
    r.optional_integer("reorder_interval", cfg.numerics.reorder_interval, 0, 1 << 30);
    r.optional_choice("p2g", cfg.numerics.p2g);
    r.optional_choice("shape_function", cfg.numerics.shape_function);
    r.optional_boolean("fused_kernels", cfg.numerics.fused_kernels);
    r.optional_boolean("energy_consistent", cfg.numerics.energy_consistent);
    r.optional_boolean("cell_averaged_strain", cfg.numerics.cell_averaged_strain);
    r.optional_boolean("pressure_relaxation", cfg.numerics.pressure_relaxation);
    r.optional_boolean("volume_correction", cfg.numerics.volume_correction);
    r.optional_boolean("split_particles", cfg.numerics.split_particles);
    r.optional_boolean("merge_particles", cfg.numerics.merge_particles);
    r.finish();
  }

  root.finish();
  return cfg;
}

// Case documents nest a few levels; a deeper one is a mistake (or an attack), and refused before
// anything recurses through it.
constexpr int max_case_depth = 32;

// Parses a case document: valid JSON, no object holding a key twice (JSON allows it and keeps the
// last; a case file that sets a key twice is a mistake), at most max_case_depth levels deep.
// Every failure is a ConfigError naming `source`.
template <class Input>
json parse_checked_json(Input&& input, const std::string& source) {
  std::vector<std::set<std::string>> keys_of_open_objects;
  std::vector<std::string> path;  // keys of the open objects, for the message
  const json::parser_callback_t check = [&](int depth, json::parse_event_t event, json& value) {
    if (depth > max_case_depth)
      throw ConfigError(source + ": nested deeper than " + std::to_string(max_case_depth) + " levels");
    switch (event) {
      case json::parse_event_t::object_start:
        keys_of_open_objects.emplace_back();
        break;
      case json::parse_event_t::object_end:
        if (!keys_of_open_objects.empty()) keys_of_open_objects.pop_back();
        break;
      case json::parse_event_t::key: {
        const std::string key = value.get<std::string>();
        if (!keys_of_open_objects.back().insert(key).second)
          throw ConfigError(source + ": the key \"" + key + "\" appears twice in one object (at nesting level " +
                            std::to_string(depth) + "); expected each key once");
        break;
      }
      default:
        break;
    }
    return true;
  };
  try {
    return json::parse(std::forward<Input>(input), check);
  } catch (const json::exception& e) {
    // Syntax errors, and numbers JSON allows but a double cannot hold (1e400).
    throw ConfigError(source + ": not valid JSON: " + e.what());
  }
}

void apply_override(json& doc, const std::string& source, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw ConfigError(source + ": --set " + assignment + ": expected PATH=VALUE, e.g. domain/cells_x=400");
  std::string path = assignment.substr(0, eq);
  if (path.front() != '/') path = "/" + path;
  const std::string text = assignment.substr(eq + 1);
  json value = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (value.is_discarded()) value = text;  // not JSON: take it as a string
  try {
    doc[json::json_pointer(path)] = value;
  } catch (const json::exception& e) {
    throw ConfigError(source + ": --set " + assignment + ": cannot set " + path + ": " + e.what());
  }
}

}  // namespace

CaseConfig parse_case(const std::string& json_text, const std::string& source, PointsFiles* points_files) {
  const json doc = parse_checked_json(json_text, source);
  CaseConfig config = parse_document(doc, source, points_files);
  config.document = doc.dump();
  return config;
}

double obstacle_reference_length(const ObstacleConfig& obstacle, double flow_x, double flow_y) {
  if (obstacle.reference_length > 0) return obstacle.reference_length;
  if (obstacle.shape == ObstacleShape::circle) return 2 * double(obstacle.radius);
  // Extent of the vertices along a direction: along the flow, or across it (the flow turned by 90 degrees).
  const bool across = obstacle.shape == ObstacleShape::rectangle;
  const double dx = across ? -flow_y : flow_x, dy = across ? flow_x : flow_y;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (size_t v = 0; v < obstacle.vertices_x.size(); ++v) {
    const double s = obstacle.vertices_x[v] * dx + obstacle.vertices_y[v] * dy;
    lo = std::min(lo, s);
    hi = std::max(hi, s);
  }
  return hi - lo;
}

std::set<std::string> case_file_keys() {
  // A case with every optional object and key the parser knows of, one obstacle of each type.
  const char* every_key = R"({
    "name": "keys", "description": "",
    "domain": {"x": [0, 4], "y": [0, 2], "cells_x": 8, "cells_y": 4},
    "physics": {"gamma": 1.4, "artificial_viscosity": {"c0": 1, "c1": 1}},
    "time": {"end": 1, "cfl": 0.5, "max_steps": 0},
    "boundaries": {"left": {"type": "inflow"}, "right": {"type": "outflow"}, "bottom": {"type": "slip_wall"},
                   "top": {"type": "far_field"}, "particle_supply": "open"},
    "free_stream": {"density": 1.4, "pressure": 1, "velocity": [1, 0]},
    "obstacles": [{"type": "circle", "centre": [1, 1], "radius": 0.1, "reference_length": 0.2},
                  {"type": "rectangle", "x": [2, 2.2], "y": [0.5, 0.7]},
                  {"type": "polygon", "file": "outline.dat", "scale": 0.1, "angle_of_attack_degrees": 1,
                   "translation": [3, 1]}],
    "particles": {"placement": "regular", "per_cell": [2, 2], "seed": 1},
    "initial_state": {"background": {"density": 1, "pressure": 1, "velocity": [0, 0]},
                      "regions": [{"x": [0, 1], "y": [0, 1], "density": 1, "pressure": 1, "velocity": [0, 0]}]},
    "output": {"directory": "out", "snapshots": 1, "checkpoint_interval": 0, "checkpoints_kept": 2,
               "phase_timers": "fenced"},
    "decomposition": {"axis": "x", "balance_interval": 0},
    "numerics": {"reorder_interval": 0, "p2g": "automatic", "shape_function": "gimp", "fused_kernels": true,
                 "energy_consistent": true, "cell_averaged_strain": false, "pressure_relaxation": true,
                 "volume_correction": true, "split_particles": true,
                 "merge_particles": true}
  })";
  PointsFiles outline;
  outline.files["outline.dat"] = {{0, 0}, {1, 0}, {0.5, 0.5}};
  std::set<std::string> keys;
  parse_document(json::parse(every_key), "keys.json", &outline, &keys);
  return keys;
}

namespace {
json gas_state_json(const GasState& s) {
  return {{"density", as_written(s.density)},
          {"pressure", as_written(s.pressure)},
          {"velocity", {as_written(s.velocity_x), as_written(s.velocity_y)}}};
}
}  // namespace

bool may_change_on_restart(const std::string& key_path) {
  for (const char* key : {"/time/end", "/time/max_steps", "/output/snapshots", "/output/checkpoint_interval",
                          "/output/checkpoints_kept", "/output/directory", "/output/phase_timers", "/description"})
    if (key_path == key) return true;
  return false;
}

std::string restart_incompatibility(const std::string& checkpoint_case, const std::string& current_case) {
  const json before = json::parse(checkpoint_case).flatten(), now = json::parse(current_case).flatten();
  std::set<std::string> keys;
  for (auto it = before.begin(); it != before.end(); ++it) keys.insert(it.key());
  for (auto it = now.begin(); it != now.end(); ++it) keys.insert(it.key());
  for (const std::string& key : keys) {
    // Array elements ("/domain/x/0") belong to their key.
    std::string owner = key;
    while (!owner.empty() && owner.find_last_of('/') != std::string::npos &&
           owner.substr(owner.find_last_of('/') + 1).find_first_not_of("0123456789") == std::string::npos)
      owner = owner.substr(0, owner.find_last_of('/'));
    if (may_change_on_restart(owner)) continue;
    const json a = before.contains(key) ? before[key] : json("(absent)");
    const json b = now.contains(key) ? now[key] : json("(absent)");
    if (a != b) return key + ": " + a.dump() + " in the checkpoint, " + b.dump() + " now";
  }
  return "";
}

std::string effective_case_json(const CaseConfig& c) {
  const json doc = c.document.empty() ? json::object() : json::parse(c.document);
  json e;
  e["name"] = c.name;
  e["description"] = c.description;
  e["domain"] = {{"x", {as_written(c.domain.x_min), as_written(c.domain.x_max)}},
                 {"y", {as_written(c.domain.y_min), as_written(c.domain.y_max)}},
                 {"cells_x", c.domain.cells_x},
                 {"cells_y", c.domain.cells_y}};
  e["physics"] = {{"gamma", as_written(c.physics.gamma)},
                  {"artificial_viscosity",
                   {{"c0", as_written(c.physics.viscosity_quadratic)}, {"c1", as_written(c.physics.viscosity_linear)}}}};
  e["time"] = {{"end", c.time.end_time}, {"cfl", c.time.cfl}, {"max_steps", c.time.max_steps}};
  e["boundaries"] = {{"left", {{"type", to_string(c.boundaries.left)}}},
                     {"right", {{"type", to_string(c.boundaries.right)}}},
                     {"bottom", {{"type", to_string(c.boundaries.bottom)}}},
                     {"top", {{"type", to_string(c.boundaries.top)}}},
                     {"particle_supply", to_string(c.boundaries.particle_supply)}};
  if (c.boundaries.has_free_stream) e["free_stream"] = gas_state_json(c.boundaries.free_stream);
  if (doc.contains("obstacles")) {
    e["obstacles"] = doc["obstacles"];
    // Points files named as the parser found them (absolute), so that the effective case works
    // from anywhere (a checkpoint's case, restarted elsewhere).
    const std::filesystem::path directory = std::filesystem::path(c.source).parent_path();
    for (json& o : e["obstacles"])
      if (o.contains("file") && o["file"].is_string() && std::filesystem::path(o["file"].get<std::string>()).is_relative())
        o["file"] = std::filesystem::absolute(directory / o["file"].get<std::string>()).lexically_normal().string();
  }
  e["particles"] = {{"placement", to_string(c.particles.placement)},
                    {"per_cell", {c.particles.per_cell_x, c.particles.per_cell_y}},
                    {"seed", c.particles.seed}};
  e["initial_state"] = {{"background", gas_state_json(c.initial_state.background)}};
  if (doc.contains("initial_state") && doc["initial_state"].contains("regions"))
    e["initial_state"]["regions"] = doc["initial_state"]["regions"];
  e["output"] = {{"directory", c.output.directory},
                 {"snapshots", c.output.snapshots},
                 {"checkpoint_interval", c.output.checkpoint_interval},
                 {"checkpoints_kept", c.output.checkpoints_kept},
                 {"phase_timers", to_string(c.output.phase_timers)}};
  e["decomposition"] = {{"axis", c.decomposition.axis == 0 ? "x" : "y"},
                        {"balance_interval", c.decomposition.balance_interval}};
  e["numerics"] = {{"reorder_interval", c.numerics.reorder_interval},
                   {"p2g", to_string(c.numerics.p2g)},
                   {"shape_function", to_string(c.numerics.shape_function)},
                   {"fused_kernels", c.numerics.fused_kernels},
                   {"energy_consistent", c.numerics.energy_consistent},
                   {"cell_averaged_strain", c.numerics.cell_averaged_strain},
                   {"pressure_relaxation", c.numerics.pressure_relaxation},
                   {"volume_correction", c.numerics.volume_correction},
                   {"split_particles", c.numerics.split_particles},
                   {"merge_particles", c.numerics.merge_particles}};
  return e.dump(2);
}

std::string load_case_document(const std::string& path, const std::vector<std::string>& overrides) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw ConfigError(path + ": is a directory; expected a case file (JSON), e.g. " +
                      (std::filesystem::path(path) / "sod.json").string());
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the case file");
  json doc = parse_checked_json(in, path);
  for (const auto& assignment : overrides) apply_override(doc, path, assignment);
  return doc.dump();
}

std::string apply_overrides(const std::string& json_text, const std::string& source,
                            const std::vector<std::string>& overrides) {
  json doc = parse_checked_json(json_text, source);
  for (const auto& assignment : overrides) apply_override(doc, source, assignment);
  return doc.dump();
}

CaseConfig load_case_file(const std::string& path, const std::vector<std::string>& overrides) {
  return parse_case(load_case_document(path, overrides), path);
}

std::string PointsFiles::serialise() const {
  json out = json::object();
  for (const auto& file : files) {
    json points = json::array();
    for (const auto& p : file.second) points.push_back({p.first, p.second});
    out[file.first] = points;
  }
  return out.dump();
}

PointsFiles PointsFiles::deserialise(const std::string& text) {
  PointsFiles result;
  const json in = json::parse(text);
  for (auto it = in.begin(); it != in.end(); ++it) {
    auto& points = result.files[it.key()];
    for (const auto& p : it.value()) points.emplace_back(p[0].get<double>(), p[1].get<double>());
  }
  return result;
}

}  // namespace mpmflow
