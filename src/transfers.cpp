#include "transfers.hpp"

#include <type_traits>
#include <utility>

#include "gas_physics.hpp"
#include "kernels/kept_scatter_view.hpp"
#include "kernels/particle_sort.hpp"
#include "kernels/transfer_kernels.hpp"

namespace mpmflow {
namespace {

// ---- On-the-fly functors of Algorithm 1 (the paper's I, zeta, eta and theta) ------------------

// The count of particles in doubt (TransferKernels::particles_in_doubt): integer sums, exact in
// any order.
using DoubtCounter = Kokkos::Experimental::ScatterView<index_t*, Kokkos::LayoutLeft, DeviceType>;

// P2G(I, M), P2G(I, M Vx), P2G(I, M Vy), P2G(I, P M / rho) for the nodes' sound speed (the
// time step, node_signal_speed, and the volume correction's mean pressure), and P2G(I, M / rho)
// for the volume correction's volume fraction:
// GridFields::mass .. volume. For a perfect gas P M / rho = (gamma - 1) M e needs no division.
// The time step's check of the particle states comes with it, since it reads them anyway: a
// particle not surely valid adds to `in_doubt`.
struct MassMomentumAndPressureVolume {
  static constexpr int num_components = 5;
  RealView mass, velocity_x, velocity_y, specific_energy, density;
  real_t gamma;
  DoubtCounter in_doubt;
  KOKKOS_FORCEINLINE_FUNCTION void operator()(index_t p, real_t (&value)[5]) const { add_count(values(p, value)); }
  // The values into `value` (an array, or a batch's lanes: LaneOutputs), and 1 for a particle in
  // doubt (a select, not a branch: so that a batch's particles run as vector lanes), which
  // add_count adds, once for a whole batch.
  template <class Values>
  KOKKOS_FORCEINLINE_FUNCTION index_t values(index_t p, Values&& value) const {
    const real_t m = mass(p), vx = velocity_x(p), vy = velocity_y(p), e = specific_energy(p), rho = density(p);
    value[0] = m;
    value[1] = m * vx;
    value[2] = m * vy;
    value[3] = perfect_gas_pressure_volume(gamma, m, e);
    value[4] = m / rho;
    return surely_valid_gas_state(gamma, rho, e, vx, vy) ? 0 : 1;
  }
  KOKKOS_FORCEINLINE_FUNCTION void add_count(index_t particles_in_doubt) const {
    if (particles_in_doubt == 0) return;
    auto count = in_doubt.access();
    count(0) += particles_in_doubt;
  }
};
// (So that the gathering P2G counts a particle once, not in each block of nodes it reaches.)
static_assert(CountsParticles<MassMomentumAndPressureVolume, MassMomentumAndPressureVolume::num_components>::value);

// P2G(I, M), P2G(I, M V), P2G(I, M rho), P2G(I, M P), P2G(I, M E): the state on the grid, for
// output (GridFields::ProjectionColumn).
struct OutputProjection {
  static constexpr int num_components = GridFields::num_projection_columns;
  RealView mass, velocity_x, velocity_y, density, specific_energy;
  real_t gamma;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, real_t (&value)[num_components]) const {
    const real_t m = mass(p);
    value[GridFields::projected_mass] = m;
    value[GridFields::projected_momentum_x] = m * velocity_x(p);
    value[GridFields::projected_momentum_y] = m * velocity_y(p);
    value[GridFields::projected_mass_density] = m * density(p);
    value[GridFields::projected_mass_pressure] = m * perfect_gas_pressure(gamma, density(p), specific_energy(p));
    value[GridFields::projected_mass_energy] = m * specific_energy(p);
  }
};

// P2G(I, M V): the momentum remap of step 8.
struct Momentum {
  static constexpr int num_components = 2;
  RealView mass, velocity_x, velocity_y;
  KOKKOS_FORCEINLINE_FUNCTION void operator()(index_t p, real_t (&value)[2]) const {
    value[0] = mass(p) * velocity_x(p);
    value[1] = mass(p) * velocity_y(p);
  }
};

// P2GD(zeta / eta, P, Q, M, rho): the internal force f_i = sum_p (P+Q) (M/rho) grad phi_i (eq. 13).
struct InternalForce {
  static constexpr int num_components = 2;
  static constexpr bool pairs_component_with_axis = true;  // (PairsComponentWithAxis)
  RealView specific_energy, viscosity, mass, density;
  real_t gamma;
  // Vectors: an array, or a batch's lanes (LaneVectorOutputs), written as vector[component][axis].
  template <class Vectors>
  KOKKOS_FORCEINLINE_FUNCTION void operator()(index_t p, Vectors&& vector) const {
    const real_t stress_times_volume =
        perfect_gas_stress_volume(gamma, mass(p), density(p), specific_energy(p), viscosity(p));
    vector[0][0] = stress_times_volume;  // zeta: x force component pairs with d/dx
    vector[0][1] = 0;
    vector[1][0] = 0;                    // eta: y force component pairs with d/dy
    vector[1][1] = stress_times_volume;
  }
};

// ---- The pressure relaxation (numerics/pressure_relaxation) --------------------------------------

// The columns of its per-cell sums. They are held in the rows of the grid's state View (row c for
// cell c: a slab has more nodes than cells), whose step-3 sums are spent by the end of step 10, so
// that the relaxation allocates nothing; P2C'd through the state's accumulator.
enum RelaxationSumColumn : int {
  relaxation_volume = 0,                    // sum V
  relaxation_internal_energy,               // sum M e (so sum V p = (gamma - 1) sum M e)
  relaxation_mass,                          // sum M (= sum V rho)
  relaxation_pressure_squared_volume,       // sum V p^2
  relaxation_density_squared_volume,        // sum V rho^2
  num_relaxation_sum_columns
};
static_assert(int(num_relaxation_sum_columns) <= int(GridFields::num_state_columns), "the sums live in the state's rows");

struct RelaxationSums {
  static constexpr int num_components = num_relaxation_sum_columns;
  RealView mass, density, specific_energy;
  real_t gamma;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, real_t (&value)[num_components]) const {
    const real_t volume = mass(p) / density(p), pressure = perfect_gas_pressure(gamma, density(p), specific_energy(p));
    value[relaxation_volume] = volume;
    value[relaxation_internal_energy] = mass(p) * specific_energy(p);
    value[relaxation_mass] = mass(p);
    value[relaxation_pressure_squared_volume] = volume * pressure * pressure;
    value[relaxation_density_squared_volume] = mass(p) * density(p);
  }
};

