#pragma once
// A case file parsed into typed, validated structs. Parsing rejects unknown keys, wrong types and
// out-of-range values with a ConfigError naming the file, the JSON path and what was expected.
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <map>
#include <set>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "kernels/types.hpp"
#include "phase_timing.hpp"

namespace mpmflow {

struct ConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Per side of the domain (paper, section 4.1, and open sides): a slip wall (no normal velocity);
// an inflow (the free-stream velocity imposed on the grid; free-stream particles enter with it);
// an outflow (no velocity imposed; the free-stream pressure acts on the side; particles leave); a
// far field (as an outflow, and where the gas at the side moves inwards, free-stream gas enters at
// that speed: subsonic sides where the flow may go either way).
enum class BoundaryType { slip_wall, inflow, outflow, far_field };
// Where the particles of open sides come from: created from the free stream outside each inflow
// (and far-field) side and removed when they leave (`open`, the particle count varies), or the
// paper's recycling, which puts each particle that leaves back at an inflow (`recycle`, a fixed
// count; a body's shock layer then starves the free stream of the mass it stores).
enum class ParticleSupply { open, recycle };
// Initial particles: the centres of a regular sub-grid of each cell, or a uniform random position
// in each cell of that sub-grid (random placement is the paper's choice for the wind-tunnel cases;
// it draws anywhere in the cell, which clumps the particles: create_initial_particles).
enum class ParticlePlacement { regular, random };
enum class ObstacleShape { circle, rectangle, polygon };
// How P2G combines contributions to a node: the execution space's ScatterView default
// (duplicated on host back-ends, atomic on GPUs), one forced, or sorted: particles grouped by
// tile of cells (by cell on GPUs) and tiles processed in colours that share no node, without
// atomics or copies, and bitwise reproducible on any thread count.
enum class P2GStrategy { automatic, duplicated, atomic, sorted };
// Particle-grid weights on the Q1 grid: the paper's bilinear MPM, contiguous-particle GIMP
// (the default: it converges under refinement where linear MPM does not; see README), or
// quadratic B-splines.
enum class ShapeFunction { linear, gimp, bspline };

struct GasState {
  real_t density = 0;
  real_t pressure = 0;
  real_t velocity_x = 0;
  real_t velocity_y = 0;
};

struct Region {  // an axis-aligned box of the initial state; later regions override earlier ones
  real_t x_min = 0, x_max = 0, y_min = 0, y_max = 0;
  GasState state;
};

struct DomainConfig {
  real_t x_min = 0, x_max = 1, y_min = 0, y_max = 1;
  int cells_x = 1, cells_y = 1;
};

struct PhysicsConfig {
  real_t gamma = 1.4;
  // Artificial viscosity q = rho h (c0 h (div v)^2 - c1 c div v) for div v < 0.
  real_t viscosity_quadratic = 1;  // c0, von Neumann-Richtmyer
  real_t viscosity_linear = 1;     // c1, Landshoff
};

// In double whatever real_t is, as the run's clock is (Simulation): in a single-precision build the
// outputs then land at the times the case asks for, not at float(end) k / snapshots.
struct TimeConfig {
  double end_time = 0;
  double cfl = 0.5;
  long max_steps = 0;  // 0: no limit
};

struct BoundaryConfig {
  BoundaryType left = BoundaryType::slip_wall;
  BoundaryType right = BoundaryType::slip_wall;
  BoundaryType bottom = BoundaryType::slip_wall;
  BoundaryType top = BoundaryType::slip_wall;
  ParticleSupply particle_supply = ParticleSupply::open;
  // The state imposed at inflow sides, given to the particles entering, and whose pressure acts on
  // outflow and far-field sides. Required when a side is open.
  bool has_free_stream = false;
  GasState free_stream;

