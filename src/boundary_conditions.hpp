#pragma once
// Boundary conditions on grid nodal vectors (Algorithm 1, steps 4 and 9) and on particles after
// their move: the wind tunnel's sides and the obstacles.
#include <array>
#include <vector>

#include "case_config.hpp"
#include "geometry.hpp"
#include "grid.hpp"
#include "halo_exchange.hpp"
#include "parallel.hpp"
#include "particles.hpp"

namespace mpmflow {

// The component of the velocity (vx, vy) into a side: along its inward normal.
KOKKOS_INLINE_FUNCTION real_t inward_speed(int side, real_t vx, real_t vy) {
  real_t nx, ny;
  inward_normal(side, nx, ny);
  return vx * nx + vy * ny;
}
// Whether a side of (acting) type `type`, which the free stream enters at `free_stream_inward`, is a
// far-field inlet: there the gas outside acts on every node of its three lines, at the pressure
// of the Riemann invariants (SidePressure), and the open sides fill no strip along it
// (OpenBoundaries).
KOKKOS_INLINE_FUNCTION bool far_field_inlet(BoundaryType type, real_t free_stream_inward) {
  return type == BoundaryType::far_field && free_stream_inward > 0;
}

// The case's sides as they act: a far-field side that the free stream enters faster than sound is
// an inflow (everything there comes from outside, the velocity too; as a far field, which imposes
// a pressure alone, it left the stream's speed free to drift: a Mach 2 stream, 2.4, through
// far-field sides at 40 x 40 cells, random placement, 2.27 by t = 3). Every part of the step takes
// its sides from here.
BoundaryConfig acting_boundaries(const CaseConfig& config);

// The domain [x_min, x_max] x [y_min, y_max] as particle kernels see it.
struct DomainBox {
  real_t x_min = 0, x_max = 0, y_min = 0, y_max = 0;

  DomainBox() = default;
  explicit DomainBox(const GridSlab& slab)
      : x_min(slab.domain_x_min), x_max(slab.domain_x_max), y_min(slab.domain_y_min), y_max(slab.domain_y_max) {}

