#pragma once
// The node-by-node phases of an MPM step (Algorithm 1, steps 2 and 5, and the remapped velocity
// step 10 interpolates): one kernel each over the slab's nodes.
#include "gas_physics.hpp"
#include "grid.hpp"

namespace mpmflow {

// 2. Zeroes the columns the step's P2Gs accumulate into.
void reset_grid(const GridFields& fields);

// The largest signal speed |v| + c over the nodes with more mass than `mass_threshold`, from
// step 3's P2G: v = mv / m and c^2 = gamma sum_p phi P V / sum_p phi M, the mass-weighted mean of
// the particles' c^2 = gamma P / rho. That is the speed the explicit grid update must resolve: a
// node's acoustic stiffness over its mass is sum_p phi gamma P V |grad phi|^2 / sum_p phi M, and
// the particles move with the nodes' velocity. A particle far lighter than its neighbours weighs
// in its nodes by its mass, not by its own |v| + c (a split particle in a near-vacuum can carry a
// FLIP velocity and a sound speed 3 times its neighbours').
real_t max_node_signal_speed(const GridFields& fields, real_t gamma, real_t mass_threshold);

// 5. The momentum equation on the grid, (mv)' = mv + dt f; then, per unit node mass, the
// velocity V-bar = (mv)' / m and the acceleration A = f / m that step 6 interpolates. Nodes with
// no more mass than `mass_threshold` count as empty: no velocity, no acceleration. The momentum
// columns are left zero, for step 8's remap to sum into (a pass over the nodes fewer than
// clearing them apart).
void update_grid_momentum(const GridFields& fields, real_t dt, real_t mass_threshold);

// The velocity step 10 differentiates: the remapped momentum (step 8) per unit node mass; with
// `midpoint`, its mean with the velocity before the step's update, V-bar - dt A. The internal
// energy the particles gain from that velocity's divergence is then exactly the kinetic energy
// the step's grid forces take from them (FLIP's kinetic energy change is the forces' work on the
// remapped mean of the particles' old and new velocities).
void compute_remap_velocity(const GridFields& fields, real_t mass_threshold, real_t dt, bool midpoint);

// The volume fraction phi_i of a node (node_volume_fraction) from its particles' volume
// sum_p N_i(X_p) M / rho and the gas volume its hat covers, ObstacleGrid::node_gas_volume: 1 where
// the particles' volumes fill the space they are in, as they must. 1 (neutral) where the hat holds
// less gas space than `smallest` (beyond the domain, a corner cut by a body, unknown at a far-field
// side), which says little about the particles around it; at most 1 where the gas volume is
// negative (next to a body: only a shortfall counts); unfilled_node_volume_fraction where the
// particles fill less than least_corrected_volume_fraction of it (a free surface, a near-vacuum:
// the particles whose stencils reach the node are then left alone), unless `gas_outside` (a
// pressure side's node: the gas outside fills what the particles leave, and presses on them).
KOKKOS_INLINE_FUNCTION real_t node_volume_fraction(real_t particle_volume, real_t gas_volume, real_t smallest,
                                                   bool gas_outside) {
  const real_t space = gas_volume < 0 ? -gas_volume : gas_volume;
  if (!(space > smallest)) return 1;
  const real_t fraction = particle_volume / space;
  if (fraction < least_corrected_volume_fraction && !gas_outside) return unfilled_node_volume_fraction;
  return gas_volume < 0 && fraction > 1 ? real_t(1) : fraction;
}

// The volume fraction of every node into GridFields::volume_fraction, and its particles'
// volume-weighted mean pressure into GridFields::mean_pressure (0 without particle volume): what
// the volume correction reads (volume_corrected_density).
// pressure_side_entry(i) is 0 or more at the nodes of the pressure sides (node_volume_fraction's
// gas_outside; PressureSideNodes::node_entry).
void compute_volume_fraction(const GridFields& fields, const RealView& node_gas_volume, real_t cell_area,
                             const Kokkos::View<const int*, DeviceType>& pressure_side_entry);

// Copies the momentum and force columns of `state` (before step 4) or the remapped momentum
// (before step 9) of the nodes the boundary conditions may change into `before_conditions`.
void keep_momentum_and_force_before_conditions(const GridFields& fields);
void keep_remap_before_conditions(const GridFields& fields);

// The work the boundary conditions did on the particles over the step, with the energy-consistent
// update. The particles' kinetic energy changed by
//   dt sum_i A_i . (mv_i + (mv)_remap,i) / 2,
// A the acceleration after the conditions and the momenta as the particles gave them (FLIP's
// change is the interpolated acceleration times the mean of the old and new velocities); their
// internal energy by -dt sum_i f_i . v_mid,i, f the particles' own force and v_mid the velocity step
// 10 differentiates. What the two do not cancel is the conditions' work. On a node the conditions
// leave alone, v_mid = (mv + (mv)_remap) / 2m and f = m A: the two cancel, so the sum runs over
// the nodes they may change (GridFields::conditioned_node: this slab's share of them, the owned
// nodes and the ghost nodes beyond the domain's sides), not over every node, where it would only
// add round-off.
double boundary_work(const GridFields& fields, real_t dt, real_t mass_threshold);

}  // namespace mpmflow