// What the particles of a cell share in the pressure relaxation, computed once per cell from its
// sums and written over them (RelaxationSumColumn's first four columns of the row): the
// fraction of the way the particles go (pressure_relaxation_fraction), the common pressure
// P = (gamma - 1) sum(M e) / sum(V), 1 / (gamma P) for the particles' shares
// (relaxed_volume_ratio), and the internal energy per volume sum(M e) / sum(V).
enum RelaxationColumn : int {
  relaxation_fraction = 0,
  relaxation_pressure,
  relaxation_inverse_gamma_pressure,
  relaxation_energy_per_volume
};

struct CellRelaxation {
  NodeFieldsView sums;
  real_t gamma, dt_over_cell_size;
  KOKKOS_INLINE_FUNCTION void operator()(index_t c) const {
    const real_t volume = sums(c, relaxation_volume), energy = sums(c, relaxation_internal_energy);
    const real_t mass = sums(c, relaxation_mass), pressure_volume = (gamma - 1) * energy;
    const real_t fraction = pressure_relaxation_fraction(
        gamma, dt_over_cell_size, volume, mass, energy,
        relative_spread(volume, pressure_volume, sums(c, relaxation_pressure_squared_volume)),
        relative_spread(volume, mass, sums(c, relaxation_density_squared_volume)));
    const bool relaxes = fraction > 0;
    const real_t inverse_volume = relaxes ? 1 / volume : real_t(0);
    sums(c, relaxation_fraction) = fraction;
    sums(c, relaxation_pressure) = pressure_volume * inverse_volume;
    sums(c, relaxation_inverse_gamma_pressure) = relaxes ? volume / (gamma * pressure_volume) : real_t(0);
    sums(c, relaxation_energy_per_volume) = energy * inverse_volume;
  }
};

// The pressure relaxation within a cell: the particles of a cell go towards its common pressure P,
// keeping the cell's volume and internal energy (so mass, momentum and energy are conserved
// exactly), each particle's volume at P its isentropic share (relaxed_volume_ratio) and its internal
// energy that volume's share of the cell's, by the cell's fraction of the way, the same for all
// its particles (so that the sums hold). Pressure differences within a cell are below what the
// grid resolves: the gas evens them out acoustically, but MPM's forces, made on the nodes, cannot,
// and the particles' volume changes, sampled at scattered points, keep making new ones.
// The particle's new cell comes with it (relax_pressures_and_locate), once its old one is read.
struct RelaxCellPressureAndLocate {
  RealView density, specific_energy, position_x, position_y;
  IndexView cell;
  NodeFieldsView cells;  // CellRelaxation's columns
  real_t gamma;
  ParticleLocator locate;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p) const {
    const index_t c = cell(p);
    cell(p) = locate(position_x(p), position_y(p));
    const real_t fraction = cells(c, relaxation_fraction);
    // Per unit of the particle's volume V = M / rho and mass, two divisions: the volume goes from V
    // to V_eq = V r (r = relaxed_volume_ratio) by the fraction, V (1 + fraction (r - 1)), and the
    // specific energy to that of the share, (E / V)_cell V_eq / M = (E / V)_cell r / rho.
    const real_t rho = density(p), e = specific_energy(p);
    const real_t ratio = relaxed_volume_ratio(perfect_gas_pressure(gamma, rho, e), cells(c, relaxation_pressure),
                                              cells(c, relaxation_inverse_gamma_pressure));
    const real_t new_volume_ratio = 1 + fraction * (ratio - 1);
    const real_t equilibrium_specific_energy = cells(c, relaxation_energy_per_volume) * ratio / rho;
    const real_t new_specific_energy = e + fraction * (equilibrium_specific_energy - e);
    // Selects, not early returns, and both fields written either way: so that a block of particles
    // runs in vector lanes (for_each_index_in_lanes).
    const bool relaxes = (fraction > 0) & (new_volume_ratio > 0) & (new_specific_energy > 0);
    density(p) = relaxes ? rho / new_volume_ratio : rho;
    specific_energy(p) = relaxes ? new_specific_energy : e;
  }
};

// ---- Cell averages (numerics/cell_averaged_strain) ----------------------------------------------

// The columns of the per-cell sums: particle volume, (P + Q) x volume, velocity divergence x volume.
enum CellSumColumn : int { cell_volume = 0, cell_stress_volume, cell_divergence_volume, num_cell_sum_columns };

// P2C(V), P2C((P + Q) V): the volume-weighted mean stress of each cell, before the force P2GD.
struct VolumeAndStress {
  static constexpr int num_components = 2;
  RealView mass, density, specific_energy, viscosity;
  real_t gamma;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, real_t (&value)[2]) const {
    value[0] = mass(p) / density(p);
    value[1] = perfect_gas_stress_volume(gamma, mass(p), density(p), specific_energy(p), viscosity(p));
  }
};

// The mean of column `column` over the volume of cell c.
KOKKOS_INLINE_FUNCTION real_t cell_mean(const NodeFieldsView& sums, index_t c, int column) {
  return sums(c, column) / sums(c, cell_volume);
}