  // (| rather than ||: every comparison made, no branch, so that a loop of these tests can run as
  // vector lanes; ParticleBoundaries::leaves_alone.)
  KOKKOS_INLINE_FUNCTION bool outside(real_t x, real_t y) const {
    return (x < x_min) | (x > x_max) | (y < y_min) | (y > y_max);
  }
  // (x, y) moved onto the domain's closure: round-off must not leave a particle a hair outside.
  KOKKOS_INLINE_FUNCTION void clamp(real_t& x, real_t& y) const {
    x = x < x_min ? x_min : (x > x_max ? x_max : x);
    y = y < y_min ? y_min : (y > y_max ? y_max : y);
  }
  // The point `depth` inside `side` (grid.hpp's Side) and `along` it from its corner at x_min or
  // y_min, clamped to the domain.
  KOKKOS_INLINE_FUNCTION void point_inside_side(int side, real_t along, real_t depth, real_t& x, real_t& y) const {
    switch (side) {
      case left_side: x = x_min + depth; y = y_min + along; break;
      case right_side: x = x_max - depth; y = y_min + along; break;
      case bottom_side: x = x_min + along; y = y_min + depth; break;
      default: x = x_min + along; y = y_max - depth; break;
    }
    clamp(x, y);
  }
  // The inverse, unclamped: how deep (x, y) lies inside `side` (negative beyond it) and how far
  // along it from its corner at x_min or y_min.
  KOKKOS_INLINE_FUNCTION void depth_and_along_side(int side, real_t x, real_t y, real_t& depth, real_t& along) const {
    switch (side) {
      case left_side: depth = x - x_min; along = y - y_min; break;
      case right_side: depth = x_max - x; along = y - y_min; break;
      case bottom_side: depth = y - y_min; along = x - x_min; break;
      default: depth = y_max - y; along = x - x_min; break;
    }
  }
};

// On the grid, per side (the side's node line and the ghost lines beyond it, which GIMP stencils
// reach):
// - inflow: the node velocity is the free stream, momentum = node mass x v_inf, no force;
// - outflow and far field: nothing imposed on the velocity; the gas outside, which the particles
//   do not represent, acts at the free-stream state (its pressure on a far-field side the free
//   stream enters from the Riemann invariants of the free stream and the gas at the side:
//   far_field_boundary_pressure): its pressure p_out where the free stream crosses the side (gas
//   leaving through an outlet, entering through a far-field inlet) on what the particles leave
//   uncovered, f_i -= p_out g_i with g_i = sum_p (M / rho) grad phi_i on the side's line, the line
//   inside and the ghost line beyond (PressureSideNodes), elsewhere as a traction on the side,
//   f_i -= p_out n \int_side N_i ds (a free stream at rest is in equilibrium either way); its mass
//   as inertia of those nodes, whose acceleration is f / (m + m_outside);
// - slip wall: the wall-normal component is removed.
// Before them, on the nodes within reach of an obstacle, the body presses on the gas with the
// gas's pressure on what the particles leave uncovered (ObstaclePressureNodes; ObstaclePressure in
// boundary_conditions.cpp says why). After them, on nodes inside an obstacle, the normal component
// is removed (eqs. 21-22 remove only its inward part: boundary_conditions.cpp says why not).
// The force the gas exerts on each obstacle (case order) in one step, as the grid transmits it,
// summed over the nodes this slab owns.
struct ObstacleForces {
  std::vector<double> x, y;
};

// The sides' conditions of one call (GridBoundaryConditions), in one launch: at most one rectangle
// of local node indices a side (its node line and the ghost lines beyond; a pressure side's line
// less a corner an earlier pressure side holds), pressure sides first, then inflow sides, then slip
// walls, the order a node under two of them takes them in. Rectangle b holds the launch's indices
// first[b] to first[b + 1] - 1.
enum class SideCondition : int { pressure, inflow, slip_wall };
struct SideConditionBands {
  int count = 0;
  Kokkos::Array<IndexRange2D, num_sides> band = {};
  Kokkos::Array<index_t, num_sides + 1> first = {};
  Kokkos::Array<SideCondition, num_sides> condition = {};
  Kokkos::Array<int, num_sides> normal_axis = {};  // a slip wall's: 0 (left, right) or 1 (bottom, top)

  void add(const IndexRange2D& nodes, SideCondition c, int axis);
};

// Lengths as integers of `unit`, 2^-40 of a cell (a volume-gradient sum is at most a few cells'
// widths, far below 2^23 of them), so that sums of them are the same bits in any order: the
// pressure sides' and the obstacles' volume gradients (PressureSideNodes, ObstaclePressureNodes).
struct GradientUnits {
  real_t unit = 0, inverse_unit = 0;

  GradientUnits() = default;
  explicit GradientUnits(real_t cell_size) : unit(cell_size / real_t(1099511627776.0)), inverse_unit(1 / unit) {}

