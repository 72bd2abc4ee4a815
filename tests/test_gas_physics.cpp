// The pointwise physics of gas_physics.hpp that the sub-cell consistency of the step rests on (the
// pressure relaxation's fraction and volume shares, the volume correction's density), the nodes'
// volume fraction (grid_phases.hpp) the correction reads, and the relaxation's pass over the
// particles (TransferKernels::relax_pressures_and_locate).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "case_config.hpp"
#include "gas_physics.hpp"
#include "grid_phases.hpp"
#include "particles.hpp"
#include "slab_state.hpp"
#include "transfers.hpp"
#include "round_off.hpp"

namespace mpmflow {
namespace {

// The far-field pressure of the Riemann invariants (gamma 1.4; free stream rho 1.4, p 1: c = 1).
// The free stream's own state meets p_inf, in and out; gas entering slower (or leaving faster)
// than the free stream meets more, which pushes it towards the free stream's normal velocity; to
// first order p_out - p_inf = rho c (un_inf - un) / 2 for gas of the free stream's sound speed.
// Supersonic: p_inf entering, the gas's own pressure leaving.
TEST(FarFieldBoundary, TheInvariantsPressureHoldsTheFreeStreamAndPushesTowardsIt) {
  const double gamma = 1.4, rho = 1.4, p = 1;
  for (double un : {0.5, -0.5, 0.0}) EXPECT_NEAR(far_field_boundary_pressure(gamma, un, rho, p, un, rho, p), p, 1e-14);
  const double slower_in = far_field_boundary_pressure(gamma, 0.49, rho, p, 0.5, rho, p);
  EXPECT_GT(slower_in, p);
  EXPECT_NEAR(slower_in - p, rho * 1.0 * 0.01 / 2, 2e-4);
  EXPECT_LT(far_field_boundary_pressure(gamma, 0.51, rho, p, 0.5, rho, p), p);
  EXPECT_GT(far_field_boundary_pressure(gamma, -0.51, rho, p, -0.5, rho, p), p);  // leaving faster
  EXPECT_EQ(far_field_boundary_pressure(gamma, 2.0, rho, 0.7, 3.0, rho, p), p);   // supersonic in
  EXPECT_EQ(far_field_boundary_pressure(gamma, -2.0, rho, 0.7, -3.0, rho, p), real_t(0.7));  // supersonic out
}

TEST(SubCellConsistency, TheAcousticFractionIsTheShareOfACellSoundCrossesAtMostAll) {
  const double h = 0.1;
  EXPECT_DOUBLE_EQ(acoustic_fraction(0.01 / h, 2.0), real_t(0.2));  // (0.2 as the build's reals hold it)
  EXPECT_DOUBLE_EQ(acoustic_fraction(0.1 / h, 2.0), 1.0);
  EXPECT_DOUBLE_EQ(acoustic_fraction(0.01 / h, 0.0), 0.0);
}

TEST(SubCellConsistency, RelativeSpreadIsTheVolumeWeightedDeviationOverTheMean) {
  // Two particles of volume 1 with q = 0.9 and 1.1: mean 1, deviation 0.1.
  EXPECT_NEAR(relative_spread(2.0, 0.9 + 1.1, 0.81 + 1.21), 0.1, round_off(1e-12));
  EXPECT_DOUBLE_EQ(relative_spread(2.0, 2.0, 2.0), 0.0);  // all equal
}

TEST(SubCellConsistency, PressureRelaxationActsOnNoiseAtTheAcousticRateAndLeavesShocksAlone) {
  const double gamma = 1.4, h = 0.1, dt = 0.01;
  // A cell of gas with c = 1: e = 1 / (gamma (gamma - 1)).
  const double mass = 1.4, energy = mass / (gamma * (gamma - 1));
  // Quiet: the acoustic fraction dt c / h = 0.1.
  EXPECT_NEAR(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.0, 0.0), 0.1, round_off(1e-12));
  // Noise of 5 %: 1 - 0.05 / 0.25 of it.
  EXPECT_NEAR(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.05, 0.01), 0.08, round_off(1e-12));
  EXPECT_NEAR(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.01, 0.05), 0.08, round_off(1e-12));
  // A shock or a contact within the cell (spread 25 % or more): nothing.
  EXPECT_EQ(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.3, 0.0), 0.0);
  EXPECT_EQ(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.0, 0.25), 0.0);
  // A long step: at most all the way.
  EXPECT_NEAR(pressure_relaxation_fraction(gamma, 1.0 / h, 1.0, mass, energy, 0.0, 0.0), 1.0, round_off(1e-12));
  // An empty cell, or one without internal energy: nothing.
  EXPECT_EQ(pressure_relaxation_fraction(gamma, dt / h, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
  EXPECT_EQ(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, 0.0, 0.0, 0.0), 0.0);
}

