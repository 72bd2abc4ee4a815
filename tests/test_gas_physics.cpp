// The pointwise physics of gas_physics.hpp that the sub-cell consistency of the step rests on (the
// pressure relaxation's fraction and volume shares, the volume correction's density), the nodes'
// volume fraction (grid_phases.hpp) the correction reads, and the relaxation's pass over the
// particles (TransferKernels::relax_pressures_and_locate).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "case_config.hpp"
#include "gas_physics.hpp"
#include "grid_phases.hpp"
#include "particles.hpp"
#include "slab_state.hpp"
#include "transfers.hpp"

namespace mpmflow {
namespace {

TEST(SubCellConsistency, TheAcousticFractionIsTheShareOfACellSoundCrossesAtMostAll) {
  const double h = 0.1;
  EXPECT_DOUBLE_EQ(acoustic_fraction(0.01 / h, 2.0), 0.2);
  EXPECT_DOUBLE_EQ(acoustic_fraction(0.1 / h, 2.0), 1.0);
  EXPECT_DOUBLE_EQ(acoustic_fraction(0.01 / h, 0.0), 0.0);
}

TEST(SubCellConsistency, RelativeSpreadIsTheVolumeWeightedDeviationOverTheMean) {
  // Two particles of volume 1 with q = 0.9 and 1.1: mean 1, deviation 0.1.
  EXPECT_NEAR(relative_spread(2.0, 0.9 + 1.1, 0.81 + 1.21), 0.1, 1e-12);
  EXPECT_DOUBLE_EQ(relative_spread(2.0, 2.0, 2.0), 0.0);  // all equal
}

TEST(SubCellConsistency, PressureRelaxationActsOnNoiseAtTheAcousticRateAndLeavesShocksAlone) {
  const double gamma = 1.4, h = 0.1, dt = 0.01;
  // A cell of gas with c = 1: e = 1 / (gamma (gamma - 1)).
  const double mass = 1.4, energy = mass / (gamma * (gamma - 1));
  // Quiet: the acoustic fraction dt c / h = 0.1.
  EXPECT_NEAR(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.0, 0.0), 0.1, 1e-12);
  // Noise of 5 %: 1 - 0.05 / 0.25 of it.
  EXPECT_NEAR(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.05, 0.01), 0.08, 1e-12);
  EXPECT_NEAR(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.01, 0.05), 0.08, 1e-12);
  // A shock or a contact within the cell (spread 25 % or more): nothing.
  EXPECT_EQ(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.3, 0.0), 0.0);
  EXPECT_EQ(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.0, 0.25), 0.0);
  // A long step: at most all the way.
  EXPECT_NEAR(pressure_relaxation_fraction(gamma, 1.0 / h, 1.0, mass, energy, 0.0, 0.0), 1.0, 1e-12);
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
  EXPECT_NEAR(shares, total, 1e-15);
  EXPECT_GT(relaxed_volume_share(volume[0], pressure[0], mean), volume[0]);
  EXPECT_LT(relaxed_volume_share(volume[1], pressure[1], mean), volume[1]);
  // To first order the isentrope V (p / P)^(1 / gamma): 2 % off in pressure, 4e-5 relative off in volume.
  const double exact = volume[0] * std::pow(1.02, 1 / gamma);
  EXPECT_NEAR(relaxed_volume_share(volume[0], 1.02, 1.0), exact, 1e-4 * exact);
}

// For particles of one pressure p the node's step is (phi - 1) p, and the density goes by
// 1 + rate (phi - 1).
double corrected_at_one_pressure(double rho, double p, double phi, double rate) {
  const double volume = 2.0;  // the node's particle volume, and its sum V p
  return volume_corrected_density(rho, p, overfill_pressure_step(phi, p * volume, volume), rate);
}

TEST(SubCellConsistency, VolumeCorrectionCompressesOverfilledAndExpandsUnderfilledSpace) {
  const double rho = 1.4, p = 1.0, rate = 0.1;
  EXPECT_DOUBLE_EQ(corrected_at_one_pressure(rho, p, 1.0, rate), rho);
  EXPECT_NEAR(corrected_at_one_pressure(rho, p, 1.1, rate), rho * 1.01, 1e-12);  // over-filled: denser
  EXPECT_NEAR(corrected_at_one_pressure(rho, p, 0.9, rate), rho * 0.99, 1e-12);  // part empty: lighter
  EXPECT_NEAR(corrected_at_one_pressure(rho, 7.0, 1.1, rate), rho * 1.01, 1e-12);  // whatever the pressure
  // Where the gas does not fill the stencil (a free surface, a near-vacuum) or phi is wild: unchanged.
  EXPECT_DOUBLE_EQ(corrected_at_one_pressure(rho, p, 0.4, rate), rho);
  EXPECT_DOUBLE_EQ(corrected_at_one_pressure(rho, p, 2.5, rate), rho);
  EXPECT_DOUBLE_EQ(corrected_at_one_pressure(rho, p, std::nan(""), rate), rho);
  EXPECT_DOUBLE_EQ(overfill_pressure_step(1.1, 1.0, 0.0), 0.0);  // a node without particle volume
  // A pressure that is not positive, a step that is not a number: unchanged.
  EXPECT_DOUBLE_EQ(volume_corrected_density(rho, 0.0, 0.1, rate), rho);
  EXPECT_DOUBLE_EQ(volume_corrected_density(rho, p, std::nan(""), rate), rho);
}