  // A length in units, rounded to the nearest.
  KOKKOS_INLINE_FUNCTION long long units(real_t length) const {
    const real_t scaled = length * inverse_unit;
    return static_cast<long long>(scaled >= 0 ? scaled + real_t(0.5) : scaled - real_t(0.5));
  }
};

// The nodes of the pressure sides (outflow, far field) on which the gas outside acts, and where
// the particles' volume gradients g_i = sum_p (M / rho) grad phi_i are summed for it (SidePressure,
// boundary_conditions.cpp): each such side's node line, the line inside it (the last particles
// fall up to a cell short of the side once their centres have crossed it) and the ghost lines
// beyond it, all along the side (the ghost nodes beyond its corners included); a node of two such
// sides is the first's (left, right, bottom, top). Every slab numbers them alike, by global node:
// entry(i, j) of local node (i, j) is the first of its two sums (x, y), or -1 where no pressure
// side holds it. The sums are integers (GradientUnits), so that they are the same bits whatever
// the order of the particles, the threads and the ranks that add them.
struct PressureSideNodes : GradientUnits {
  static constexpr int inner_layers = 1;  // node lines inside the side
  static constexpr int layers = inner_layers + 1 + GridSlab::ghost_layers;
  int count = 0;
  Kokkos::Array<int, num_sides> side = {};
  // Whether the free stream crosses the side: leaves through it (an outflow side, or a far-field
  // side it crosses outwards) or enters through it (a far-field side: an inlet).
  Kokkos::Array<bool, num_sides> crossed = {};
  bool any_crossed = false;
  // By Side: the far-field sides the free stream enters, whose gas outside acts at every node of
  // the three lines, at the pressure of the Riemann invariants (SidePressure).
  Kokkos::Array<bool, num_sides> inlet = {};
  // By Side: the outflow sides, whose gas outside acts at every node of the three lines at the
  // free-stream pressure.
  Kokkos::Array<bool, num_sides> outflow = {};
  Kokkos::Array<index_t, num_sides> first_entry = {};
  index_t entries = 0;
  index_t node_offset_x = 0, node_offset_y = 0, cells_x = 0, cells_y = 0;
  // By local node: entry(i, j) of the node (-1 everywhere where no side is a pressure side), made
  // once: the volume gradients' particles look each stencil node's entry up (entry_of) instead of
  // taking the node's (i, j) apart by a division and walking the sides (the cylinder's
  // boundary-conditions phase about 0.1 ms a step faster: docs/performance_history.md, "The volume
  // gradients' entries"), and the volume correction reads which nodes a side holds from it, where
  // the gas outside fills the space the particles leave (compute_volume_fraction). The sides'
  // lines are fixed for the run.
  Kokkos::View<int*, DeviceType> node_entry;

  PressureSideNodes() = default;
  PressureSideNodes(const GridSlab& slab, const std::array<BoundaryType, num_sides>& side_type,
                    const GasState& free_stream);

  KOKKOS_INLINE_FUNCTION static index_t nodes_along(index_t cells) { return cells + 1 + 2 * GridSlab::ghost_layers; }
  // The entry of local node `node` (as ObstaclePressureNodes::entry_of).
  KOKKOS_INLINE_FUNCTION index_t entry_of(index_t node) const { return node_entry(node); }
  KOKKOS_INLINE_FUNCTION index_t entry(index_t i, index_t j) const {
    int slot;
    return entry(i, j, slot);
  }
  // The same, with the side that holds the node (its place in side[]).
  KOKKOS_INLINE_FUNCTION index_t entry(index_t i, index_t j, int& slot) const {
    const index_t gi = i + node_offset_x, gj = j + node_offset_y;
    for (int k = 0; k < count; ++k) {
      const int s = side[k];
      const bool across_x = s == left_side || s == right_side;
      const index_t beyond =  // lines past the side (negative inside)
          s == left_side ? -gi : s == right_side ? gi - cells_x : s == bottom_side ? -gj : gj - cells_y;
      const index_t layer = inner_layers + beyond;
      const index_t along = (across_x ? gj : gi) + GridSlab::ghost_layers;
      const index_t along_count = nodes_along(across_x ? cells_y : cells_x);
      if (layer >= 0 && layer < layers && along >= 0 && along < along_count) {
        slot = k;
        return first_entry[k] + 2 * (layer * along_count + along);
      }
    }
    return -1;
  }
};

// The nodes where the obstacles press on the gas with its pressure (ObstacleGrid::body_nodes, less
// the nodes a pressure side holds, whose gauge stands for all the space its particles leave
// uncovered: PressureSideNodes). Node k: nodes(k), the obstacle nearest it (-1 where another slab
// owns the node), and entries 2 k, 2 k + 1 of the particles' volume gradients g = sum_p (M / rho)
// grad phi on it, integers like PressureSideNodes' (GradientUnits); entry(node) of a local node is
// 2 k, or -1.
struct ObstaclePressureNodes : GradientUnits {
  IndexView nodes, obstacle;
  Kokkos::View<int*, DeviceType> entry;  // by local node
  index_t count = 0;

  ObstaclePressureNodes() = default;
  ObstaclePressureNodes(const GridSlab& slab, const ObstacleGrid& obstacles, const PressureSideNodes& side_nodes);

