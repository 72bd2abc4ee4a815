#include "particles.hpp"

#include "gas_physics.hpp"

namespace mpmflow {

ParticleState::ParticleState(index_t n)
    : count(n),
      position_x("particle_position_x", n),
      position_y("particle_position_y", n),
      velocity_x("particle_velocity_x", n),
      velocity_y("particle_velocity_y", n),
      grid_velocity_x("particle_grid_velocity_x", n),
      grid_velocity_y("particle_grid_velocity_y", n),
      mass("particle_mass", n),
      density("particle_density", n),
      specific_energy("particle_specific_energy", n),
      pressure("particle_pressure", n),
      artificial_viscosity("particle_artificial_viscosity", n),
      domain_stretch_x("particle_domain_stretch_x", n),
      domain_stretch_y("particle_domain_stretch_y", n),
      cell("particle_cell", n),
      id("particle_id", n) {}

GasState initial_state_at(const InitialStateConfig& initial, real_t x, real_t y) {
  GasState state = initial.background;
  for (const Region& region : initial.regions)
    if (x >= region.x_min && x < region.x_max && y >= region.y_min && y < region.y_max) state = region.state;
  return state;
}

ParticleState create_initial_particles(const CaseConfig& config, const GridSlab& slab) {
  const int ppx = config.particles.per_cell_x;
  const int ppy = config.particles.per_cell_y;
  const index_t per_cell = ppx * ppy;
  const index_t owned_cells_x = slab.owned_cell_end_x - slab.owned_cell_begin_x;
  const index_t owned_cells_y = slab.owned_cell_end_y - slab.owned_cell_begin_y;
  ParticleState particles(owned_cells_x * owned_cells_y * per_cell);

  // Built on the host once at start-up, then copied to the device.
  auto x = Kokkos::create_mirror_view(particles.position_x);
  auto y = Kokkos::create_mirror_view(particles.position_y);
  auto vx = Kokkos::create_mirror_view(particles.velocity_x);
  auto vy = Kokkos::create_mirror_view(particles.velocity_y);
  auto m = Kokkos::create_mirror_view(particles.mass);
  auto rho = Kokkos::create_mirror_view(particles.density);
  auto e = Kokkos::create_mirror_view(particles.specific_energy);
  auto p = Kokkos::create_mirror_view(particles.pressure);
  auto id = Kokkos::create_mirror_view(particles.id);

  const real_t hx = slab.geometry.spacing_x;
  const real_t hy = slab.geometry.spacing_y;
  const real_t particle_volume = slab.cell_area() / per_cell;
  const real_t gamma = config.physics.gamma;
  index_t k = 0;
  for (index_t cj = slab.owned_cell_begin_y; cj < slab.owned_cell_end_y; ++cj)
    for (index_t ci = slab.owned_cell_begin_x; ci < slab.owned_cell_end_x; ++ci)
      for (int b = 0; b < ppy; ++b)
        for (int a = 0; a < ppx; ++a, ++k) {
          // Regular placement: the centres of a ppx x ppy sub-grid of the cell.
          const real_t px = slab.domain_x_min + hx * (ci + (a + real_t(0.5)) / ppx);
          const real_t py = slab.domain_y_min + hy * (cj + (b + real_t(0.5)) / ppy);
          const GasState s = initial_state_at(config.initial_state, px, py);
          x(k) = px;
          y(k) = py;
          vx(k) = s.velocity_x;
          vy(k) = s.velocity_y;
          rho(k) = s.density;
          m(k) = s.density * particle_volume;
          p(k) = s.pressure;
          e(k) = perfect_gas_specific_energy(gamma, s.density, s.pressure);
          id(k) = (static_cast<particle_id_t>(cj) * slab.global_cells_x + ci) * per_cell + b * ppx + a;
        }

  Kokkos::deep_copy(particles.position_x, x);
  Kokkos::deep_copy(particles.position_y, y);
  Kokkos::deep_copy(particles.velocity_x, vx);
  Kokkos::deep_copy(particles.velocity_y, vy);
  Kokkos::deep_copy(particles.mass, m);
  Kokkos::deep_copy(particles.density, rho);
  Kokkos::deep_copy(particles.specific_energy, e);
  Kokkos::deep_copy(particles.pressure, p);
  Kokkos::deep_copy(particles.id, id);
  Kokkos::deep_copy(particles.domain_stretch_x, real_t(1));
  Kokkos::deep_copy(particles.domain_stretch_y, real_t(1));
  Kokkos::deep_copy(particles.grid_velocity_x, particles.velocity_x);
  Kokkos::deep_copy(particles.grid_velocity_y, particles.velocity_y);
  update_cell_map(slab.geometry, particles);
  return particles;
}

void update_cell_map(const GridGeometry& geometry, const ParticleState& particles) {
  const auto x = particles.position_x;
  const auto y = particles.position_y;
  const auto cell = particles.cell;
  Kokkos::parallel_for(
      "update_cell_map", Kokkos::RangePolicy<ExecutionSpace>(0, particles.count),
      KOKKOS_LAMBDA(const index_t p) { cell(p) = geometry.cell_of(x(p), y(p)); });
}

}  // namespace mpmflow
