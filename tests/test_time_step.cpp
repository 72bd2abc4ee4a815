// The time step from the nodes (Solver::stable_time_step, max_node_signal_speed) and the grid it
// prepares for the next advance().
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "gas_physics.hpp"
#include "particles.hpp"
#include "solver.hpp"
#include "grid_phases.hpp"
#include "slab_state.hpp"
#include "transfers.hpp"
#include "kernels/index_lanes.hpp"
#include "kernels/transfer_kernels.hpp"
#include "round_off.hpp"

namespace mpmflow {
namespace {

// cases/sod.json at 100 cells (square cells), no output.
CaseConfig sod_case() {
  return load_case_file(std::string(MPMFLOW_SOURCE_DIR) + "/cases/sod.json",
                        {"domain/y=[0,0.01]", "initial_state/regions/0/y=[0,0.01]", "output/snapshots=0"});
}

std::unique_ptr<Solver> make_solver(const CaseConfig& config) {
  const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
  return std::make_unique<Solver>(config, slab, create_initial_particles(config, slab));
}

real_t value_at(const RealView& view, index_t k) {
  real_t value;
  Kokkos::deep_copy(value, Kokkos::subview(view, k));
  return value;
}

// Particle k given velocity (vx, 0) and its mass scaled by `mass_factor` (its volume with it, as
// splitting does: the same density and pressure).
void disturb(ParticleState& pt, index_t k, real_t vx, real_t mass_factor) {
  auto set = [&](const RealView& field, real_t value) { Kokkos::deep_copy(Kokkos::subview(field, k), value); };
  set(pt.velocity_x, vx);
  set(pt.mass, value_at(pt.mass, k) * mass_factor);
}

// The P2G's cheap test of the particle states (surely_valid_gas_state) never passes a state the
// time step's check (is_valid_gas_state) rejects, over ordinary, broken and extreme values; it
// passes the ordinary ones.
TEST(TimeStep, ASurelyValidStateIsValid) {
  using limits = std::numeric_limits<real_t>;
  const real_t gamma = 1.4, inf = limits::infinity(), nan = limits::quiet_NaN();
  // The extremes in terms of real_t's range (in double: about 2e-300, 1e150, 1e155 and 2e300): a
  // tiny value, one whose square fits, one whose square overflows, and one near the largest.
  const real_t root_of_largest = std::sqrt(limits::max());
  const real_t tiny = real_t(1e8) * limits::min(), square_fits = root_of_largest / real_t(1e4),
               square_overflows = root_of_largest * real_t(7.5), near_largest = limits::max() / real_t(1e8);
  const std::vector<real_t> values = {0, 1, -1, tiny, square_fits, square_overflows, near_largest, -near_largest,
                                      inf, -inf, nan};
  long surely = 0;
  for (real_t rho : values)
    for (real_t e : values)
      for (real_t vx : values)
        for (real_t vy : {real_t(0), real_t(2), square_overflows, nan}) {
          if (!surely_valid_gas_state(gamma, rho, e, vx, vy)) continue;
          ++surely;
          const real_t p = perfect_gas_pressure(gamma, rho, e);
          EXPECT_TRUE(is_valid_gas_state(rho, p, signal_speed(vx, vy, perfect_gas_sound_speed(gamma, e))))
              << "rho " << rho << " e " << e << " v (" << vx << ", " << vy << ")";
        }
  EXPECT_GT(surely, 0);
  EXPECT_TRUE(surely_valid_gas_state(gamma, 1.4, 1.78, 3, -0.5));
  EXPECT_TRUE(surely_valid_gas_state(gamma, 1e-6, 1e-8, 0, 0));
}

// The two forms of the loops below: the CPUs' vector lanes over blocks of indices, and the GPUs'
// index a thread, each run on whatever back-end the tests run on.
enum class LoopForm { in_blocks, one_by_one };

// The largest of the first n values with largest_over_indices' form `form` (a free function: nvcc
// takes device lambdas only in free or public member functions, and a TEST's body is private).
real_t largest_of(const RealView& values, index_t n, real_t nan_counts_as, LoopForm form) {
  const auto value_of = KOKKOS_LAMBDA(const index_t i) { return values(i); };
  return form == LoopForm::in_blocks ? largest_over_indices_in_blocks("test_largest", n, nan_counts_as, value_of)
                                     : largest_over_indices_one_by_one("test_largest", n, nan_counts_as, value_of);
}

// largest_over_indices (the nodes' signal speed runs in its vector lanes on CPUs), both forms: the
// largest value over lengths that end within a block of lanes and on its edge, wherever in the
// range it lies; a NaN anywhere wins as the caller's mark; no indices give Kokkos::Max's identity.
TEST(TimeStep, TheLargestOverIndicesFindsItAnywhereAndANaNWins) {
  const real_t mark = std::numeric_limits<real_t>::max(), nan = std::nan("");
  for (const LoopForm form : {LoopForm::in_blocks, LoopForm::one_by_one}) {
    SCOPED_TRACE(form == LoopForm::in_blocks ? "in blocks" : "one by one");
    for (index_t n : {1, 31, 32, 33, 100, 1000}) {
      for (index_t at : {index_t(0), n / 2, n - 1}) {
        RealView values("values", n);
        auto host = Kokkos::create_mirror_view(values);
        for (index_t i = 0; i < n; ++i) host(i) = real_t(0.5) + real_t(i % 7) / 16;
        host(at) = 3;
        Kokkos::deep_copy(values, host);
        EXPECT_EQ(largest_of(values, n, mark, form), 3) << n << " " << at;
        Kokkos::deep_copy(Kokkos::subview(values, at), nan);
        EXPECT_EQ(largest_of(values, n, mark, form), mark) << n << " " << at;
      }
    }
    EXPECT_EQ(largest_of(RealView("none", 0), 0, mark, form), std::numeric_limits<real_t>::lowest());
  }
}

// Marks with for_each_index_where's form `form`, where index i in [first, last) is a multiple of
// `every` (a free function, for nvcc, as largest_of).
IndexView marked_where(index_t n, index_t first, index_t last, index_t every, LoopForm form) {
  IndexView mark("mark", n);
  const auto maybe = KOKKOS_LAMBDA(const index_t i) { return i % every == 0; };
  const auto body = KOKKOS_LAMBDA(const index_t i) { mark(i) += 1; };
  if (form == LoopForm::in_blocks) for_each_index_where_in_blocks("test_where", first, last, maybe, body);
  else for_each_index_where_one_by_one("test_where", first, last, maybe, body);
  return mark;
}

// for_each_index_where (the far-field sides' strips take it), both forms: the body runs once for
// each index of the range the test selects and for no other, over ranges that start and end within
// a block of lanes and on its edges, and for no index of an empty range.
TEST(TimeStep, ForEachIndexWhereRunsTheBodyForTheSelectedIndicesAlone) {
  const index_t n = 1000;
  for (const LoopForm form : {LoopForm::in_blocks, LoopForm::one_by_one})
    for (index_t first : {0, 7, 32}) {
      for (index_t last : {first, first + 1, index_t(64), index_t(999), n}) {
        for (index_t every : {1, 5, 33}) {
          const auto mark =
              Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), marked_where(n, first, last, every, form));
          index_t wrong = 0;
          for (index_t i = 0; i < n; ++i) wrong += mark(i) != ((i >= first && i < last && i % every == 0) ? 1 : 0);
          EXPECT_EQ(wrong, 0) << (form == LoopForm::in_blocks ? "in blocks " : "one by one ") << first << " "
                              << last << " " << every;
        }
      }
    }
}

