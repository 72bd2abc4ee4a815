#include "boundary_conditions.hpp"

#include <algorithm>
#include <cmath>

#include "gas_physics.hpp"

namespace mpmflow {
namespace {

// Calls f(node, i, j) for the nodes (i, j) of a rectangle of local node indices, one thread each.
template <class F>
void for_nodes(const char* label, const GridGeometry& geo, const IndexRange2D& nodes, const F& f) {
  if (nodes.empty()) return;
  const index_t width = nodes.extent_x();
  const index_t i0 = nodes.begin_x, j0 = nodes.begin_y;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, nodes.size()), KOKKOS_LAMBDA(const index_t k) {
        const index_t i = i0 + k % width, j = j0 + k / width;
        f(geo.node_index(i, j), i, j);
      });
}

// The nodes of `line` that are nodes of the domain (not the ghost nodes beyond its corners).
IndexRange2D within_domain(const GridSlab& slab, const IndexRange2D& line) {
  const IndexRange2D domain = slab.domain_node_space();
  return {std::max(line.begin_x, domain.begin_x), std::min(line.end_x, domain.end_x),
          std::max(line.begin_y, domain.begin_y), std::min(line.end_y, domain.end_y)};
}

// (Free functions rather than private members: CUDA forbids device lambdas in private members.)
void apply_open_sides(const GridSlab& slab, const std::array<BoundaryType, num_sides>& side_type,
                      const GasState& free_stream, const NodeFieldsView& momentum, int column_x,
                      const NodeFieldsView& state, bool with_force) {
  const GridGeometry& geo = slab.geometry;
  const real_t vx = free_stream.velocity_x, vy = free_stream.velocity_y;
  for (int s = 0; s < num_sides; ++s) {
    const Side side = static_cast<Side>(s);
    if (side_type[s] == BoundaryType::inflow) {
      for (int layer = 0; layer <= GridSlab::ghost_layers; ++layer)
        for_nodes("inflow_nodes", geo, slab.boundary_node_line(side, layer),
                  KOKKOS_LAMBDA(const index_t node, index_t, index_t) {
                    const real_t m = state(node, GridFields::mass);
                    momentum(node, column_x) = m * vx;
                    momentum(node, column_x + 1) = m * vy;
                    if (with_force) {
                      state(node, GridFields::force_x) = 0;
                      state(node, GridFields::force_y) = 0;
                    }
                  });
    } else if ((side_type[s] == BoundaryType::outflow || side_type[s] == BoundaryType::far_field) && with_force) {
      // Traction of the free-stream pressure: -p_inf n times the integral of N_i along the side,
      // one node spacing per node and half of one at the side's ends.
      const IndexRange2D line = within_domain(slab, slab.boundary_node_line(side, 0));
      const bool column = side == left_side || side == right_side;  // the side is a node column
      const real_t spacing = column ? geo.spacing_y : geo.spacing_x;
      // Local indices along the side of its first and last node (global nodes 0 and cells).
      const index_t first = column ? slab.local_node_y(0) : slab.local_node_x(0);
      const index_t last = column ? slab.local_node_y(slab.global_cells_y) : slab.local_node_x(slab.global_cells_x);
      const real_t outward = (side == left_side || side == bottom_side) ? real_t(-1) : real_t(1);
      const real_t push = -free_stream.pressure * outward;
      // A node on the side holds free_stream density x length x half a cell of mass when the gas
      // beside it is the free stream. Where particles have thinned out (gas leaving along a side
      // parallel to the flow), the node gets the traction in proportion to the mass it holds, so
      // the acceleration the traction causes never exceeds that of a full node; applied whole to
      // a nearly empty node it would throw the few particles there into the domain.
      const real_t normal_spacing = column ? geo.spacing_x : geo.spacing_y;
      const real_t full_mass_per_length = free_stream.density * normal_spacing / 2;
      for_nodes("outflow_pressure", geo, line, KOKKOS_LAMBDA(const index_t node, const index_t i, const index_t j) {
        const index_t k = column ? j : i;
        const real_t length = (k == first || k == last) ? spacing / 2 : spacing;
        const real_t full_mass = full_mass_per_length * length;
        const real_t mass = state(node, GridFields::mass);
        const real_t share = mass < full_mass ? mass / full_mass : real_t(1);
        state(node, column ? GridFields::force_x : GridFields::force_y) += push * length * share;
      });
    }
  }
}

