#pragma once
// The four generic particle/grid transfer kernels of the paper (eqs. 16-19), as templates over
// on-the-fly functors (the paper's Figs. 1-4). The mapped quantity is never stored: a functor
// computes it from state arrays for one particle (P2G, P2GD) or one node (G2P, G2PD), and for the
// grid-to-particle kernels a second functor (the "sink") consumes the interpolated value for that
// particle, so a physics update can be fused into the interpolation loop without a temporary.
//
// Functor contracts, with N = Functor::num_components:
//   P2G  particle functor:  void operator()(index_t p, real_t (&value)[N]) const
//   P2GD particle functor:  void operator()(index_t p, real_t (&vector)[N][2]) const
//   G2P  node functor:      void operator()(index_t node, real_t (&value)[N]) const
//        sink:              void operator()(index_t p, const real_t (&value)[N]) const
//   G2PD node functor as G2P; sink: void operator()(index_t p, const real_t (&gradient)[N][2]) const
// Optionally, for a batch's particles as vector lanes on CPUs: a P2G functor's
// index_t values(index_t p, Values value) and void add_count(index_t n) (WritesValuesInLanes), a
// P2GD functor's call operator over any Vectors (LaneVectorOutputs), a sink's over any Values and
// Gradients (TakesLanes).
//
// The shape-function policy (kernels/shape_functions.hpp) gives each particle's stencil of nodes,
// weights and weight gradients, so the same kernels serve linear MPM and GIMP.
//
// P2G and P2GD accumulate into columns [first_component, first_component + N) of a (node,
// component) View in one of three ways, chosen by the arguments' types. No hand-written atomics:
//  - all particles at once (a particle count, or ParticleBatches) through a Kokkos ScatterView,
//    duplicated or atomic: the ScatterView decides how concurrent contributions to one node are
//    combined;
//  - tile colour by tile colour (ColouredTiles, CPUs) straight into the View (DirectNodeAccess):
//    the tiles of cells of one colour are far enough apart that no two touch a common node, so
//    each node is written by one thread at a time, in an order fixed by the tiles and the
//    particles' grouping alone. Bitwise the same result for any thread count;
//  - with the particles grouped by cell (ColouredCells, GPUs), a thread a block of nodes, which
//    gathers what the particles of the cells around it add to its nodes, in an order fixed by the
//    cells and the particles' grouping alone (walk_nodes_gathering): bitwise the same again.
// The traversal also decides how the stencils are computed: a particle count is the reference
// path, one particle per thread, as the paper's kernels; ParticleBatches and ColouredTiles compute
// the stencils of batches of particles together in vector lanes on CPUs (Shape::fill_batch), the
// solver's path, tested against the reference.
#include <algorithm>
#include <cstddef>
#include <iterator>
#include <type_traits>

#include <Kokkos_ScatterView.hpp>

#include "kernels/index_lanes.hpp"
#include "kernels/particle_sort.hpp"
#include "kernels/shape_functions.hpp"

namespace mpmflow {

// Where the particles are: positions and the cell map kept in step with them.
struct ParticleLocations {
  RealView x;
  RealView y;
  IndexView cell;
};

// The ScatterView type used for P2G, parameterised by its duplication mode. Duplicated copies
// combine without atomics (the CPU default); non-duplicated ones need atomic contributions.
template <class Duplication>
struct ScatterContributionFor {
  using type = Kokkos::Experimental::ScatterNonAtomic;
};
template <>
struct ScatterContributionFor<Kokkos::Experimental::ScatterNonDuplicated> {
  using type = Kokkos::Experimental::ScatterAtomic;
};

template <class Duplication>
using NodeScatterView =
    Kokkos::Experimental::ScatterView<real_t**, Kokkos::LayoutLeft, DeviceType,
                                      Kokkos::Experimental::ScatterSum, Duplication,
                                      typename ScatterContributionFor<Duplication>::type>;

// Prepares a ScatterView for a P2G into `target` columns that the caller has zeroed: duplicated
// copies are cleared; an atomic ScatterView writes into `target` itself and must not clear the
// columns other P2G passes have already filled.
template <class ScatterViewType>
void p2g_begin(ScatterViewType& scatter, const NodeFieldsView& target) {
  scatter.reset_except(target);
}

// Combines the duplicated copies into `target` (no-op for an atomic ScatterView).
template <class ScatterViewType>
void p2g_end(ScatterViewType& scatter, const NodeFieldsView& target) {
  scatter.contribute_into(target);
}

// Particles grouped by cell, for the GPU path (CellOrder in kernels/particle_sort.hpp builds it):
// P2G gathered by blocks of nodes (walk_nodes_gathering), G2P a thread a cell (walk_cells), or a
// team of threads a tile (walk_tiles_in_teams) for a body that reads nodes and adds into them. The
// particles of local cell c are particle(cell_offset(c)) .. particle(cell_offset(c + 1) - 1).
struct ColouredCells {
  IndexView cell_offset;
  IndexView particle;
  index_t cells_x = 0, cells_y = 0;
  int team_size = 0;  // threads per team; 0: Kokkos chooses (the tests ask for 2 on CPUs)
};

// A tile of the coloured traversals: its extent in cells along x and y.
struct TileExtent {
  index_t x, y;
};

// Particles grouped by tile (the coloured traversal's tiles of `tile` cells, below, numbered row of
// tiles by row of tiles: tile_of_each_cell), in increasing index within each tile, for the
// coloured traversal with a thread per tile (the CPU path; TileOrder builds it): the particles of
// tile t are particle(tile_offset(t)) .. particle(tile_offset(t + 1) - 1). Particles reordered by
// cell lie in long runs of consecutive indices within a tile (each a row of the tile), and stay
// in them as they move among the tile's cells: the walk takes such a run's batches as consecutive
// particles, whose loads and updates run as vector lanes.
struct ColouredTiles {
  IndexView tile_offset;
  IndexView particle;
  index_t cells_x = 0, cells_y = 0;
  TileExtent tile{0, 0};  // (walk_tile_for)
};

// All particles, for the fast traversal (for_each_particle_stencil below): batched stencils on
// CPUs. A plain particle count is the reference traversal, one particle at a time.
struct ParticleBatches {
  index_t count = 0;
};

// A (node, component) View written in place: the accumulator of the coloured traversal.
struct DirectNodeAccess {
  NodeFieldsView target;
  KOKKOS_INLINE_FUNCTION const DirectNodeAccess& access() const { return *this; }
  KOKKOS_INLINE_FUNCTION real_t& operator()(index_t node, int component) const { return target(node, component); }
};

// A thread's window on a tile's nodes (the CPU walks, walk_tiles_staged and
// walk_tiles_through_windows): node by node, the node's W columns together, so that what a
// particle adds to a node, or reads from it, is one vector operation, not a scalar one per column.
// Node n (a node of the grid, within the window) at row n - base.
template <int W>
struct NodeMajorWindowOf {
  static constexpr int width = W;
  real_t* data;
  index_t base;
  int first_component;  // the node fields' column of the window's column 0
  KOKKOS_INLINE_FUNCTION const NodeMajorWindowOf& access() const { return *this; }
  KOKKOS_INLINE_FUNCTION real_t* node(index_t n) const { return data + (n - base) * W; }
  // Node (a, b) of stencil s, its place computed in the pointer's width, so that the compiler takes
  // the stencil's first node once and the others at constant offsets from it and its rows. (As
  // node(s.node(a, b)), in index_t, each node took 4 instructions of its own: the sum, the
  // subtraction, the scaling and the sign extension.)
  template <class StencilType>
  KOKKOS_FORCEINLINE_FUNCTION real_t* node(const StencilType& s, int a, int b) const {
    return data + (std::ptrdiff_t(s.first_node) - base + a + std::ptrdiff_t(b) * s.row_stride) * W;
  }
  KOKKOS_INLINE_FUNCTION real_t& operator()(index_t n, int component) const {
    return node(n)[component - first_component];
  }
};
// 8 columns: one AVX-512 vector of doubles (P2G's seven, G2PD's five).
using NodeMajorWindow = NodeMajorWindowOf<8>;
// The width of a window for `columns` columns: 2, 4 or 8 (a vector of 128, 256 or 512 bits).
constexpr int window_width_for(int columns) { return columns <= 2 ? 2 : columns <= 4 ? 4 : 8; }

// G2P node functor reading columns [first_column, first_column + N) of a (node, column) View, as
// they are (the solver's: node values per unit mass, divided by the node mass once per node on the
// grid, not per particle in the kernel as the paper's theta functor does: grid_phases.hpp).
template <int N>
struct NodeColumns {
  static constexpr int num_components = N;
  NodeFieldsView fields;
  int first_column;
  KOKKOS_FORCEINLINE_FUNCTION void operator()(index_t node, real_t (&value)[N]) const {
    for (int c = 0; c < N; ++c) value[c] = fields(node, first_column + c);
  }
};

template <class NodeFunctor>
struct IsNodeColumns : std::false_type {};
template <int N>
struct IsNodeColumns<NodeColumns<N>> : std::true_type {};

// The same columns copied into a thread's window (walk_tiles_through_windows): a node's N values
// side by side, the first N of the window's W.
template <int N, int W>
struct WindowColumns {
  static constexpr int num_components = N;
  NodeMajorWindowOf<W> window;
  KOKKOS_FORCEINLINE_FUNCTION void operator()(index_t node, real_t (&value)[N]) const {
    copy(window.node(node), value);
  }
  // A node's values from its place in the window.
  KOKKOS_FORCEINLINE_FUNCTION static void copy(const real_t* columns, real_t (&value)[N]) {
    for (int c = 0; c < N; ++c) value[c] = columns[c];
  }
};
// The node functor's values at node (a, b) of stencil s (those of WindowColumns from the window's
// place of the node, NodeMajorWindowOf::node(s, a, b)).
template <class NodeFunctor, class StencilType, int N>
KOKKOS_FORCEINLINE_FUNCTION void stencil_node_values(const NodeFunctor& node_functor, const StencilType& s, int a,
                                                     int b, real_t (&value)[N]) {
  node_functor(s.node(a, b), value);
}
template <int N, int W, class StencilType>
KOKKOS_FORCEINLINE_FUNCTION void stencil_node_values(const WindowColumns<N, W>& node_functor, const StencilType& s,
                                                     int a, int b, real_t (&value)[N]) {
  WindowColumns<N, W>::copy(node_functor.window.node(s, a, b), value);
}
template <class NodeFunctor>
struct IsWindowColumns : std::false_type {};
template <int N, int W>
struct IsWindowColumns<WindowColumns<N, W>> : std::true_type {};

// The coloured traversal writes in place: nothing to prepare or combine.
inline void p2g_begin(DirectNodeAccess&, const NodeFieldsView&) {}
inline void p2g_end(DirectNodeAccess&, const NodeFieldsView&) {}

// Runs body(p, stencil) for every particle p, with its stencil from the shape policy: the particle
// loops all four transfer kernels share. This one is the reference traversal (a particle count):
// one thread per particle.
template <class Shape, class Body>
void for_each_particle_stencil(const char* label, const Shape& shape, const ParticleLocations& particles,
                               index_t num_particles, const Body& body) {
  const auto x = particles.x;
  const auto y = particles.y;
  const auto cell = particles.cell;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, num_particles),
      KOKKOS_LAMBDA(const index_t p) { body(p, shape(p, cell(p), x(p), y(p))); });
}

// A body that can also run in two phases over a batch: gather(stencil, lanes, l) reads the nodes
// for lane l, finish(p, lanes, l) does the rest (G2PD: the particle update), in a loop of its own
// marked for vectorisation. (GCC 12 still keeps that loop scalar, "no vectype" for the lanes'
// loads; the split alone made G2PD a third faster, measured.) Marked by a member
// gathers_then_finishes = true.
template <class Body, class = void>
struct GathersThenFinishes : std::false_type {};
template <class Body>
struct GathersThenFinishes<Body, std::void_t<decltype(Body::gathers_then_finishes)>>
    : std::integral_constant<bool, Body::gathers_then_finishes> {};

// A G2P or G2PD sink that writes nothing but its own particle's data, marked by a member type
// writes_only_its_particle = std::true_type: its calls for different particles may run as vector
// lanes (their loop is marked so). (One that adds to its particle's cell, as cell-averaged strain
// does, may not.) A type, not a constant: nvcc warns of a constant that its build never reads.
template <class Sink, class = void>
struct WritesOnlyItsParticle : std::false_type {};
template <class Sink>
struct WritesOnlyItsParticle<Sink, std::void_t<typename Sink::writes_only_its_particle>>
    : Sink::writes_only_its_particle {};
// A body that can also run in two phases over a batch the other way round: prepare(p, lanes, l)
// computes what particle p adds to the nodes (the P2G functors: its state's sums, divisions
// among them), add_prepared(stencil, lanes, l) adds it. The divisions of one particle then no longer
// wait behind the previous particle's stores, nor its stores behind them. The same arithmetic in
// the same order: the same bits. Marked by a member prepares_then_scatters = true.
template <class Body, class = void>
struct PreparesThenScatters : std::false_type {};
template <class Body>
struct PreparesThenScatters<Body, std::void_t<decltype(Body::prepares_then_scatters)>>
    : std::integral_constant<bool, Body::prepares_then_scatters> {};