// Marks every index of [0, n) with for_each_index_in_lanes' form `form` (a free function, for nvcc,
// as largest_of).
IndexView marked_each(index_t n, LoopForm form) {
  IndexView mark("mark", n + 1);  // one more, which no body may touch
  const auto body = KOKKOS_LAMBDA(const index_t i) { mark(i) += 1; };
  if (form == LoopForm::in_blocks) for_each_index_in_blocks("test_each", n, body);
  else for_each_index_one_by_one("test_each", n, body);
  return mark;
}

// for_each_index_in_lanes (the relaxation's passes and the cell map take it), both forms: the body
// runs once for each index, over counts that end within a block of lanes and on its edge, and for
// none beyond.
TEST(TimeStep, ForEachIndexInLanesRunsTheBodyOnceForEachIndex) {
  for (const LoopForm form : {LoopForm::in_blocks, LoopForm::one_by_one})
    for (index_t n : {0, 1, 31, 32, 33, 64, 1000}) {
      const auto mark = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), marked_each(n, form));
      index_t wrong = 0;
      for (index_t i = 0; i <= n; ++i) wrong += mark(i) != (i < n ? 1 : 0);
      EXPECT_EQ(wrong, 0) << (form == LoopForm::in_blocks ? "in blocks " : "one by one ") << n;
    }
}