TEST(SubCellConsistency, RelaxedVolumeSharesKeepTheCellsVolumeAndFollowTheIsentrope) {
  const double gamma = 1.4;
  // Three particles of a cell with pressures around 1: at the common pressure their volumes sum to
  // the cell's (to round-off), the high-pressure particle expands and the low one is compressed.
  const double volume[3] = {0.2, 0.3, 0.5}, pressure[3] = {1.1, 0.95, 0.99};
  double total = 0, pressure_volume = 0;
  for (int k = 0; k < 3; ++k) total += volume[k], pressure_volume += volume[k] * pressure[k];
  const double mean = pressure_volume / total;
  // A particle's volume at the common pressure: its volume times relaxed_volume_ratio.
  auto relaxed_volume_share = [&](double v, double p, double common) {
    return v * relaxed_volume_ratio(p, common, 1 / (gamma * common));
  };
  double shares = 0;
  for (int k = 0; k < 3; ++k) shares += relaxed_volume_share(volume[k], pressure[k], mean);
  EXPECT_NEAR(shares, total, round_off(1e-15));
  EXPECT_GT(relaxed_volume_share(volume[0], pressure[0], mean), volume[0]);
  EXPECT_LT(relaxed_volume_share(volume[1], pressure[1], mean), volume[1]);
  // To first order the isentrope V (p / P)^(1 / gamma): 2 % off in pressure, 4e-5 relative off in volume.
  const double exact = volume[0] * std::pow(1.02, 1 / gamma);
  EXPECT_NEAR(relaxed_volume_share(volume[0], 1.02, 1.0), exact, 1e-4 * exact);
}

TEST(SubCellConsistency, VolumeCorrectionCompressesOverfilledAndExpandsUnderfilledSpace) {
  // A particle at its nodes' mean pressure (real_t: unchanged is the density as the build holds it).
  const real_t rho = 1.4, rate = 0.1, p = 1.0;
  EXPECT_DOUBLE_EQ(volume_corrected_density(rho, 1.0, rate, p, p), rho);
  EXPECT_NEAR(volume_corrected_density(rho, 1.1, rate, p, p), rho * 1.01, round_off(1e-12));  // over-filled: denser
  EXPECT_NEAR(volume_corrected_density(rho, 0.9, rate, p, p), rho * 0.99, round_off(1e-12));  // part empty: lighter
  // Where the gas does not fill the stencil (a free surface, a near-vacuum) or phi is wild: unchanged.
  EXPECT_DOUBLE_EQ(volume_corrected_density(rho, 0.4, rate, p, p), rho);
  EXPECT_DOUBLE_EQ(volume_corrected_density(rho, 2.5, rate, p, p), rho);
  EXPECT_DOUBLE_EQ(volume_corrected_density(rho, std::nan(""), rate, p, p), rho);
  // A pressure that is not positive: unchanged.
  EXPECT_DOUBLE_EQ(volume_corrected_density(rho, 1.1, rate, 0.0, p), rho);
  EXPECT_DOUBLE_EQ(volume_corrected_density(rho, 1.1, rate, -1.0, p), rho);
}