// How a batch's bodies run: particle by particle, gathering then finishing, preparing then
// scattering, or (both) gathering, then finishing and preparing, then scattering.
// (A trait, not a constexpr function: nvcc warns of a host function called in a device lambda.)
enum class BatchBodies : int { one_by_one, gather_then_finish, prepare_then_scatter, gather_finish_scatter };
template <class Body>
struct BatchBodiesOf {
  static constexpr BatchBodies value =
      GathersThenFinishes<Body>::value && PreparesThenScatters<Body>::value ? BatchBodies::gather_finish_scatter
      : GathersThenFinishes<Body>::value                                     ? BatchBodies::gather_then_finish
      : PreparesThenScatters<Body>::value                                    ? BatchBodies::prepare_then_scatter
                                                                              : BatchBodies::one_by_one;
};
template <BatchBodies B>
using BatchBodiesTag = std::integral_constant<int, static_cast<int>(B)>;
template <class Body>
using BatchBodiesTagOf = BatchBodiesTag<BatchBodiesOf<Body>::value>;

// Its per-batch storage for L lanes (nothing for other bodies).
template <class Body, int L, bool = GathersThenFinishes<Body>::value || PreparesThenScatters<Body>::value>
struct BatchLanes {
  struct type {};
};
template <class Body, int L>
struct BatchLanes<Body, L, true> {
  using type = typename Body::template Lanes<L>;
};

// The fast traversal where the particles are in host memory (CPUs): batches of
// stencil_batch_size consecutive particles, the batch's stencils computed first, one particle per
// vector lane (Shape::fill_batch), then the body for each particle. Computing the weights is most
// of a kernel's work, and it stays scalar when it is done particle by particle. The same sums as
// the reference traversal (tested against it), to round-off. Elsewhere (GPUs) it is the reference
// traversal. As many particles as index_lanes.hpp's blocks hold indices.
constexpr int stencil_batch_size = index_block_size;

// A batch's bodies, particle by particle (nvcc allows no `if constexpr` around what a device lambda
// captures, hence overloads). `particle(l)` is lane l's particle.
template <int L, class Body, class Batch, class Particles>
KOKKOS_FORCEINLINE_FUNCTION void run_bodies(const Body& body, const Batch& batch, const Particles& particle,
                                            int count, index_t row_stride,
                                            BatchBodiesTag<BatchBodies::one_by_one>) {
  for (int l = 0; l < count; ++l) body(particle(l), batch.stencil(l, row_stride));
}
// ... or the node reads particle by particle, then the particle updates. The node reads stay
// scalar: GCC otherwise turns them into vector gathers over the lanes (the stencils' nodes), which
// cost more than scalar loads on CPUs (on AMD Zen 4: the linear G2PD 8 % slower, measured). The
// updates run as vector lanes over consecutive particles; over listed ones (the sorted traversal's
// batches that are not consecutive) they stay scalar too, since their loads and stores of the
// particles' fields would become gathers and scatters (a quarter of the sorted G2P-then-P2G's
// time, measured). A loop with an exit is one GCC does not vectorise.
template <int L, class Body, class Lanes>
KOKKOS_FORCEINLINE_FUNCTION void finish_lanes(const Body& body, const ConsecutiveParticles& particle, int count,
                                              Lanes& lanes) {
  MPMFLOW_VECTORISE
  for (int l = 0; l < count; ++l) body.finish(particle(l), lanes, l);
}
template <int L, class Body, class Lanes>
KOKKOS_FORCEINLINE_FUNCTION void finish_lanes(const Body& body, const ListedParticles& particle, int count,
                                              Lanes& lanes) {
  for (int l = 0; l < L; ++l) {
    if (l == count) break;
    body.finish(particle(l), lanes, l);
  }
}
// A gathering body whose gather(stencil, lanes, l) only loads lane l's node values, and whose
// interpolate_lanes(batch, count, lanes) then weighs them for all the batch's lanes at once, from
// the batch's weights, as vector lanes: marked by a member interpolates_in_lanes = true.
template <class Body, class = void>
struct InterpolatesInLanes : std::false_type {};
template <class Body>
struct InterpolatesInLanes<Body, std::void_t<decltype(Body::interpolates_in_lanes)>>
    : std::integral_constant<bool, Body::interpolates_in_lanes> {};
template <int L, class Body, class Batch, class Lanes>
KOKKOS_FORCEINLINE_FUNCTION void interpolate_lanes(const Body&, const Batch&, int, Lanes&, std::false_type) {}
template <int L, class Body, class Batch, class Lanes>
KOKKOS_FORCEINLINE_FUNCTION void interpolate_lanes(const Body& body, const Batch& batch, int count, Lanes& lanes,
                                                   std::true_type) {
  body.interpolate_lanes(batch, count, lanes);
}
template <int L, class Body, class Batch, class Particles, class Lanes>
KOKKOS_FORCEINLINE_FUNCTION void gather_then_finish(const Body& body, const Batch& batch, const Particles& particle,
                                                    int count, index_t row_stride, Lanes& lanes) {
  for (int l = 0; l < L; ++l) {
    if (l == count) break;
    body.gather(batch.stencil(l, row_stride), lanes, l);
  }
  interpolate_lanes<L>(body, batch, count, lanes, InterpolatesInLanes<Body>());
  finish_lanes<L>(body, particle, count, lanes);
}
template <int L, class Body, class Batch, class Particles>
KOKKOS_FORCEINLINE_FUNCTION void run_bodies(const Body& body, const Batch& batch, const Particles& particle,
                                            int count, index_t row_stride,
                                            BatchBodiesTag<BatchBodies::gather_then_finish>) {
  typename BatchLanes<Body, L>::type lanes;
  gather_then_finish<L>(body, batch, particle, count, row_stride, lanes);
}
// What each particle of a batch adds, particle by particle, or (a body that can, where the batch's
// particles are consecutive) for all of them at once (body.prepare_lanes), as vector lanes.
template <class Body, int L, class = void>
struct PreparesInLanes : std::false_type {};
template <class Body, int L>
struct PreparesInLanes<Body, L, std::void_t<decltype(Body::template prepares_in_lanes<L>)>>
    : std::integral_constant<bool, Body::template prepares_in_lanes<L>> {};
template <int L, class Body, class Particles, class Lanes, bool InLanes>
KOKKOS_FORCEINLINE_FUNCTION void prepare_lanes(const Body& body, const Particles& particle, int count, Lanes& lanes,
                                               std::integral_constant<bool, InLanes>) {
  for (int l = 0; l < count; ++l) body.prepare(particle(l), lanes, l);
}
template <int L, class Body, class Lanes>
KOKKOS_FORCEINLINE_FUNCTION void prepare_lanes(const Body& body, const ConsecutiveParticles& particle, int count,
                                               Lanes& lanes, std::true_type) {
  body.prepare_lanes(particle, count, lanes);
}
// ... or what each particle adds, then the additions.
template <int L, class Body, class Batch, class Particles>
KOKKOS_FORCEINLINE_FUNCTION void run_bodies(const Body& body, const Batch& batch, const Particles& particle,
                                            int count, index_t row_stride,
                                            BatchBodiesTag<BatchBodies::prepare_then_scatter>) {
  typename BatchLanes<Body, L>::type lanes;
  prepare_lanes<L>(body, particle, count, lanes, PreparesInLanes<Body, L>());
  for (int l = 0; l < count; ++l) body.add_prepared(batch.stencil(l, row_stride), lanes, l);
}
// ... or the node reads, then the particle updates (each preparing what its particle adds), then
// the additions (G2P then P2G).
template <int L, class Body, class Batch, class Particles>
KOKKOS_FORCEINLINE_FUNCTION void run_bodies(const Body& body, const Batch& batch, const Particles& particle,
                                            int count, index_t row_stride,
                                            BatchBodiesTag<BatchBodies::gather_finish_scatter>) {
  typename BatchLanes<Body, L>::type lanes;
  gather_then_finish<L>(body, batch, particle, count, row_stride, lanes);
  for (int l = 0; l < count; ++l) body.add_prepared(batch.stencil(l, row_stride), lanes, l);
}

// One batch: its stencils, then its bodies.
template <int L, class Shape, class Body, class Particles>
KOKKOS_FORCEINLINE_FUNCTION void run_batch(const Shape& shape, const Body& body, const Particles& particle, int count,
                                           const index_t* cell, const real_t* x, const real_t* y,
                                           index_t row_stride) {
  StencilBatch<Shape::stencil_width, L> batch;
  shape.fill_batch(particle, count, cell, x, y, batch);
  run_bodies<L>(body, batch, particle, count, row_stride, BatchBodiesTagOf<Body>());
}

template <class Shape, class Body>
void for_each_particle_batch(const char* label, const Shape& shape, const ParticleLocations& particles,
                             index_t num_particles, const Body& body) {
  const auto x = particles.x;
  const auto y = particles.y;
  const auto cell = particles.cell;
  constexpr int L = stencil_batch_size;
  const index_t row_stride = shape.grid.geometry.nodes_x;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, (num_particles + L - 1) / L), KOKKOS_LAMBDA(const index_t k) {
        const index_t first = k * L;
        const int count = num_particles - first < L ? static_cast<int>(num_particles - first) : L;
        run_batch<L>(shape, body, ConsecutiveParticles{first}, count, cell.data(), x.data(), y.data(), row_stride);
      });
}

template <class Shape, class Body>
void for_each_particle_stencil(const char* label, const Shape& shape, const ParticleLocations& particles,
                               const ParticleBatches& batches, const Body& body) {
  if constexpr (cpu_code_paths)
    for_each_particle_batch(label, shape, particles, batches.count, body);
  else
    for_each_particle_stencil(label, shape, particles, batches.count, body);
}

// The same, tile by tile: the cells are grouped in tiles and the tiles in four colours (2 x 2); the
// tiles of one colour run in parallel, one thread per tile walking its particles in index order
// (walk_tiles, ColouredTiles), or one team per tile (walk_tiles_in_teams, ColouredCells: the GPU
// path, for a body that reads nodes and adds into them; P2G alone gathers, walk_nodes_gathering,
// and G2P takes a thread a cell, walk_cells). A particle of cell (ci, cj) reaches nodes ci - r + 1
// .. ci + r (r = Shape::colour_period / 2), so two tiles of one colour, a tile apart, share no node
// when the tile is wider and taller than 2 r - 2 cells. Every node's sum so comes in an order fixed
// by the tiles and the particles' grouping alone: the same bits for any thread count. Tiles wide
// along x, where the cell order runs: a tile's row is a long stretch of consecutive particles (once
// reordered by cell), and 4 passes over the grid instead of colour_period^2 for single cells. On
// CPUs the stencils of a tile's particles are computed in batches, as for ParticleBatches.
//
// A team's tile on GPUs (ColouredCells, TeamTile): small, so that a colour has many of them.
constexpr TileExtent team_tile{64, 4};
// A thread's tile on CPUs (ColouredTiles), as large as the grid allows (walk_tile_for), chosen by
// the grid and the case's reordering alone, so that the sums' order does not depend on the
// threads. Each colour's pass fetches the nodes its tiles reach, and the other passes fetch again
// those of a tile's ring; a large tile's rows of nodes and of particles are long streams.
//  - Rectangles (walk_rectangle_for): the largest of walk_tiles_largest_first that gives at least
//    min_walk_tiles tiles, so that the threads have enough to share. A sorted P2G on one thread,
//    the cylinder at 448 x 224 reordered every step, took 40-42 ms a step with tiles of 64 x 4
//    cells, 35-36 with 128 x 16, and 33-37 with all the small tiles in one pass in order
//    (docs/performance_history.md).
//  - Where the run reorders its particles by cell, strips of whole rows of cells,
//    walk_strip_heights rows tall, where they give as many tiles a pass as the rectangles (or
//    enough_walk_tiles_a_pass): a strip is one stretch of the cell order, so that once reordered
//    its particles are one run (its batches all consecutive, none cut at a row's end) and its
//    window whole rows of nodes; with no tile beside it, two colour passes over the grid instead
//    of four. On the cylinder at 448 x 224 (28 strips of 8 rows
//    against 56 tiles of 128 x 16; kernel timer, least over the steps, reordered every 20 steps):
//    on two threads P2G 13.4-14.4 -> 12.1-13.0 ms a step, the fused G2P + remap P2G 8.1-9.0 ->
//    7.1-7.8, G2PD 9.8-10.5 -> 9.2-10.2; on one 26.4-26.5 -> 24.9-25.3, 15.4-15.6 -> 14.3-14.4 and
//    19.5 -> 19.3. Strips of 16 rows (7 a pass) left two threads unevenly loaded: P2G 15.6 ms.
//    Particles never reordered drift out of cell order, and a strip's particles then reach all
//    over its window, twice a rectangle's nodes; such a run keeps the rectangles: the cylinder
//    never reordered, 0.4 time units on two threads, took 29.0-31.3 ms a step for P2G in strips
//    and 24.9-25.9 in rectangles, 1.01-1.09e7 and 1.22-1.27e7 particle-steps/s for the run.
constexpr TileExtent walk_tiles_largest_first[] = {{128, 16}, {64, 8}, {64, 4}};
constexpr index_t min_walk_tiles = 32;
constexpr TileExtent smallest_walk_tile = walk_tiles_largest_first[std::size(walk_tiles_largest_first) - 1];
constexpr index_t walk_strip_heights[] = {8, 4};
constexpr index_t enough_walk_tiles_a_pass = 64;  // two a thread for 32 threads

