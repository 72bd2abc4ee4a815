#pragma once
// Inviscid perfect gas with artificial viscosity: the pointwise physics of the particle update
// (paper eqs. 3-5 and Algorithm 1, step 10), as small pure functions usable on host and device.
#include "kernels/device_math.hpp"

namespace mpmflow {

// p = (gamma - 1) rho e
KOKKOS_INLINE_FUNCTION real_t perfect_gas_pressure(real_t gamma, real_t density, real_t specific_energy) {
  return (gamma - 1) * density * specific_energy;
}

KOKKOS_INLINE_FUNCTION real_t perfect_gas_specific_energy(real_t gamma, real_t density, real_t pressure) {
  return pressure / ((gamma - 1) * density);
}

// c = sqrt(gamma p / rho); a non-positive pressure gives c = 0 rather than NaN, so the time step
// stays defined long enough for the caller to report the bad particle.
KOKKOS_INLINE_FUNCTION real_t sound_speed(real_t gamma, real_t pressure, real_t density) {
  const real_t c2 = gamma * pressure / density;
  return c2 > 0 ? square_root(c2) : real_t(0);
}

// The same for a perfect gas from its specific internal energy: c^2 = gamma p / rho =
// gamma (gamma - 1) e, without the division; 0 for a non-positive energy, as above.
KOKKOS_INLINE_FUNCTION real_t perfect_gas_sound_speed_squared(real_t gamma, real_t specific_energy) {
  const real_t c2 = gamma * (gamma - 1) * specific_energy;
  return c2 > 0 ? c2 : real_t(0);
}
KOKKOS_INLINE_FUNCTION real_t perfect_gas_sound_speed(real_t gamma, real_t specific_energy) {
  return square_root(perfect_gas_sound_speed_squared(gamma, specific_energy));
}

// P V of a perfect gas of mass M and volume V = M / rho: (gamma - 1) M e, without the division.
KOKKOS_INLINE_FUNCTION real_t perfect_gas_pressure_volume(real_t gamma, real_t mass, real_t specific_energy) {
  return (gamma - 1) * mass * specific_energy;
}
// (P + Q) V, with the artificial viscosity Q: what the particle's stress gives the nodes (eq. 13).
KOKKOS_INLINE_FUNCTION real_t perfect_gas_stress_volume(real_t gamma, real_t mass, real_t density,
                                                        real_t specific_energy, real_t viscosity) {
  return perfect_gas_pressure_volume(gamma, mass, specific_energy) + viscosity * (mass / density);
}

// von Neumann-Richtmyer (c0, quadratic) + Landshoff (c1, linear) artificial viscosity in its
// dimensionally consistent form q = rho h (c0 h (div v)^2 - c1 c div v), active in compression only.
// (The paper's eq. 4 squares rho as well, which does not have units of pressure.)
KOKKOS_INLINE_FUNCTION real_t artificial_viscosity(real_t density, real_t sound_speed_value,
                                                   real_t cell_size, real_t velocity_divergence,
                                                   real_t c0, real_t c1) {
  if (velocity_divergence >= 0) return 0;
  return density * cell_size *
         (c0 * cell_size * velocity_divergence * velocity_divergence -
          c1 * sound_speed_value * velocity_divergence);
}

// Continuity along a particle path: rho' = rho / (1 + dt div v).
KOKKOS_INLINE_FUNCTION real_t advanced_density(real_t density, real_t dt, real_t velocity_divergence) {
  return density / (1 + dt * velocity_divergence);
}

// Energy along a particle path: e' = e - dt (p + q) / rho div v.
KOKKOS_INLINE_FUNCTION real_t advanced_specific_energy(real_t specific_energy, real_t dt, real_t pressure,
                                                       real_t viscosity, real_t density,
                                                       real_t velocity_divergence) {
  return specific_energy - dt * (pressure + viscosity) / density * velocity_divergence;
}

// Fastest signal at a particle, |v| + c, which bounds the explicit time step.
KOKKOS_INLINE_FUNCTION real_t signal_speed(real_t vx, real_t vy, real_t sound_speed_value) {
  return square_root(vx * vx + vy * vy) + sound_speed_value;
}

// A particle state the solver can go on from: a positive density, a pressure and a finite signal
// speed below the largest real (which the time step uses as its "invalid" mark). Every comparison
// is false on NaN, so NaN anywhere fails it.
KOKKOS_INLINE_FUNCTION bool is_valid_gas_state(real_t density, real_t pressure, real_t signal_speed_value) {
  return density > 0 && pressure == pressure && signal_speed_value < largest_real;
}

// A perfect gas's state (density, specific energy, velocity) that is_valid_gas_state accepts for
// sure, tested without a square root: |v|^2 + c^2 finite implies |v| + c finite. (The converse
// fails only for speeds beyond 1e154: such a state is in doubt, and is_valid_gas_state decides.)
// All three tests are made (&, not &&): no branch, so that P2G's particles run as vector lanes.
KOKKOS_INLINE_FUNCTION bool surely_valid_gas_state(real_t gamma, real_t density, real_t specific_energy, real_t vx,
                                                   real_t vy) {
  const real_t pressure = perfect_gas_pressure(gamma, density, specific_energy);
  return (density > 0) & (pressure == pressure) &
         (vx * vx + vy * vy + perfect_gas_sound_speed_squared(gamma, specific_energy) < largest_real);
}

// The pressure at a subsonic far-field boundary from the Riemann invariants of the flow normal to
// it (un the normal velocity, positive inwards): the one entering, un + 2 c / (gamma - 1), from the
// free stream (un_inf, c_inf), the one leaving, un - 2 c / (gamma - 1), from the gas inside (un,
// c); their mean the boundary's normal velocity, their difference its sound speed; its entropy
// p / rho^gamma the free stream's where that velocity points in, the gas's where it points out.
// A stream of the free stream's normal velocity and sound speed meets p_inf (the state outside is
// the same); one slower inwards, or faster outwards, meets more, one faster inwards or slower
// outwards less: the gas outside pushes the normal velocity towards the free stream's instead of
// holding the pressure alone, which leaves the normal velocity free to drift. Supersonic: all from
// outside going in (p_inf), all from inside going out (p).
KOKKOS_INLINE_FUNCTION real_t far_field_boundary_pressure(real_t gamma, real_t un, real_t density, real_t pressure,
                                                          real_t un_inf, real_t density_inf, real_t pressure_inf) {
  const real_t c = sound_speed(gamma, pressure, density), c_inf = sound_speed(gamma, pressure_inf, density_inf);
  if (un >= c) return pressure_inf;
  if (un <= -c) return pressure;
  const real_t entering = un_inf + 2 * c_inf / (gamma - 1), leaving = un - 2 * c / (gamma - 1);
  const real_t un_boundary = (entering + leaving) / 2, c_boundary = (gamma - 1) * (entering - leaving) / 4;
  if (!(c_boundary > 0)) return pressure_inf;
  // rho = (c^2 / (gamma s))^(1 / (gamma - 1)) and p = rho c^2 / gamma, with s = p / rho^gamma:
  // p = p_s (c / c_s)^(2 gamma / (gamma - 1)) for the state (p_s, c_s) whose entropy it takes.
  const real_t p_s = un_boundary > 0 ? pressure_inf : pressure, c_s = un_boundary > 0 ? c_inf : c;
  return p_s * power(c_boundary / c_s, 2 * gamma / (gamma - 1));
}

// ---- Sub-cell consistency (numerics/pressure_relaxation and numerics/volume_correction) ---------

// The fraction of a volume or pressure mismatch below the grid's resolution that the gas evens
// out in a step of dt: dt c / h, the share of a cell that sound crosses (at most all of it). With
// dt / h given (once per step, not a division per particle).
KOKKOS_INLINE_FUNCTION real_t acoustic_fraction(real_t dt_over_cell_size, real_t sound_speed) {
  const real_t fraction = dt_over_cell_size * sound_speed;
  return fraction < 1 ? fraction : real_t(1);
}

// The relative spread (volume-weighted standard deviation over mean) of a quantity of a cell from
// its sums of V q and V q^2: variance / mean^2 = V sum(V q^2) / sum(V q)^2 - 1 (one division).
KOKKOS_INLINE_FUNCTION real_t relative_spread(real_t volume, real_t sum, real_t sum_of_squares) {
  const real_t relative_variance = volume * sum_of_squares / (sum * sum) - 1;
  return sum > 0 && relative_variance > 0 ? square_root(relative_variance) : real_t(0);
}

// The fraction of the way to one pressure that the particles of a cell go in a step of dt: the
// acoustic rate dt c / h (c the cell's sound speed, c^2 = gamma (gamma - 1) sum(M e) / sum(M): a
// pressure difference across a cell evens out in about the time sound takes to cross it), times
// 1 - s / 0.25, s the larger relative spread of the cell's pressures and densities (noise is a few
// per cent; a shock or a contact within the cell, or a particle unlike its neighbours near a
// vacuum, is left alone). 0 where the cell holds no gas. (dt / h given: once a step.)
KOKKOS_INLINE_FUNCTION real_t pressure_relaxation_fraction(real_t gamma, real_t dt_over_cell_size, real_t volume,
                                                           real_t mass, real_t internal_energy, real_t pressure_spread,
                                                           real_t density_spread) {
  if (!(volume > 0 && mass > 0 && internal_energy > 0)) return 0;
  const real_t spread = pressure_spread > density_spread ? pressure_spread : density_spread;
  const real_t fraction = acoustic_fraction(dt_over_cell_size, perfect_gas_sound_speed(gamma, internal_energy / mass)) *
                          (1 - spread / real_t(0.25));
  return fraction > 0 ? fraction : real_t(0);
}

// A particle's volume at its cell's mean pressure P (= sum V p / sum V) in the pressure relaxation,
// over its volume V: compressed or expanded isentropically, (p / P)^(1 / gamma), to first order in
// the pressure difference, 1 + (p - P) / (gamma P), which the relaxation acts on (differences of a
// few per cent). To that order the shares V r sum to the cell's volume exactly: sum V (p - P) = 0.
// With 1 / (gamma P) given: the relaxation computes it once per cell, not once per particle.
KOKKOS_INLINE_FUNCTION real_t relaxed_volume_ratio(real_t pressure, real_t mean_pressure,
                                                   real_t inverse_gamma_mean_pressure) {
  return 1 + (pressure - mean_pressure) * inverse_gamma_mean_pressure;
}

// A particle's density corrected towards the space its volume shares: with phi the volume
// fraction at the particle (the nodes' sum of the particles' volumes over the gas space they
// cover, interpolated), the density times 1 + rate (phi - 1) w, rate = acoustic_fraction. Where the
// particles' volumes over-fill their space (phi > 1) they are compressed, where they leave part of
// it empty expanded. w weighs the particle by its pressure p against its nodes' mean pressure P
// (their particles' volume-weighted mean, interpolated), 1 for a particle at P:
//  - compressed, w = P / p: the pressure step that takes up the over-fill is the same for all,
//    and the soft, thin particles give the most volume for it. With the same fraction for all
//    (the correction until 2026-12-03) a dense particle sharing its nodes with thin gas (behind an
//    aerofoil) was compressed again and again, since its small volume never brought phi down:
//    densities of 1e10, and at Mach 0.5 a negative one. A soft particle compressed goes towards P
//    and takes less the next step; the change is at most a doubling.
//  - expanded, w = min(1, p / P): no particle below its nodes' mean pressure expands at the full
//    rate. (By the same pressure step the thin ones would expand the most, their pressure falling
//    further from P at every step, towards a vacuum.)
// The specific energy is kept, so the energy is conserved exactly (the pressure follows the
// density). Left alone where phi is far from 1 (below least_corrected_volume_fraction: the gas
// does not fill the stencil, at a free surface or near a vacuum; above most_corrected_volume_
// fraction), and where p or P is not positive. (A node the gas leaves more than half empty makes
// phi far beyond the range at every particle whose stencil reaches it: unfilled_node_volume_
// fraction.)
constexpr real_t least_corrected_volume_fraction = real_t(0.5), most_corrected_volume_fraction = 2;
// The volume fraction a node takes where the particles' volumes fill less than least_corrected_
// volume_fraction of the gas space of its hat (node_volume_fraction): so far beyond the range that
// a particle's phi, interpolated over its stencil, is beyond it too wherever the stencil reaches
// such a node (with a weight above 1e-29), and the particle is left alone. The mean phi over the
// stencil told too little: at the edge of a near-vacuum (the base behind a blunt body) a stencil
// whose nodes are 1, 1 and 0.2 full averages 0.8, and the particles there were expanded towards
// the empty space at every step, each time at their specific energy (a free expansion: entropy
// made), then compressed again by the flow along their isentrope: heated step by step. A square
// block in the Mach 3 cylinder's place (README, Status) held 169 to 426 particles above twenty
// times the stagnation energy at t = 1.5 with seeds 1 to 4, 11 to 22 with this rule.
constexpr real_t unfilled_node_volume_fraction = real_t(1e30);
KOKKOS_INLINE_FUNCTION real_t volume_corrected_density(real_t density, real_t volume_fraction, real_t rate,
                                                       real_t pressure, real_t mean_pressure) {
  if (!(volume_fraction > least_corrected_volume_fraction && volume_fraction < most_corrected_volume_fraction &&
        pressure > 0 && mean_pressure > 0))
    return density;
  // (Both divisions made, then one taken, and the bounds as at_most_one, not selects: GCC
  // vectorises no loop in which a branch guards a division, and took few selects more here before
  // it left the particle updates of a batch, vector lanes otherwise, scalar.)
  const real_t down = mean_pressure / pressure, up = pressure / mean_pressure;
  const real_t share = volume_fraction > 1 ? down : at_most_one(up);
  const real_t change = rate * (volume_fraction - 1) * share;
  return density * (1 + at_most_one(change));
}

}  // namespace mpmflow
