// Every phase of a step is a named Kokkos profiling region, so the standard Kokkos tools (and
// nsys / rocprof through their connectors) see the step's structure under the names the run's
// phase table prints. Checked through the Kokkos Tools region callbacks.
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <string>
#include <vector>

#include "case_config.hpp"
#include "launch_census.hpp"
#include "particles.hpp"
#include "solver.hpp"

namespace mpmflow {
namespace {

struct RegionLog {
  std::vector<std::string> open;  // the region stack
  std::set<std::string> seen;
  bool unbalanced = false;
};
RegionLog& region_log() {
  static RegionLog log;
  return log;
}
void on_push(const char* name) {
  region_log().open.push_back(name);
  region_log().seen.insert(name);
}
void on_pop() {
  if (region_log().open.empty()) region_log().unbalanced = true;
  else region_log().open.pop_back();
}

// The regions two steps of a coarse cylinder run open (reordering every step).
std::set<std::string> regions_of_two_steps(bool fused) {
  const CaseConfig config = load_case_file(
      std::string(MPMFLOW_SOURCE_DIR) + "/cases/cylinder_mach3.json",
      {"domain/cells_x=40", "domain/cells_y=20", "numerics/reorder_interval=1",
       std::string("numerics/fused_kernels=") + (fused ? "true" : "false")});
  const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
  Solver solver(config, slab, create_initial_particles(config, slab));
  region_log() = RegionLog();
  Kokkos::Tools::Experimental::set_push_region_callback(on_push);
  Kokkos::Tools::Experimental::set_pop_region_callback(on_pop);
  for (int k = 0; k < 2; ++k) solver.advance(solver.stable_time_step());
  Kokkos::Tools::Experimental::set_push_region_callback(nullptr);
  Kokkos::Tools::Experimental::set_pop_region_callback(nullptr);
  EXPECT_FALSE(region_log().unbalanced);
  EXPECT_TRUE(region_log().open.empty()) << "a region was left open: " << region_log().open.back();
  // The phase table and the regions are the same names.
  for (const Phase phase : solver.timers().phases())
    EXPECT_TRUE(region_log().seen.count(phase_name(phase))) << phase_name(phase);
  return region_log().seen;
}

TEST(Profiling, EveryPhaseIsANamedRegion) {
  const std::set<std::string> regions = regions_of_two_steps(true);
  for (const Phase phase : {Phase::time_step, Phase::grid_reset, Phase::p2g_mass_momentum_force,
                            Phase::halo_exchange, Phase::boundary_conditions, Phase::grid_momentum_update,
                            Phase::g2p_p2g_velocity_momentum, Phase::grid_remap_velocity,
                            Phase::g2pd_particle_update, Phase::particle_move, Phase::open_sides,
                            Phase::migration, Phase::reorder})
    EXPECT_TRUE(regions.count(phase_name(phase))) << "no region " << phase_name(phase);
}

// What the benchmark's --launch-census counts (launch_census.hpp): launches of each kind, by label,
// and copies between Views, not fills. (Free functions: nvcc allows no device lambda in a test's
// body, a private member function.)
void fill_with_indices(const RealView& a) {
  Kokkos::parallel_for(
      "census_fill", Kokkos::RangePolicy<ExecutionSpace>(0, a.extent(0)), KOKKOS_LAMBDA(const index_t i) { a(i) = i; });
}
double sum_of(const RealView& a) {
  double sum = 0;
  Kokkos::parallel_reduce(
      "census_sum", Kokkos::RangePolicy<ExecutionSpace>(0, a.extent(0)),
      KOKKOS_LAMBDA(const index_t i, double& total) { total += a(i); }, sum);
  return sum;
}

TEST(Profiling, TheLaunchCensusCountsLaunchesReductionsAndViewCopies) {
  const RealView a("census_a", 100), b("census_b", 100);  // (their initialisation before the census)
  const LaunchCensus census(/*by_label=*/true);
  fill_with_indices(a);
  fill_with_indices(a);
  EXPECT_EQ(sum_of(a), 4950.0);
  Kokkos::deep_copy(b, a);
  Kokkos::deep_copy(b, real_t(0));  // a fill that fences: a launch (or a memset), not a copy
  fill_in_order(b, real_t(1));      // a fill in the execution space's order: neither
  EXPECT_EQ(census.by_label().at("census_fill"), 2);
  EXPECT_EQ(census.by_label().at("census_sum"), 1);
  EXPECT_EQ(census.by_label().at("copy census_b <- census_a"), 1);
  EXPECT_EQ(census.by_label().at("fenced fill census_b"), 1);
  EXPECT_EQ(census.reductions(), 1);
  EXPECT_EQ(census.view_copies(), 1);
  EXPECT_EQ(census.fenced_fills(), 1);
  // The three launches above, and at most the fills' own.
  EXPECT_GE(census.launches(), 3);
  EXPECT_LE(census.launches(), 5);
}

// No step fills a View through a deep_copy that fences (on a GPU each is two waits for the device;
// fill_in_order fills in the execution space's order instead): the cylinder (an obstacle, open
// sides, splitting and merging), with the cell-averaged strain (its cell sums), and the aerofoil
// (far-field sides, their strips).
TEST(Profiling, NoStepFillsAViewWithFences) {
  const std::string cases = std::string(MPMFLOW_SOURCE_DIR) + "/cases/";
  const std::vector<std::pair<std::string, std::vector<std::string>>> runs = {
      {"cylinder_mach3.json", {"domain/cells_x=40", "domain/cells_y=20"}},
      {"cylinder_mach3.json", {"domain/cells_x=40", "domain/cells_y=20", "numerics/cell_averaged_strain=true"}},
      {"aerofoil_transonic.json", {"domain/cells_x=50", "domain/cells_y=34"}}};
  for (const auto& [file, settings] : runs) {
    SCOPED_TRACE(file + (settings.size() > 2 ? " " + settings.back() : ""));
    const CaseConfig config = load_case_file(cases + file, settings);
    const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
    Solver solver(config, slab, create_initial_particles(config, slab));
    for (int k = 0; k < 3; ++k) solver.advance(solver.stable_time_step());
    const LaunchCensus census(/*by_label=*/true);
    for (int k = 0; k < 5; ++k) solver.advance(solver.stable_time_step());
    EXPECT_GT(census.launches(), 5 * 20);  // (the census saw the steps)
    EXPECT_EQ(census.fenced_fills(), 0);
    for (const auto& [label, count] : census.by_label())
      EXPECT_NE(label.rfind("fenced fill ", 0), 0u) << label << ": " << count << " in 5 steps";
  }
}

// No kernel of a step is launched once a particle field: particles move whole (splitting's halves,
// the open sides' hole filling) and the open sides' totals are one reduction, where a launch a field
// or a total made a dozen launches of a kind a step (on a GPU each costs microseconds however
// little it does). Kokkos' own fills and initialisations aside, and the reorder's (one field at a
// time by design: it holds one field twice at most, not all of them).
TEST(Profiling, NoKernelOfAStepIsLaunchedOnceAParticleField) {
  const CaseConfig config = load_case_file(std::string(MPMFLOW_SOURCE_DIR) + "/cases/cylinder_mach3.json",
                                           {"domain/cells_x=40", "domain/cells_y=20", "numerics/reorder_interval=0"});
  const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
  Solver solver(config, slab, create_initial_particles(config, slab));
  for (int k = 0; k < 30; ++k) solver.advance(solver.stable_time_step());  // a wake that splits
  int fields = 0;
  solver.particles().for_each_field([&](const auto&) { ++fields; });
  constexpr int steps = 5;
  std::map<std::string, long long> launches;
  {
    const LaunchCensus census(/*by_label=*/true);
    for (int k = 0; k < steps; ++k) solver.advance(solver.stable_time_step());
    launches = census.by_label();
  }
  for (const char* covered : {"split_copy", "particle_fill_holes", "open_side_totals"})
    EXPECT_TRUE(launches.count(covered)) << covered << " not launched: the test does not cover it";
  for (const auto& [label, count] : launches) {
    if (label.rfind("Kokkos::", 0) == 0 || label.rfind("copy ", 0) == 0 || label.rfind("fenced fill ", 0) == 0)
      continue;
    EXPECT_LT(count, steps * fields) << label << ": " << count << " launches in " << steps << " steps";
  }
}

// output/phase_timers: fenced, the timers wait for each phase's kernels (a fence a phase call);
// unfenced, they add no wait to the step, and time and name the same phases. What the step computes
// is the same either way (bit for bit through the sorted P2G: the atomic one, a GPU's default, adds
// in an order that changes from run to run).
TEST(Profiling, UnfencedPhaseTimersAddNoWaitToTheStep) {
  struct Timed {
    PhaseTimers timers;
    ParticleState particles;
  };
  auto run = [](const char* timing) {
    const CaseConfig config =
        load_case_file(std::string(MPMFLOW_SOURCE_DIR) + "/cases/cylinder_mach3.json",
                       {"domain/cells_x=40", "domain/cells_y=20", "numerics/p2g=sorted",
                        std::string("output/phase_timers=") + timing});
    const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
    Solver solver(config, slab, create_initial_particles(config, slab));
    for (int k = 0; k < 5; ++k) solver.advance(solver.stable_time_step());
    return Timed{solver.timers(), solver.particles()};
  };
  const Timed fenced = run("fenced"), unfenced = run("unfenced");
  EXPECT_EQ(fenced.timers.timing(), PhaseTiming::fenced);
  EXPECT_EQ(unfenced.timers.timing(), PhaseTiming::unfenced);
  long calls = 0;
  for (const Phase phase : fenced.timers.phases()) calls += fenced.timers.entry(phase).calls;
  EXPECT_GT(calls, 5 * 10);
  EXPECT_EQ(fenced.timers.fences(), calls);
  EXPECT_EQ(unfenced.timers.fences(), 0);
  ASSERT_EQ(unfenced.timers.phases(), fenced.timers.phases());
  for (const Phase phase : fenced.timers.phases())
    EXPECT_EQ(unfenced.timers.entry(phase).calls, fenced.timers.entry(phase).calls) << phase_name(phase);
  ASSERT_EQ(unfenced.particles.count, fenced.particles.count);
  const auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), fenced.particles.position_x);
  const auto x_unfenced = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), unfenced.particles.position_x);
  for (index_t p = 0; p < fenced.particles.count; ++p) ASSERT_EQ(x_unfenced(p), x(p)) << "particle " << p;
}

TEST(Profiling, UnfusedKernelsAreRegionsOfTheirOwn) {
  const std::set<std::string> regions = regions_of_two_steps(false);
  EXPECT_TRUE(regions.count(phase_name(Phase::g2p_velocity_acceleration)));
  EXPECT_TRUE(regions.count(phase_name(Phase::p2g_momentum_remap)));
  EXPECT_FALSE(regions.count(phase_name(Phase::g2p_p2g_velocity_momentum)));
}

}  // namespace
}  // namespace mpmflow
