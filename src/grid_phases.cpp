#include "grid_phases.hpp"

namespace mpmflow {
namespace {

// theta(a, m) = a / m on a node: 1 / m where the node carries mass, 0 on (nearly) empty nodes.
KOKKOS_INLINE_FUNCTION real_t per_unit_node_mass(real_t node_mass, real_t mass_threshold) {
  return node_mass > mass_threshold ? real_t(1) / node_mass : real_t(0);
}

}  // namespace

void reset_grid(const GridFields& fields) {
  Kokkos::deep_copy(fields.state, real_t(0));
  Kokkos::deep_copy(fields.momentum_remap, real_t(0));
}

void update_grid_momentum(const GridFields& fields, real_t dt, real_t mass_threshold) {
  const NodeFieldsView state = fields.state, per_unit_mass = fields.per_unit_mass;
  Kokkos::parallel_for(
      "grid_momentum_update", Kokkos::RangePolicy<ExecutionSpace>(0, static_cast<index_t>(state.extent(0))), KOKKOS_LAMBDA(const index_t i) {
        state(i, GridFields::momentum_x) += dt * state(i, GridFields::force_x);
        state(i, GridFields::momentum_y) += dt * state(i, GridFields::force_y);
        const real_t inv_m = per_unit_node_mass(state(i, GridFields::mass), mass_threshold);
        per_unit_mass(i, GridFields::velocity_x) = state(i, GridFields::momentum_x) * inv_m;
        per_unit_mass(i, GridFields::velocity_y) = state(i, GridFields::momentum_y) * inv_m;
        per_unit_mass(i, GridFields::acceleration_x) = state(i, GridFields::force_x) * inv_m;
        per_unit_mass(i, GridFields::acceleration_y) = state(i, GridFields::force_y) * inv_m;
      });
}

void compute_remap_velocity(const GridFields& fields, real_t mass_threshold) {
  const NodeFieldsView state = fields.state, remap = fields.momentum_remap, per_unit_mass = fields.per_unit_mass;
  Kokkos::parallel_for(
      "grid_remap_velocity", Kokkos::RangePolicy<ExecutionSpace>(0, static_cast<index_t>(state.extent(0))), KOKKOS_LAMBDA(const index_t i) {
        const real_t inv_m = per_unit_node_mass(state(i, GridFields::mass), mass_threshold);
        per_unit_mass(i, GridFields::remap_velocity_x) = remap(i, GridFields::remap_momentum_x) * inv_m;
        per_unit_mass(i, GridFields::remap_velocity_y) = remap(i, GridFields::remap_momentum_y) * inv_m;
      });
}

}  // namespace mpmflow