// The internal force with the cell's mean P + Q: f_i = sum_p (P + Q)_cell (M / rho) grad phi_i.
struct CellAveragedInternalForce {
  static constexpr int num_components = 2;
  static constexpr bool pairs_component_with_axis = true;  // (PairsComponentWithAxis)
  RealView mass, density;
  IndexView cell;
  NodeFieldsView cell_sums;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, real_t (&vector)[2][2]) const {
    const real_t stress_times_volume = cell_mean(cell_sums, cell(p), cell_stress_volume) * mass(p) / density(p);
    vector[0][0] = stress_times_volume;
    vector[0][1] = 0;
    vector[1][0] = 0;
    vector[1][1] = stress_times_volume;
  }
};

// Sink of step 6-7: V updated with the interpolated acceleration (GridFields::acceleration_x, y).
struct Accelerate {
  RealView velocity_x, velocity_y;
  real_t dt;
  KOKKOS_FORCEINLINE_FUNCTION void operator()(index_t p, const real_t (&value)[2]) const {
    velocity_x(p) += dt * value[0];
    velocity_y(p) += dt * value[1];
  }
};

// Steps 6-8 for one particle, for the fused kernel: the sink above, then the particle's new
// momentum M V' for the remap P2G.
struct AccelerateThenCarryMomentum {
  using writes_only_its_particle = std::true_type;  // (WritesOnlyItsParticle)
  static constexpr int num_components = 2;
  Accelerate accelerate;
  RealView mass;
  KOKKOS_FORCEINLINE_FUNCTION void operator()(index_t p, const real_t (&value)[2], real_t (&momentum)[2]) const {
    accelerate(p, value);
    momentum[0] = mass(p) * accelerate.velocity_x(p);
    momentum[1] = mass(p) * accelerate.velocity_y(p);
  }
};

// What step 10 interpolates at each particle, in one G2P-and-G2PD: GridFields::velocity_x ..
// mean_pressure, of which it takes V-bar's values (the move, step 11), the remapped velocity's
// gradient and the volume fraction's and mean pressure's values (the volume correction).
using MoveAndRemapVelocity = NodeColumns<6>;
enum MoveAndRemapVelocityColumn : int {
  moving_velocity = 0,
  remapped_velocity = GridFields::remap_velocity_x - GridFields::velocity_x,
  volume_fraction_at_particle = GridFields::volume_fraction - GridFields::velocity_x,
  mean_pressure_at_particle = GridFields::mean_pressure - GridFields::velocity_x
};

// Step 11's move, X' = X + dt V-bar, V-bar interpolated at the step-10 stencil; the walls, sides
// and obstacles come after (apply_particle_boundaries). (Values: as UpdateThermodynamics takes them.)
struct AdvancePosition {
  RealView position_x, position_y;
  real_t dt;
  template <class Values>
  KOKKOS_FORCEINLINE_FUNCTION void operator()(index_t p, Values value) const {
    position_x(p) += dt * value[moving_velocity];
    position_y(p) += dt * value[moving_velocity + 1];
  }
};

// Sink of step 10: density, energy and artificial viscosity from div V (the pressure follows from
// the density and the energy, perfect_gas_pressure, and is not stored), the density corrected
// towards the volume fraction (numerics/volume_correction); the particle domain's stretches
// (diagonal of the deformation gradient, used by GIMP) from dVx/dx and dVy/dy.
struct UpdateThermodynamics {
  using writes_only_its_particle = std::true_type;  // (WritesOnlyItsParticle)
  // What operator() below reads of MoveAndRemapVelocity's interpolations (InterpolationsRead): the
  // moving velocity, the volume fraction and the mean pressure, and of the remapped velocity's
  // gradient its diagonal, dVx/dx and dVy/dy: six of the eighteen. (One read but not listed is not
  // in the CPU walk's lanes: ParticleUpdate.TheSortedWalkGivesTheUpdateEveryInterpolationItReads.)
  using reads_interpolations =
      InterpolationsRead<(1u << moving_velocity) | (1u << (moving_velocity + 1)) |
                             (1u << volume_fraction_at_particle) | (1u << mean_pressure_at_particle),
                         1u << remapped_velocity, 1u << (remapped_velocity + 1)>;
  AdvancePosition advance;
  RealView density, specific_energy, viscosity, stretch_x, stretch_y;
  real_t dt, gamma, cell_size, c0, c1;
  // The options as reals, 1 or 0: GCC 12 keeps a loop scalar whose selects test a bool that does
  // not change in it (the particle updates of a batch), and vectorises them on a comparison of reals.
  real_t energy_consistent, volume_correction;
  real_t dt_over_cell_size;  // dt / cell_size, once a step (acoustic_fraction)
  // Values and Gradients: arrays, or a batch's lanes (LaneValues, LaneGradients), read as
  // value[column] and gradient[column][axis].
  // (Forced inline: in a batch's update loop a call keeps the loop scalar. With the volume
  // correction weighed by pressure, GCC 12 left it out of line in six of the batch loops: 24 of
  // transfers.cpp's 30 vectorised (-fopt-info-vec), 30 with it forced.)
  template <class Values, class Gradients>
  KOKKOS_FORCEINLINE_FUNCTION void operator()(index_t p, Values value, Gradients gradient) const {
    advance(p, value);
    const real_t dvx_dx = gradient[remapped_velocity][0], dvy_dy = gradient[remapped_velocity + 1][1];
    const real_t div_v = dvx_dx + dvy_dy;
    stretch_x(p) *= 1 + dt * dvx_dx;
    stretch_y(p) *= 1 + dt * dvy_dy;
    const real_t rho = density(p), e = specific_energy(p), pressure = perfect_gas_pressure(gamma, rho, e);
    // (Once: the viscosity and the volume correction both take it.)
    const real_t sound_speed = perfect_gas_sound_speed(gamma, e);
    const real_t q = artificial_viscosity(rho, sound_speed, cell_size, div_v, c0, c1);
    // Energy-consistent: the viscous pressure that made this step's forces, so that the heat is
    // exactly the kinetic energy the viscosity removed; the paper's update takes the new one.
    const real_t previous_q = viscosity(p);  // (read either way: a load under the select kept GCC scalar)
    const real_t q_of_work = energy_consistent != 0 ? previous_q : q;
    specific_energy(p) = advanced_specific_energy(e, dt, pressure, q_of_work, rho, div_v);
    const real_t advanced = advanced_density(rho, dt, div_v);
    density(p) = volume_correction != 0
                     ? volume_corrected_density(advanced, value[volume_fraction_at_particle],
                                                acoustic_fraction(dt_over_cell_size, sound_speed), pressure,
                                                value[mean_pressure_at_particle])
                     : advanced;
    viscosity(p) = q;
  }
};