  KOKKOS_INLINE_FUNCTION index_t entry_of(index_t node) const { return entry(node); }
};

// What step 4 sums from the particles for the gas outside the pressure sides and for the bodies:
// the volume gradients g_i = sum_p (M / rho) grad phi_i on the crossed pressure sides' nodes
// (PressureSideNodes; SidePressure reads them only there) and on the obstacles' pressure nodes
// (ObstaclePressureNodes), and by local cell which of the two a particle there may add to
// (reaches_side, reaches_obstacle: a cell within widest_stencil_reach of such a node), so that one
// pass over the particles' cells (4 B a particle) selects those whose stencils are computed,
// instead of a pass over their positions for each (16 B a particle and a test). A particle of an
// unmarked cell adds nothing to either, and the sums are integers: the same sums, bit for bit, as
// from every particle (GridConditions.TheCellsMarkedForTheVolumeGradientsHoldEveryParticleThatAddsToThem).
struct BoundaryVolumeGradients {
  static constexpr unsigned char reaches_side = 1, reaches_obstacle = 2;
  PressureSideNodes side_nodes;
  Kokkos::View<long long*, DeviceType> side_gradients;  // (no cell is marked for them where no side is crossed)
  ObstaclePressureNodes obstacle_nodes;
  Kokkos::View<long long*, DeviceType> obstacle_gradients;
  Kokkos::View<const unsigned char*, DeviceType> cell_reach;  // by local cell
};

class GridBoundaryConditions {
 public:
  GridBoundaryConditions() = default;
  GridBoundaryConditions(const CaseConfig& config, const GridSlab& slab, const ObstacleGrid& obstacles);

  // Step 4: momentum and force columns of `state` (the node mass is its mass column); with
  // `forces`, the force on each obstacle that the step transmits.
  void apply_to_momentum_and_force(const NodeFieldsView& state, ObstacleForces* forces = nullptr) const;
  // Step 9: the remapped momentum in columns column_x, column_x + 1 of `momentum`.
  void apply_to_momentum(const NodeFieldsView& momentum, int column_x, const NodeFieldsView& state) const;
  // The nodes of `within` (local node indices) whose momentum, force or remapped momentum the two
  // may change, in increasing order: the side lines they visit and the obstacles' nodes. (The
  // energy budget's work of the conditions is a sum over these alone: boundary_work.)
  IndexView conditioned_nodes(const IndexRange2D& within) const;

  // The pressure sides' nodes and their volume gradients, which step 4 needs: cleared, filled by
  // TransferKernels::add_pressure_side_volume_gradients from this slab's particles, summed over the
  // ranks (sum_pressure_side_gradients), then read by apply_to_momentum_and_force.
  const PressureSideNodes& pressure_side_nodes() const { return pressure_side_nodes_; }
  const Kokkos::View<long long*, DeviceType>& pressure_side_gradients() const { return pressure_side_gradients_; }
  void clear_pressure_side_gradients() const;
  void sum_pressure_side_gradients(const ParallelContext& context) const;
  // The same for the obstacles' nodes (ObstaclePressureNodes), summed over the slabs that share a
  // node through `halo` (collective: every slab of a case with obstacles calls it), with two columns
  // of `scratch`, a node field step 5 overwrites, as buffer.
  bool has_obstacles() const { return obstacles_.num_obstacles > 0; }
  const ObstaclePressureNodes& obstacle_pressure_nodes() const { return obstacle_pressure_nodes_; }
  const Kokkos::View<long long*, DeviceType>& obstacle_pressure_gradients() const {
    return obstacle_pressure_gradients_;
  }
  void clear_obstacle_pressure_gradients() const;
  void sum_obstacle_pressure_gradients(const HaloExchange& halo, const NodeFieldsView& scratch) const;
  // Both, and the cells whose particles may add to them, for
  // TransferKernels::add_boundary_volume_gradients.
  BoundaryVolumeGradients volume_gradients() const {
    return {pressure_side_nodes_, pressure_side_gradients_, obstacle_pressure_nodes_, obstacle_pressure_gradients_,
            volume_gradient_cells_};
  }