// The sums over i in [0, n) where i is a multiple of `every` of i + 1 into total i % 3, by
// sums_over_indices_where's form `form` (a free function, for nvcc, as largest_of).
std::vector<double> summed_where(index_t n, index_t every, LoopForm form) {
  std::vector<double> totals(3, -1.0);  // (not 0: each must be written)
  const auto maybe = KOKKOS_LAMBDA(const index_t i) { return i % every == 0; };
  const auto body = KOKKOS_LAMBDA(const index_t i, double* sums) { sums[i % 3] += double(i + 1); };
  if (form == LoopForm::in_blocks)
    sums_over_indices_where_in_blocks("test_sums_where", n, 3, maybe, body, totals.data());
  else
    sums_over_indices_where_one_by_one("test_sums_where", n, 3, maybe, body, totals.data());
  return totals;
}

// sums_over_indices_where (the particle rules' lost energy and obstacle impulses take it), both
// forms: what the body adds for each selected index, once, and for no other (whole numbers: exact
// in any order), into each total, over counts that end within a block of lanes and on its edge,
// within a chunk of sum_in_fixed_chunks and on its edge, and zeros for no indices.
TEST(TimeStep, SumsOverIndicesWhereAddTheSelectedIndicesAlone) {
  for (const LoopForm form : {LoopForm::in_blocks, LoopForm::one_by_one})
    for (index_t n : {0, 1, 31, 32, 33, 64, 1000, 1024, 1025, 5000})
      for (index_t every : {1, 5, 33}) {
        std::vector<double> expected(3, 0.0);
        for (index_t i = 0; i < n; i += every) expected[static_cast<size_t>(i % 3)] += double(i + 1);
        EXPECT_EQ(summed_where(n, every, form), expected)
            << (form == LoopForm::in_blocks ? "in blocks " : "one by one ") << n << " " << every;
      }
}