// Tiles of `tile` cells over cells_x x cells_y cells along x and y, and in all.
KOKKOS_INLINE_FUNCTION index_t tiles_along_x(index_t cells_x, TileExtent tile) { return (cells_x + tile.x - 1) / tile.x; }
KOKKOS_INLINE_FUNCTION index_t tiles_along_y(index_t cells_y, TileExtent tile) { return (cells_y + tile.y - 1) / tile.y; }
KOKKOS_INLINE_FUNCTION index_t num_tiles(index_t cells_x, index_t cells_y, TileExtent tile) {
  return tiles_along_x(cells_x, tile) * tiles_along_y(cells_y, tile);
}

// The tiles of `tile` cells of one of the four colours: colour (a, b) holds tiles (a + 2 i, b + 2 j),
// `columns` of them per row, `rows` rows; its k-th tile, that tile's number and its cells.
struct TileColour {
  index_t a = 0, b = 0, columns = 0, rows = 0;
  index_t cells_x = 0, cells_y = 0, tiles_x = 0;
  TileExtent tile;

  TileColour(index_t cells_x_, index_t cells_y_, int colour, TileExtent tile_)
      : a(colour % 2), b(colour / 2), cells_x(cells_x_), cells_y(cells_y_), tiles_x(tiles_along_x(cells_x_, tile_)),
        tile(tile_) {
    const index_t tiles_y = tiles_along_y(cells_y, tile);
    columns = (tiles_x - a + 1) / 2 > 0 ? (tiles_x - a + 1) / 2 : 0;
    rows = (tiles_y - b + 1) / 2 > 0 ? (tiles_y - b + 1) / 2 : 0;
  }
  index_t tiles() const { return columns * rows; }
  // Tile k's place among all tiles, (tile_x(k), tile_y(k)), and its number there.
  KOKKOS_INLINE_FUNCTION index_t tile_x(index_t k) const { return a + 2 * (k % columns); }
  KOKKOS_INLINE_FUNCTION index_t tile_y(index_t k) const { return b + 2 * (k / columns); }
  KOKKOS_INLINE_FUNCTION index_t tile_number(index_t k) const { return tile_x(k) + tiles_x * tile_y(k); }
  // The cells [ci_begin, ci_end) x [cj_begin, cj_end) of tile k.
  KOKKOS_INLINE_FUNCTION void cells_of_tile(index_t k, index_t& ci_begin, index_t& ci_end, index_t& cj_begin,
                                            index_t& cj_end) const {
    ci_begin = tile_x(k) * tile.x;
    cj_begin = tile_y(k) * tile.y;
    ci_end = ci_begin + tile.x < cells_x ? ci_begin + tile.x : cells_x;
    cj_end = cj_begin + tile.y < cells_y ? cj_begin + tile.y : cells_y;
  }
};

// The tiles of the fullest colour's pass: colour 0's.
inline index_t walk_tiles_a_pass(index_t cells_x, index_t cells_y, TileExtent tile) {
  return TileColour(cells_x, cells_y, 0, tile).tiles();
}

// The walk's rectangles for a grid of cells_x x cells_y cells, and its tile there for particles
// in `order` (above).
inline TileExtent walk_rectangle_for(index_t cells_x, index_t cells_y) {
  for (const TileExtent tile : walk_tiles_largest_first)
    if (num_tiles(cells_x, cells_y, tile) >= min_walk_tiles) return tile;
  return smallest_walk_tile;
}
inline TileExtent walk_tile_for(index_t cells_x, index_t cells_y, ParticleOrder order) {
  const TileExtent rectangle = walk_rectangle_for(cells_x, cells_y);
  if (order == ParticleOrder::never_reordered) return rectangle;
  const index_t wanted = std::min(walk_tiles_a_pass(cells_x, cells_y, rectangle), enough_walk_tiles_a_pass);
  for (const index_t height : walk_strip_heights) {
    const TileExtent strip{cells_x, height};
    if (walk_tiles_a_pass(cells_x, cells_y, strip) >= wanted) return strip;
  }
  return rectangle;
}

// Whether the walk keeps `threads` threads busy on a grid of cells_x x cells_y cells: a colour's pass
// holds at least two tiles a thread (taken as threads come free), so that numerics/p2g = automatic
// can take the sorted P2G on CPUs (transfers.cpp). Its tiles are chosen by the grid and the
// particles' order alone, so a small grid, or a CPU of many threads, leaves threads idle in each pass.
inline bool walk_keeps_threads_busy(index_t cells_x, index_t cells_y, ParticleOrder order, int threads) {
  return walk_tiles_a_pass(cells_x, cells_y, walk_tile_for(cells_x, cells_y, order)) >=
         2 * static_cast<index_t>(threads);
}

// Each cell's tile of `extent` cells, tiles numbered row of tiles by row of tiles (ColouredTiles' grouping).
inline IndexView tile_of_each_cell(index_t cells_x, index_t cells_y, TileExtent extent) {
  IndexView tile(Kokkos::view_alloc(Kokkos::WithoutInitializing, "tile_of_cell"), cells_x * cells_y);
  const index_t tiles_x = tiles_along_x(cells_x, extent), tile_x = extent.x, tile_y = extent.y;
  Kokkos::parallel_for(
      "tile_of_cell", Kokkos::RangePolicy<ExecutionSpace>(0, cells_x * cells_y), KOKKOS_LAMBDA(const index_t c) {
        const index_t cj = c / cells_x, ci = c - cj * cells_x;
        tile(c) = ci / tile_x + tiles_x * (cj / tile_y);
      });
  return tile;
}

// The particles grouped by tile for ColouredTiles, rebuilt by build() as they move: CellOrder over
// the tiles, with the map from cell to tile kept while the grid's size stays the same. The tiles
// are walk_tile_for's for particles in `order`.
class TileOrder {
 public:
  explicit TileOrder(ParticleOrder order) : particle_order_(order) {}
  const ColouredTiles& build(const IndexView& particle_cell, index_t num_particles, index_t cells_x,
                             index_t cells_y) {
    if (tiles_.cells_x != cells_x || tiles_.cells_y != cells_y) {
      tiles_.tile = walk_tile_for(cells_x, cells_y, particle_order_);
      tile_of_cell_ = tile_of_each_cell(cells_x, cells_y, tiles_.tile);
    }
    order_.build(particle_cell, num_particles, tile_of_cell_, num_tiles(cells_x, cells_y, tiles_.tile));
    tiles_ = {order_.bin_offset(), order_.particle(), cells_x, cells_y, tiles_.tile};
    return tiles_;
  }
  size_t bytes() const { return order_.bytes() + tile_of_cell_.span() * sizeof(index_t); }

 private:
  ParticleOrder particle_order_;
  CellOrder order_;
  IndexView tile_of_cell_;
  ColouredTiles tiles_;
};

// An empty grouping of the particles, by tile (TileOrder: its tiles for particles in `order`) or
// by cell (CellOrder: every cell alike, whatever the particles' order). (A template, so that only
// the one in use is compiled.)
template <class Grouping>
Grouping make_particle_grouping(ParticleOrder order) {
  if constexpr (std::is_same<Grouping, TileOrder>::value)
    return Grouping(order);
  else
    return Grouping();
}

// The next batch of a tile's particles from slot s of its list `order` (slots before `end`), as the
// CPU walk takes them: up to stencil_batch_size consecutive particles, taken as such: the next 32
// if they are consecutive (the list strictly increases, so they are when the last is the first +
// 31), else those before the first break in the run (a particle that left the tile, one that came
// from another, the end of a row of the tile) if there are at least 8 of them; else the next 32 as
// listed particles. The batches depend on the list alone, not on the threads.
struct TileBatch {
  int count;
  bool consecutive;
};
KOKKOS_INLINE_FUNCTION TileBatch next_tile_batch(const index_t* order, index_t s, index_t end) {
  constexpr int L = stencil_batch_size, min_consecutive_batch = 8;
  const int count = end - s < L ? static_cast<int>(end - s) : L;
  if (order[s + count - 1] - order[s] == count - 1) return {count, true};
  int run = 1;
  while (order[s + run] == order[s] + run) ++run;  // (stops before s + count - 1)
  return run >= min_consecutive_batch ? TileBatch{run, true} : TileBatch{count, false};
}

// A tile's listed particles order[begin, end), batch by batch as next_tile_batch cuts them.
template <class Shape, class Body>
KOKKOS_INLINE_FUNCTION void run_tile_batches(const Shape& shape, const Body& body, const index_t* order, index_t begin,
                                             index_t end, const index_t* cell, const real_t* x, const real_t* y,
                                             index_t row_stride) {
  constexpr int L = stencil_batch_size;
  for (index_t s = begin; s < end;) {
    const TileBatch batch = next_tile_batch(order, s, end);
    if (batch.consecutive)
      run_batch<L>(shape, body, ConsecutiveParticles{order[s]}, batch.count, cell, x, y, row_stride);
    else
      run_batch<L>(shape, body, ListedParticles{order + s}, batch.count, cell, x, y, row_stride);
    s += batch.count;
  }
}

// One thread per tile (the CPU path): the tile's particles in index order, in the batches of
// next_tile_batch.
template <class Shape, class Body>
void walk_tiles(const char* label, const Shape& shape, const ParticleLocations& particles,
                const ColouredTiles& tiled, const Body& body) {
  const auto x = particles.x;
  const auto y = particles.y;
  const auto cell = particles.cell;
  const index_t row_stride = shape.grid.geometry.nodes_x;
  const IndexView offset = tiled.tile_offset, order = tiled.particle;
  // (A plain `if` on it below: nvcc allows no `if constexpr` around what a device lambda captures.)
  constexpr bool batched = cpu_code_paths;
  for (int colour = 0; colour < 4; ++colour) {
    const TileColour tiles(tiled.cells_x, tiled.cells_y, colour, tiled.tile);
    if (tiles.tiles() == 0) continue;
    // Tiles taken as threads come free: few and large, they hold unequal numbers of particles.
    // (Which thread adds a tile changes no sum.)
    using Dynamic = Kokkos::RangePolicy<ExecutionSpace, Kokkos::Schedule<Kokkos::Dynamic>>;
    Kokkos::parallel_for(
        label, Dynamic(0, tiles.tiles(), Kokkos::ChunkSize(1)), KOKKOS_LAMBDA(const index_t k) {
          const index_t t = tiles.tile_number(k);
          const index_t begin = offset(t), end = offset(t + 1);
          if (batched) {
            run_tile_batches(shape, body, order.data(), begin, end, cell.data(), x.data(), y.data(), row_stride);
          } else {
            for (index_t s = begin; s < end; ++s) {
              const index_t p = order(s);
              body(p, shape(p, cell(p), x(p), y(p)));
            }
          }
        });
  }
}

// A body that writes nothing but node fields, through a DirectNodeAccess `scatter` (P2G, P2GD),
// marked by a member type only_writes_nodes: each node's share can be gathered by a thread of its
// own (walk_nodes_gathering), or added into a thread's window (StagesInWindow).
template <class Body, class = void>
struct OnlyWritesNodes : std::false_type {};
template <class Body>
struct OnlyWritesNodes<Body, std::void_t<typename Body::only_writes_nodes>>
    : std::is_same<decltype(std::declval<Body&>().scatter), DirectNodeAccess> {};

// A body that writes no node (G2P, G2P + G2PD: it reads nodes and writes its particle, or adds into
// its particle's cell), marked by a member type writes_no_nodes: with the particles grouped by cell
// (ColouredCells) a thread a cell writes exclusively, without colours (walk_cells).
template <class Body, class = void>
struct WritesNoNodes : std::false_type {};
template <class Body>
struct WritesNoNodes<Body, std::void_t<typename Body::writes_no_nodes>> : std::true_type {};

// What a team does with a tile of the coloured traversal on GPUs (walk_tiles_in_teams), for a body
// that reads nodes as well as adding into them (the fused G2P + remap P2G; one that only writes
// nodes gathers instead, walk_nodes_gathering, and one that writes none takes a thread a cell,
// walk_cells). The team takes the tile's cells in colour_period^2 sub-colours, one after the other;
// the cells of one sub-colour, colour_period apart, share no node, and a thread takes each with its
// particles in order, writing the node fields directly. Every node's sum so comes in an order fixed
// by the cells and the particle order alone, as in walk_tiles (but another order than walk_tiles':
// the two agree to round-off).
template <class Shape, class Body>
struct TeamTile {
  using Team = typename Kokkos::TeamPolicy<ExecutionSpace>::member_type;
  static constexpr index_t P = Shape::colour_period;

  Shape shape;
  RealView x, y;
  IndexView cell, offset, order;
  Body body;
  TileColour tiles;