// Step 10 with cell-averaged strain, first pass: the domain's stretches from the particle's own
// gradient, and its divergence x volume into its cell (the cell it had before this move).
template <class Access>
struct StretchAndCellDivergence {
  AdvancePosition advance;
  RealView stretch_x, stretch_y, mass, density;
  IndexView cell;
  Access cell_sums;
  real_t dt;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, const real_t (&value)[MoveAndRemapVelocity::num_components],
                                         const real_t (&gradient)[MoveAndRemapVelocity::num_components][2]) const {
    advance(p, value);
    const real_t dvx_dx = gradient[remapped_velocity][0], dvy_dy = gradient[remapped_velocity + 1][1];
    stretch_x(p) *= 1 + dt * dvx_dx;
    stretch_y(p) *= 1 + dt * dvy_dy;
    const auto& access = cell_sums.access();
    access(cell(p), cell_divergence_volume) += (dvx_dx + dvy_dy) * mass(p) / density(p);
  }
};

// Second pass: density, energy and viscosity from the cell's mean divergence; the
// energy-consistent work with the cell's mean P + Q that made the force.
struct UpdateThermodynamicsFromCellMeans {
  RealView density, specific_energy, viscosity;
  IndexView cell;
  NodeFieldsView cell_sums;
  real_t dt, gamma, cell_size, c0, c1;
  bool energy_consistent;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p) const {
    const index_t c = cell(p);
    const real_t div_v = cell_mean(cell_sums, c, cell_divergence_volume);
    const real_t rho = density(p), e = specific_energy(p), pressure = perfect_gas_pressure(gamma, rho, e);
    const real_t q = artificial_viscosity(rho, perfect_gas_sound_speed(gamma, e), cell_size, div_v, c0, c1);
    // The cell's mean (P + Q) x V, shared out by volume, is what this particle's share of the force
    // was made of; the paper's update takes the particle's own pressure and the new viscosity.
    const real_t work_pressure = energy_consistent ? cell_mean(cell_sums, c, cell_stress_volume) : pressure + q;
    specific_energy(p) = advanced_specific_energy(e, dt, work_pressure, real_t(0), rho, div_v);
    density(p) = advanced_density(rho, dt, div_v);
    viscosity(p) = q;
  }
};

// ---- Shapes ---------------------------------------------------------------------------------

// The shape policy with the particle Views of now (migration may have reallocated them).
LinearShape current_shape(const LinearShape& shape, const ParticleState&) { return shape; }
BSplineShape current_shape(const BSplineShape& shape, const ParticleState&) { return shape; }
GimpShape current_shape(GimpShape shape, const ParticleState& particles) {
  shape.stretch_x = particles.domain_stretch_x;
  shape.stretch_y = particles.domain_stretch_y;
  return shape;
}

// The shape policy of a case on a slab of `geometry` (the particle Views come with current_shape).
template <class Shape>
Shape make_shape(const CaseConfig& config, const GridGeometry& geometry);
template <>
LinearShape make_shape<LinearShape>(const CaseConfig&, const GridGeometry& geometry) {
  return LinearShape{geometry};
}
template <>
BSplineShape make_shape<BSplineShape>(const CaseConfig&, const GridGeometry& geometry) {
  return BSplineShape{geometry};
}
template <>
GimpShape make_shape<GimpShape>(const CaseConfig& config, const GridGeometry& geometry) {
  // Each particle's initial domain is its share of the cell, ppc_x x ppc_y per cell.
  return GimpShape{geometry, geometry.spacing_x / (2 * config.particles.per_cell_x),
                   geometry.spacing_y / (2 * config.particles.per_cell_y), RealView(), RealView()};
}

// ---- The pressure sides' and the obstacles' volume gradients ------------------------------------

// What a particle adds to the volume gradients g_i = sum_p (M / rho) grad phi_i of the nodes its
// cell's mark names (BoundaryVolumeGradients: a crossed pressure side's, whose numbers are
// PressureSideNodes::entry's, and an obstacle's, ObstaclePressureNodes::entry's; a node is never
// both), through ScatterViews of integers: their sums are the same in any order.
template <class Shape>
struct AddVolumeGradients {
  using Scatter = KeptScatterView<long long>::Scatter;
  Shape shape;
  BoundaryVolumeGradients sums;
  RealView x, y, mass, density;
  IndexView cell;
  Scatter side_scatter, obstacle_scatter;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t p) const {
    const index_t c = cell(p);
    const auto stencil = shape(p, c, x(p), y(p));
    const real_t volume = mass(p) / density(p);
    const unsigned char mark = sums.cell_reach(c);
    if (mark & BoundaryVolumeGradients::reaches_side) add(stencil, volume, sums.side_nodes, side_scatter);
    if (mark & BoundaryVolumeGradients::reaches_obstacle) add(stencil, volume, sums.obstacle_nodes, obstacle_scatter);
  }
  // The stencil's share of the sums on the nodes `nodes` numbers (entry_of), through `scatter`.
  template <class Stencil, class Nodes>
  KOKKOS_INLINE_FUNCTION void add(const Stencil& stencil, real_t volume, const Nodes& nodes,
                                  const Scatter& scatter) const {
    auto access = scatter.access();
    for (int k = 0; k < stencil.size; ++k) {
      const index_t entry = nodes.entry_of(stencil.node(k));
      if (entry < 0) continue;
      access(entry) += nodes.units(volume * stencil.grad_x(k));
      access(entry + 1) += nodes.units(volume * stencil.grad_y(k));
    }
  }
};