// The nodes' signal speed is |mv / m| + sqrt(gamma (sum phi P V) / m) over the nodes holding more
// than the threshold's mass: against a host loop, over a grid of varied nodes, one of them fast
// and one nearly empty node faster, which must not count.
TEST(TimeStep, TheNodesSignalSpeedIsTheLargestOverTheNodesHoldingMass) {
  const CaseConfig config = sod_case();
  const SlabState slab_state(config, make_grid_slab(config.domain, 0, config.domain.cells_x));
  const GridFields& fields = slab_state.fields();
  auto state = Kokkos::create_mirror_view(fields.state);
  const index_t fast = 57, empty = 90, nodes = static_cast<index_t>(state.extent(0));
  ASSERT_GT(nodes, empty);
  for (index_t i = 0; i < nodes; ++i) {
    const real_t m = real_t(0.5) + real_t(i % 5) / 10;
    state(i, GridFields::mass) = m;
    state(i, GridFields::momentum_x) = real_t(i % 3 - 1) * m / 5;
    state(i, GridFields::momentum_y) = real_t(i % 4) * m / 7;
    state(i, GridFields::pressure_volume) = m * (1 + real_t(i % 6) / 10);
  }
  state(fast, GridFields::momentum_x) = 7 * state(fast, GridFields::mass);
  state(empty, GridFields::mass) = 1e-30;
  state(empty, GridFields::momentum_x) = 100 * 1e-30;
  Kokkos::deep_copy(fields.state, state);
  const real_t gamma = 1.4, threshold = 1e-20;
  real_t expected = 0;
  for (index_t i = 0; i < nodes; ++i) {
    const real_t m = state(i, GridFields::mass);
    if (!(m > threshold)) continue;
    expected = std::max(expected, std::hypot(state(i, GridFields::momentum_x) / m, state(i, GridFields::momentum_y) / m) +
                                      std::sqrt(gamma * state(i, GridFields::pressure_volume) / m));
  }
  EXPECT_GT(expected, 7);
  EXPECT_LT(expected, 100);
  EXPECT_NEAR(max_node_signal_speed(fields, gamma, threshold), expected, round_off(1e-14) * expected);
}

// Step 3's P2G counts the particles in doubt of its own pass, with each P2G strategy: none, then
// the two given a negative density (neighbours, in one batch of the CPU walk's vector lanes, which
// counts a batch's at once), then none again once they are mended.
TEST(TimeStep, TheP2GCountsTheParticlesInDoubtOfItsOwnPass) {
  for (const P2GStrategy strategy : {P2GStrategy::duplicated, P2GStrategy::atomic, P2GStrategy::sorted}) {
    CaseConfig config = sod_case();
    config.numerics.p2g = strategy;
    const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
    const ParticleState pt = create_initial_particles(config, slab);
    GridFields fields(slab.geometry);
    const auto transfers = make_transfer_kernels(config, slab.geometry, fields);
    const index_t victims[] = {17, 19};
    const real_t density = value_at(pt.density, victims[0]);
    ASSERT_EQ(value_at(pt.density, victims[1]), density);
    auto set_density = [&](real_t value) {
      for (const index_t victim : victims) Kokkos::deep_copy(Kokkos::subview(pt.density, victim), value);
    };
    transfers->p2g_mass_momentum_force(pt);
    EXPECT_EQ(transfers->particles_in_doubt(), 0);
    set_density(-1);
    transfers->p2g_mass_momentum_force(pt);
    EXPECT_EQ(transfers->particles_in_doubt(), 2);
    set_density(density);
    transfers->p2g_mass_momentum_force(pt);
    EXPECT_EQ(transfers->particles_in_doubt(), 0) << "the count of an earlier pass stayed";
  }
}

// numerics/p2g = automatic: on CPUs the sorted P2G where its walk keeps the threads busy (the
// cylinder's 448 x 224 cells on these tests' 1 or 2 threads), else duplicated (Sod's 100 x 1);
// atomic on GPUs.
TEST(TimeStep, AutomaticP2GTakesTheSortedWalkWhereItKeepsTheThreadsBusy) {
  CaseConfig sod = sod_case();
  CaseConfig wide = sod;
  wide.domain.cells_x = 448;
  wide.domain.cells_y = 224;
  CaseConfig wide_reordered = wide;
  wide_reordered.numerics.reorder_interval = 20;
  for (const CaseConfig& config : {sod, wide, wide_reordered}) {
    ASSERT_EQ(config.numerics.p2g, P2GStrategy::automatic);
    const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
    GridFields fields(slab.geometry);
    const auto transfers = make_transfer_kernels(config, slab.geometry, fields);
    const bool busy = walk_keeps_threads_busy(slab.geometry.cells_x(), slab.geometry.cells_y(),
                                              particle_order_of(config.numerics),
                                              ExecutionSpace().concurrency());
    const P2GStrategy expected = !cpu_code_paths ? P2GStrategy::atomic
                                 : busy          ? P2GStrategy::sorted
                                                 : P2GStrategy::duplicated;
    EXPECT_EQ(transfers->strategy(), expected) << config.domain.cells_x << " x " << config.domain.cells_y;
    if (cpu_code_paths && ExecutionSpace().concurrency() <= 7)
      EXPECT_EQ(transfers->strategy(), config.domain.cells_y > 1 ? P2GStrategy::sorted : P2GStrategy::duplicated);
  }
}