  KOKKOS_INLINE_FUNCTION void operator()(const Team& team) const {
    index_t ci_begin, ci_end, cj_begin, cj_end;
    tiles.cells_of_tile(team.league_rank(), ci_begin, ci_end, cj_begin, cj_end);
    for (index_t sub = 0; sub < P * P; ++sub) {
      // The cells of sub-colour `sub`, a thread each.
      const index_t ci_first = ci_begin + sub % P, cj_first = cj_begin + sub / P;
      const index_t nx = ci_first < ci_end ? (ci_end - ci_first + P - 1) / P : 0;
      const index_t ny = cj_first < cj_end ? (cj_end - cj_first + P - 1) / P : 0;
      Kokkos::parallel_for(Kokkos::TeamThreadRange(team, nx * ny), [&](const index_t m) {
        const index_t c = ci_first + P * (m % nx) + tiles.cells_x * (cj_first + P * (m / nx));
        for (index_t s = offset(c); s < offset(c + 1); ++s) {
          const index_t p = order(s);
          body(p, shape(p, cell(p), x(p), y(p)));
        }
      });
      team.team_barrier();
    }
  }
};

// The most node columns a thread of walk_nodes_gathering sums (the node state's 7, the output
// projection's 6), and the nodes it sums: a block of gather_block x gather_block.
constexpr int max_gathered_columns = 8;
constexpr index_t gather_block = 2;
using GatherBlockStencil = SeparableStencil<gather_block>;

// Particle p's share of the nodes of a block (walk_nodes_gathering), given as a stencil over the
// block whose factors are the particle's own on the nodes its stencil holds and zero on the others:
// the body's add_share where it has one (a body whose functor counts particles, in doubt: counted
// only where `counted`, in one block of the particle's nodes), or else the body itself.
template <class Body, class = void>
struct AddsShares : std::false_type {};
template <class Body>
struct AddsShares<Body, std::void_t<decltype(std::declval<const Body&>().add_share(
                            index_t(0), std::declval<const GatherBlockStencil&>(), true))>> : std::true_type {};
template <class Body>
KOKKOS_FORCEINLINE_FUNCTION void add_share(const Body& body, index_t p, const GatherBlockStencil& s, bool counted) {
  if constexpr (AddsShares<Body>::value)
    body.add_share(p, s, counted);
  else
    body(p, s);
}

// P2G on GPUs with the particles grouped by cell (ColouredCells), for a body that only writes nodes
// (OnlyWritesNodes): a thread a block of gather_block x gather_block nodes, which sums what the
// particles of the cells whose stencils may reach the block add to its nodes (a particle of cell
// ci reaches node lines ci - r + 1 .. ci + r, r = colour_period / 2), row of cells by row, each
// cell's particles in order, and adds the sums into the nodes once. Every node's sum so comes in
// an order fixed by the cells and the particle order alone: the same bits for any number of
// threads (another order than the CPU walk's: the two agree to round-off). No atomics, no colours,
// no scratch memory, and every thread busy. The price: each particle's stencil is computed by each
// block whose cells' range holds the particle's cell ((2 r + 1)^2 / 4 blocks on average: 2.25 for
// the linear shape, 6.25 for GIMP and B-splines), and its values by each block its stencil meets. A particle's share is
// the body's operations on a stencil over the block (the same products as on its own stencil;
// zero factors for the block's nodes outside it: the 3-wide stencils hold such nodes too). (With a
// node a thread, each particle's stencil was computed 16 times for GIMP, which made the GPU paths'
// tests on CPUs 1.14 times as long as with the blocks; a team a tile, whose threads took a cell each in colour_period^2
// sub-colours with the nodes staged in scratch memory, took 5.6 times as long as atomic P2G on an
// H200: docs/performance_history.md, "On GPUs".)
template <class Shape, class Body>
void walk_nodes_gathering(const char* label, const Shape& shape, const ParticleLocations& particles,
                          const ColouredCells& cells, const Body& body) {
  using Stencil = decltype(shape(index_t(0), index_t(0), real_t(0), real_t(0)));
  constexpr index_t K = Stencil::width, B = gather_block, r = Shape::colour_period / 2;
  const NodeFieldsView target = body.scatter.target;
  const int components = static_cast<int>(target.extent(1));
  if (components > max_gathered_columns)
    Kokkos::abort("walk_nodes_gathering: more node columns than max_gathered_columns");
  const GridGeometry geometry = shape.grid.geometry;
  const index_t nodes_x = geometry.nodes_x, nodes_y = geometry.nodes_y;
  const index_t blocks_x = (nodes_x + B - 1) / B, blocks_y = (nodes_y + B - 1) / B;
  const index_t cells_x = cells.cells_x, cells_y = cells.cells_y;
  const RealView x = particles.x, y = particles.y;
  const IndexView offset = cells.cell_offset, order = cells.particle;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, blocks_x * blocks_y), KOKKOS_LAMBDA(const index_t k) {
        const index_t bj = k / blocks_x, i0 = B * (k - bj * blocks_x), j0 = B * bj;
        real_t sums[B * B * max_gathered_columns];  // node (a, b) of the block, column c: a + B b + B^2 c
        for (int m = 0; m < B * B * components; ++m) sums[m] = 0;  // (the columns the body adds to)
        Body local = body;  // adding into `sums`
        local.scatter.target = NodeFieldsView(sums, B * B, components);
        const index_t ci_begin = i0 > r ? i0 - r : 0, ci_end = i0 + B - 1 + r < cells_x ? i0 + B - 1 + r : cells_x;
        const index_t cj_begin = j0 > r ? j0 - r : 0, cj_end = j0 + B - 1 + r < cells_y ? j0 + B - 1 + r : cells_y;
        for (index_t cj = cj_begin; cj < cj_end; ++cj)
          for (index_t ci = ci_begin; ci < ci_end; ++ci) {
            const index_t c = ci + cells_x * cj;
            for (index_t s = offset(c); s < offset(c + 1); ++s) {
              const index_t p = order(s);
              const Stencil st = shape(p, c, x(p), y(p));
              const index_t fi = geometry.node_i_of(st.first_node), fj = geometry.node_j_of(st.first_node);
              GatherBlockStencil block;
              block.first_node = 0;
              block.row_stride = B;
              bool meets_x = false, meets_y = false;
              for (index_t d = 0; d < B; ++d) {
                const index_t a = i0 + d - fi, b = j0 + d - fj;
                const bool in_x = a >= 0 && a < K, in_y = b >= 0 && b < K;
                block.wx[d] = in_x ? st.wx[a] : real_t(0), block.gx[d] = in_x ? st.gx[a] : real_t(0);
                block.wy[d] = in_y ? st.wy[b] : real_t(0), block.gy[d] = in_y ? st.gy[b] : real_t(0);
                meets_x = meets_x || in_x, meets_y = meets_y || in_y;
              }
              if (!(meets_x && meets_y)) continue;
              // (Counted in the block of the particle's first node, once.)
              add_share(local, p, block, fi >= i0 && fi < i0 + B && fj >= j0 && fj < j0 + B);
            }
          }
        for (index_t b = 0; b < B; ++b)
          for (index_t a = 0; a < B; ++a) {
            if (i0 + a >= nodes_x || j0 + b >= nodes_y) continue;  // (a block past the grid's last node)
            const index_t n = geometry.node_index(i0 + a, j0 + b);
            for (int c = 0; c < components; ++c) target(n, c) += sums[a + B * b + B * B * c];
          }
      });
}

// The windows of the CPU walks (walk_window_pass): a window holds whole
// rows of nodes (row stride nodes_x, so that a stencil's node n is the window's row n - base), of
// which a tile's reach is used: tile.x + 2 r - 1 by tile.y + 2 r - 1 nodes from (ci_begin - r + 1,
// cj_begin - r + 1), r = colour_period / 2. Its last row reaches window_x nodes past its start,
// which is more than nodes_x where the reach starts left of the grid (i0 < 0) on a grid narrower
// than the reach: so window_y - 1 whole rows and window_x nodes.
struct TileReach {
  index_t i0, j0;                  // the window's first node (may lie outside the grid)
  index_t i_begin, i_end, j_begin, j_end;  // its nodes within the grid
};
struct TileWindows {
  index_t nodes_x, nodes_y, window_x, window_y, r;
  template <class Shape>
  static TileWindows of(const Shape& shape, TileExtent tile) {
    constexpr index_t r = Shape::colour_period / 2;
    return {shape.grid.geometry.nodes_x, shape.grid.geometry.nodes_y, tile.x + 2 * r - 1, tile.y + 2 * r - 1, r};
  }
  size_t bytes(int width) const { return size_t(nodes_x * (window_y - 1) + window_x) * width * sizeof(real_t); }
  // The reach of the tile whose first cell is (ci_begin, cj_begin).
  KOKKOS_INLINE_FUNCTION TileReach reach(index_t ci_begin, index_t cj_begin) const {
    const index_t i0 = ci_begin - r + 1, j0 = cj_begin - r + 1;
    return {i0,
            j0,
            i0 > 0 ? i0 : 0,
            i0 + window_x < nodes_x ? i0 + window_x : nodes_x,
            j0 > 0 ? j0 : 0,
            j0 + window_y < nodes_y ? j0 + window_y : nodes_y};
  }
  KOKKOS_INLINE_FUNCTION index_t base(const TileReach& reach) const { return reach.i0 + nodes_x * reach.j0; }
};

// A body that only writes nodes (OnlyWritesNodes) and can add into a thread's node-major window
// instead: body.through(window) (P2GAndP2GDBody).
template <class Body, class = void>
struct StagesInWindow : std::false_type {};
template <class Body>
struct StagesInWindow<Body, std::void_t<decltype(std::declval<const Body&>().through(std::declval<NodeMajorWindow>()))>>
    : OnlyWritesNodes<Body> {};

// The node columns a tile's window takes (walk_tiles_in_windows): `read` columns of `source` from
// first_read, copied in as the window's first columns, and `added` columns that the particles add
// into, the window's next ones (zeroed), then added into `written` from first_written.
struct WindowColumnsOfTiles {
  NodeFieldsView source;
  int first_read, read;
  NodeFieldsView written;
  int first_written, added;
};

// All tiles in one pass, for a body that writes nothing two tiles share (as TileColour gives one
// colour's).
struct AllTiles {
  index_t count;
  KOKKOS_INLINE_FUNCTION index_t tile_number(index_t k) const { return k; }
  index_t tiles() const { return count; }
};

// The tiles of `tiles` (AllTiles or a TileColour), a thread each, each tile's nodes first copied
// into a window of the thread's (TileWindows) node by node as `columns` says; its particles then
// read (and add into) the window (body.through(window)); the columns added into are then added
// into the node fields. (A tile without particles is skipped: its window would add zeros.)
template <int W, class Shape, class Body, class Tiles>
void walk_window_pass(const char* label, const Shape& shape, const ParticleLocations& particles,
                      const ColouredTiles& tiled, const Tiles& tiles, const Body& body,
                      const WindowColumnsOfTiles& columns) {
  const TileWindows windows = TileWindows::of(shape, tiled.tile);
  const index_t nodes_x = windows.nodes_x;
  const size_t window_bytes = windows.bytes(W);
  const TileExtent tile = tiled.tile;
  const index_t tiles_x = tiles_along_x(tiled.cells_x, tile);
  const IndexView offset = tiled.tile_offset, order = tiled.particle;
  const NodeFieldsView source = columns.source, written = columns.written;
  const int first_read = columns.first_read, read = columns.read;
  const int first_written = columns.first_written, added = columns.added;
  using Policy = Kokkos::TeamPolicy<ExecutionSpace, Kokkos::Schedule<Kokkos::Dynamic>>;
  using Team = typename Policy::member_type;
  Policy policy(tiles.tiles(), 1);
  // A node's W columns are one vector (64 bytes, a cache line, for 8 doubles): the window starts on
  // a vector's boundary, so that no node's vector straddles two lines. (get_shmem aligns to 8 bytes
  // only; the OpenMP scratch started 48 bytes past a line here, every node access a split one:
  // aligned, P2G and G2PD took 7 % less, docs/performance_history.md.)
  constexpr size_t window_alignment = W * sizeof(real_t);
  policy.set_scratch_size(0, Kokkos::PerTeam(window_bytes + window_alignment));
  Kokkos::parallel_for(label, policy, KOKKOS_LAMBDA(const Team& team) {
    const index_t t = tiles.tile_number(team.league_rank());
    if (offset(t) == offset(t + 1)) return;
    const TileReach reach = windows.reach((t % tiles_x) * tile.x, (t / tiles_x) * tile.y);
    const NodeMajorWindowOf<W> window{
        static_cast<real_t*>(team.team_scratch(0).get_shmem_aligned(window_bytes, window_alignment)),
        windows.base(reach), first_written - read};
    for (index_t j = reach.j_begin; j < reach.j_end; ++j) {
      // The row's nodes zeroed whole (one contiguous stretch), then the columns read written over
      // their first ones. Zeroing only the columns past `read` made GCC call memset once a node for
      // those few bytes (24 for G2PD's window): with the copies, 5.8-5.9 % of a run's samples against
      // 3.8-4.6 % now (docs/performance_history.md, "The windows' fill").
      for (index_t i = reach.i_begin; i < reach.i_end; ++i)
        for (int c = 0; c < W; ++c) window.node(i + nodes_x * j)[c] = 0;
      for (int c = 0; c < read; ++c)
        for (index_t i = reach.i_begin; i < reach.i_end; ++i)
          window.node(i + nodes_x * j)[c] = source(i + nodes_x * j, first_read + c);
    }
    run_tile_batches(shape, body.through(window), order.data(), offset(t), offset(t + 1), particles.cell.data(),
                     particles.x.data(), particles.y.data(), nodes_x);
    for (index_t j = reach.j_begin; j < reach.j_end; ++j)
      for (int c = 0; c < added; ++c)
        for (index_t i = reach.i_begin; i < reach.i_end; ++i)
          written(i + nodes_x * j, first_written + c) += window.node(i + nodes_x * j)[read + c];
  });
}

