// Google Benchmark programs for the MPM step and each of its kernels, with a STREAM-style triad
// measured in the same run. Every phase is timed by the solver's own phase timers (which fence),
// so the figures are those a real run reports, and each is turned into particle-steps per second
// and an effective bandwidth through the traffic model below.
//
// Traffic model (bytes moved per particle per step, double precision, 4-byte cell index): the
// particle fields each kernel reads and writes, once each, plus the grid columns it touches
// divided by the particles per cell (node count ~ cell count). Stencil weights are computed,
// not stored, so they cost no traffic. GIMP kernels also read the two particle stretches.
//   p2g_mass_momentum_force  reads x y cell m vx vy p q rho            = 8 x 8 + 4 = 68
//                            grid: 5 columns accumulated (read + write) = 80 / ppc
//   g2p_velocity_acceleration reads x y cell vx vy, writes vx vy vbx vby = 4 x 8 + 4 + 4 x 8 = 68
//                            grid: 5 columns read (m, mv, f)           = 40 / ppc
//   p2g_momentum_remap       reads x y cell m vx vy                     = 5 x 8 + 4 = 44
//                            grid: 2 columns accumulated                = 32 / ppc
//   g2pd_particle_update     reads x y cell rho e p q, writes rho e p q = 6 x 8 + 4 + 4 x 8 = 84
//                            (GIMP: stretches read and written, +32)
//                            grid: 3 columns read (m, remapped mv)      = 24 / ppc
//   particle_move            reads x y vbx vby, writes x y              = 48
//   cell_map                 reads x y, writes cell                     = 20
//   time_step                reads vx vy p rho                          = 32
//   reorder (BinSort)        every field read and written once through a permutation, plus the
//                            keys and the permutation vector           = 2 x 116 + 8 = 240
// The whole step is the sum of its phases. GIMP adds 16 bytes (two stretches) to every kernel
// that evaluates a stencil (the four transfer kernels).
#include <benchmark/benchmark.h>

#include <cstdio>
#include <map>
#include <string>

#include "case_config.hpp"
#include "particles.hpp"
#include "solver.hpp"

