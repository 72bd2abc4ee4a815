#pragma once
// Boundary conditions on grid nodal vectors (Algorithm 1, steps 4 and 9) and on particles after
// their move: the wind tunnel's sides and the obstacles.
#include <cstdint>

#include "case_config.hpp"
#include "counter_random.hpp"
#include "geometry.hpp"
#include "grid.hpp"
#include "particles.hpp"

namespace mpmflow {

// On the grid, per side (the side's node line and the ghost lines beyond it, which GIMP stencils
// reach):
// - inflow: the node velocity is the free stream, momentum = node mass x v_inf, no force;
// - outflow: nothing imposed on the velocity; the free-stream pressure acts on the side as a
//   traction, f_i -= p_inf n \int_side N_i ds, the pressure of the gas outside that the particles
//   inside do not see (a free stream at rest is then in equilibrium);
// - slip wall: the wall-normal component is removed.
// Then, on nodes inside an obstacle, the inward normal component is removed (eqs. 21-22).
class GridBoundaryConditions {
 public:
  GridBoundaryConditions() = default;
  GridBoundaryConditions(const CaseConfig& config, const GridSlab& slab, const ObstacleGrid& obstacles);

  // Step 4: momentum and force columns of `state` (the node mass is its mass column).
  void apply_to_momentum_and_force(const NodeFieldsView& state) const;
  // Step 9: the remapped momentum in columns column_x, column_x + 1 of `momentum`.
  void apply_to_momentum(const NodeFieldsView& momentum, int column_x, const NodeFieldsView& state) const;

 private:
  GridSlab slab_;
  BoundaryType side_type_[num_sides] = {};
  GasState free_stream_;
  ObstacleGrid obstacles_;
};

// After the move (Algorithm 1, step 11): a particle that crossed a slip wall is mirrored back and
// loses its outward normal velocity; one that left through an inflow or outflow side is recycled
// (below); one that entered an obstacle is put back on its surface, along the normal, and loses
// its inward normal velocity. No particle is ever outside the domain or inside an obstacle.
//
// Recycling: the particle re-enters at a random point of a random inflow cell, in the strip next
// to the side that the free stream swept clean during this step (depth |v_inf . n| dt, at most one
// cell), with the free-stream state and the free-stream particle mass; so the particle count never
// changes and, in a steady free stream, the inflow cells keep their particle density. Its random
// numbers depend on the seed, its id and the step only.
struct ParticleBoundaries {
  real_t x_min = 0, x_max = 0, y_min = 0, y_max = 0;
  BoundaryType side_type[num_sides] = {};
  GridGeometry grid;
  DeviceObstacleSet obstacles;
  IndexView cell_near_obstacle;
  bool has_obstacles = false;
  real_t surface_offset = 0;  // how far outside the surface a particle is put back

  // Recycling.
  int num_inflow_sides = 0;
  int inflow_side[num_sides] = {};
  real_t inflow_length_end[num_sides] = {};  // cumulative side lengths
  real_t strip_depth[num_sides] = {};
  GasState free_stream;
  real_t free_stream_specific_energy = 0;
  real_t free_stream_particle_mass = 0;
  std::uint64_t seed = 0;
  std::uint64_t step = 0;

  ParticleBoundaries() = default;
  ParticleBoundaries(const CaseConfig& config, const GridSlab& slab, const ObstacleGrid& obstacle_grid);

  // The strips and the random stream of the step about to move the particles by dt.
  void prepare_step(real_t dt, long step_index);

  // Moves particle p by dt V-bar and applies the rules above.
  KOKKOS_INLINE_FUNCTION void move(index_t p, real_t dt, const ParticleState& pt) const;

