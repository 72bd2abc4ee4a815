#include "grid_phases.hpp"

#include "gas_physics.hpp"
#include "kernels/index_lanes.hpp"

namespace mpmflow {
namespace {

// theta(a, m) = a / m on a node: 1 / m where the node carries mass, 0 on (nearly) empty nodes.
KOKKOS_INLINE_FUNCTION real_t per_unit_node_mass(real_t node_mass, real_t mass_threshold) {
  return node_mass > mass_threshold ? real_t(1) / node_mass : real_t(0);
}

}  // namespace

void reset_grid(const GridFields& fields) {
  fill_in_order(fields.state, real_t(0));
}

real_t max_node_signal_speed(const GridFields& fields, real_t gamma, real_t mass_threshold) {
  const NodeFieldsView state = fields.state;
  // (Selects, not an early return for empty nodes: the nodes run as vector lanes.)
  return largest_over_indices(
      "node_signal_speed", static_cast<index_t>(state.extent(0)), largest_real, KOKKOS_LAMBDA(const index_t i) {
        const real_t m = state(i, GridFields::mass);
        const bool holds_mass = m > mass_threshold;
        const real_t divisor = holds_mass ? m : real_t(1);  // (an empty node's speed is dropped below)
        const real_t inv_m = real_t(1) / divisor;
        // sound_speed(gamma, P, rho) = sqrt(gamma P / rho): here sqrt(gamma (sum phi P V) / (sum phi M)).
        const real_t speed = signal_speed(state(i, GridFields::momentum_x) * inv_m, state(i, GridFields::momentum_y) * inv_m,
                                          sound_speed(gamma, state(i, GridFields::pressure_volume), divisor));
        return holds_mass ? speed : real_t(0);
      });
}

void update_grid_momentum(const GridFields& fields, real_t dt, real_t mass_threshold) {
  const NodeFieldsView state = fields.state, per_unit_mass = fields.per_unit_mass;
  Kokkos::parallel_for(
      "grid_momentum_update", Kokkos::RangePolicy<ExecutionSpace>(0, static_cast<index_t>(state.extent(0))), KOKKOS_LAMBDA(const index_t i) {
        const real_t momentum_x = state(i, GridFields::momentum_x) + dt * state(i, GridFields::force_x);
        const real_t momentum_y = state(i, GridFields::momentum_y) + dt * state(i, GridFields::force_y);
        // (mv)' lives on as V-bar; its columns take the remap's sums next (step 8).
        state(i, GridFields::momentum_x) = 0;
        state(i, GridFields::momentum_y) = 0;
        const real_t inv_m = per_unit_node_mass(state(i, GridFields::mass), mass_threshold);
        per_unit_mass(i, GridFields::velocity_x) = momentum_x * inv_m;
        per_unit_mass(i, GridFields::velocity_y) = momentum_y * inv_m;
        per_unit_mass(i, GridFields::acceleration_x) = state(i, GridFields::force_x) * inv_m;
        per_unit_mass(i, GridFields::acceleration_y) = state(i, GridFields::force_y) * inv_m;
      });
}

void compute_remap_velocity(const GridFields& fields, real_t mass_threshold, real_t dt, bool midpoint) {
  const NodeFieldsView state = fields.state, per_unit_mass = fields.per_unit_mass;
  // Weights of the remapped and of the old velocity V-bar - dt A.
  const real_t remap_weight = midpoint ? real_t(0.5) : real_t(1);
  const real_t old_weight = midpoint ? real_t(0.5) : real_t(0);
  Kokkos::parallel_for(
      "grid_remap_velocity", Kokkos::RangePolicy<ExecutionSpace>(0, static_cast<index_t>(state.extent(0))), KOKKOS_LAMBDA(const index_t i) {
        const real_t inv_m = per_unit_node_mass(state(i, GridFields::mass), mass_threshold);
        const real_t old_x = per_unit_mass(i, GridFields::velocity_x) - dt * per_unit_mass(i, GridFields::acceleration_x);
        const real_t old_y = per_unit_mass(i, GridFields::velocity_y) - dt * per_unit_mass(i, GridFields::acceleration_y);
        per_unit_mass(i, GridFields::remap_velocity_x) =
            remap_weight * state(i, GridFields::momentum_x) * inv_m + old_weight * old_x;
        per_unit_mass(i, GridFields::remap_velocity_y) =
            remap_weight * state(i, GridFields::momentum_y) * inv_m + old_weight * old_y;
      });
}

void compute_volume_fraction(const GridFields& fields, const RealView& node_gas_volume, real_t cell_area,
                             const Kokkos::View<const int*, DeviceType>& pressure_side_entry) {
  const NodeFieldsView state = fields.state, per_unit_mass = fields.per_unit_mass;
  const RealView gas_volume = node_gas_volume;
  const real_t smallest = real_t(0.25) * cell_area;
  const Kokkos::View<const int*, DeviceType> side_entry = pressure_side_entry;
  Kokkos::parallel_for(
      "grid_volume_fraction", Kokkos::RangePolicy<ExecutionSpace>(0, static_cast<index_t>(state.extent(0))),
      KOKKOS_LAMBDA(const index_t i) {
        const real_t volume = state(i, GridFields::volume);
        per_unit_mass(i, GridFields::volume_fraction) =
            node_volume_fraction(volume, gas_volume(i), smallest, side_entry(i) >= 0);
        per_unit_mass(i, GridFields::mean_pressure) =
            volume > 0 ? state(i, GridFields::pressure_volume) / volume : real_t(0);
      });
}

namespace {

// A node vector (two state columns from `from`) kept in two before_conditions columns from `to`.
struct KeptVector {
  int from, to;
};

// before_conditions(k, kept[v].to + c) = state(conditioned_node(k), kept[v].from + c), c = 0, 1,
// for the first `count` vectors: one launch for them all.
void keep_vectors(const char* label, const GridFields& fields, Kokkos::Array<KeptVector, 2> kept, int count) {
  const NodeFieldsView state = fields.state, raw = fields.before_conditions;
  const IndexView node_of = fields.conditioned_node;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, static_cast<index_t>(node_of.extent(0))),
      KOKKOS_LAMBDA(const index_t k) {
        for (int v = 0; v < count; ++v)
          for (int c = 0; c < 2; ++c) raw(k, kept[v].to + c) = state(node_of(k), kept[v].from + c);
      });
}

}  // namespace