// walk_window_pass over all tiles in one pass, or colour by colour where the body adds into nodes
// (`coloured`): tiles of one colour share no node.
template <int W, class Shape, class Body>
void walk_tiles_in_windows(const char* label, const Shape& shape, const ParticleLocations& particles,
                           const ColouredTiles& tiled, const Body& body, const WindowColumnsOfTiles& columns,
                           bool coloured) {
  if (!coloured)
    return walk_window_pass<W>(label, shape, particles, tiled,
                               AllTiles{num_tiles(tiled.cells_x, tiled.cells_y, tiled.tile)}, body, columns);
  for (int colour = 0; colour < 4; ++colour) {
    const TileColour tiles(tiled.cells_x, tiled.cells_y, colour, tiled.tile);
    if (tiles.tiles() > 0) walk_window_pass<W>(label, shape, particles, tiled, tiles, body, columns);
  }
}

// walk_tiles with each tile's nodes staged in a window of the thread's (CPUs): zeroed, the tile's
// particles added into it as walk_tiles adds them into the node fields, then added to the node
// fields once; with its columns further apart than a window is wide, walk_tiles.
template <class Shape, class Body>
void walk_tiles_staged(const char* label, const Shape& shape, const ParticleLocations& particles,
                       const ColouredTiles& tiled, const Body& body) {
  constexpr int W = NodeMajorWindow::width;
  const int first = body.first_written_column(), components = body.end_written_column() - first;
  if (components > W) return walk_tiles(label, shape, particles, tiled, body);
  walk_tiles_in_windows<W>(label, shape, particles, tiled, body,
                           WindowColumnsOfTiles{NodeFieldsView(), 0, 0, body.scatter.target, first, components}, true);
}

// A body that reads its nodes through a thread's window, marked by a member reads_through_window =
// true: one that reads node columns (NodeColumns: the first window_columns_read of the window's
// window_columns) and writes its particle (G2PAndG2PDBody), or besides adds into node columns
// (G2PThenP2GBody, through DirectNodeAccess: the window's next columns); body.through(window) is
// the same body reading (and adding into) the window.
template <class Body, class = void>
struct ReadsThroughWindow : std::false_type {};
template <class Body>
struct ReadsThroughWindow<Body, std::void_t<decltype(Body::reads_through_window)>>
    : std::integral_constant<bool, Body::reads_through_window> {};

// The tiles' particles of a body that reads its nodes through windows (CPUs): all tiles in one
// pass where it only writes its particles (no colours: nothing two tiles write is shared), colour
// by colour where it adds into nodes too.
template <class Shape, class Body>
void walk_tiles_through_windows(const char* label, const Shape& shape, const ParticleLocations& particles,
                                const ColouredTiles& tiled, const Body& body) {
  constexpr int W = window_width_for(Body::window_columns);
  constexpr bool adds = Body::window_columns > Body::window_columns_read;
  WindowColumnsOfTiles columns{body.node_functor.fields, body.node_functor.first_column, Body::window_columns_read,
                               NodeFieldsView(), 0, 0};
  if constexpr (adds) {
    columns.written = body.scatter.target;
    columns.first_written = body.first_component;
    columns.added = Body::window_columns - Body::window_columns_read;
  }
  walk_tiles_in_windows<W>(label, shape, particles, tiled, body, columns, adds);
}

// A thread per cell, its particles in order (ColouredCells), for a body that writes no node
// (WritesNoNodes): what it adds into its particle's cell comes in the particles' order, as on a
// team's tile (where the cells of a sub-colour took a thread each, one thread in colour_period^2
// busy at a time), but every thread busy.
template <class Shape, class Body>
void walk_cells(const char* label, const Shape& shape, const ParticleLocations& particles, const ColouredCells& cells,
                const Body& body) {
  const RealView x = particles.x, y = particles.y;
  const IndexView offset = cells.cell_offset, order = cells.particle;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, cells.cells_x * cells.cells_y), KOKKOS_LAMBDA(const index_t c) {
        for (index_t s = offset(c); s < offset(c + 1); ++s) {
          const index_t p = order(s);
          body(p, shape(p, c, x(p), y(p)));
        }
      });
}

// A team of threads per tile (the GPU path): TeamTile.
template <class Shape, class Body>
void walk_tiles_in_teams(const char* label, const Shape& shape, const ParticleLocations& particles,
                         const ColouredCells& cells, const Body& body) {
  for (int colour = 0; colour < 4; ++colour) {
    const TileColour tiles(cells.cells_x, cells.cells_y, colour, team_tile);
    if (tiles.tiles() == 0) continue;
    const TeamTile<Shape, Body> tile{shape,          particles.x, particles.y, particles.cell, cells.cell_offset,
                                     cells.particle, body,        tiles};
    auto policy = cells.team_size > 0 ? Kokkos::TeamPolicy<ExecutionSpace>(tiles.tiles(), cells.team_size)
                                      : Kokkos::TeamPolicy<ExecutionSpace>(tiles.tiles(), Kokkos::AUTO);
    Kokkos::parallel_for(label, policy, tile);
  }
}

// (ColouredCells or ColouredTiles.)
template <class Shape, class Body, class Coloured,
          class = std::enable_if_t<std::is_same<Coloured, ColouredCells>::value ||
                                   std::is_same<Coloured, ColouredTiles>::value>>
void for_each_particle_stencil(const char* label, const Shape& shape, const ParticleLocations& particles,
                               const Coloured& coloured, const Body& body) {
  constexpr TileExtent tile = std::is_same<Coloured, ColouredCells>::value ? team_tile : smallest_walk_tile;
  static_assert(tile.x > Shape::colour_period - 2 && tile.y > Shape::colour_period - 2,
                "tiles of one colour must not share a node");
  // (A strip has no tile beside it: only its height counts.)
  static_assert(walk_strip_heights[std::size(walk_strip_heights) - 1] > Shape::colour_period - 2,
                "strips of one colour must not share a node");
  if constexpr (std::is_same<Coloured, ColouredCells>::value && OnlyWritesNodes<Body>::value)
    walk_nodes_gathering(label, shape, particles, coloured, body);
  else if constexpr (std::is_same<Coloured, ColouredCells>::value && WritesNoNodes<Body>::value)
    walk_cells(label, shape, particles, coloured, body);
  else if constexpr (std::is_same<Coloured, ColouredCells>::value)
    walk_tiles_in_teams(label, shape, particles, coloured, body);
  else if constexpr (StagesInWindow<Body>::value && cpu_code_paths)
    walk_tiles_staged(label, shape, particles, coloured, body);
  else if constexpr (ReadsThroughWindow<Body>::value && cpu_code_paths)
    walk_tiles_through_windows(label, shape, particles, coloured, body);
  else
    walk_tiles(label, shape, particles, coloured, body);
}

// Runs body(p) for every particle p, without a stencil: all particles at once, or one thread per
// tile (ColouredTiles) walking its particles in order, so that a body writing to its particle's
// cell (P2C) writes exclusively and in a fixed order (no colours needed: a particle touches one
// cell). (Grouped by cell, ColouredCells, P2C walks each cell's particles itself: p2c below.)
template <class Body>
void for_each_particle(const char* label, index_t num_particles, const Body& body) {
  Kokkos::parallel_for(label, Kokkos::RangePolicy<ExecutionSpace>(0, num_particles), body);
}
template <class Body>
void for_each_particle(const char* label, const ParticleBatches& batches, const Body& body) {
  for_each_particle(label, batches.count, body);
}
template <class Body>
void for_each_particle(const char* label, const ColouredTiles& tiles, const Body& body) {
  const IndexView offset = tiles.tile_offset, order = tiles.particle;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, num_tiles(tiles.cells_x, tiles.cells_y, tiles.tile)),
      KOKKOS_LAMBDA(const index_t t) {
        const index_t begin = offset(t), end = offset(t + 1);
        for (index_t s = begin; s < end; ++s) body(order(s));
      });
}

// P2C body: cell(c, first + k) += F_k(p) for the cell c holding particle p.
template <class Access, class ParticleFunctor>
struct P2CBody {
  static constexpr int N = ParticleFunctor::num_components;
  Access scatter;
  IndexView cell;
  int first_component;
  ParticleFunctor functor;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t p) const {
    real_t value[N];
    functor(p, value);
    const auto& access = scatter.access();
    for (int c = 0; c < N; ++c) access(cell(p), first_component + c) += value[c];
  }
};

// P2C: per-cell sums over the particles of each cell, cell(c, first + k) += sum_{p in c} F_k(p),
// into a (cell, component) View through the same accumulators as P2G (a ScatterView over the
// cells, or DirectNodeAccess with the particles grouped by tile; by cell, the overload below). The
// particle functor follows the P2G contract.
template <class ScatterViewType, class ParticleFunctor, class Traversal>
void p2c(const char* label, const IndexView& particle_cell, const Traversal& traversal, ScatterViewType& scatter,
         int first_component, const ParticleFunctor& functor) {
  for_each_particle(label, traversal,
                    P2CBody<ScatterViewType, ParticleFunctor>{scatter, particle_cell, first_component, functor});
}
// ... with the particles grouped by cell (ColouredCells): each cell sums its particles in order in
// registers and writes its sums once. The same sums, bitwise, as adding each particle into the
// zeroed cell in the same order (0 + a = a).
template <class ParticleFunctor>
void p2c(const char* label, const IndexView&, const ColouredCells& cells, DirectNodeAccess& scatter,
         int first_component, const ParticleFunctor& functor) {
  constexpr int N = ParticleFunctor::num_components;
  const IndexView offset = cells.cell_offset, order = cells.particle;
  const NodeFieldsView target = scatter.target;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, cells.cells_x * cells.cells_y), KOKKOS_LAMBDA(const index_t c) {
        const index_t begin = offset(c), end = offset(c + 1);
        if (begin == end) return;
        real_t sum[N], value[N];
        functor(order(begin), sum);
        for (index_t s = begin + 1; s < end; ++s) {
          functor(order(s), value);
          for (int k = 0; k < N; ++k) sum[k] += value[k];
        }
        for (int k = 0; k < N; ++k) target(c, first_component + k) += sum[k];
      });
}

// The kernels below walk a stencil row by row (b along y, a along x) and use its tensor-product
// form: phi(a, b) = wx[a] wy[b], so the y factor multiplies a whole row once.

// value_c = sum_i F_c(node i) phi_i over stencil s: the interpolation of G2P.
template <class StencilType, class NodeFunctor, int N>
KOKKOS_FORCEINLINE_FUNCTION void interpolate(const StencilType& s, const NodeFunctor& node_functor, real_t (&value)[N]) {
  constexpr int K = StencilType::width;
  for (int c = 0; c < N; ++c) value[c] = 0;
  for (int b = 0; b < K; ++b) {
    real_t row[N];  // sum over the row of wx[a] F
    for (int c = 0; c < N; ++c) row[c] = 0;
    for (int a = 0; a < K; ++a) {
      real_t node_value[N];
      stencil_node_values(node_functor, s, a, b, node_value);
      for (int c = 0; c < N; ++c) row[c] += s.wx[a] * node_value[c];
    }
    for (int c = 0; c < N; ++c) value[c] += s.wy[b] * row[c];
  }
}

// node(i, first + c) += value_c phi_i over stencil s: the accumulation of P2G.
template <class StencilType, class Access, int N>
KOKKOS_FORCEINLINE_FUNCTION void accumulate(const StencilType& s, const Access& access, int first_component,
                                       const real_t (&value)[N]) {
  constexpr int K = StencilType::width;
  for (int b = 0; b < K; ++b) {
    real_t row[N];  // F wy[b]
    for (int c = 0; c < N; ++c) row[c] = value[c] * s.wy[b];
    for (int a = 0; a < K; ++a)
      for (int c = 0; c < N; ++c) access(s.node(a, b), first_component + c) += s.wx[a] * row[c];
  }
}

// ... into a thread's window (NodeMajorWindowOf): the same operations in the same order, a node's N
// columns as one vector (GCC keeps them scalar through the window's operator()).
template <class StencilType, int W, int N>
KOKKOS_FORCEINLINE_FUNCTION void accumulate(const StencilType& s, const NodeMajorWindowOf<W>& window,
                                            int first_component, const real_t (&value)[N]) {
  constexpr int K = StencilType::width;
  const int column = first_component - window.first_component;
  for (int b = 0; b < K; ++b) {
    real_t row[N];  // F wy[b]
    for (int c = 0; c < N; ++c) row[c] = value[c] * s.wy[b];
    real_t* const row_nodes = window.node(s, 0, b) + column;
    for (int a = 0; a < K; ++a) {
      real_t* node = row_nodes + a * W;
      const real_t wx = s.wx[a];
      MPMFLOW_VECTORISE
      for (int c = 0; c < N; ++c) node[c] += wx * row[c];
    }
  }
}