// Dense gas sharing an over-filled node with thin gas at a fraction of its pressure: one pressure
// step for all, so the thin, soft particles are compressed far more than the dense ones (the same
// fraction for all compressed dense particles again and again: densities of 1e10 behind the
// aerofoil). For one node's particles: the thin one's relative change p_dense / p_thin times the
// dense one's; and within the bounds of a uniform gas's (at most doubled, at least halved).
TEST(SubCellConsistency, VolumeCorrectionCompressesTheSoftParticlesOfAMixedNodeMost) {
  const double rate = 0.2;
  const double thin_volume = 8, thin_pressure = 0.05, dense_volume = 0.1, dense_pressure = 20;
  const double volume = thin_volume + dense_volume, pressure_volume = thin_volume * thin_pressure +
                                                                     dense_volume * dense_pressure;
  const double step = overfill_pressure_step(1.5, pressure_volume, volume);
  const double dense_change = volume_corrected_density(1.0, dense_pressure, step, rate) - 1;
  const double thin_change = volume_corrected_density(1.0, thin_pressure, step, rate) - 1;
  EXPECT_GT(dense_change, 0);
  EXPECT_LT(dense_change, 0.002);  // (the old correction: rate (phi - 1) = 0.1)
  EXPECT_NEAR(thin_change, std::min(1.0, dense_change * dense_pressure / thin_pressure), 1e-12);
  EXPECT_GT(thin_change, 0.1);
  EXPECT_LE(thin_change, 1.0);
  EXPECT_GE(volume_corrected_density(1.0, thin_pressure, -step, rate), 0.5);  // under-filled: at most halved
}

TEST(SubCellConsistency, NodeVolumeFractionIsNeutralWhereTheSpaceIsUnknownAndOneSidedNextToABody) {
  const double smallest = 0.25;
  EXPECT_DOUBLE_EQ(node_volume_fraction(1.1, 1.0, smallest), 1.1);
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.5, 0.5, smallest), 1.0);  // on a side: half the space, half the volume
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.3, 0.0, smallest), 1.0);  // beyond the domain, at a far-field side
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.3, 0.2, smallest), 1.0);  // a corner cut by a body
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.45, -0.5, smallest), 0.9);  // next to a body: a shortfall counts
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.6, -0.5, smallest), 1.0);   // an excess does not
}

// A copy of a View's elements on the host (a mirror of a host View is the View itself).
template <class T>
std::vector<T> host_copy(const Kokkos::View<T*, Kokkos::LayoutLeft, DeviceType>& view) {
  std::vector<T> copy(view.extent(0));
  Kokkos::deep_copy(Kokkos::View<T*, Kokkos::HostSpace, Kokkos::MemoryUnmanaged>(copy.data(), copy.size()), view);
  return copy;
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
    const ThermodynamicConstants constants{gamma, h, config.physics.viscosity_quadratic,
                                           config.physics.viscosity_linear};
    // Sod's one row of cells lies between ghost rows: the interior cell 7 along x.
    const index_t noisy_cell = slab.geometry.cell_of(real_t(0.075), real_t(0.005));
    std::vector<real_t> rho = host_copy(pt.density);
    const std::vector<index_t> cell = host_copy(pt.cell);
    for (index_t k = 0; k < pt.count; ++k)
      rho[k] *= 1 + (cell[k] == noisy_cell ? real_t(0.4) * (k % 2 ? 1 : -1)
                                           : real_t(0.04) * std::sin(real_t(1.7) * k));
    Kokkos::deep_copy(pt.density,
                      Kokkos::View<real_t*, Kokkos::HostSpace, Kokkos::MemoryUnmanaged>(rho.data(), rho.size()));
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
      EXPECT_NEAR(relaxed - mean, (1 - fraction) * (p - mean), 0.05 * std::fabs(p - mean) + 1e-12 * mean)
          << "particle " << k << " of cell " << cell[k] << ", fraction " << fraction;
    }
    int relaxed_cells = 0, still_cells = 0;
    for (const auto& [c, sums] : before) {
      EXPECT_NEAR(after[c].volume, sums.volume, 1e-12 * sums.volume) << "cell " << c;
      EXPECT_NEAR(after[c].energy, sums.energy, 1e-12 * sums.energy) << "cell " << c;
      (sums.fraction > 0 ? relaxed_cells : still_cells) += 1;
      if (c == noisy_cell) EXPECT_EQ(sums.fraction, 0) << "a spread of 40 % is left alone";
    }
    EXPECT_EQ(relaxed_cells, 99);  // (the contact lies on a cell face: no cell's spread holds it)
    EXPECT_EQ(still_cells, 1);
  }
}

}  // namespace
}  // namespace mpmflow