// TransferKernels::add_boundary_volume_gradients with the case's shape, through ScatterViews kept
// by the caller.
template <class Shape>
void sum_boundary_volume_gradients(const Shape& shape, const ParticleState& pt, const BoundaryVolumeGradients& sums,
                                   KeptScatterView<long long>& side_scatter,
                                   KeptScatterView<long long>& obstacle_scatter) {
  if (pt.count == 0 || sums.cell_reach.extent(0) == 0) return;
  using Adder = AddVolumeGradients<Shape>;
  const Adder add_particle{shape,
                           sums,
                           pt.position_x,
                           pt.position_y,
                           pt.mass,
                           pt.density,
                           pt.cell,
                           side_scatter.into(sums.side_gradients),
                           obstacle_scatter.into(sums.obstacle_gradients)};
  const IndexView cell = pt.cell;
  const Kokkos::View<const unsigned char*, DeviceType> reach = sums.cell_reach;
  // (One by one on every back-end: the test's loads of a byte by cell keep its loop scalar anyway.
  // With the test in lanes and then a loop over the lanes it selected, for_each_index_where's CPU
  // form, the cylinder's boundary-conditions phase at 448 x 224 cells took 1.85-2.01 ms a step,
  // against 1.35-1.57 this way, three paired runs.)
  for_each_index_where_one_by_one(
      "boundary_volume_gradients", 0, pt.count, KOKKOS_LAMBDA(const index_t p) { return reach(cell(p)) != 0; },
      add_particle);
  side_scatter.contribute_into(sums.side_gradients);
  obstacle_scatter.contribute_into(sums.obstacle_gradients);
}

// ---- How P2G accumulates ----------------------------------------------------------------------

// The state's momentum columns, where steps 6-8 remap the momentum: a View of their own (LayoutLeft:
// two whole columns, contiguous), so that that P2G combines two columns, not seven.
NodeFieldsView momentum_columns(const NodeFieldsView& state) {
  return Kokkos::subview(state, Kokkos::ALL, std::make_pair(int(GridFields::momentum_x), int(GridFields::momentum_x) + 2));
}

// Through ScatterViews, duplicated (a copy of the node fields per thread, summed at the end) or
// atomic: all particles at once. Duplicated, the state's ScatterView holds the state itself as its
// first copy (fields.state becomes that copy; the View the grid allocated is let go first): the
// other copies are summed into it, one copy fewer held and read. The remap into the momentum
// columns has a ScatterView of its own over those columns.
template <class Duplication>
class ScatterAccumulation {
 public:
  static constexpr bool duplicated = std::is_same<Duplication, Kokkos::Experimental::ScatterDuplicated>::value;
  static constexpr bool fuses_g2p_with_remap = true;  // (TransferKernels::fuses_g2p_with_remap)
  using Access = NodeScatterView<Duplication>;

  ScatterAccumulation(GridFields& fields, const NodeFieldsView& cell_sums, ParticleOrder /* (walks no tiles) */)
      : state_(adopt_state(fields)), momentum_(momentum_columns(fields.state)), cells_(cell_sums) {}
  void prepare(const ParticleState&, const GridGeometry&) {}
  // Batched stencils on CPUs (for_each_particle_stencil).
  ParticleBatches traversal(const ParticleState& particles) const { return ParticleBatches{particles.count}; }
  // For a kernel that only reads nodes and writes its particle: the same.
  ParticleBatches reading_traversal(const ParticleState& particles) const { return traversal(particles); }
  // Step 3 (and the pressure relaxation's cell sums).
  Access& state() { return state_; }
  // Step 8, the remap into the momentum columns (its column 0: momentum_x).
  Access& momentum() { return momentum_; }
  // Its sum into the momentum columns, which hold zeros (update_grid_momentum): duplicated, the second
  // copy added into the first, which is then copied over them. (Kokkos' contribute_into adds the
  // two copies one after the other into the columns, each element's second addition waiting on its
  // first: 0.36 ms a step, against 0.21 ms for the state's seven columns.) The same sums, 0 + a + b
  // = a + b.
  void end_momentum(const NodeFieldsView& zeroed_momentum) {
    if constexpr (duplicated) {
      momentum_.contribute_into(momentum_.subview());
      Kokkos::deep_copy(zeroed_momentum, momentum_.subview());
    } else {
      p2g_end(momentum_, zeroed_momentum);
    }
  }
  Access& cells() { return cells_; }
  // An accumulator into another View (the output projection), made for the occasion.
  Access into(const NodeFieldsView& target) const { return Access(target); }
  P2GStrategy strategy() const { return duplicated ? P2GStrategy::duplicated : P2GStrategy::atomic; }
  // A duplicated ScatterView holds one copy of its target per thread (the state's first is the
  // state itself).
  size_t extra_bytes() const {
    if (!duplicated) return 0;
    const size_t copies = static_cast<size_t>(ExecutionSpace().concurrency());
    return sizeof(real_t) * ((copies - 1) * state_.subview().span() +
                             copies * (momentum_.subview().span() + cells_.subview().span()));
  }