  // The type of every side, in the order of grid.hpp's Side (left, right, bottom, top).
  std::array<BoundaryType, 4> side_types() const { return {left, right, bottom, top}; }
  bool any(BoundaryType type) const {
    const auto types = side_types();
    return std::find(types.begin(), types.end(), type) != types.end();
  }
  bool any_open() const {
    return any(BoundaryType::inflow) || any(BoundaryType::outflow) || any(BoundaryType::far_field);
  }
};

// A solid obstacle, resolved at load time into the shape the signed distance function uses: a
// circle, or a closed polygon (a rectangle is one; a points file is read, transformed and checked).
struct ObstacleConfig {
  ObstacleShape shape = ObstacleShape::circle;
  std::string description;  // "/obstacles/0 (circle)", for messages
  real_t centre_x = 0, centre_y = 0, radius = 0;    // circle
  std::vector<real_t> vertices_x, vertices_y;      // polygon and rectangle, without a repeated closing point
  // Of each edge v (from vertex v to vertex v + 1, the last back to the first): the side of the
  // domain it lies on (grid.hpp's Side: the step's floor and end), where it is not a surface the
  // gas meets; -1 for a surface. Empty: every edge is a surface.
  std::vector<int> edge_side;
  // The length drag and lift coefficients are taken on; 0: the obstacle's default (see
  // obstacle_reference_length).
  real_t reference_length = 0;
};

// The length an obstacle's drag and lift coefficients are taken on, with the free stream along
// the unit vector (flow_x, flow_y): `reference_length` when the case gives one; else a circle's
// diameter, a rectangle's extent across the flow (a bluff body's frontal height), a polygon's
// extent along the flow (an aerofoil's chord).
double obstacle_reference_length(const ObstacleConfig& obstacle, double flow_x, double flow_y);

struct ParticleConfig {
  ParticlePlacement placement = ParticlePlacement::regular;
  int per_cell_x = 2;
  int per_cell_y = 2;
  // Every random number of a run (random placement, particles entering at open sides, recycling)
  // is a function of this seed and of what it places (a particle's id and the step, or a side,
  // its column and row of entering particles): runs repeat exactly, on any number of threads or ranks.
  unsigned long seed = 0;
};

struct InitialStateConfig {
  GasState background;
  std::vector<Region> regions;
};

struct OutputConfig {
  std::string directory;  // default: output/<case name>
  int snapshots = 10;     // outputs equidistant in time, the final state included; 0: none
  // A checkpoint every this many steps and at the end; 0: none.
  long checkpoint_interval = 0;
  int checkpoints_kept = 2;  // the newest this many checkpoint files are kept; 0: all
  PhaseTiming phase_timers = PhaseTiming::fenced;
};

// How a distributed run splits the grid: slabs along one axis, one per MPI rank.
struct DecompositionConfig {
  int axis = 0;              // 0: slabs along x (cuts at x = const), 1: along y
  int balance_interval = 0;  // rebalance the slabs every this many steps; 0: never
};

struct NumericsConfig {
  // Reorder particles by cell every N steps; 0: never. Particles never reordered drift out of cell
  // order, and the transfer kernels then reach their nodes all over: the cylinder at 448 x 224
  // cells ran 14-25 % slower never reordered than reordered every 20 steps
  // (docs/performance_history.md), the sort costing about one P2G every 20 steps.
  int reorder_interval = 20;
  P2GStrategy p2g = P2GStrategy::automatic;
  ShapeFunction shape_function = ShapeFunction::gimp;
  // G2P of velocity and acceleration fused with the momentum remap P2G (steps 6-8): one stencil
  // and one pass over the particles instead of two. false runs the two generic kernels.
  bool fused_kernels = true;
  // The particles' internal energy gains the work the grid forces do over the step: p dV with the
  // mean of the grid velocity before and after the step's update, and the same (P + Q) and volume
  // the forces were made of, so that kinetic + internal energy is conserved to round-off in a
  // closed box. false: the paper's update, p dV with the remapped end-of-step velocity and the new Q.
  bool energy_consistent = true;
  // The particles of a cell share one volume change (the volume-weighted mean velocity divergence
  // of the cell) and the force one stress (the cell's mean P + Q): cell-averaged volumetric strain,
  // as "F-bar" methods use against volumetric locking. Measured (README, Numerics): with the
  // default pressure relaxation and volume correction it adds nothing to a free stream's quiet and
  // smears Toro's near-vacuum; the volume correction does not act with it.
  bool cell_averaged_strain = false;
  // The particles of each cell go towards one pressure at the acoustic rate dt c / h per step,
  // keeping the cell's volume and internal energy (pressure_relaxation_fraction, gas_physics.hpp):
  // pressure differences within a cell are below what the grid resolves, the gas would even them
  // out, MPM's forces cannot. Cells holding a shock, a contact or a near-vacuum are left alone.
  // Measured (README, Numerics): a free Mach 3 stream of random particles scatters 3-4 % instead
  // of 12-17 %; Sod and Toro's test 2 come closer to the exact solutions.
  bool pressure_relaxation = true;
  // Each particle's density is corrected towards the volume fraction of its nodes (the particles'
  // volumes over the space they share, volume_corrected_density, gas_physics.hpp) at the acoustic
  // rate, less where the particle's pressure is already beyond its nodes' mean: scattered particles' volumes do not tile the space, their pressure forces do work that
  // makes the volumes grow (a free stream's particles held 1.5 % more volume than their space
  // after 3 tunnel lengths, a subsonic far-field tunnel 13 % with its pressure 15 % low). Not near
  // obstacles nor far-field sides (ObstacleGrid::node_gas_volume).
  bool volume_correction = true;
  // A particle whose volume has doubled splits in two (particle_splitting.hpp), so that no gap
  // opens in the gas where it expands strongly (Toro's test 2: 25 cells wide without at 100 cells).
  // On by default since the volume correction expands the particles squeezed against a body's
  // front, which splitting used to multiply (README, Numerics).
  bool split_particles = true;
  // Two tiny particles of a cell (split particles compressed again to under a quarter of a placed
  // particle's volume) merge into one (particle_merging.hpp). On by default: it acts only on split
  // particles, and with splitting it cuts the Mach 3 cylinder's steps from 12160 to 4210 (200 x 100,
  // with the particles' time step of then).
  bool merge_particles = true;
};

struct CaseConfig {
  std::string source;    // the file it came from, for messages
  std::string document;  // its JSON text, after --set (effective_case_json starts from it)
  std::string name;
  std::string description;
  DomainConfig domain;
  PhysicsConfig physics;
  TimeConfig time;
  BoundaryConfig boundaries;
  std::vector<ObstacleConfig> obstacles;
  ParticleConfig particles;
  InitialStateConfig initial_state;
  OutputConfig output;
  NumericsConfig numerics;
  DecompositionConfig decomposition;
};

// The points files (obstacle outlines) a case reads, by path, so that one MPI rank can read them
// and hand them to the others with the case text.
struct PointsFiles {
  std::map<std::string, std::vector<std::pair<double, double>>> files;
  std::string serialise() const;
  static PointsFiles deserialise(const std::string& text);
};

// Reads and validates `path`, after applying `overrides` of the form "json/path=value" (value
// parsed as JSON, or taken as a string when it is not valid JSON).
CaseConfig load_case_file(const std::string& path, const std::vector<std::string>& overrides = {});

// The case file's JSON text with the overrides applied (not validated yet).
std::string load_case_document(const std::string& path, const std::vector<std::string>& overrides = {});
// A case document's text (from `source`, for messages) with the overrides applied.
std::string apply_overrides(const std::string& json_text, const std::string& source,
                            const std::vector<std::string>& overrides);

// Validates a case document; `source` names it in error messages (and points files resolve
// against its directory). Points files come from `points_files` when it holds them; those read
// from disk are added to it.
CaseConfig parse_case(const std::string& json_text, const std::string& source, PointsFiles* points_files = nullptr);

// Every key path the parser reads ("/domain/cells_x", "/obstacles/*/radius": array elements as
// "*"), objects included: the parser's own table of keys, against which the JSON Schema of case
// files (cases/mpmflow_case.schema.json) is checked.
std::set<std::string> case_file_keys();

// The case as it runs: its document (after --set) with every key the parser reads and the case
// leaves out set to the default it took, in canonical order (2-space indented JSON). Parsing the
// result gives the same case. Obstacles and initial regions are as the document gives them.
std::string effective_case_json(const CaseConfig& config);

// Whether a case file's number fits the build's reals without becoming infinite: in a
// single-precision build a float holds at most 3.4e38, and a pressure of 1e300 was read as
// infinity, the run stopping only after its first step at a particle with an infinite pressure.
// (Any JSON number fits a double.) The case loader refuses the number, naming its key.
template <class Real>
bool fits_in(double value) {
  return std::fabs(value) <= static_cast<double>(std::numeric_limits<Real>::max());
}

// A configured number as a case file writes it: the shortest decimal that reads back as `value`
// in its own type, so that a single-precision build's effective case (and a restart's refusal
// quoting it) says 1.4 where the case said 1.4, not 1.399999976158142, float's nearest value to
// 1.4 widened to double. The value itself for double.
template <class Real>
double as_written(Real value) {
  if constexpr (std::is_same<Real, double>::value) {
    return value;
  } else {
    // (to_chars and from_chars, not printf and strtod: they ignore the locale's decimal point.)
    char text[64];
    const std::to_chars_result written = std::to_chars(text, text + sizeof(text), value);
    double read = 0;
    std::from_chars(text, written.ptr, read);
    return read;
  }
}

// The keys a restart may change: the end time, the output schedule and folder, the step limit,
// how phases are timed, the description. (Everything else of a checkpoint's case must stay as it was.)
bool may_change_on_restart(const std::string& key_path);

// The first difference between two effective cases (effective_case_json texts) at a key that may
// not change on a restart: "/physics/gamma: 1.4 in the checkpoint, 1.67 now"; empty when none.
std::string restart_incompatibility(const std::string& checkpoint_case, const std::string& current_case);

// ---- The names of enum values in case files and messages: one table per enum, which the parser
// reads and to_string prints.

template <class Enum>
struct EnumName {
  const char* name;
  Enum value;
};

template <class Enum>
struct EnumNames;  // specialised for each enum of a case file: static constexpr EnumName<Enum> table[]

template <>
struct EnumNames<BoundaryType> {
  static constexpr EnumName<BoundaryType> table[] = {
      {"slip_wall", BoundaryType::slip_wall},
      {"inflow", BoundaryType::inflow},
      {"outflow", BoundaryType::outflow},
      {"far_field", BoundaryType::far_field}};
};
template <>
struct EnumNames<ParticleSupply> {
  static constexpr EnumName<ParticleSupply> table[] = {{"open", ParticleSupply::open},
                                                       {"recycle", ParticleSupply::recycle}};
};
template <>
struct EnumNames<ParticlePlacement> {
  static constexpr EnumName<ParticlePlacement> table[] = {{"regular", ParticlePlacement::regular},
                                                          {"random", ParticlePlacement::random}};
};
template <>
struct EnumNames<ObstacleShape> {
  static constexpr EnumName<ObstacleShape> table[] = {
      {"circle", ObstacleShape::circle}, {"rectangle", ObstacleShape::rectangle}, {"polygon", ObstacleShape::polygon}};
};
template <>
struct EnumNames<P2GStrategy> {
  static constexpr EnumName<P2GStrategy> table[] = {{"automatic", P2GStrategy::automatic},
                                                    {"duplicated", P2GStrategy::duplicated},
                                                    {"atomic", P2GStrategy::atomic},
                                                    {"sorted", P2GStrategy::sorted}};
};
template <>
struct EnumNames<PhaseTiming> {
  static constexpr EnumName<PhaseTiming> table[] = {{"fenced", PhaseTiming::fenced},
                                                    {"unfenced", PhaseTiming::unfenced}};
};
template <>
struct EnumNames<ShapeFunction> {
  static constexpr EnumName<ShapeFunction> table[] = {{"linear", ShapeFunction::linear}, {"gimp", ShapeFunction::gimp}, {"bspline", ShapeFunction::bspline}};
};

// The case-file name of an enum value.
template <class Enum, class = decltype(EnumNames<Enum>::table)>
const char* to_string(Enum value) {
  for (const EnumName<Enum>& entry : EnumNames<Enum>::table)
    if (entry.value == value) return entry.name;
  return "?";
}

}  // namespace mpmflow