// A particle weighed by its pressure against its nodes' mean. Compressed: one 20 times above the
// mean by a twentieth of the full rate, one at a tenth of it by ten times the full rate, at most a
// doubling (compressed at the full rate, dense particles in thin gas behind the aerofoil were
// compressed again and again: densities of 1e10). Expanded: one at a tenth of the mean by a tenth
// of the full rate, one above it by the full rate.
TEST(SubCellConsistency, VolumeCorrectionTakesTheOverfillFromTheSoftParticlesAndExpandsNoneBelowTheMeanFully) {
  const real_t rho = 1.4, rate = 0.1, mean = 1.0;
  EXPECT_NEAR(volume_corrected_density(rho, 1.5, rate, 20.0, mean), rho * (1 + 0.05 / 20), round_off(1e-12));
  EXPECT_NEAR(volume_corrected_density(rho, 1.5, rate, 0.1, mean), rho * 1.5, round_off(1e-12));
  EXPECT_NEAR(volume_corrected_density(rho, 1.5, rate, 0.001, mean), rho * 2, round_off(1e-12));  // at most doubled
  EXPECT_NEAR(volume_corrected_density(rho, 0.6, rate, 0.1, mean), rho * (1 - 0.04 * 0.1), round_off(1e-12));
  EXPECT_NEAR(volume_corrected_density(rho, 0.6, rate, 20.0, mean), rho * 0.96, round_off(1e-12));
  // Repeated over many steps at phi = 1.5 (the dense particle's volume does not bring phi down),
  // its density grows as its pressure over the mean allows, not geometrically: by
  // rate (phi - 1) mean / ((gamma - 1) e) a step, 0.0035, to 1.5 rho after 200 steps. (Bounded by
  // 1.5 rho instead, the test failed in single precision, which reached it to the last bit.)
  double dense = rho, pressure = 20.0;
  const double energy = pressure / (0.4 * dense);
  for (int step = 0; step < 200; ++step) {
    dense = volume_corrected_density(dense, 1.5, rate, pressure, mean);
    pressure = 0.4 * dense * energy;
  }
  EXPECT_NEAR(dense, rho + 200 * rate * 0.5 * mean / (0.4 * energy), round_off(1e-12));  // (at the full rate, 1.05^200 = 1.7e4 times)
  // And a thin particle at a tenth of the mean in an under-filled node thins out slowly, not
  // geometrically at the full rate (0.96^200 = 2.8e-4 times).
  double thin = 0.14;
  pressure = 0.1;
  const double thin_energy = pressure / (0.4 * thin);
  for (int step = 0; step < 200; ++step) {
    thin = volume_corrected_density(thin, 0.6, rate, pressure, mean);
    pressure = 0.4 * thin * thin_energy;
  }
  EXPECT_GT(thin, 0.14 / 2);
}

TEST(SubCellConsistency, NodeVolumeFractionIsNeutralWhereTheSpaceIsUnknownAndOneSidedNextToABody) {
  const double smallest = 0.25;
  for (const bool gas_outside : {false, true}) {
    EXPECT_DOUBLE_EQ(node_volume_fraction(1.1, 1.0, smallest, gas_outside), real_t(1.1));
    EXPECT_DOUBLE_EQ(node_volume_fraction(0.5, 0.5, smallest, gas_outside), 1.0);  // on a side: half the space, half the volume
    EXPECT_DOUBLE_EQ(node_volume_fraction(0.3, 0.0, smallest, gas_outside), 1.0);  // beyond the domain, at a far-field side
    EXPECT_DOUBLE_EQ(node_volume_fraction(0.3, 0.2, smallest, gas_outside), 1.0);  // a corner cut by a body
    EXPECT_DOUBLE_EQ(node_volume_fraction(0.45, -0.5, smallest, gas_outside), real_t(0.9));  // next to a body: a shortfall counts
    EXPECT_DOUBLE_EQ(node_volume_fraction(0.6, -0.5, smallest, gas_outside), 1.0);   // an excess does not
  }
}

// A node whose space the particles fill less than half of (the edge of a near-vacuum, a gap
// between the gas and a body) marks every particle whose stencil reaches it, whatever its weight
// there, as one the volume correction leaves alone; a pressure side's node does not (the gas
// outside fills what the particles leave). A particle whose stencil's nodes are 1, 1 and 0.2 full
// (phi 0.8 as a mean) had been expanded at every step, at its specific energy, and heated as the
// flow compressed it again (README, Status: the block's wake).
TEST(SubCellConsistency, ANodeTheGasLeavesMoreThanHalfEmptyLeavesTheParticlesReachingItAlone) {
  const real_t smallest = 0.25, rho = 1.4, rate = 0.1, p = 1.0;
  const double unfilled = node_volume_fraction(0.2, 1.0, smallest, false);
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.2, 1.0, smallest, true), real_t(0.2));  // a pressure side's
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.5, 1.0, smallest, false), 0.5);  // half full: a fraction still
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.2, -1.0, smallest, false), unfilled);  // a gap beside a body
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.0, 1.0, smallest, false), unfilled);
  for (const double weight : {0.5, 1e-3, 1e-12, 1e-25}) {
    const double phi = (1 - weight) * 0.95 + weight * unfilled;  // interpolated over the stencil
    EXPECT_DOUBLE_EQ(volume_corrected_density(rho, phi, rate, p, p), rho) << weight;
  }
  EXPECT_NEAR(volume_corrected_density(rho, 0.95, rate, p, p), rho * 0.995, round_off(1e-12));  // without that node: expanded
  // Single precision too: the sum of a stencil's nine nodes at the mark stays finite.
  EXPECT_LT(9 * static_cast<double>(unfilled_node_volume_fraction), static_cast<double>(std::numeric_limits<float>::max()));
}