 private:
  GridSlab slab_;
  std::array<BoundaryType, num_sides> side_type_ = {};
  GasState free_stream_;
  real_t gamma_ = 0;
  ObstacleGrid obstacles_;
  // The sides' rectangles for step 4 (with the pressure sides) and for step 9 (without).
  SideConditionBands bands_with_pressure_, bands_without_pressure_;
  PressureSideNodes pressure_side_nodes_;
  Kokkos::View<long long*, DeviceType> pressure_side_gradients_;
  Kokkos::View<long long*, DeviceType>::HostMirror pressure_side_gradients_host_;
  ObstaclePressureNodes obstacle_pressure_nodes_;
  Kokkos::View<long long*, DeviceType> obstacle_pressure_gradients_;
  Kokkos::View<const unsigned char*, DeviceType> volume_gradient_cells_;
};

// A particle's cell, which the next step's kernels start from: its local cell, or left_the_domain
// for one that left through an open side (OpenBoundaries::exchange removes or recycles it).
struct ParticleLocator {
  DomainBox domain;
  GridGeometry grid;
  real_t inverse_spacing_x = grid.inverse_spacing(0), inverse_spacing_y = grid.inverse_spacing(1);
  // The cell computed either way and then selected (cell_of clamps, so it is a cell outside the
  // domain too): a branch would keep a loop of these scalar (the pressure relaxation's).
  KOKKOS_INLINE_FUNCTION index_t operator()(real_t x, real_t y) const {
    const index_t cell = grid.cell_of(x, y, inverse_spacing_x, inverse_spacing_y);
    return domain.outside(x, y) ? index_t(left_the_domain) : cell;
  }
};

// After the move (Algorithm 1, step 11, X' = X + dt V-bar, made by the step-10 kernel): a particle
// that crossed a slip wall is mirrored back and loses its outward normal velocity; one that
// entered an obstacle is put back on its surface, along the normal, and loses its inward normal
// velocity. One that crossed an open side (inflow, outflow, far field) is left where it is, outside
// the domain: the open sides remove or recycle it (open_boundaries.hpp). No particle stays inside
// an obstacle.
struct ParticleBoundaries {
  DomainBox domain;
  BoundaryType side_type[num_sides] = {};  // a C array: device code reads it
  GridGeometry grid;
  DeviceObstacleSet obstacles;
  IndexView cell_near_obstacle;
  real_t near_x_min = 1, near_x_max = 0, near_y_min = 1, near_y_max = 0;  // ObstacleGrid's box
  bool has_obstacles = false;
  real_t surface_offset = 0;  // how far outside the surface a particle is put back

  ParticleBoundaries() = default;
  ParticleBoundaries(const CaseConfig& config, const GridSlab& slab, const ObstacleGrid& obstacle_grid);