void apply_slip_walls(const GridSlab& slab, const std::array<BoundaryType, num_sides>& side_type,
                      const NodeFieldsView& fields, int column_x) {
  const GridGeometry& geo = slab.geometry;
  for (int s = 0; s < num_sides; ++s) {
    if (side_type[s] != BoundaryType::slip_wall) continue;
    const int normal_column = column_x + (s == left_side || s == right_side ? 0 : 1);
    for (int layer = 0; layer <= GridSlab::ghost_layers; ++layer)
      for_nodes("slip_wall", geo, slab.boundary_node_line(static_cast<Side>(s), layer),
                KOKKOS_LAMBDA(const index_t node, index_t, index_t) { fields(node, normal_column) = 0; });
  }
}

void remove_inward_component(const ObstacleGrid& obstacles, const NodeFieldsView& fields, int column_x) {
  const index_t count = obstacles.num_obstacle_nodes();
  if (count == 0) return;
  const IndexView nodes = obstacles.obstacle_nodes;
  const NodeFieldsView normals = obstacles.obstacle_normals;
  Kokkos::parallel_for(
      "obstacle_nodes", Kokkos::RangePolicy<ExecutionSpace>(0, count), KOKKOS_LAMBDA(const index_t k) {
        const index_t node = nodes(k);
        const real_t nx = normals(k, 0), ny = normals(k, 1);
        // (a.n - |a.n|) / 2 is a.n where it points into the obstacle, 0 otherwise (eqs. 21-22).
        const real_t a_n = fields(node, column_x) * nx + fields(node, column_x + 1) * ny;
        const real_t inward = (a_n - (a_n < 0 ? -a_n : a_n)) / 2;
        fields(node, column_x) -= inward * nx;
        fields(node, column_x + 1) -= inward * ny;
      });
}

}  // namespace

GridBoundaryConditions::GridBoundaryConditions(const CaseConfig& config, const GridSlab& slab,
                                               const ObstacleGrid& obstacles)
    : slab_(slab),
      side_type_(config.boundaries.side_types()),
      free_stream_(config.boundaries.free_stream),
      obstacles_(obstacles) {}

void GridBoundaryConditions::apply_to_momentum_and_force(const NodeFieldsView& state) const {
  apply_open_sides(slab_, side_type_, free_stream_, state, GridFields::momentum_x, state, /*with_force=*/true);
  apply_slip_walls(slab_, side_type_, state, GridFields::momentum_x);
  apply_slip_walls(slab_, side_type_, state, GridFields::force_x);
  remove_inward_component(obstacles_, state, GridFields::momentum_x);
  remove_inward_component(obstacles_, state, GridFields::force_x);
}

void GridBoundaryConditions::apply_to_momentum(const NodeFieldsView& momentum, int column_x,
                                               const NodeFieldsView& state) const {
  apply_open_sides(slab_, side_type_, free_stream_, momentum, column_x, state, /*with_force=*/false);
  apply_slip_walls(slab_, side_type_, momentum, column_x);
  remove_inward_component(obstacles_, momentum, column_x);
}

ParticleBoundaries::ParticleBoundaries(const CaseConfig& config, const GridSlab& slab,
                                       const ObstacleGrid& obstacle_grid)
    : domain(slab),
      grid(slab.geometry),
      obstacles(obstacle_grid.obstacles),
      cell_near_obstacle(obstacle_grid.cell_near_obstacle),
      has_obstacles(!obstacle_grid.obstacles.empty()),
      surface_offset(real_t(1e-6) * slab.cell_size()) {
  const auto types = config.boundaries.side_types();
  std::copy(types.begin(), types.end(), side_type);
}

void move_particles(const ParticleBoundaries& boundaries, const ParticleState& particles, real_t dt) {
  const ParticleBoundaries rules = boundaries;
  const ParticleState pt = particles;
  Kokkos::parallel_for(
      "particle_move", Kokkos::RangePolicy<ExecutionSpace>(0, pt.count),
      KOKKOS_LAMBDA(const index_t p) { rules.move(p, dt, pt); });
}

}  // namespace mpmflow