namespace mpmflow {
namespace {

// A uniform free stream (rho 1.4, p 1, v = (3, 0), unit sound speed) through [0, 4] x [0, 2], the
// cylinder case's domain and state, without the cylinder: every particle moves and crosses cells.
CaseConfig free_stream_case(long target_cells, int ppc_per_axis, ShapeFunction shape, int reorder_interval) {
  CaseConfig c;
  c.name = "benchmark";
  c.source = "benchmark";
  // 2:1 domain: cells_x = 2 cells_y, cells_x * cells_y ~ target_cells.
  const int cells_y = std::max(1, static_cast<int>(std::lround(std::sqrt(target_cells / 2.0))));
  c.domain = {0, 4, 0, 2, 2 * cells_y, cells_y};
  c.time.end_time = 1e9;  // benchmarks step a fixed number of times
  c.particles.per_cell_x = c.particles.per_cell_y = ppc_per_axis;
  c.initial_state.background = {1.4, 1.0, 3.0, 0.0};
  c.output.snapshots = 0;
  c.numerics.shape_function = shape;
  c.numerics.reorder_interval = reorder_interval;
  return c;
}

struct PhaseTraffic {
  double particle_bytes;
  double grid_bytes_per_cell;  // divided by particles per cell
  bool uses_stencil;           // GIMP adds its stretches
};

const std::map<std::string, PhaseTraffic>& traffic_model() {
  static const std::map<std::string, PhaseTraffic> model = {
      {"p2g_mass_momentum_force", {68, 80, true}},  {"g2p_velocity_acceleration", {68, 40, true}},
      {"p2g_momentum_remap", {44, 32, true}},       {"g2pd_particle_update", {84, 24, true}},
      {"particle_move", {48, 0, false}},            {"cell_map", {20, 0, false}},
      {"time_step", {32, 0, false}},                {"reorder", {240, 0, false}},
      {"grid_reset", {0, 56, false}},               {"grid_momentum_update", {0, 32, false}},
      {"boundary_conditions", {0, 0, false}}};
  return model;
}

double phase_bytes_per_particle(const std::string& phase, int ppc, ShapeFunction shape) {
  const auto it = traffic_model().find(phase);
  if (it == traffic_model().end()) return 0;
  const PhaseTraffic& t = it->second;
  double bytes = t.particle_bytes + t.grid_bytes_per_cell / ppc;
  if (shape == ShapeFunction::gimp && t.uses_stencil) bytes += 16;
  if (shape == ShapeFunction::gimp && phase == "g2pd_particle_update") bytes += 16;  // stretches written
  return bytes;
}

// args: target cells, particles per cell along each axis, shape (0 linear, 1 gimp), reorder interval
void BM_Step(benchmark::State& state) {
  const long target_cells = state.range(0);
  const int ppc_axis = static_cast<int>(state.range(1));
  const ShapeFunction shape = state.range(2) ? ShapeFunction::gimp : ShapeFunction::linear;
  const int reorder = static_cast<int>(state.range(3));
  const CaseConfig config = free_stream_case(target_cells, ppc_axis, shape, reorder);
  const GridSlab slab = make_grid_slab(config.domain, 0, config.domain.cells_x);
  Solver solver(config, slab, create_initial_particles(config, slab));
  const double n = solver.particles().count;
  const int ppc = ppc_axis * ppc_axis;

  // One step outside the timing: first-touch allocation of the ScatterView copies.
  solver.advance(solver.stable_time_step());
  solver.timers() = PhaseTimers();
  for (auto _ : state) solver.advance(solver.stable_time_step());
  // (stable_time_step is a phase of its own: it runs inside the loop, timed by the same timers.)

  const PhaseTimers& timers = solver.timers();
  const double steps = static_cast<double>(state.iterations());
  double step_seconds = 0, step_bytes = 0;
  for (const auto& name : timers.names()) {
    const double seconds = timers.entry(name).seconds / steps;
    const double bytes = phase_bytes_per_particle(name, ppc, shape) * n;
    step_seconds += seconds;
    step_bytes += bytes;
    if (traffic_model().count(name) && traffic_model().at(name).particle_bytes > 0) {
      state.counters[name + "_Mpps"] = n / seconds / 1e6;
      state.counters[name + "_GBps"] = bytes / seconds / 1e9;
    }
  }
  const Solver::MemoryUse memory = solver.memory_use();
  state.counters["particles"] = n;
  state.counters["cells"] = static_cast<double>(config.domain.cells_x) * config.domain.cells_y;
  state.counters["step_particle_steps_per_s"] = n / step_seconds;
  state.counters["step_GBps"] = step_bytes / step_seconds / 1e9;
  state.counters["traffic_bytes_per_particle"] = step_bytes / n;
  state.counters["memory_bytes_per_particle"] = memory.total() / n;
  state.counters["memory_bytes_per_node"] =
      double(memory.grid_bytes + memory.scatter_copy_bytes) / slab.geometry.num_nodes();
  state.SetLabel(std::string(to_string(shape)) + (reorder ? ", reorder every " + std::to_string(reorder) : ""));
}

// STREAM triad a = b + s c on Views far larger than the caches: the bandwidth the machine gives.
void BM_Triad(benchmark::State& state) {
  const index_t n = static_cast<index_t>(state.range(0));
  RealView a("triad_a", n), b("triad_b", n), c("triad_c", n);
  Kokkos::deep_copy(b, 1.0);
  Kokkos::deep_copy(c, 2.0);
  const real_t s = 3;
  double seconds = 0;
  for (auto _ : state) {
    Kokkos::Timer timer;
    Kokkos::parallel_for(
        "triad", Kokkos::RangePolicy<ExecutionSpace>(0, n), KOKKOS_LAMBDA(const index_t i) { a(i) = b(i) + s * c(i); });
    Kokkos::fence();
    seconds += timer.seconds();
  }
  // Three arrays of n reals each pass through memory once per iteration (write-allocate not counted).
  state.counters["GBps"] = 3.0 * sizeof(real_t) * n * static_cast<double>(state.iterations()) / seconds / 1e9;
}

BENCHMARK(BM_Triad)->Arg(1 << 25)->Unit(benchmark::kMillisecond)->UseRealTime();
// Grid sizes x particles per cell (4, 9, 16) x shape, without reordering; then with reordering
// every 10 steps at the target size (1e5 cells, 9 per cell).
BENCHMARK(BM_Step)
    ->ArgsProduct({{10000, 100000}, {2, 3, 4}, {0, 1}, {0}})
    ->Args({100000, 3, 0, 10})
    ->Args({100000, 3, 1, 10})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace mpmflow

int main(int argc, char** argv) {
  Kokkos::ScopeGuard kokkos(argc, argv);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