 private:
  KOKKOS_INLINE_FUNCTION void recycle(index_t p, const ParticleState& pt, real_t& x, real_t& y) const;
  KOKKOS_INLINE_FUNCTION bool in_obstacle(real_t x, real_t y) const {
    return has_obstacles && obstacles(x, y).distance < 0;
  }
};

// Algorithm 1, step 11: every particle moved by dt V-bar, with the rules above, for the step
// numbered `step` (the random stream of recycling).
void move_particles(const ParticleBoundaries& boundaries, const ParticleState& particles, real_t dt, long step);

// ---- inline definitions --------------------------------------------------------------------------

KOKKOS_INLINE_FUNCTION void ParticleBoundaries::move(index_t p, real_t dt, const ParticleState& pt) const {
  real_t x = pt.position_x(p) + dt * pt.grid_velocity_x(p);
  real_t y = pt.position_y(p) + dt * pt.grid_velocity_y(p);
  // Slip walls: mirror, and keep no velocity out of the domain.
  if (x < x_min && side_type[left_side] == BoundaryType::slip_wall) {
    x = 2 * x_min - x;
    if (pt.velocity_x(p) < 0) pt.velocity_x(p) = 0;
  }
  if (x > x_max && side_type[right_side] == BoundaryType::slip_wall) {
    x = 2 * x_max - x;
    if (pt.velocity_x(p) > 0) pt.velocity_x(p) = 0;
  }
  if (y < y_min && side_type[bottom_side] == BoundaryType::slip_wall) {
    y = 2 * y_min - y;
    if (pt.velocity_y(p) < 0) pt.velocity_y(p) = 0;
  }
  if (y > y_max && side_type[top_side] == BoundaryType::slip_wall) {
    y = 2 * y_max - y;
    if (pt.velocity_y(p) > 0) pt.velocity_y(p) = 0;
  }
  // Open sides: whatever is still outside left through an inflow or outflow side.
  if (x < x_min || x > x_max || y < y_min || y > y_max) recycle(p, pt, x, y);
  if (has_obstacles && cell_near_obstacle(grid.cell_of(x, y, /*include_ghosts=*/true))) {
    const SignedDistance sd = obstacles(x, y);
    if (sd.distance < 0) {
      x += (surface_offset - sd.distance) * sd.normal_x;
      y += (surface_offset - sd.distance) * sd.normal_y;
      const real_t vn = pt.velocity_x(p) * sd.normal_x + pt.velocity_y(p) * sd.normal_y;
      if (vn < 0) {
        pt.velocity_x(p) -= vn * sd.normal_x;
        pt.velocity_y(p) -= vn * sd.normal_y;
      }
    }
  }
  // Round-off must not leave a particle a hair outside (an obstacle touching a side, a mirror).
  pt.position_x(p) = x < x_min ? x_min : (x > x_max ? x_max : x);
  pt.position_y(p) = y < y_min ? y_min : (y > y_max ? y_max : y);
}

KOKKOS_INLINE_FUNCTION void ParticleBoundaries::recycle(index_t p, const ParticleState& pt, real_t& x,
                                                        real_t& y) const {
  const std::uint64_t id = static_cast<std::uint64_t>(pt.id(p));
  constexpr int max_attempts = 16;  // a point inside an obstacle touching the inflow side is drawn again
  for (int attempt = 0; attempt < max_attempts; ++attempt) {
    const real_t along = static_cast<real_t>(counter_uniform(seed, id, step, 2 * attempt)) *
                         inflow_length_end[num_inflow_sides - 1];
    const real_t depth_fraction = static_cast<real_t>(counter_uniform(seed, id, step, 2 * attempt + 1));
    int k = 0;
    while (k < num_inflow_sides - 1 && along >= inflow_length_end[k]) ++k;
    const real_t t = along - (k > 0 ? inflow_length_end[k - 1] : real_t(0));
    const real_t depth = depth_fraction * strip_depth[k];
    switch (inflow_side[k]) {
      case left_side: x = x_min + depth; y = y_min + t; break;
      case right_side: x = x_max - depth; y = y_min + t; break;
      case bottom_side: x = x_min + t; y = y_min + depth; break;
      default: x = x_min + t; y = y_max - depth; break;
    }
    if (!in_obstacle(x, y)) break;
  }
  pt.velocity_x(p) = free_stream.velocity_x;
  pt.velocity_y(p) = free_stream.velocity_y;
  pt.grid_velocity_x(p) = free_stream.velocity_x;
  pt.grid_velocity_y(p) = free_stream.velocity_y;
  pt.density(p) = free_stream.density;
  pt.pressure(p) = free_stream.pressure;
  pt.specific_energy(p) = free_stream_specific_energy;
  pt.mass(p) = free_stream_particle_mass;
  pt.artificial_viscosity(p) = 0;
  pt.domain_stretch_x(p) = 1;
  pt.domain_stretch_y(p) = 1;
}

}  // namespace mpmflow