  ParticleLocator locator() const { return {domain, grid}; }
  // Within the box of the cells an obstacle may reach into (ObstacleGrid): only there does a
  // particle look up its cell's flag (two divisions and a load).
  // (The box is empty, min above max, where no cell is near an obstacle, as without obstacles, so
  // no flag is tested; and & rather than &&, as in DomainBox::outside.)
  KOKKOS_INLINE_FUNCTION bool near_an_obstacle(real_t x, real_t y) const {
    return (x >= near_x_min) & (x <= near_x_max) & (y >= near_y_min) & (y <= near_y_max);
  }
  // Whether no rule applies to a particle at (x, y): within the domain and away from every
  // obstacle (the common case). Both tests make every comparison and test no flag: conditional
  // loads of the bounds, or a test of a flag, keep a loop of these tests scalar.
  KOKKOS_INLINE_FUNCTION bool leaves_alone(real_t x, real_t y) const {
    return !domain.outside(x, y) & !near_an_obstacle(x, y);
  }
  // Applies the rules above to moved particle p; where an obstacle takes its inward normal
  // velocity, returns true with the momentum it took (the particle's loss: the gas's impulse on the
  // obstacle) and the obstacle. `stopped` gets the kinetic energy the rules took from it.
  KOKKOS_INLINE_FUNCTION bool apply(index_t p, const ParticleState& pt, real_t& impulse_x, real_t& impulse_y,
                                    index_t& obstacle, double& stopped) const;
};

// Algorithm 1, step 11, after the particles have moved by dt V-bar: the rules above for every one.
// With `forces`, adds to each obstacle's force the momentum its surface took from the particles
// over dt (the inward normal velocity of those that entered it). Returns the kinetic energy the
// particles lost to slip walls and obstacles (the velocity these rules take). The cells are
// not updated: locate_particles, or a pass that already visits every particle after the rules
// (the pressure relaxation's: TransferKernels::relax_pressures_and_locate).
double apply_particle_rules(const ParticleBoundaries& boundaries, const ParticleState& particles, real_t dt,
                            ObstacleForces* forces = nullptr);
// Every particle's cell (ParticleLocator).
void locate_particles(const ParticleBoundaries& boundaries, const ParticleState& particles);
// Both.
double apply_particle_boundaries(const ParticleBoundaries& boundaries, const ParticleState& particles, real_t dt,
                                 ObstacleForces* forces = nullptr);

// ---- inline definitions --------------------------------------------------------------------------

KOKKOS_INLINE_FUNCTION bool ParticleBoundaries::apply(index_t p, const ParticleState& pt, real_t& impulse_x,
                                                      real_t& impulse_y, index_t& obstacle, double& stopped) const {
  // Most particles meet no rule: they read their position only, and write nothing.
  const real_t x_moved = pt.position_x(p), y_moved = pt.position_y(p);
  stopped = 0;
  // Within the domain and away from every obstacle: no rule applies (the common case, tested first).
  if (leaves_alone(x_moved, y_moved)) return false;
  real_t x = x_moved, y = y_moved;
  // The kinetic energy a rule takes, 0.5 M (the velocity component it removes)^2, summed here
  // (times M at the end): each removes a component orthogonal to what is left.
  real_t removed = 0;
  // Slip walls: mirror, and keep no velocity out of the domain.
  if (x < domain.x_min && side_type[left_side] == BoundaryType::slip_wall) {
    x = 2 * domain.x_min - x;
    const real_t vx = pt.velocity_x(p);
    if (vx < 0) removed += vx * vx, pt.velocity_x(p) = 0;
  }
  if (x > domain.x_max && side_type[right_side] == BoundaryType::slip_wall) {
    x = 2 * domain.x_max - x;
    const real_t vx = pt.velocity_x(p);
    if (vx > 0) removed += vx * vx, pt.velocity_x(p) = 0;
  }
  if (y < domain.y_min && side_type[bottom_side] == BoundaryType::slip_wall) {
    y = 2 * domain.y_min - y;
    const real_t vy = pt.velocity_y(p);
    if (vy < 0) removed += vy * vy, pt.velocity_y(p) = 0;
  }
  if (y > domain.y_max && side_type[top_side] == BoundaryType::slip_wall) {
    y = 2 * domain.y_max - y;
    const real_t vy = pt.velocity_y(p);
    if (vy > 0) removed += vy * vy, pt.velocity_y(p) = 0;
  }
  // Open sides: whatever is still outside has left the domain through one of them, and stays
  // where it went (no obstacle, no clamp).
  bool hit = false;
  if (!domain.outside(x, y)) {
    if (near_an_obstacle(x, y) && cell_near_obstacle(grid.cell_of(x, y, /*include_ghosts=*/true))) {
      const SignedDistance sd = obstacles(x, y);
      if (sd.distance < 0) {
        x += (surface_offset - sd.distance) * sd.normal_x;
        y += (surface_offset - sd.distance) * sd.normal_y;
        const real_t vn = pt.velocity_x(p) * sd.normal_x + pt.velocity_y(p) * sd.normal_y;
        if (vn < 0) {
          pt.velocity_x(p) -= vn * sd.normal_x;
          pt.velocity_y(p) -= vn * sd.normal_y;
          removed += vn * vn;
          impulse_x = pt.mass(p) * vn * sd.normal_x;  // into the obstacle
          impulse_y = pt.mass(p) * vn * sd.normal_y;
          obstacle = sd.obstacle;
          hit = true;
        }
      }
    }
    domain.clamp(x, y);  // an obstacle touching a side, a mirror
  }
  if (x != x_moved) pt.position_x(p) = x;
  if (y != y_moved) pt.position_y(p) = y;
  stopped = removed > 0 ? 0.5 * double(pt.mass(p)) * double(removed) : 0.0;
  return hit;
}

}  // namespace mpmflow