void keep_momentum_and_force_before_conditions(const GridFields& fields) {
  keep_vectors("keep_momentum_and_force", fields,
               {{{GridFields::momentum_x, GridFields::raw_momentum_x}, {GridFields::force_x, GridFields::raw_force_x}}},
               2);
}

void keep_remap_before_conditions(const GridFields& fields) {
  keep_vectors("keep_remap", fields, {{{GridFields::momentum_x, GridFields::raw_remap_momentum_x}, {0, 0}}}, 1);
}

namespace {

// boundary_work's sum over the conditioned nodes (an array reduction of one total, for
// sum_in_fixed_order).
struct BoundaryWorkSum {
  using value_type = double[];
  unsigned value_count = 1;  // (Kokkos' name: the length of an array reduction)
  NodeFieldsView state, raw, per_unit_mass;
  IndexView node_of;
  real_t mass_threshold;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t k, value_type sum) const {
    const index_t node = node_of(k);
    const real_t inv_m = per_unit_node_mass(state(node, GridFields::mass), mass_threshold);
    // The particles' kinetic energy change, per dt ...
    const real_t mean_momentum_x = real_t(0.5) * (raw(k, GridFields::raw_momentum_x) + raw(k, GridFields::raw_remap_momentum_x));
    const real_t mean_momentum_y = real_t(0.5) * (raw(k, GridFields::raw_momentum_y) + raw(k, GridFields::raw_remap_momentum_y));
    const double kinetic = double(inv_m) * (state(node, GridFields::force_x) * mean_momentum_x +
                                            state(node, GridFields::force_y) * mean_momentum_y);
    // ... plus their internal energy change.
    const double internal = -(raw(k, GridFields::raw_force_x) * per_unit_mass(node, GridFields::remap_velocity_x) +
                              raw(k, GridFields::raw_force_y) * per_unit_mass(node, GridFields::remap_velocity_y));
    sum[0] += kinetic + internal;
  }
};

}  // namespace

double boundary_work(const GridFields& fields, real_t dt, real_t mass_threshold) {
  double work = 0;
  sum_in_fixed_order("boundary_work", static_cast<index_t>(fields.conditioned_node.extent(0)),
                     BoundaryWorkSum{1, fields.state, fields.before_conditions, fields.per_unit_mass,
                                     fields.conditioned_node, mass_threshold},
                     &work);
  return double(dt) * work;
}

}  // namespace mpmflow