// The per-particle bodies of the kernels below are named functors with a templated call operator
// (the stencil type depends on the shape), not generic lambdas: nvcc cannot pass a generic device
// lambda into a template that launches its own device lambda.

// P2G body: node(i, first + c) += F_c(p) phi_i(X_p).
template <class Access, class ParticleFunctor>
struct P2GBody {
  using only_writes_nodes = std::true_type;  // (OnlyWritesNodes)
  static constexpr int N = ParticleFunctor::num_components;
  Access scatter;
  int first_component;
  ParticleFunctor functor;
  template <class StencilType>
  KOKKOS_FORCEINLINE_FUNCTION void operator()(const index_t p, const StencilType& s) const {
    real_t value[N];
    functor(p, value);
    accumulate(s, scatter.access(), first_component, value);
  }
};

// P2GD body: node(i, first + c) += G_c(p) . grad phi_i(X_p).
template <class Access, class ParticleFunctor>
struct P2GDBody {
  using only_writes_nodes = std::true_type;  // (OnlyWritesNodes)
  static constexpr int N = ParticleFunctor::num_components;
  Access scatter;
  int first_component;
  ParticleFunctor functor;
  template <class StencilType>
  KOKKOS_FORCEINLINE_FUNCTION void operator()(const index_t p, const StencilType& s) const {
    constexpr int K = StencilType::width;
    real_t vector[N][2];
    functor(p, vector);
    const auto& access = scatter.access();
    for (int b = 0; b < K; ++b) {
      real_t row_x[N], row_y[N];  // G_x wy[b] and G_y gy[b]
      for (int c = 0; c < N; ++c) {
        row_x[c] = vector[c][0] * s.wy[b];
        row_y[c] = vector[c][1] * s.gy[b];
      }
      for (int a = 0; a < K; ++a)
        for (int c = 0; c < N; ++c)
          access(s.node(a, b), first_component + c) += s.gx[a] * row_x[c] + s.wx[a] * row_y[c];
    }
  }
};

// One lane of a batch's per-particle values, stored component by component (each component's L
// lanes side by side), as value[c], and of its per-particle vectors as vector[c][axis]: written
// (Element real_t) by a P2G functor (LaneOutputs) and a P2GD one (LaneVectorOutputs), read (const
// real_t) by a G2P-and-G2PD sink (LaneValues, LaneGradients). A functor or sink whose call operator
// is a template over what it takes gets these, and its calls for a batch's lanes then run as vector
// lanes (GCC 12 keeps the loop scalar when each lane's values are an array of their own: "no
// vectype" for their strided loads).
template <int L, class Element>
struct LaneComponents {
  Element* first;  // the lane's component 0
  KOKKOS_FORCEINLINE_FUNCTION Element& operator[](int c) const { return first[c * L]; }
};
template <int L, class Element>
struct LaneVectors {
  Element* first;  // the lane's component 0 along x
  KOKKOS_FORCEINLINE_FUNCTION LaneComponents<L, Element> operator[](int c) const {
    return LaneComponents<L, Element>{first + 2 * c * L};
  }
};
template <int L>
using LaneOutputs = LaneComponents<L, real_t>;
template <int L>
using LaneVectorOutputs = LaneVectors<L, real_t>;
template <int L>
using LaneValues = LaneComponents<L, const real_t>;
template <int L>
using LaneGradients = LaneVectors<L, const real_t>;
// A P2G functor that writes its values through a template (functor.values(p, value)) and returns
// what it counts of the particle (a particle in doubt: 1), which functor.add_count(n) then adds for
// a whole batch at once; a P2GD functor whose call operator takes LaneVectorOutputs.
template <class Functor, int L, class = void>
struct WritesValuesInLanes : std::false_type {};
template <class Functor, int L>
struct WritesValuesInLanes<Functor, L,
                           std::void_t<decltype(std::declval<const Functor&>().values(index_t(0), LaneOutputs<L>{})),
                                       decltype(std::declval<const Functor&>().add_count(index_t(0)))>>
    : std::true_type {};
template <class Functor, int L, class = void>
struct WritesVectorsInLanes : std::false_type {};
template <class Functor, int L>
struct WritesVectorsInLanes<Functor, L,
                            std::void_t<decltype(std::declval<const Functor&>()(index_t(0), LaneVectorOutputs<L>{}))>>
    : std::true_type {};
// A P2G functor of N values that returns what it counts of a particle (values(p, value) into an
// array) and adds such counts (add_count), as WritesValuesInLanes without lanes. (Asked of lanes of
// one, the lanes' version, never called then, made nvcc warn of it as declared and unused.)
template <class Functor, int N, class = void>
struct CountsParticles : std::false_type {};
template <class Functor, int N>
struct CountsParticles<Functor, N,
                       std::void_t<decltype(std::declval<const Functor&>().values(index_t(0), std::declval<real_t (&)[N]>())),
                                   decltype(std::declval<const Functor&>().add_count(index_t(0)))>> : std::true_type {};

// A P2GD functor whose component d has its axis-d part alone, G_d = g_d e_d (zeta and eta of eq. 13,
// the force of an isotropic stress: F_d = g_d dphi/dx_d), marked by pairs_component_with_axis =
// true. It still writes the other parts, as zeros: the reference traversal adds them.
template <class Functor, class = void>
struct PairsComponentWithAxis : std::false_type {};
template <class Functor>
struct PairsComponentWithAxis<Functor, std::void_t<decltype(Functor::pairs_component_with_axis)>>
    : std::integral_constant<bool, Functor::pairs_component_with_axis && Functor::num_components == 2> {};

// P2G and P2GD body in one: F(p) phi_i into the value columns, G(p) . grad phi_i into the vector ones.
template <class Access, class ValueFunctor, class VectorFunctor>
struct P2GAndP2GDBody {
  using only_writes_nodes = std::true_type;  // (OnlyWritesNodes)
  static constexpr int NV = ValueFunctor::num_components;
  static constexpr int ND = VectorFunctor::num_components;
  Access scatter;
  int first_value_component;
  ValueFunctor value_functor;
  int first_vector_component;
  VectorFunctor vector_functor;
  template <class StencilType>
  KOKKOS_FORCEINLINE_FUNCTION void operator()(const index_t p, const StencilType& s) const {
    real_t value[NV];
    real_t vector[ND][2];
    value_functor(p, value);
    vector_functor(p, vector);
    add(s, value, vector);
  }
  // The same on a block of nodes (walk_nodes_gathering), the particle counted (in doubt) only where
  // `counted`: in one block of its nodes, not in each.
  template <class StencilType>
  KOKKOS_FORCEINLINE_FUNCTION void add_share(const index_t p, const StencilType& s, bool counted) const {
    real_t value[NV];
    real_t vector[ND][2];
    if constexpr (CountsParticles<ValueFunctor, NV>::value) {
      const index_t in_doubt = value_functor.values(p, value);
      if (counted) value_functor.add_count(in_doubt);
    } else {
      value_functor(p, value);
    }
    vector_functor(p, vector);
    add(s, value, vector);
  }
  // In two phases over a batch (PreparesThenScatters).
  static constexpr bool prepares_then_scatters = true;
  static constexpr bool into_window = std::is_same<Access, NodeMajorWindow>::value;
  static constexpr int W = NodeMajorWindow::width;
  template <int L>
  struct ColumnLanes {
    real_t value[L][NV];
    real_t vector[L][ND][2];
  };
  // Into a window (NodeMajorWindow): each particle's additions as node vectors of W columns, F in
  // the value columns of `value`, G_y and G_x in the vector columns of `along_y` and `across`, so
  // that a node's addition is one vector operation: w += wx[a] (wy[b] value + gy[b] along_y) +
  // gx[a] wy[b] across. Made for the whole batch before any is added: a vector read right after
  // its elements were stored one by one waits for the stores (no store forwarding), which made a
  // first version slower than the column by column addition.
  template <int L>
  struct NodeVectorLanes {
    static constexpr int size = L;
    real_t value[L][W], along_y[L][W], across[L][W];
    // (prepare_lanes: the functors' values and vectors, lane by lane in each component.)
    real_t lane_value[NV][L], lane_vector[ND][2][L];
    index_t counted[L];
  };
  // ... or, where the vector functor pairs each component with its axis (PairsComponentWithAxis: the
  // step's force), one node vector a particle: F in the value columns, g_d in vector column d.
  // Node (a, b) adds it times the factors of column a of the stencil and of row b, column by column
  // wx[a] wy[b] for the values, gx[a] wy[b] for g_x's column and wx[a] gy[b] for g_y's: a
  // multiplication and an addition a node, and a third of the stores that make the vectors. The
  // factors are taken by 0/1 columns (takes_gx, takes_gy; w (1 - t) + g t is w or g exactly), not
  // comparisons, which GCC made branches of. P2G 0.92-0.95 times as long as with three vectors
  // (docs/performance_history.md, "P2G's force as one node vector a particle").
  static constexpr bool one_node_vector = PairsComponentWithAxis<VectorFunctor>::value;
  template <int L>
  struct PairedNodeVectorLanes {
    static constexpr int size = L;
    real_t value[L][W];
    real_t takes_gx[W], takes_gy[W];
    real_t lane_value[NV][L], lane_vector[ND][2][L];
    index_t counted[L];
  };
  template <int L>
  using WindowLanes = std::conditional_t<one_node_vector, PairedNodeVectorLanes<L>, NodeVectorLanes<L>>;
  // The functors of a batch of consecutive particles at once, as vector lanes (their divisions 8 at a
  // time with AVX-512; particle by particle they were a quarter of P2G's time), then the node vectors.
  // (A conjunction: a body not into a window does not ask the functors about lanes, whose versions
  // for lanes a GPU build then never calls, and nvcc warned of them as declared and unused.)
  template <int L>
  static constexpr bool prepares_in_lanes =
      std::conjunction<std::integral_constant<bool, into_window>, WritesValuesInLanes<ValueFunctor, L>,
                       WritesVectorsInLanes<VectorFunctor, L>>::value;
  template <class VectorLanes>
  KOKKOS_FORCEINLINE_FUNCTION void prepare_lanes(const ConsecutiveParticles& particle, int count,
                                                 VectorLanes& lanes) const {
    constexpr int L = VectorLanes::size;
    MPMFLOW_VECTORISE
    for (int l = 0; l < count; ++l) {
      lanes.counted[l] = value_functor.values(particle(l), LaneOutputs<L>{&lanes.lane_value[0][l]});
      vector_functor(particle(l), LaneVectorOutputs<L>{&lanes.lane_vector[0][0][l]});
    }
    index_t counted = 0;
    for (int l = 0; l < count; ++l) counted += lanes.counted[l];
    value_functor.add_count(counted);
    // Each lane's values copied into arrays for node_vectors: reading them there through LaneValues
    // and LaneVectors instead made P2G 8 % slower (ten paired runs), node_vectors' stores into the
    // lanes (value, along_y, across) then perhaps aliasing what it reads.
    for (int l = 0; l < count; ++l) {
      real_t value[NV];
      real_t vector[ND][2];
      for (int c = 0; c < NV; ++c) value[c] = lanes.lane_value[c][l];
      for (int c = 0; c < ND; ++c) {
        vector[c][0] = lanes.lane_vector[c][0][l];
        vector[c][1] = lanes.lane_vector[c][1][l];
      }
      node_vectors(value, vector, lanes, l);
    }
    set_factor_columns(lanes);
  }
  template <int L>
  using Lanes = std::conditional_t<into_window, WindowLanes<L>, ColumnLanes<L>>;
  template <int L>
  KOKKOS_FORCEINLINE_FUNCTION void prepare(const index_t p, ColumnLanes<L>& lanes, int l) const {
    value_functor(p, lanes.value[l]);
    vector_functor(p, lanes.vector[l]);
  }
  template <class VectorLanes>
  KOKKOS_FORCEINLINE_FUNCTION void prepare(const index_t p, VectorLanes& lanes, int l) const {
    real_t value[NV];
    real_t vector[ND][2];
    value_functor(p, value);
    vector_functor(p, vector);
    node_vectors(value, vector, lanes, l);
    if (l == 0) set_factor_columns(lanes);
  }
  template <class StencilType, int L>
  KOKKOS_FORCEINLINE_FUNCTION void add_prepared(const StencilType& s, const ColumnLanes<L>& lanes, int l) const {
    add(s, lanes.value[l], lanes.vector[l]);
  }
  template <class StencilType, int L>
  KOKKOS_FORCEINLINE_FUNCTION void add_prepared(const StencilType& s, const NodeVectorLanes<L>& lanes, int l) const {
    add_node_vectors(s, lanes.value[l], lanes.along_y[l], lanes.across[l]);
  }
  template <class StencilType, int L>
  KOKKOS_FORCEINLINE_FUNCTION void add_prepared(const StencilType& s, const PairedNodeVectorLanes<L>& lanes,
                                                int l) const {
    constexpr int K = StencilType::width;
    real_t column_factor[K][W];
    for (int a = 0; a < K; ++a) {
      const real_t wx = s.wx[a], gx = s.gx[a];
      for (int c = 0; c < W; ++c) column_factor[a][c] = wx * (1 - lanes.takes_gx[c]) + gx * lanes.takes_gx[c];
    }
    for (int b = 0; b < K; ++b) {
      real_t row[W];  // the particle's node vector times the row's factors
      const real_t wy = s.wy[b], gy = s.gy[b];
      for (int c = 0; c < W; ++c) row[c] = lanes.value[l][c] * (wy * (1 - lanes.takes_gy[c]) + gy * lanes.takes_gy[c]);
      real_t* const row_nodes = scatter.node(s, 0, b);
      for (int a = 0; a < K; ++a) {
        real_t* node = row_nodes + a * W;
        MPMFLOW_VECTORISE
        for (int c = 0; c < W; ++c) node[c] += row[c] * column_factor[a][c];
      }
    }
  }
  // The same body adding into a thread's window (walk_tiles_staged).
  using staged_body = P2GAndP2GDBody<NodeMajorWindow, ValueFunctor, VectorFunctor>;
  KOKKOS_INLINE_FUNCTION staged_body through(const NodeMajorWindow& window) const {
    return {window, first_value_component, value_functor, first_vector_component, vector_functor};
  }
  // The node fields' columns it writes: [first_written_column(), end_written_column()).
  int first_written_column() const {
    return first_value_component < first_vector_component ? first_value_component : first_vector_component;
  }
  int end_written_column() const {
    return first_value_component + NV > first_vector_component + ND ? first_value_component + NV
                                                                     : first_vector_component + ND;
  }
  template <int L>
  KOKKOS_FORCEINLINE_FUNCTION void node_vectors(const real_t (&value)[NV], const real_t (&vector)[ND][2],
                                                NodeVectorLanes<L>& lanes, int l) const {
    real_t(&node_value)[W] = lanes.value[l];
    real_t(&along_y)[W] = lanes.along_y[l];
    real_t(&across)[W] = lanes.across[l];
    for (int c = 0; c < W; ++c) node_value[c] = along_y[c] = across[c] = 0;
    const int fv = first_value_component - scatter.first_component;
    const int fd = first_vector_component - scatter.first_component;
    for (int c = 0; c < NV; ++c) node_value[fv + c] = value[c];
    for (int c = 0; c < ND; ++c) {
      along_y[fd + c] = vector[c][1];
      across[fd + c] = vector[c][0];
    }
  }
  template <int L>
  KOKKOS_FORCEINLINE_FUNCTION void node_vectors(const real_t (&value)[NV], const real_t (&vector)[ND][2],
                                                PairedNodeVectorLanes<L>& lanes, int l) const {
    real_t(&node_value)[W] = lanes.value[l];
    for (int c = 0; c < W; ++c) node_value[c] = 0;
    const int fv = first_value_component - scatter.first_component;
    const int fd = first_vector_component - scatter.first_component;
    for (int c = 0; c < NV; ++c) node_value[fv + c] = value[c];
    for (int d = 0; d < ND; ++d) node_value[fd + d] = vector[d][d];
  }
  template <int L>
  KOKKOS_FORCEINLINE_FUNCTION void set_factor_columns(NodeVectorLanes<L>&) const {}
  template <int L>
  KOKKOS_FORCEINLINE_FUNCTION void set_factor_columns(PairedNodeVectorLanes<L>& lanes) const {
    const int fd = first_vector_component - scatter.first_component;
    for (int c = 0; c < W; ++c) lanes.takes_gx[c] = lanes.takes_gy[c] = 0;
    lanes.takes_gx[fd] = 1;
    lanes.takes_gy[fd + 1] = 1;
  }
  template <class StencilType>
  KOKKOS_FORCEINLINE_FUNCTION void add_node_vectors(const StencilType& s, const real_t (&node_value)[W],
                                                    const real_t (&along_y)[W], const real_t (&across)[W]) const {
    constexpr int K = StencilType::width;
    for (int b = 0; b < K; ++b) {
      real_t along[W], across_b[W];  // the row's wy[b] F + gy[b] G_y and wy[b] G_x
      const real_t wy = s.wy[b], gy = s.gy[b];
      for (int c = 0; c < W; ++c) {
        along[c] = wy * node_value[c] + gy * along_y[c];
        across_b[c] = wy * across[c];
      }
      real_t* const row_nodes = scatter.node(s, 0, b);
      for (int a = 0; a < K; ++a) {
        real_t* node = row_nodes + a * W;
        const real_t wx = s.wx[a], gx = s.gx[a];
        MPMFLOW_VECTORISE
        for (int c = 0; c < W; ++c) node[c] += wx * along[c] + gx * across_b[c];
      }
    }
  }
  // Column by column (into a window too, through its operator(): its batches take the node vectors
  // above).
  template <class StencilType>
  KOKKOS_FORCEINLINE_FUNCTION void add(const StencilType& s, const real_t (&value)[NV],
                                       const real_t (&vector)[ND][2]) const {
    constexpr int K = StencilType::width;
    const auto& access = scatter.access();
    for (int b = 0; b < K; ++b) {
      real_t row[NV], row_x[ND], row_y[ND];
      for (int c = 0; c < NV; ++c) row[c] = value[c] * s.wy[b];
      for (int c = 0; c < ND; ++c) {
        row_x[c] = vector[c][0] * s.wy[b];
        row_y[c] = vector[c][1] * s.gy[b];
      }
      for (int a = 0; a < K; ++a) {
        const index_t node = s.node(a, b);
        for (int c = 0; c < NV; ++c) access(node, first_value_component + c) += s.wx[a] * row[c];
        for (int c = 0; c < ND; ++c)
          access(node, first_vector_component + c) += s.gx[a] * row_x[c] + s.wx[a] * row_y[c];
      }
    }
  }
};