// A copy of a View's elements on the host (a mirror of a host View is the View itself).
template <class T>
std::vector<T> host_copy(const Kokkos::View<T*, Kokkos::LayoutLeft, DeviceType>& view) {
  std::vector<T> copy(view.extent(0));
  Kokkos::deep_copy(Kokkos::View<T*, Kokkos::HostSpace, Kokkos::MemoryUnmanaged>(copy.data(), copy.size()), view);
  return copy;
}
// ... and back: `values` into the View's elements.
template <class T>
void copy_into(const Kokkos::View<T*, Kokkos::LayoutLeft, DeviceType>& view, const std::vector<T>& values) {
  Kokkos::deep_copy(view,
                    Kokkos::View<const T*, Kokkos::HostSpace, Kokkos::MemoryUnmanaged>(values.data(), values.size()));
}

// The relaxation's pass over the particles (run in vector lanes on CPUs), on Sod's cells with a few
// per cent of density noise, and one cell with 40 %: in each cell that relaxes (fraction f from its
// sums, pressure_relaxation_fraction), the volume sum(M / rho) and the internal energy sum(M e) are
// kept to round-off and each particle's pressure goes the fraction f of the way to the cell's
// P = (gamma - 1) sum(M e) / sum(V), p' - P = (1 - f) (p - P) to first order in the noise (a pass
// that relaxed the density alone would give (1 - f / gamma) (p - P)); the noisy cell does not relax
// and is left alone, bit for bit. Every particle then has the cell of its position. With each P2G
// strategy: their cell sums differ.
TEST(SubCellConsistency, TheRelaxationPassKeepsEachCellsVolumeAndEnergyAndEvensItsPressures) {
  for (const P2GStrategy strategy : {P2GStrategy::sorted, P2GStrategy::duplicated}) {
    SCOPED_TRACE(static_cast<int>(strategy));
    CaseConfig config = load_case_file(std::string(MPMFLOW_SOURCE_DIR) + "/cases/sod.json",
                                       {"domain/y=[0,0.01]", "initial_state/regions/0/y=[0,0.01]",
                                        "output/snapshots=0", "numerics/pressure_relaxation=true"});
    config.numerics.p2g = strategy;
    const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
    const SlabState slab_state(config, slab);
    ParticleState pt = create_initial_particles(config, slab);
    GridFields fields(slab.geometry);
    const auto transfers = make_transfer_kernels(config, slab.geometry, fields);
    const real_t gamma = config.physics.gamma, h = slab.cell_size(), dt = real_t(0.4) * h;  // dt c / h about 0.45
    const ThermodynamicConstants constants = thermodynamic_constants(config, h);
    // Sod's one row of cells lies between ghost rows: the interior cell 7 along x.
    const index_t noisy_cell = slab.geometry.cell_of(real_t(0.075), real_t(0.005));
    std::vector<real_t> rho = host_copy(pt.density);
    const std::vector<index_t> cell = host_copy(pt.cell);
    for (index_t k = 0; k < pt.count; ++k)
      rho[k] *= 1 + (cell[k] == noisy_cell ? real_t(0.4) * (k % 2 ? 1 : -1)
                                           : real_t(0.04) * std::sin(real_t(1.7) * k));
    copy_into(pt.density, rho);
    const std::vector<real_t> e = host_copy(pt.specific_energy), m = host_copy(pt.mass);
    // What the relaxation's sums are made of, per cell, before.
    struct Sums {
      double volume = 0, energy = 0, mass = 0, pressure_squared_volume = 0, density_squared_volume = 0;
      double fraction = 0;  // the cell's, as the relaxation makes it from the sums above
    };
    std::map<index_t, Sums> before;
    for (index_t k = 0; k < pt.count; ++k) {
      Sums& c = before[cell[k]];
      const double v = m[k] / rho[k], p = perfect_gas_pressure(gamma, rho[k], e[k]);
      c.volume += v, c.energy += m[k] * e[k], c.mass += m[k];
      c.pressure_squared_volume += v * p * p, c.density_squared_volume += m[k] * rho[k];
    }
    for (auto& [c, sums] : before)
      sums.fraction = pressure_relaxation_fraction(
          gamma, dt / h, sums.volume, sums.mass, sums.energy,
          relative_spread(sums.volume, (gamma - 1) * sums.energy, sums.pressure_squared_volume),
          relative_spread(sums.volume, sums.mass, sums.density_squared_volume));
    transfers->p2g_mass_momentum_force(pt);  // (as in a step: the sorted strategy groups its particles there)
    transfers->relax_pressures_and_locate(pt, constants, dt, slab_state.particle_boundaries().locator());

    const std::vector<real_t> rho_after = host_copy(pt.density), e_after = host_copy(pt.specific_energy);
    const std::vector<real_t> x = host_copy(pt.position_x), y = host_copy(pt.position_y);
    const std::vector<index_t> cell_after = host_copy(pt.cell);
    std::map<index_t, Sums> after;
    for (index_t k = 0; k < pt.count; ++k) {
      EXPECT_EQ(cell_after[k], slab.geometry.cell_of(x[k], y[k])) << "particle " << k;
      const Sums& c = before[cell[k]];
      after[cell[k]].volume += m[k] / rho_after[k];
      after[cell[k]].energy += m[k] * e_after[k];
      const double fraction = c.fraction;
      if (fraction == 0) {
        EXPECT_EQ(rho_after[k], rho[k]) << "particle " << k << " of cell " << cell[k];
        EXPECT_EQ(e_after[k], e[k]) << "particle " << k << " of cell " << cell[k];
        continue;
      }
      const double mean = (gamma - 1) * c.energy / c.volume, p = perfect_gas_pressure(gamma, rho[k], e[k]);
      const double relaxed = perfect_gas_pressure(gamma, rho_after[k], e_after[k]);
      EXPECT_NEAR(relaxed - mean, (1 - fraction) * (p - mean), 0.05 * std::fabs(p - mean) + round_off(1e-12) * mean)
          << "particle " << k << " of cell " << cell[k] << ", fraction " << fraction;
    }
    int relaxed_cells = 0, still_cells = 0;
    for (const auto& [c, sums] : before) {
      EXPECT_NEAR(after[c].volume, sums.volume, round_off(1e-12) * sums.volume) << "cell " << c;
      EXPECT_NEAR(after[c].energy, sums.energy, round_off(1e-12) * sums.energy) << "cell " << c;
      (sums.fraction > 0 ? relaxed_cells : still_cells) += 1;
      if (c == noisy_cell) EXPECT_EQ(sums.fraction, 0) << "a spread of 40 % is left alone";
    }
    EXPECT_EQ(relaxed_cells, 99);  // (the contact lies on a cell face: no cell's spread holds it)
    EXPECT_EQ(still_cells, 1);
  }
}