 private:
  static Access adopt_state(GridFields& fields) {
    if (!duplicated) return Access(fields.state);
    const std::string label = fields.state.label();
    const size_t nodes = fields.state.extent(0), columns = fields.state.extent(1);
    fields.state = NodeFieldsView();  // released before the copies are made: the peak
    Access access(label, nodes, columns);
    fields.state = access.subview();
    return access;
  }

  // Kept alive across steps: creating a duplicated ScatterView allocates a copy per thread.
  Access state_;
  Access momentum_;
  Access cells_;  // the per-cell sums of cell-averaged strain
};

// Sorted: the particles grouped (rebuilt every step since the particles move), then P2G straight
// into the node fields. No copies, no atomics, and the same sums in the same order for any thread
// count: bitwise reproducible. On CPUs grouped by tile, in index order (ColouredTiles: a thread per
// tile, tile colour by tile colour, whose particles reordered by cell are long runs of consecutive
// ones); on GPUs by cell (ColouredCells: a thread per block of nodes gathers its nodes' sums,
// walk_nodes_gathering).
class ColouredAccumulation {
 public:
  using Access = DirectNodeAccess;
  static constexpr bool by_tile = cpu_code_paths;
  // By cell, P2G gathers a block of nodes' sums in a thread of the block's (walk_nodes_gathering),
  // from particles that the fused kernel would update in the same pass: G2P, then the remap P2G.
  static constexpr bool fuses_g2p_with_remap = by_tile;
  using Traversal = std::conditional_t<by_tile, ColouredTiles, ColouredCells>;

  ColouredAccumulation(GridFields& fields, const NodeFieldsView& cell_sums, ParticleOrder particle_order)
      : state_{fields.state}, momentum_{momentum_columns(fields.state)}, cell_sums_{cell_sums},
        order_{make_particle_grouping<Order>(particle_order)} {}
  void prepare(const ParticleState& particles, const GridGeometry& grid) {
    traversal_ = group(order_, particles, grid);
  }
  const Traversal& traversal(const ParticleState&) const { return traversal_; }
  // For a kernel that only reads nodes and writes its particle: on CPUs the tiles, each reading its
  // nodes through a window (walk_tiles_through_windows); on GPUs all particles at once (the cells'
  // teams would only cost it colours). (A template, defined before its use for its return type.)
  template <class Grouped>
  static auto reading(const Grouped& grouped, const ParticleState& particles) {
    if constexpr (std::is_same<Grouped, ColouredTiles>::value)
      return grouped;
    else
      return ParticleBatches{particles.count};
  }
  auto reading_traversal(const ParticleState& particles) const { return reading(traversal_, particles); }
  Access& state() { return state_; }
  Access& momentum() { return momentum_; }
  void end_momentum(const NodeFieldsView&) {}  // written in place
  Access& cells() { return cell_sums_; }
  Access into(const NodeFieldsView& target) const { return Access{target}; }
  P2GStrategy strategy() const { return P2GStrategy::sorted; }
  size_t extra_bytes() const { return order_.bytes(); }

 private:
  Access state_, momentum_, cell_sums_;
  // The particles grouped by tile, or by cell. (A template, so that only the one in use is compiled:
  // nvcc warns of an overload never called.)
  template <class Order>
  static Traversal group(Order& order, const ParticleState& particles, const GridGeometry& grid) {
    if constexpr (std::is_same<Order, TileOrder>::value) {
      return order.build(particles.cell, particles.count, grid.cells_x(), grid.cells_y());
    } else {
      order.build(particles.cell, particles.count, grid.num_cells());
      // Teams of Kokkos' size (GPUs: many threads); taking the GPU's paths on the host, every
      // thread in one team, so that a team's threads share its tile as on a GPU (Kokkos' size on
      // the host is one a core).
      const int team_size = gpu_code_paths_on_host ? ExecutionSpace().concurrency() : 0;
      return Traversal{order.bin_offset(), order.particle(), grid.cells_x(), grid.cells_y(), team_size};
    }
  }

  using Order = std::conditional_t<by_tile, TileOrder, CellOrder>;
  Order order_;
  Traversal traversal_;
};

// ---- The transfers, specialised -----------------------------------------------------------------

template <class Accumulation, class Shape>
class Transfers final : public TransferKernels {
 public:
  // (The accumulation may give `fields` its state View: ScatterAccumulation.)
  Transfers(const CaseConfig& config, const GridGeometry& geometry, GridFields& fields)
      : geometry_(geometry),
        cell_averaged_strain_(config.numerics.cell_averaged_strain),
        pressure_relaxation_(config.numerics.pressure_relaxation),
        gamma_(config.physics.gamma),
        cell_sums_("cell_sums", cell_averaged_strain_ ? geometry.num_cells() : 0, num_cell_sum_columns),
        accumulation_(fields, cell_sums_, particle_order_of(config.numerics)),
        fields_(fields),
        shape_(make_shape<Shape>(config, geometry)),
        in_doubt_count_("p2g_particles_in_doubt", 1),
        in_doubt_count_host_(host_mirror(in_doubt_count_)),
        in_doubt_(in_doubt_count_) {}