// G2P body: value_c = sum_i F_c(node i) phi_i(X_p), handed to sink(p, value).
template <class NodeFunctor, class ParticleSink>
struct G2PBody {
  using writes_no_nodes = std::true_type;  // (WritesNoNodes)
  static constexpr int N = NodeFunctor::num_components;
  NodeFunctor node_functor;
  ParticleSink sink;
  template <class StencilType>
  KOKKOS_FORCEINLINE_FUNCTION void operator()(const index_t p, const StencilType& s) const {
    real_t value[N];
    interpolate(s, node_functor, value);
    sink(p, value);
  }
};

// G2P then P2G body: the interpolated value goes to update(p, value, out), and out is accumulated.
template <class NodeFunctor, class ParticleUpdate, class Access>
struct G2PThenP2GBody {
  static constexpr int N = NodeFunctor::num_components;
  static constexpr int M = ParticleUpdate::num_components;
  NodeFunctor node_functor;
  ParticleUpdate update;
  Access scatter;
  int first_component;
  template <class StencilType>
  KOKKOS_FORCEINLINE_FUNCTION void operator()(const index_t p, const StencilType& s) const {
    real_t value[N];
    interpolate(s, node_functor, value);
    real_t out[M];
    update(p, value, out);
    accumulate(s, scatter.access(), first_component, out);
  }
  // In three phases over a batch (GathersThenFinishes and PreparesThenScatters), where the update
  // writes nothing but its own particle: the interpolations, the updates, the additions. (Its
  // interpolations of two columns in vector lanes, as G2PAndG2PDBody's, were slower with GIMP: the
  // node values' stores into the lanes cost more than the few multiply-adds they save.)
  static constexpr bool gathers_then_finishes = WritesOnlyItsParticle<ParticleUpdate>::value;
  static constexpr bool prepares_then_scatters = WritesOnlyItsParticle<ParticleUpdate>::value;
  template <int L>
  struct Lanes {
    real_t value[L][N];
    real_t out[L][M];
  };
  template <class StencilType, int L>
  KOKKOS_FORCEINLINE_FUNCTION void gather(const StencilType& s, Lanes<L>& lanes, int l) const {
    interpolate(s, node_functor, lanes.value[l]);
  }
  template <int L>
  KOKKOS_FORCEINLINE_FUNCTION void finish(index_t p, Lanes<L>& lanes, int l) const {
    update(p, lanes.value[l], lanes.out[l]);
  }
  template <class StencilType, int L>
  KOKKOS_FORCEINLINE_FUNCTION void add_prepared(const StencilType& s, const Lanes<L>& lanes, int l) const {
    accumulate(s, scatter.access(), first_component, lanes.out[l]);
  }
  // The same body reading its node columns from a thread's window and adding into the window's next
  // columns (walk_tiles_through_windows, ReadsThroughWindow): a node's reads one vector load, its
  // additions one vector load, multiply-add and store, instead of a scalar one per column in
  // columns 0.8 MB apart, and their address arithmetic.
  static constexpr bool reads_through_window = IsNodeColumns<NodeFunctor>::value &&
                                               std::is_same<Access, DirectNodeAccess>::value &&
                                               gathers_then_finishes && N + M <= NodeMajorWindow::width;
  static constexpr int window_columns_read = N, window_columns = N + M;
  template <int W>
  KOKKOS_INLINE_FUNCTION G2PThenP2GBody<WindowColumns<N, W>, ParticleUpdate, NodeMajorWindowOf<W>> through(
      const NodeMajorWindowOf<W>& window) const {
    return {{window}, update, window, first_component};
  }
};

// Whether a G2P-and-G2PD sink takes a batch's interpolated values and gradients as lanes
// (LaneValues, LaneGradients); otherwise it gets each lane's values copied into arrays.
template <class Sink, int L, class = void>
struct TakesLanes : std::false_type {};
template <class Sink, int L>
struct TakesLanes<Sink, L,
                  std::void_t<decltype(std::declval<const Sink&>()(index_t(0), std::declval<LaneValues<L>>(),
                                                                   std::declval<LaneGradients<L>>()))>>
    : std::true_type {};

// Which of a G2P-and-G2PD sink's interpolations it reads: the values, gradients along x and along y
// of the components whose bits are set, as a member type reads_interpolations =
// InterpolationsRead<values, gradients_x, gradients_y>; all of them for a sink without it. Where
// the interpolations come from a thread's window (walk_tiles_through_windows), only those are
// stored into the batch's lanes and the rest left unset: a sink reading one it does not list would
// read whatever the stack held (the step's update is tested against the batches' path, which
// stores all). (A type: nvcc warns of a constant its build never reads.)
template <unsigned Values, unsigned GradientsX, unsigned GradientsY>
struct InterpolationsRead {
  KOKKOS_INLINE_FUNCTION static constexpr bool value(int c) { return (Values >> c) & 1u; }
  KOKKOS_INLINE_FUNCTION static constexpr bool gradient_x(int c) { return (GradientsX >> c) & 1u; }
  KOKKOS_INLINE_FUNCTION static constexpr bool gradient_y(int c) { return (GradientsY >> c) & 1u; }
};
template <class Sink, class = void>
struct InterpolationsReadByOf {
  using type = InterpolationsRead<~0u, ~0u, ~0u>;
};
template <class Sink>
struct InterpolationsReadByOf<Sink, std::void_t<typename Sink::reads_interpolations>> {
  using type = typename Sink::reads_interpolations;
};
template <class Sink>
using InterpolationsReadBy = typename InterpolationsReadByOf<Sink>::type;