// Step 10's particle update (G2P and G2PD with UpdateThermodynamics) on the CPUs' sorted walk, whose
// windows store into a batch's lanes only the interpolations the update says it reads
// (InterpolationsRead), against the same update on the duplicated ScatterView's batches, which
// store them all: the same particles to round-off. Every node column the update interpolates
// varies from node to node and every particle field it reads from particle to particle, so an
// interpolation read but not listed (whatever the stack held, in the walk) shows. Linear and GIMP,
// with the volume correction and the energy-consistent work. (A function of its own: after the
// test's skip on GPUs, nvcc warns of an unreachable loop.)
void expect_the_sorted_walks_update_to_be_the_batches_one() {
  for (const char* shape : {"linear", "gimp"}) {
    SCOPED_TRACE(shape);
    std::vector<std::vector<real_t>> updated[2];
    const P2GStrategy strategies[2] = {P2GStrategy::sorted, P2GStrategy::duplicated};
    for (int s = 0; s < 2; ++s) {
      CaseConfig config = load_case_file(std::string(MPMFLOW_SOURCE_DIR) + "/cases/cylinder_mach3.json",
                                         {"domain/cells_x=48", "domain/cells_y=24", "output/snapshots=0",
                                          std::string("numerics/shape_function=") + shape});
      config.numerics.p2g = strategies[s];
      const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
      ParticleState pt = create_initial_particles(config, slab);
      GridFields fields(slab.geometry);
      const auto transfers = make_transfer_kernels(config, slab.geometry, fields);
      ASSERT_EQ(transfers->strategy(), strategies[s]);
      // Particles' fields varied, then step 3 as in a step (the sorted walk groups the particles there).
      const auto vary = [](const RealView& field, real_t amplitude, real_t rate, real_t offset) {
        std::vector<real_t> values = host_copy(field);
        for (size_t k = 0; k < values.size(); ++k)
          values[k] = (offset + values[k]) * (1 + amplitude * std::sin(rate * k));
        copy_into(field, values);
      };
      vary(pt.density, real_t(0.05), real_t(1.3), 0);
      vary(pt.specific_energy, real_t(0.03), real_t(0.7), 0);
      vary(pt.artificial_viscosity, real_t(0.5), real_t(0.4), real_t(0.01));
      vary(pt.domain_stretch_x, real_t(0.1), real_t(0.9), 0);
      vary(pt.domain_stretch_y, real_t(0.1), real_t(1.1), 0);
      transfers->p2g_mass_momentum_force(pt);
      // The node columns step 10 reads (MoveAndRemapVelocity), each varying in its own way.
      const GridGeometry& g = slab.geometry;
      const real_t pressure = config.initial_state.background.pressure;  // (the particles' before the variations)
      ASSERT_GT(pressure, 0);
      auto nodes = Kokkos::create_mirror_view(fields.per_unit_mass);
      for (index_t j = 0; j < g.nodes_y; ++j)
        for (index_t i = 0; i < g.nodes_x; ++i) {
          const index_t n = g.node_index(i, j);
          nodes(n, GridFields::velocity_x) = 3 + 0.4 * std::sin(0.37 * i + 0.21 * j);
          nodes(n, GridFields::velocity_y) = 0.3 * std::cos(0.29 * i - 0.43 * j);
          nodes(n, GridFields::remap_velocity_x) = 3 + 0.5 * std::sin(0.23 * i) * std::cos(0.31 * j);
          nodes(n, GridFields::remap_velocity_y) = 0.4 * std::cos(0.19 * i + 0.27 * j);
          nodes(n, GridFields::volume_fraction) = 1 + 0.2 * std::sin(0.41 * i - 0.17 * j);
          nodes(n, GridFields::mean_pressure) = pressure * (1 + 0.1 * std::cos(0.13 * i + 0.53 * j));
        }
      Kokkos::deep_copy(fields.per_unit_mass, nodes);
      const real_t h = slab.cell_size();
      const ThermodynamicConstants constants = thermodynamic_constants(config, h);
      ASSERT_TRUE(constants.energy_consistent && constants.volume_correction);  // (the case's, as a run takes them)
      transfers->g2pd_particle_update(pt, constants, real_t(0.1) * h / 4);
      for (const RealView& field : {pt.density, pt.specific_energy, pt.artificial_viscosity, pt.position_x,
                                    pt.position_y, pt.domain_stretch_x, pt.domain_stretch_y})
        updated[s].push_back(host_copy(field));
    }
    const char* names[] = {"density", "specific energy", "viscosity", "x", "y", "stretch x", "stretch y"};
    for (size_t f = 0; f < updated[0].size(); ++f) {
      const std::vector<real_t>& walked = updated[0][f];
      const std::vector<real_t>& batched = updated[1][f];
      ASSERT_EQ(walked.size(), batched.size());
      double largest = 0;
      for (const real_t value : batched) largest = std::max<double>(largest, std::fabs(value));
      ASSERT_GT(largest, 0) << names[f];
      for (size_t k = 0; k < walked.size(); ++k)
        ASSERT_NEAR(walked[k], batched[k], 1e-12 * largest) << names[f] << " of particle " << k;
    }
  }
}
TEST(ParticleUpdate, TheSortedWalkGivesTheUpdateEveryInterpolationItReads) {
  if (!std::is_same<MemorySpace, Kokkos::HostSpace>::value) GTEST_SKIP() << "the windows are the CPUs' walk";
  expect_the_sorted_walks_update_to_be_the_batches_one();
}

}  // namespace
}  // namespace mpmflow