  void p2g_mass_momentum_force(const ParticleState& pt) override {
    accumulation_.prepare(pt, geometry_);
    if (cell_averaged_strain_) {  // each cell's volume and (P + Q) x volume, for its mean stress
      fill_in_order(cell_sums_, real_t(0));
      p2g_begin(accumulation_.cells(), cell_sums_);
      p2c("p2c_volume_stress", pt.cell, accumulation_.traversal(pt), accumulation_.cells(), cell_volume,
          VolumeAndStress{pt.mass, pt.density, pt.specific_energy, pt.artificial_viscosity, gamma_});
      p2g_end(accumulation_.cells(), cell_sums_);
    }
    p2g_begin(accumulation_.state(), fields_.state);
    fill_in_order(in_doubt_count_, 0);
    in_doubt_.reset_except(in_doubt_count_);
    // Fused: the paper's P2G(M), P2G(M V) and P2GD((P + Q) M / rho) in one pass over the particles.
    const MassMomentumAndPressureVolume mass_and_momentum{
        pt.mass, pt.velocity_x, pt.velocity_y, pt.specific_energy, pt.density, gamma_, in_doubt_};
    if (cell_averaged_strain_)
      p2g_and_p2gd("p2g_mass_momentum_force", current_shape(shape_, pt), pt.locations(), accumulation_.traversal(pt),
                   accumulation_.state(), GridFields::mass, mass_and_momentum, GridFields::force_x,
                   CellAveragedInternalForce{pt.mass, pt.density, pt.cell, cell_sums_});
    else
      p2g_and_p2gd("p2g_mass_momentum_force", current_shape(shape_, pt), pt.locations(), accumulation_.traversal(pt),
                   accumulation_.state(), GridFields::mass, mass_and_momentum, GridFields::force_x,
                   InternalForce{pt.specific_energy, pt.artificial_viscosity, pt.mass, pt.density, gamma_});
    p2g_end(accumulation_.state(), fields_.state);
    in_doubt_.contribute_into(in_doubt_count_);
  }

  void add_boundary_volume_gradients(const ParticleState& pt, const BoundaryVolumeGradients& sums) override {
    sum_boundary_volume_gradients(current_shape(shape_, pt), pt, sums, side_gradient_scatter_,
                                  obstacle_gradient_scatter_);
  }

  index_t particles_in_doubt() const override {
    Kokkos::deep_copy(in_doubt_count_host_, in_doubt_count_);
    return in_doubt_count_host_(0);
  }

  void g2p_p2g_velocity_momentum(const ParticleState& pt, real_t dt) override {
    if constexpr (Accumulation::fuses_g2p_with_remap) {
      const NodeFieldsView momentum = momentum_columns(fields_.state);
      p2g_begin(accumulation_.momentum(), momentum);
      g2p_then_p2g("g2p_p2g_velocity_momentum", current_shape(shape_, pt), pt.locations(),
                   accumulation_.traversal(pt), NodeColumns<2>{fields_.per_unit_mass, GridFields::acceleration_x},
                   AccelerateThenCarryMomentum{Accelerate{pt.velocity_x, pt.velocity_y, dt}, pt.mass},
                   accumulation_.momentum(), 0);
      accumulation_.end_momentum(momentum);
    } else {
      g2p_velocity_acceleration(pt, dt);
      p2g_momentum_remap(pt);
    }
  }

  void g2p_velocity_acceleration(const ParticleState& pt, real_t dt) override {
    g2p("g2p_velocity_acceleration", current_shape(shape_, pt), pt.locations(), ParticleBatches{pt.count},
        NodeColumns<2>{fields_.per_unit_mass, GridFields::acceleration_x},
        Accelerate{pt.velocity_x, pt.velocity_y, dt});
  }

  void p2g_momentum_remap(const ParticleState& pt) override {
    const NodeFieldsView momentum = momentum_columns(fields_.state);
    p2g_begin(accumulation_.momentum(), momentum);
    p2g("p2g_momentum_remap", current_shape(shape_, pt), pt.locations(), accumulation_.traversal(pt),
        accumulation_.momentum(), 0, Momentum{pt.mass, pt.velocity_x, pt.velocity_y});
    accumulation_.end_momentum(momentum);
  }

  void g2pd_particle_update(const ParticleState& pt, const ThermodynamicConstants& k, real_t dt) override {
    if (cell_averaged_strain_) {
      // The divergence x volume of each cell (its volume and mean stress are the force's, step 3:
      // the particles have not moved since) ...
      fill_in_order(Kokkos::subview(cell_sums_, Kokkos::ALL, int(cell_divergence_volume)), real_t(0));
      using Access = std::decay_t<decltype(accumulation_.cells())>;
      p2g_begin(accumulation_.cells(), cell_sums_);
      g2p_and_g2pd("g2pd_cell_divergence", current_shape(shape_, pt), pt.locations(), accumulation_.traversal(pt),
                   MoveAndRemapVelocity{fields_.per_unit_mass, GridFields::velocity_x},
                   StretchAndCellDivergence<Access>{advance(pt, dt), pt.domain_stretch_x, pt.domain_stretch_y, pt.mass,
                                                    pt.density, pt.cell, accumulation_.cells(), dt});
      p2g_end(accumulation_.cells(), cell_sums_);
      // ... then every particle's state from its cell's means.
      for_each_particle("particle_update_cell_means", pt.count,
                        UpdateThermodynamicsFromCellMeans{pt.density, pt.specific_energy,
                                                          pt.artificial_viscosity, pt.cell, cell_sums_, dt, k.gamma,
                                                          k.cell_size, k.viscosity_quadratic, k.viscosity_linear,
                                                          k.energy_consistent});
    } else {
      g2p_and_g2pd("g2pd_particle_update", current_shape(shape_, pt), pt.locations(), accumulation_.reading_traversal(pt),
                   MoveAndRemapVelocity{fields_.per_unit_mass, GridFields::velocity_x},
                   UpdateThermodynamics{advance(pt, dt), pt.density, pt.specific_energy, pt.artificial_viscosity,
                                        pt.domain_stretch_x, pt.domain_stretch_y, dt, k.gamma, k.cell_size,
                                        k.viscosity_quadratic, k.viscosity_linear,
                                        k.energy_consistent ? real_t(1) : 0, k.volume_correction ? real_t(1) : 0,
                                        dt / k.cell_size});
    }
  }

  void p2g_output_projection(const ParticleState& pt, const NodeFieldsView& target) override {
    fill_in_order(target, real_t(0));
    accumulation_.prepare(pt, geometry_);
    auto access = accumulation_.into(target);
    p2g_begin(access, target);
    p2g("p2g_output_projection", current_shape(shape_, pt), pt.locations(), accumulation_.traversal(pt), access,
        GridFields::projected_mass,
        OutputProjection{pt.mass, pt.velocity_x, pt.velocity_y, pt.density, pt.specific_energy, gamma_});
    p2g_end(access, target);
  }