// The CPU walk's tiles follow numerics/reorder_interval: strips where they pay for particles
// reordered by cell, rectangles for particles never reordered (kernels/transfer_kernels.hpp).
TEST(TimeStep, TheReorderIntervalNamesTheParticlesOrderForTheWalk) {
  NumericsConfig numerics;
  numerics.reorder_interval = 0;
  EXPECT_EQ(particle_order_of(numerics), ParticleOrder::never_reordered);
  for (const int interval : {1, 20}) {
    numerics.reorder_interval = interval;
    EXPECT_EQ(particle_order_of(numerics), ParticleOrder::reordered_by_cell) << "every " << interval << " steps";
  }
}

TEST(TimeStep, ALightParticleWithAnOutlyingVelocityDoesNotSetItAPlacedOneDoes) {
  const CaseConfig config = sod_case();
  const real_t undisturbed = make_solver(config)->stable_time_step();
  // Gas at rest: sound speeds sqrt(1.4) and sqrt(1.4 * 0.1 / 0.125), so dt = 0.5 h / sqrt(1.4).
  EXPECT_NEAR(undisturbed, 0.5 * 0.01 / std::sqrt(1.4), round_off(1e-12));
  auto light = make_solver(config);
  disturb(light->particles(), 60, 20.0, 1e-3);  // a thousandth of its mass, |v| 20 c
  auto placed = make_solver(config);
  disturb(placed->particles(), 60, 20.0, 1.0);
  // The light one moves its nodes' velocity by about 20 / 3000 (3 particles per cell, 2 cells).
  EXPECT_GT(light->stable_time_step(), 0.95 * undisturbed);
  // A placed particle that fast sets it: its nodes move at about a third of its speed.
  EXPECT_LT(placed->stable_time_step(), 0.25 * undisturbed);
}

TEST(TimeStep, TheGridItPreparesIsDiscardedWhenTheParticlesChange) {
  // The two runs are compared bit for bit, so P2G must sum in an order that timing does not change:
  // sorted, on every back-end (atomic, the GPUs' automatic choice, differed in the last bits there).
  CaseConfig config = sod_case();
  config.numerics.p2g = P2GStrategy::sorted;
  auto a = make_solver(config), b = make_solver(config);
  const real_t dt = a->stable_time_step();  // a's grid now holds its particles as they are...
  disturb(a->particles(), 60, 2.0, 1.0);   // ... until they change
  disturb(b->particles(), 60, 2.0, 1.0);
  a->advance(dt);
  b->advance(dt);  // b projects its particles in advance()
  // A second step, in which the pressure the moving particle built up pushes back.
  a->advance(a->stable_time_step());
  b->advance(b->stable_time_step());
  // Stale, a's grid would have moved particle 60 with its old velocity in the first step.
  ASSERT_EQ(a->particles().count, b->particles().count);
  for (const RealView ParticleState::*field : {&ParticleState::position_x, &ParticleState::density, &ParticleState::velocity_x}) {
    const auto fa = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), a->particles().*field);
    const auto fb = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), b->particles().*field);
    for (index_t k = 0; k < a->particles().count; ++k) ASSERT_EQ(fa(k), fb(k)) << k;
  }
  // The steps saw the disturbance: the particle was slowed by the pressure it built up ahead.
  EXPECT_LT(value_at(a->particles().velocity_x, 60), 1.99);
}

}  // namespace
}  // namespace mpmflow