// G2P and G2PD body in one: value_c = sum_i F_c(node i) phi_i(X_p) and gradient_c = sum_i
// F_c(node i) grad phi_i(X_p), handed to sink(p, value, gradient). The value costs a multiply-add
// per row and column more than the gradient alone: its row sums are the gradient's along y.
// K: the shape's stencil width (Shape::stencil_width).
template <class NodeFunctor, class ParticleSink, int K>
struct G2PAndG2PDBody {
  using writes_no_nodes = std::true_type;  // (WritesNoNodes)
  static constexpr int N = NodeFunctor::num_components;
  NodeFunctor node_functor;
  ParticleSink sink;
  template <class StencilType>
  KOKKOS_FORCEINLINE_FUNCTION void interpolate_at(const StencilType& s, real_t (&value)[N],
                                                  real_t (&gradient)[N][2]) const {
    static_assert(StencilType::width == K, "the body's stencil width is the shape's");
    for (int c = 0; c < N; ++c) value[c] = gradient[c][0] = gradient[c][1] = 0;
    for (int b = 0; b < K; ++b) {
      real_t row_w[N], row_g[N];  // sums over the row of wx[a] F and gx[a] F
      for (int c = 0; c < N; ++c) row_w[c] = row_g[c] = 0;
      for (int a = 0; a < K; ++a) {
        real_t node_value[N];
        node_functor(s.node(a, b), node_value);
        for (int c = 0; c < N; ++c) {
          row_w[c] += s.wx[a] * node_value[c];
          row_g[c] += s.gx[a] * node_value[c];
        }
      }
      for (int c = 0; c < N; ++c) {
        value[c] += s.wy[b] * row_w[c];
        gradient[c][0] += s.wy[b] * row_g[c];
        gradient[c][1] += s.gy[b] * row_w[c];
      }
    }
  }
  template <class StencilType>
  KOKKOS_FORCEINLINE_FUNCTION void operator()(const index_t p, const StencilType& s) const {
    real_t value[N], gradient[N][2];
    interpolate_at(s, value, gradient);
    sink(p, value, gradient);
  }
  // In three phases over a batch (for_each_particle_stencil, ParticleBatches), where the sink allows
  // its calls to run as vector lanes: the node values of the L particles' stencils, particle by
  // particle (scalar loads: vector gathers cost more on CPUs); then their interpolations, as vector
  // lanes, from the batch's weights (the multiply-adds, 70 a particle for linear, 8 lanes at a time
  // with AVX-512; the same operations in the same order as interpolate_at); then the
  // sinks. The lanes' values are stored component by component, and handed to a sink that takes
  // them as they are (LaneValues, LaneGradients) or copied into arrays for one that does not.
  //
  // Reading a thread's window (WindowColumns, walk_tiles_through_windows), where a node's columns
  // lie side by side: particle by particle, each node's columns as one vector of the window's
  // width, a multiply-add of it per weight (the same operations in the same order), the results
  // stored into the lanes for the sinks. Nine vector loads a GIMP particle instead of 45 scalar
  // loads and stores, and their address arithmetic, which were half of G2PD's time. Only the
  // results the sink reads are stored (InterpolationsRead): each is a scalar store out of a vector
  // register, and the step's update reads 6 of its 18 (storing all of them was 28 % of linear
  // G2PD's samples, `perf annotate`). The batches' path (ColumnLanes), whose stores are vector
  // lanes, stores them all: the tests compare the two.
  static constexpr bool from_window = IsWindowColumns<NodeFunctor>::value;
  static constexpr bool gathers_then_finishes = WritesOnlyItsParticle<ParticleSink>::value;
  static constexpr bool interpolates_in_lanes = !from_window;
  template <int L>
  struct ColumnLanes {
    static constexpr int size = L;
    real_t node_value[N][K * K][L];  // node (a, b) of lane l's stencil at a + K b, component by component
    real_t value[N][L];
    real_t gradient[N][2][L];
  };
  template <int L>
  struct InterpolatedLanes {
    static constexpr int size = L;
    real_t value[N][L];
    real_t gradient[N][2][L];
  };
  template <int L>
  using Lanes = std::conditional_t<from_window, InterpolatedLanes<L>, ColumnLanes<L>>;
  template <class StencilType, int L>
  KOKKOS_FORCEINLINE_FUNCTION void gather(const StencilType& s, ColumnLanes<L>& lanes, int l) const {
    static_assert(StencilType::width == K, "the body's stencil width is the shape's");
    for (int b = 0; b < K; ++b)
      for (int a = 0; a < K; ++a) {
        real_t node_value[N];
        node_functor(s.node(a, b), node_value);
        for (int c = 0; c < N; ++c) lanes.node_value[c][a + K * b][l] = node_value[c];
      }
  }
  template <class StencilType, int L>
  KOKKOS_FORCEINLINE_FUNCTION void gather(const StencilType& s, InterpolatedLanes<L>& lanes, int l) const {
    static_assert(StencilType::width == K, "the body's stencil width is the shape's");
    constexpr int W = decltype(node_functor.window)::width;
    real_t value[W], gradient_x[W], gradient_y[W];
    for (int c = 0; c < W; ++c) value[c] = gradient_x[c] = gradient_y[c] = 0;
    for (int b = 0; b < K; ++b) {
      real_t row_w[W], row_g[W];
      for (int c = 0; c < W; ++c) row_w[c] = row_g[c] = 0;
      const real_t* const row_nodes = node_functor.window.node(s, 0, b);
      for (int a = 0; a < K; ++a) {
        const real_t* node = row_nodes + a * W;
        const real_t wx = s.wx[a], gx = s.gx[a];
        MPMFLOW_VECTORISE
        for (int c = 0; c < W; ++c) {
          row_w[c] += wx * node[c];
          row_g[c] += gx * node[c];
        }
      }
      const real_t wy = s.wy[b], gy = s.gy[b];
      MPMFLOW_VECTORISE
      for (int c = 0; c < W; ++c) {
        value[c] += wy * row_w[c];
        gradient_x[c] += wy * row_g[c];
        gradient_y[c] += gy * row_w[c];
      }
    }
    using Read = InterpolationsReadBy<ParticleSink>;
    for (int c = 0; c < N; ++c) {
      if (Read::value(c)) lanes.value[c][l] = value[c];
      if (Read::gradient_x(c)) lanes.gradient[c][0][l] = gradient_x[c];
      if (Read::gradient_y(c)) lanes.gradient[c][1][l] = gradient_y[c];
    }
  }
  // The same body reading the node functor's columns from a thread's window, where they fit in it
  // (walk_tiles_through_windows), and the sink writes only its particle (so that the tiles need no
  // colours).
  static constexpr bool reads_through_window =
      IsNodeColumns<NodeFunctor>::value && WritesOnlyItsParticle<ParticleSink>::value && N <= NodeMajorWindow::width;
  static constexpr int window_columns_read = N, window_columns = N;
  template <int W>
  KOKKOS_INLINE_FUNCTION G2PAndG2PDBody<WindowColumns<N, W>, ParticleSink, K> through(
      const NodeMajorWindowOf<W>& window) const {
    return {{window}, sink};
  }
  template <class Batch, int L>
  KOKKOS_FORCEINLINE_FUNCTION void interpolate_lanes(const Batch& batch, int count, ColumnLanes<L>& lanes) const {
    MPMFLOW_VECTORISE
    for (int l = 0; l < count; ++l) {
      real_t value[N], gradient_x[N], gradient_y[N];
      for (int c = 0; c < N; ++c) value[c] = gradient_x[c] = gradient_y[c] = 0;
      for (int b = 0; b < K; ++b) {
        real_t row_w[N], row_g[N];
        for (int c = 0; c < N; ++c) row_w[c] = row_g[c] = 0;
        for (int a = 0; a < K; ++a)
          for (int c = 0; c < N; ++c) {
            row_w[c] += batch.wx[a][l] * lanes.node_value[c][a + K * b][l];
            row_g[c] += batch.gx[a][l] * lanes.node_value[c][a + K * b][l];
          }
        for (int c = 0; c < N; ++c) {
          value[c] += batch.wy[b][l] * row_w[c];
          gradient_x[c] += batch.wy[b][l] * row_g[c];
          gradient_y[c] += batch.gy[b][l] * row_w[c];
        }
      }
      for (int c = 0; c < N; ++c) {
        lanes.value[c][l] = value[c];
        lanes.gradient[c][0][l] = gradient_x[c];
        lanes.gradient[c][1][l] = gradient_y[c];
      }
    }
  }
  // (LanesType: ColumnLanes<L> or InterpolatedLanes<L>.)
  template <class LanesType>
  KOKKOS_FORCEINLINE_FUNCTION void finish(index_t p, const LanesType& lanes, int l) const {
    finish(p, lanes, l, TakesLanes<ParticleSink, LanesType::size>());
  }
  template <class LanesType>
  KOKKOS_FORCEINLINE_FUNCTION void finish(index_t p, const LanesType& lanes, int l, std::true_type) const {
    constexpr int L = LanesType::size;
    sink(p, LaneValues<L>{&lanes.value[0][l]}, LaneGradients<L>{&lanes.gradient[0][0][l]});
  }
  template <class LanesType>
  KOKKOS_FORCEINLINE_FUNCTION void finish(index_t p, const LanesType& lanes, int l, std::false_type) const {
    using Read = InterpolationsReadBy<ParticleSink>;  // (those not stored are not copied either)
    real_t value[N], gradient[N][2];
    for (int c = 0; c < N; ++c) {
      value[c] = Read::value(c) ? lanes.value[c][l] : real_t(0);
      gradient[c][0] = Read::gradient_x(c) ? lanes.gradient[c][0][l] : real_t(0);
      gradient[c][1] = Read::gradient_y(c) ? lanes.gradient[c][1][l] : real_t(0);
    }
    sink(p, value, gradient);
  }
};

// A G2PD sink, sink(p, gradient), as a G2P-and-G2PD one that leaves the values unused.
template <class GradientSink>
struct GradientOnly {
  using writes_only_its_particle = std::integral_constant<bool, WritesOnlyItsParticle<GradientSink>::value>;
  GradientSink sink;
  template <int N>
  KOKKOS_FORCEINLINE_FUNCTION void operator()(index_t p, const real_t (&)[N], const real_t (&gradient)[N][2]) const {
    sink(p, gradient);
  }
};

// P2G (eq. 16): node(i, c) += sum_p F_c(p) phi_i(X_p).
template <class Shape, class ScatterViewType, class ParticleFunctor, class Traversal>
void p2g(const char* label, const Shape& shape, const ParticleLocations& particles, const Traversal& traversal,
         ScatterViewType& scatter, int first_component, const ParticleFunctor& functor) {
  for_each_particle_stencil(label, shape, particles, traversal,
                            P2GBody<ScatterViewType, ParticleFunctor>{scatter, first_component, functor});
}

// P2GD (eq. 18): node(i, c) += sum_p G_c(p) . grad phi_i(X_p).
template <class Shape, class ScatterViewType, class ParticleFunctor, class Traversal>
void p2gd(const char* label, const Shape& shape, const ParticleLocations& particles, const Traversal& traversal,
          ScatterViewType& scatter, int first_component, const ParticleFunctor& functor) {
  for_each_particle_stencil(label, shape, particles, traversal,
                            P2GDBody<ScatterViewType, ParticleFunctor>{scatter, first_component, functor});
}

// P2G and P2GD fused (Algorithm 1, step 3): one pass, one stencil evaluation per particle, for
// node(i, value columns) += F(p) phi_i and node(i, vector columns) += G(p) . grad phi_i into the
// same ScatterView. Worth it because the stencil (and for GIMP its weights) dominates both.
template <class Shape, class ScatterViewType, class ValueFunctor, class VectorFunctor, class Traversal>
void p2g_and_p2gd(const char* label, const Shape& shape, const ParticleLocations& particles,
                  const Traversal& traversal, ScatterViewType& scatter, int first_value_component,
                  const ValueFunctor& value_functor, int first_vector_component,
                  const VectorFunctor& vector_functor) {
  for_each_particle_stencil(label, shape, particles, traversal,
                            P2GAndP2GDBody<ScatterViewType, ValueFunctor, VectorFunctor>{
                                scatter, first_value_component, value_functor, first_vector_component,
                                vector_functor});
}

// G2P (eq. 17): value_c(p) = sum_i F_c(node i) phi_i(X_p), handed to sink(p, value).
template <class Shape, class NodeFunctor, class ParticleSink, class Traversal>
void g2p(const char* label, const Shape& shape, const ParticleLocations& particles, const Traversal& traversal,
         const NodeFunctor& node_functor, const ParticleSink& sink) {
  for_each_particle_stencil(label, shape, particles, traversal, G2PBody<NodeFunctor, ParticleSink>{node_functor, sink});
}

// G2P then P2G in one pass (Algorithm 1, steps 6-8 fused): for each particle, value_c(p) =
// sum_i F_c(node i) phi_i(X_p) as in g2p; update(p, value, out) consumes it and returns the
// particle's contribution, and node(i, c) += out_c(p) phi_i(X_p) as in p2g, with the same stencil.
// Valid when the P2G target is not what the G2P reads. Saves the second stencil evaluation and the
// second read of the particle positions (the paper ran the two as separate kernels).
//   update: static constexpr int num_components (M);
//           void operator()(index_t p, const real_t (&value)[N], real_t (&out)[M]) const
template <class Shape, class NodeFunctor, class ParticleUpdate, class ScatterViewType, class Traversal>
void g2p_then_p2g(const char* label, const Shape& shape, const ParticleLocations& particles,
                  const Traversal& traversal, const NodeFunctor& node_functor, const ParticleUpdate& update,
                  ScatterViewType& scatter, int first_component) {
  for_each_particle_stencil(label, shape, particles, traversal,
                            G2PThenP2GBody<NodeFunctor, ParticleUpdate, ScatterViewType>{
                                node_functor, update, scatter, first_component});
}

// G2PD (eq. 19): gradient_c(p) = sum_i F_c(node i) grad phi_i(X_p), handed to sink(p, gradient).
// The traversal is a particle count, or ColouredCells where the sink writes to its particle's cell.
template <class Shape, class NodeFunctor, class ParticleSink, class Traversal>
void g2pd(const char* label, const Shape& shape, const ParticleLocations& particles, const Traversal& traversal,
          const NodeFunctor& node_functor, const ParticleSink& sink) {
  using Body = G2PAndG2PDBody<NodeFunctor, GradientOnly<ParticleSink>, Shape::stencil_width>;
  for_each_particle_stencil(label, shape, particles, traversal, Body{node_functor, {sink}});
}

// G2P and G2PD in one pass, with one stencil: value_c(p) = sum_i F_c(node i) phi_i(X_p) and
// gradient_c(p) = sum_i F_c(node i) grad phi_i(X_p), handed to sink(p, value, gradient). (Algorithm
// 1 interpolates V-bar in step 6 and keeps it per particle until the move, step 11; taking it here,
// where the step-10 gradient is read, saves the two per-particle fields and their traffic.)
template <class Shape, class NodeFunctor, class ParticleSink, class Traversal>
void g2p_and_g2pd(const char* label, const Shape& shape, const ParticleLocations& particles,
                  const Traversal& traversal, const NodeFunctor& node_functor, const ParticleSink& sink) {
  using Body = G2PAndG2PDBody<NodeFunctor, ParticleSink, Shape::stencil_width>;
  for_each_particle_stencil(label, shape, particles, traversal, Body{node_functor, sink});
}

}  // namespace mpmflow