  P2GStrategy strategy() const override { return accumulation_.strategy(); }
  bool fuses_g2p_with_remap() const override { return Accumulation::fuses_g2p_with_remap; }
  size_t scratch_bytes() const override { return accumulation_.extra_bytes(); }

  bool relaxes_pressure() const override { return pressure_relaxation_; }

  // The particles are grouped by the cells they had before the move (pt.cell, and the cell order of
  // this step's P2G, are still those): any grouping of neighbours conserves. The sums go into the
  // state View's rows (RelaxationSumColumn).
  void relax_pressures_and_locate(const ParticleState& pt, const ThermodynamicConstants& k, real_t dt,
                                  const ParticleLocator& locate) override {
    const NodeFieldsView sums = fields_.state;
    fill_in_order(Kokkos::subview(sums, Kokkos::ALL, std::make_pair(0, int(num_relaxation_sum_columns))), real_t(0));
    p2g_begin(accumulation_.state(), sums);
    p2c("p2c_relaxation_sums", pt.cell, accumulation_.traversal(pt), accumulation_.state(), relaxation_volume,
        RelaxationSums{pt.mass, pt.density, pt.specific_energy, k.gamma});
    p2g_end(accumulation_.state(), sums);
    for_each_index_in_lanes("cell_relaxation", geometry_.num_cells(), CellRelaxation{sums, k.gamma, dt / k.cell_size});
    for_each_index_in_lanes("cell_pressure_relaxation", pt.count,
                            RelaxCellPressureAndLocate{pt.density, pt.specific_energy, pt.position_x,
                                                       pt.position_y, pt.cell, sums, k.gamma, locate});
  }

 private:
  static AdvancePosition advance(const ParticleState& pt, real_t dt) { return {pt.position_x, pt.position_y, dt}; }

  GridGeometry geometry_;
  bool cell_averaged_strain_;
  bool pressure_relaxation_;
  real_t gamma_;
  NodeFieldsView cell_sums_;  // (cell, CellSumColumn) with cell-averaged strain
  Accumulation accumulation_;
  GridFields fields_;  // (after accumulation_, which may set its state)
  Shape shape_;
  IndexView in_doubt_count_;  // of the last p2g_mass_momentum_force
  // Its host copy, kept: read every step, a mirror made for each read would be a host allocation a
  // step on a GPU (on CPUs the View itself).
  IndexView::HostMirror in_doubt_count_host_;
  DoubtCounter in_doubt_;
  // Step 4's additions into the volume gradients (add_boundary_volume_gradients).
  KeptScatterView<long long> side_gradient_scatter_, obstacle_gradient_scatter_;
};

template <class Accumulation>
std::unique_ptr<TransferKernels> make_for_shape(const CaseConfig& config, const GridGeometry& geometry,
                                                GridFields& fields) {
  switch (config.numerics.shape_function) {
    case ShapeFunction::gimp: return std::make_unique<Transfers<Accumulation, GimpShape>>(config, geometry, fields);
    case ShapeFunction::bspline:
      return std::make_unique<Transfers<Accumulation, BSplineShape>>(config, geometry, fields);
    case ShapeFunction::linear: break;
  }
  return std::make_unique<Transfers<Accumulation, LinearShape>>(config, geometry, fields);
}

}  // namespace

ThermodynamicConstants thermodynamic_constants(const CaseConfig& config, real_t cell_size) {
  return {config.physics.gamma,
          cell_size,
          config.physics.viscosity_quadratic,
          config.physics.viscosity_linear,
          config.numerics.energy_consistent,
          config.numerics.volume_correction && !config.numerics.cell_averaged_strain};
}

ParticleOrder particle_order_of(const NumericsConfig& numerics) {
  return numerics.reorder_interval > 0 ? ParticleOrder::reordered_by_cell : ParticleOrder::never_reordered;
}

std::unique_ptr<TransferKernels> make_transfer_kernels(const CaseConfig& config, const GridGeometry& geometry,
                                                       GridFields& fields) {
  using Kokkos::Experimental::ScatterDuplicated;
  using Kokkos::Experimental::ScatterNonDuplicated;
  switch (config.numerics.p2g) {
    case P2GStrategy::sorted: return make_for_shape<ColouredAccumulation>(config, geometry, fields);
    case P2GStrategy::duplicated: return make_for_shape<ScatterAccumulation<ScatterDuplicated>>(config, geometry, fields);
    case P2GStrategy::atomic: return make_for_shape<ScatterAccumulation<ScatterNonDuplicated>>(config, geometry, fields);
    case P2GStrategy::automatic: break;
  }
  // Where the grid lives in host memory (CPUs): sorted, wherever its walk keeps the threads busy,
  // since it adds each tile's nodes in a window in cache (walk_tiles_staged) and keeps no copies;
  // faster than duplicated, and deterministic (README, Deterministic P2G;
  // docs/performance_history.md). Else Kokkos' own rule: duplicated copies on CPUs (few threads,
  // cheap copies), atomics on GPUs (thousands of threads, copies unaffordable).
  if (cpu_code_paths) {
    if (walk_keeps_threads_busy(geometry.cells_x(), geometry.cells_y(), particle_order_of(config.numerics),
                                ExecutionSpace().concurrency()))
      return make_for_shape<ColouredAccumulation>(config, geometry, fields);
    return make_for_shape<ScatterAccumulation<ScatterDuplicated>>(config, geometry, fields);
  }
  return make_for_shape<ScatterAccumulation<ScatterNonDuplicated>>(config, geometry, fields);
}

}  // namespace mpmflow
