// Invariants of the Q1 shape functions and of the generic transfer kernels.
#include <gtest/gtest.h>


#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numeric>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include "kernels/blas1.hpp"
#include "kernels/particle_compaction.hpp"
#include "kernels/particle_sort.hpp"
#include "kernels/transfer_kernels.hpp"
#include "round_off.hpp"

namespace mpmflow {
namespace {

// An 8 x 7 cell grid with spacing (0.5, 0.25) and origin (-1, 2): nothing about it is special.
// As in the solver's slabs, the outer layer of cells is a ghost layer: particles live in cells
// [1, cells - 1), and GIMP stencils of particles in the outer particle cells reach the ghost nodes.
GridGeometry test_grid() {
  GridGeometry g;
  g.origin_x = -1;
  g.origin_y = 2;
  g.spacing_x = 0.5;
  g.spacing_y = 0.25;
  g.nodes_x = 12;  // wide enough for inner nodes of the B-spline's support (inner_margin 3)
  g.nodes_y = 11;
  return g;
}

struct HostParticles {
  std::vector<real_t> x, y, mass;
};

// Particles uniformly at random in the non-ghost cells, random masses.
HostParticles random_particles(const GridGeometry& g, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(g.node_x(1), g.node_x(g.cells_x() - 1)),
      uy(g.node_y(1), g.node_y(g.cells_y() - 1));
  std::uniform_real_distribution<double> um(0.5, 2.0);
  HostParticles p;
  for (int k = 0; k < n; ++k) {
    p.x.push_back(ux(rng));
    p.y.push_back(uy(rng));
    p.mass.push_back(um(rng));
  }
  return p;
}

// ppc x ppc particles per cell at the centres of a regular sub-grid, unit mass each: placement
// symmetric about every interior node.
HostParticles regular_particles(const GridGeometry& g, int ppc) {
  HostParticles p;
  for (int cj = 1; cj < g.cells_y() - 1; ++cj)
    for (int ci = 1; ci < g.cells_x() - 1; ++ci)
      for (int b = 0; b < ppc; ++b)
        for (int a = 0; a < ppc; ++a) {
          p.x.push_back(g.node_x(ci) + g.spacing_x * (a + 0.5) / ppc);
          p.y.push_back(g.node_y(cj) + g.spacing_y * (b + 0.5) / ppc);
          p.mass.push_back(1.0);
        }
  return p;
}

RealView to_device(const std::vector<real_t>& values, const char* label) {
  RealView v(std::string(label), values.size());
  auto h = Kokkos::create_mirror_view(v);
  for (size_t k = 0; k < values.size(); ++k) h(k) = values[k];
  Kokkos::deep_copy(v, h);
  return v;
}

struct DeviceParticles {
  ParticleLocations where;
  RealView mass;
  index_t count;
};

DeviceParticles to_device(const GridGeometry& g, const HostParticles& p) {
  DeviceParticles d;
  d.count = static_cast<index_t>(p.x.size());
  d.where.x = to_device(p.x, "x");
  d.where.y = to_device(p.y, "y");
  d.where.cell = IndexView("cell", d.count);
  d.mass = to_device(p.mass, "mass");
  const auto x = d.where.x, y = d.where.y;
  const auto cell = d.where.cell;
  Kokkos::parallel_for(
      d.count, KOKKOS_LAMBDA(const index_t k) { cell(k) = g.cell_of(x(k), y(k)); });
  return d;
}

// The shape policies under test, each built for a grid and a set of particles. GIMP particles get
// the domain of 3 x 3 particles per cell at stretch 1. inner_margin: node lines from the grid edge
// a node must be for its support to lie wholly in the particles' region (one cell in from the
// edge): support half-widths 1, 7/6 and 3/2 cells.
struct MakeLinear {
  static LinearShape make(const GridGeometry& g, index_t) { return LinearShape{g}; }
  static constexpr const char* name = "linear";
  static constexpr int inner_margin = 2;
};
struct MakeGimp {
  static GimpShape make(const GridGeometry& g, index_t n) {
    RealView sx("stretch_x", n), sy("stretch_y", n);
    Kokkos::deep_copy(sx, 1.0);
    Kokkos::deep_copy(sy, 1.0);
    return GimpShape{g, g.spacing_x / 6, g.spacing_y / 6, sx, sy};
  }
  static constexpr const char* name = "gimp";
  static constexpr int inner_margin = 2;
};

struct MakeBSpline {
  static BSplineShape make(const GridGeometry& g, index_t) { return BSplineShape{g}; }
  static constexpr const char* name = "bspline";
  static constexpr int inner_margin = 3;
};

real_t linear_field(real_t x, real_t y) { return 3.0 - 2.0 * x + 0.75 * y; }

// Particle functors used below.
// M, M f(X). Written through a template, as the step's values are (WritesValuesInLanes), so that a
// P2G body whose vectors can be too makes a batch of consecutive particles' in vector lanes; it
// counts no particle.
struct MassAndLinearField {
  static constexpr int num_components = 2;
  RealView mass, x, y;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, real_t (&v)[2]) const { add_count(values(p, v)); }
  template <class Values>
  KOKKOS_INLINE_FUNCTION index_t values(index_t p, Values&& v) const {
    v[0] = mass(p);
    v[1] = mass(p) * (3.0 - 2.0 * x(p) + 0.75 * y(p));
    return 0;
  }
  KOKKOS_INLINE_FUNCTION void add_count(index_t) const {}
};

struct ConstantStressTimesVolume {  // G = s M (1, 0) and s M (0, 1), as the internal force
  static constexpr int num_components = 2;
  RealView mass;
  real_t stress;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, real_t (&v)[2][2]) const {
    v[0][0] = stress * mass(p);
    v[0][1] = 0;
    v[1][0] = 0;
    v[1][1] = stress * mass(p);
  }
};

struct VaryingVectors {  // G_c = M (1 + c + x, 2 - c y): every component differs from particle to particle
  static constexpr int num_components = 2;
  RealView mass, x, y;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, real_t (&v)[2][2]) const {
    for (int c = 0; c < 2; ++c) {
      v[c][0] = mass(p) * (1 + c + x(p));
      v[c][1] = mass(p) * (2 - c * y(p));
    }
  }
};

// G_0 = (M (1 + x), 0), G_1 = (0, M (2 - y)): each component along its own axis alone, as the step's
// force (PairsComponentWithAxis), which a window then adds as one node vector a particle. Written
// through a template, as the step's functors are, so that a batch of consecutive particles makes
// them in vector lanes (WritesVectorsInLanes).
struct PairedVectors {
  static constexpr int num_components = 2;
  static constexpr bool pairs_component_with_axis = true;
  RealView mass, x, y;
  template <class Vectors>
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, Vectors&& v) const {
    v[0][0] = mass(p) * (1 + x(p));
    v[0][1] = 0;
    v[1][0] = 0;
    v[1][1] = mass(p) * (2 - y(p));
  }
};

struct NodeColumnsRatio {  // node value = fields(i, 1) / fields(i, 0)
  static constexpr int num_components = 1;
  NodeFieldsView fields;
  KOKKOS_INLINE_FUNCTION void operator()(index_t i, real_t (&v)[1]) const {
    v[0] = fields(i, 0) > 0 ? fields(i, 1) / fields(i, 0) : 0;
  }
};

struct NodeColumn {  // node value = fields(i, 0)
  static constexpr int num_components = 1;
  NodeFieldsView fields;
  KOKKOS_INLINE_FUNCTION void operator()(index_t i, real_t (&v)[1]) const { v[0] = fields(i, 0); }
};

struct StoreValue {
  RealView out;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, const real_t (&v)[1]) const { out(p) = v[0]; }
};

struct StoreGradient {
  // Lets the batched traversal run it in vector lanes (G2PAndG2PDBody's two phases), so that the
  // tests of the batched mode cover that path.
  using writes_only_its_particle = std::true_type;
  RealView out_x, out_y;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, const real_t (&g)[1][2]) const {
    out_x(p) = g[0][0];
    out_y(p) = g[0][1];
  }
};

// Component `c` of the interpolated values and gradients, read through whatever the kernel hands
// over: arrays, or the batched traversal's lanes as they are (LaneValues, LaneGradients: a sink with
// a template call operator takes them). With StoreGradient (arrays, through GradientOnly) the tests
// of the batched mode cover both ways.
template <int c>
struct StoreValueAndGradient {
  using writes_only_its_particle = std::true_type;  // as StoreGradient
  RealView value, out_x, out_y;
  template <class Values, class Gradients>
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, Values v, Gradients g) const {
    value(p) = v[c];
    out_x(p) = g[c][0];
    out_y(p) = g[c][1];
  }
};
static_assert(TakesLanes<StoreValueAndGradient<0>, stencil_batch_size>::value, "the lanes handed as they are");
static_assert(!TakesLanes<GradientOnly<StoreGradient>, stencil_batch_size>::value, "the lanes copied into arrays");

struct TwoLinearNodeFields {  // node values f and 3 f - 1, f = fields(i, 0)
  static constexpr int num_components = 2;
  NodeFieldsView fields;
  KOKKOS_INLINE_FUNCTION void operator()(index_t i, real_t (&v)[2]) const {
    v[0] = fields(i, 0);
    v[1] = 3 * fields(i, 0) - 1;
  }
};

using Dup = Kokkos::Experimental::ScatterDuplicated;
using Atomic = Kokkos::Experimental::ScatterNonDuplicated;

// The sorted, coloured P2G (no ScatterView): the third accumulation mode under test, one thread
// per tile (Coloured: ColouredTiles, the CPU path), or a team per tile (ColouredTeams:
// ColouredCells, the GPU path, run here on the CPU).
struct Coloured {};
struct ColouredTeams {};
template <class D>
constexpr bool is_coloured = std::is_same<D, Coloured>::value || std::is_same<D, ColouredTeams>::value;

// The particles `d` on `g` grouped for the coloured traversal of mode D: by tile or by cell.
template <class D>
struct ColouredTraversal {
  static constexpr bool teams = std::is_same<D, ColouredTeams>::value;
  using Order = std::conditional_t<teams, CellOrder, TileOrder>;
  // By tile, the tiles for particles reordered by cell: the test grids below walk strips where
  // they pay, as the cylinder's case does.
  Order order = make_particle_grouping<Order>(ParticleOrder::reordered_by_cell);
  std::conditional_t<teams, ColouredCells, ColouredTiles> cells;
  static ColouredTraversal of(const GridGeometry& g, const DeviceParticles& d) {
    ColouredTraversal t;
    if constexpr (teams) {
      t.order.build(d.where.cell, d.count, g.num_cells());
      t.cells = ColouredCells{t.order.bin_offset(), t.order.particle(), g.cells_x(), g.cells_y()};
      // Teams of as many threads as there are (up to 2): the sub-colours' exclusive writes under test.
      t.cells.team_size = Kokkos::DefaultExecutionSpace().concurrency() > 1 ? 2 : 1;
    } else {
      t.cells = t.order.build(d.where.cell, d.count, g.cells_x(), g.cells_y());
    }
    return t;
  }
};
// The duplicated ScatterView with the fast traversal (ParticleBatches: batched stencils on CPUs);
// the other ScatterView modes take the reference traversal, one particle at a time.
struct Batched {};

// The ScatterView duplication of mode D (Batched: duplicated).
template <class D>
using DuplicationOf = std::conditional_t<std::is_same<D, Batched>::value, Dup, D>;

// The traversal of all particles for mode D.
template <class D>
auto all_of(const DeviceParticles& d) {
  if constexpr (std::is_same<D, Batched>::value) return ParticleBatches{d.count};
  else return d.count;
}

// Runs P2G of `functor` into a fresh (nodes x columns) View with a ScatterView of mode D, or
// colour by colour for the coloured modes.
template <class D, bool derivative, class Shape, class Functor>
NodeFieldsView run_p2g(const Shape& shape, const DeviceParticles& d, int columns, const Functor& f) {
  NodeFieldsView fields("fields", shape.grid.geometry.num_nodes(), columns);
  if constexpr (is_coloured<D>) {
    const auto t = ColouredTraversal<D>::of(shape.grid.geometry, d);
    DirectNodeAccess direct{fields};
    if constexpr (derivative) p2gd("test_p2gd", shape, d.where, t.cells, direct, 0, f);
    else p2g("test_p2g", shape, d.where, t.cells, direct, 0, f);
    return fields;
  } else {
    NodeScatterView<DuplicationOf<D>> scatter(fields);
    p2g_begin(scatter, fields);
    if constexpr (derivative) p2gd("test_p2gd", shape, d.where, all_of<D>(d), scatter, 0, f);
    else p2g("test_p2g", shape, d.where, all_of<D>(d), scatter, 0, f);
    p2g_end(scatter, fields);
    return fields;
  }
}

// Every kernel test runs for each ScatterView mode and each shape function.
template <class D, class M>
struct Config {
  using Duplication = D;
  using MakeShape = M;
};
template <class C>
class TransferKernels : public ::testing::Test {};
using Configs =
    ::testing::Types<Config<Dup, MakeLinear>, Config<Atomic, MakeLinear>, Config<Coloured, MakeLinear>,
                     Config<Batched, MakeLinear>, Config<Dup, MakeGimp>, Config<Atomic, MakeGimp>,
                     Config<Coloured, MakeGimp>, Config<Batched, MakeGimp>, Config<Dup, MakeBSpline>,
                     Config<Atomic, MakeBSpline>, Config<Coloured, MakeBSpline>, Config<Batched, MakeBSpline>,
                     Config<ColouredTeams, MakeLinear>, Config<ColouredTeams, MakeGimp>,
                     Config<ColouredTeams, MakeBSpline>>;
struct ConfigNames {
  template <class C>
  static std::string GetName(int) {
    using D = typename C::Duplication;
    const char* mode = std::is_same<D, Dup>::value        ? "_duplicated"
                       : std::is_same<D, Coloured>::value ? "_sorted"
                       : std::is_same<D, ColouredTeams>::value ? "_sorted_teams"
                       : std::is_same<D, Batched>::value  ? "_batched"
                                                          : "_atomic";
    return std::string(C::MakeShape::name) + mode;
  }
};
TYPED_TEST_SUITE(TransferKernels, Configs, ConfigNames);

// Nodes whose whole support lies inside the particle region (`margin` node lines in from the grid
// edge, the shape's inner_margin): regular placement is symmetric about them.
bool is_inner_node(const GridGeometry& g, int i, int j, int margin) {
  return i >= margin && j >= margin && i <= g.nodes_x - 1 - margin && j <= g.nodes_y - 1 - margin;
}

// Each particle's stencil (its nodes, weights and gradients), evaluated where the shape's Views
// live (on the GPU in a GPU build: a GIMP shape's stretches are device Views, which the host may
// not read) and copied to the host for the checks.
using StencilNodes = Kokkos::View<index_t**, MemorySpace>;
using StencilValues = Kokkos::View<real_t**, MemorySpace>;
struct HostStencils {  // (particle, stencil entry)
  StencilNodes::HostMirror node;
  StencilValues::HostMirror weight, grad_x, grad_y;
};
template <class Shape>
struct EvaluateStencils {
  Shape shape;
  ParticleLocations where;
  StencilNodes node;
  StencilValues weight, grad_x, grad_y;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t p) const {
    const auto s = shape(p, where.cell(p), where.x(p), where.y(p));
    for (int a = 0; a < Shape::stencil_size; ++a) {
      node(p, a) = s.node(a);
      weight(p, a) = s.weight(a);
      grad_x(p, a) = s.grad_x(a);
      grad_y(p, a) = s.grad_y(a);
    }
  }
};
template <class Shape>
HostStencils stencils_on_host(const Shape& shape, const ParticleLocations& where, index_t count) {
  constexpr int S = Shape::stencil_size;
  EvaluateStencils<Shape> evaluate{shape,
                                   where,
                                   StencilNodes("stencil_node", count, S),
                                   StencilValues("stencil_weight", count, S),
                                   StencilValues("stencil_grad_x", count, S),
                                   StencilValues("stencil_grad_y", count, S)};
  Kokkos::parallel_for("test_stencils", Kokkos::RangePolicy<ExecutionSpace>(0, count), evaluate);
  return {Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), evaluate.node),
          Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), evaluate.weight),
          Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), evaluate.grad_x),
          Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), evaluate.grad_y)};
}

// True when every node particle p's stencil weights is an inner node.
bool stencil_is_inner(const HostStencils& stencils, const GridGeometry& g, int margin, index_t p) {
  for (size_t a = 0; a < stencils.node.extent(1); ++a) {
    const index_t node = stencils.node(p, a);
    if (stencils.weight(p, a) != 0 && !is_inner_node(g, g.node_i_of(node), g.node_j_of(node), margin)) return false;
  }
  return true;
}

TYPED_TEST(TransferKernels, PartitionOfUnityAndZeroGradientSum) {
  const GridGeometry g = test_grid();
  const DeviceParticles d = to_device(g, random_particles(g, 500, 1));
  const auto shape = TypeParam::MakeShape::make(g, d.count);
  using Shape = std::remove_const_t<decltype(shape)>;
  const HostStencils s = stencils_on_host(shape, d.where, d.count);
  for (index_t k = 0; k < d.count; ++k) {
    double sum = 0, gx = 0, gy = 0;
    for (int a = 0; a < Shape::stencil_size; ++a) {
      EXPECT_GE(s.weight(k, a), -round_off(1e-15));
      EXPECT_LE(s.weight(k, a), 1 + round_off(1e-15));
      sum += s.weight(k, a);
      gx += s.grad_x(k, a);
      gy += s.grad_y(k, a);
    }
    EXPECT_NEAR(sum, 1.0, round_off(1e-14));
    EXPECT_NEAR(gx, 0.0, round_off(1e-12));
    EXPECT_NEAR(gy, 0.0, round_off(1e-12));
  }
}

// The CPU path's batched stencils (Shape::fill_batch) against the shape's own, particle by
// particle: consecutive particles (ParticleBatches) and listed ones in another order (the sorted
// P2G's cell order), with a batch left part empty, and GIMP particles of many sizes.
template <class M>
class BatchedStencils : public ::testing::Test {};
using Shapes = ::testing::Types<MakeLinear, MakeGimp, MakeBSpline>;
struct ShapeNames {
  template <class M>
  static std::string GetName(int) {
    return M::name;
  }
};
TYPED_TEST_SUITE(BatchedStencils, Shapes, ShapeNames);

TYPED_TEST(BatchedStencils, EqualThePerParticleStencils) {
  if (!std::is_same<MemorySpace, Kokkos::HostSpace>::value) GTEST_SKIP() << "batches are the CPU path";
  const GridGeometry g = test_grid();
  const HostParticles p = random_particles(g, 1001, 11);  // not a whole number of batches
  const DeviceParticles d = to_device(g, p);
  auto shape = TypeParam::make(g, d.count);
  if constexpr (std::is_same<decltype(shape), GimpShape>::value) {
    std::mt19937 rng(12);
    std::uniform_real_distribution<double> stretch(0.002, 4.0);  // past both clamps of the half-length
    for (index_t k = 0; k < d.count; ++k) {
      shape.stretch_x(k) = stretch(rng);
      shape.stretch_y(k) = stretch(rng);
    }
  }
  std::vector<index_t> listed(static_cast<size_t>(d.count));
  std::iota(listed.begin(), listed.end(), 0);
  std::shuffle(listed.begin(), listed.end(), std::mt19937(13));
  constexpr int L = stencil_batch_size;
  constexpr int K = decltype(shape)::stencil_width;
  int compared = 0;
  for (index_t first = 0; first < d.count; first += L) {
    const int count = std::min<index_t>(L, d.count - first);
    StencilBatch<K, L> consecutive, from_list;
    shape.fill_batch(ConsecutiveParticles{first}, count, d.where.cell.data(), d.where.x.data(), d.where.y.data(),
                     consecutive);
    shape.fill_batch(ListedParticles{listed.data() + first}, count, d.where.cell.data(), d.where.x.data(),
                     d.where.y.data(), from_list);
    for (int l = 0; l < count; ++l)
      for (const auto& [particle, batch] : {std::make_pair(first + l, &consecutive),
                                            std::make_pair(listed[static_cast<size_t>(first + l)], &from_list)}) {
        const auto expected = shape(particle, d.where.cell(particle), d.where.x(particle), d.where.y(particle));
        const auto got = batch->stencil(l, g.nodes_x);
        ASSERT_EQ(got.first_node, expected.first_node) << "particle " << particle;
        for (int a = 0; a < K; ++a) {
          // The same arithmetic, vectorised: equal but for how the compiler contracts it into FMAs.
          EXPECT_NEAR(got.wx[a], expected.wx[a], round_off(1e-15)) << "particle " << particle;
          EXPECT_NEAR(got.wy[a], expected.wy[a], round_off(1e-15)) << "particle " << particle;
          EXPECT_NEAR(got.gx[a], expected.gx[a], round_off(1e-14) * std::fabs(expected.gx[a]) + round_off(1e-15)) << "particle " << particle;
          EXPECT_NEAR(got.gy[a], expected.gy[a], round_off(1e-14) * std::fabs(expected.gy[a]) + round_off(1e-15)) << "particle " << particle;
        }
        ++compared;
      }
  }
  EXPECT_EQ(compared, 2 * d.count);
}

// The conservation totals' sums accumulate in double in either precision: 2^20 tenths (each
// real_t(0.1), so that the expected sum is exact in double but for round-off) summed in float were
// 0.41 % off (KokkosBlas::sum of floats on two threads, tried in a single-precision build); in
// double its worst-case round-off, n eps = 2^-33 = 1.2e-10 of it, is within the bound of 1e-9.
TEST(Blas1, SumsAndDotsAccumulateInDouble) {
  const index_t n = index_t(1) << 20;
  const RealView tenths("tenths", n), ones("ones", n);
  Kokkos::deep_copy(tenths, real_t(0.1));
  Kokkos::deep_copy(ones, real_t(1));
  const double expected = double(n) * double(real_t(0.1));
  EXPECT_NEAR(blas_sum(tenths), expected, 1e-9 * expected);
  EXPECT_NEAR(blas_dot(tenths, ones), expected, 1e-9 * expected);
  EXPECT_NEAR(sum_in_double(tenths), expected, 1e-9 * expected);
  EXPECT_NEAR(dot_in_double(ones, tenths), expected, 1e-9 * expected);
}

// fill_in_order fills every entry of a View of rows (FillRows: by blocks of rows on CPUs, a row a
// thread on GPUs) and nothing outside it: the grid's state (LayoutLeft, 7 columns, a row count
// neither a vector's width nor index_block_size divides), its first columns as a subview (the
// relaxation's sums), the counting sort's LayoutRight counters, and a View of one column (Kokkos'
// fill). Each View holds other
// values before; beside the subview, the columns it leaves keep theirs.
TEST(Fills, FillInOrderFillsEveryRowAndColumnAndNothingElse) {
  const index_t rows = 1001;
  const NodeFieldsView state("state", rows, 7);
  Kokkos::deep_copy(state, real_t(-1));
  fill_in_order(state, real_t(2.5));
  const auto state_host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), state);
  for (index_t i = 0; i < rows; ++i)
    for (int c = 0; c < 7; ++c) ASSERT_EQ(state_host(i, c), real_t(2.5)) << i << ", " << c;

  fill_in_order(Kokkos::subview(state, Kokkos::ALL, std::make_pair(0, 4)), real_t(0));
  Kokkos::deep_copy(state_host, state);
  for (index_t i = 0; i < rows; ++i)
    for (int c = 0; c < 7; ++c) ASSERT_EQ(state_host(i, c), real_t(c < 4 ? 0 : 2.5)) << i << ", " << c;

  const Kokkos::View<index_t**, Kokkos::LayoutRight, DeviceType> counters("counters", 37, 3);
  Kokkos::deep_copy(counters, 5);
  fill_in_order(counters, 0);
  const auto counters_host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), counters);
  for (index_t i = 0; i < 37; ++i)
    for (int c = 0; c < 3; ++c) ASSERT_EQ(counters_host(i, c), 0) << i << ", " << c;

  const RealView column("column", rows);
  fill_in_order(column, real_t(-3));
  const auto column_host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), column);
  for (index_t i = 0; i < rows; ++i) ASSERT_EQ(column_host(i), real_t(-3)) << i;
}

// Two totals over particles for sum_in_fixed_chunks: sum v_k, and sum v_k^2.
struct SumAndSquares {
  using value_type = double[];
  unsigned value_count = 2;
  RealView v;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t k, value_type sums) const {
    sums[0] += v(k);
    sums[1] += double(v(k)) * v(k);
  }
};

// sum_in_fixed_chunks (the CPUs' sums for the diagnostics and the boundaries' totals) sums each
// chunk in index order and then the chunks in order, whatever the thread count: bitwise the
// totals of that order on the host, over values whose sum's last bits depend on the order (a
// plain sum in index order, which Kokkos' reduction gives on one thread, differs), for counts
// within a chunk, on its edge and past it; and zeros for none. (Run on 1 and 2 threads by ctest.)
TEST(Reductions, FixedChunksSumInTheirOrderOnAnyThreadCount) {
  const index_t chunk = 100;
  for (index_t n : {0, 1, 99, 100, 101, 1000, 12345}) {
    const RealView v("v", n);
    auto host = Kokkos::create_mirror_view(v);
    for (index_t k = 0; k < n; ++k) host(k) = real_t((k % 7 == 0 ? 1e6 : 1.0) / (k + 1)) * real_t(k % 2 ? -1 : 1);
    Kokkos::deep_copy(v, host);
    double expected[2] = {0, 0}, in_index_order = 0;
    for (index_t first = 0; first < n; first += chunk) {
      double chunk_sums[2] = {0, 0};
      for (index_t k = first; k < std::min(n, first + chunk); ++k) {
        chunk_sums[0] += host(k);
        chunk_sums[1] += double(host(k)) * host(k);
        in_index_order += host(k);
      }
      expected[0] += chunk_sums[0];
      expected[1] += chunk_sums[1];
    }
    double totals[2] = {-1, -1};  // (not 0: each must be written)
    sum_in_fixed_chunks("test_fixed_chunks", n, chunk, SumAndSquares{2, v}, totals);
    EXPECT_EQ(totals[0], expected[0]) << n;
    EXPECT_EQ(totals[1], expected[1]) << n;
    if (n == 12345) EXPECT_NE(in_index_order, expected[0]) << "values whose sum depends on the order";
  }
}

TEST(ShapeFunctions, ColumnAndRowOfACellAreExactForLargeGrids) {
  // The multiplication that replaces the integer division, at the largest cell indices a grid of
  // 46340 x 46340 cells (2^31 cells in all) has, and at every cell of a row of a tall one.
  for (const index_t cells_x : {1, 3, 448, 46340}) {
    GridGeometry geometry;
    geometry.nodes_x = cells_x + 1;
    geometry.nodes_y = 2;
    const StencilGrid grid(geometry);
    const index_t last_row = std::numeric_limits<index_t>::max() / cells_x - 1;
    for (const index_t row : {index_t(0), index_t(1), index_t(777), last_row})
      for (index_t column = 0; column < cells_x; column += std::max<index_t>(1, cells_x / 97)) {
        index_t ci = -1, cj = -1;
        grid.column_and_row(column + cells_x * row, ci, cj);
        ASSERT_EQ(ci, column) << "cells_x " << cells_x << ", row " << row;
        ASSERT_EQ(cj, row) << "cells_x " << cells_x << ", column " << column;
      }
  }
}

TEST(ShapeFunctions, NodalInterpolationProperty) {
  const GridGeometry g = test_grid();
  // At a cell's corner node the weight of that node is 1 and the others 0.
  const SeparableStencil<2> s = q1_stencil(StencilGrid(g), g.cell_of(g.node_x(2), g.node_y(3)), g.node_x(2), g.node_y(3));
  // (GIMP averages the hat over the particle domain, so it is not interpolating: not tested.)
  EXPECT_EQ(s.node(0), g.node_index(2, 3));
  EXPECT_DOUBLE_EQ(s.weight(0), 1.0);
  EXPECT_DOUBLE_EQ(s.weight(1) + s.weight(2) + s.weight(3), 0.0);
}

TEST(ShapeFunctions, BranchFreeGimpWeightsEqualThePiecewiseForm) {
  // gimp_axis_weights (what the kernels use) against gimp_weight_1d at each of the three nodes,
  // over positions across the whole half-cell range and domain sizes from tiny to half a cell,
  // including the piece boundaries |d| = l, h - l, h + l.
  const real_t h = 0.37;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uxi(-0.5, 0.5), ulambda(1e-3, 0.5);
  std::vector<std::pair<double, double>> cases;
  for (int k = 0; k < 20000; ++k) cases.emplace_back(uxi(rng), ulambda(rng));
  for (double lambda : {1e-3, 0.1, 0.25, 0.5})
    for (double xi : {-0.5, -lambda, 0.0, lambda, 0.5, 1 - lambda - 1, 0.5 - lambda}) cases.emplace_back(xi, lambda);
  for (const auto& [xi, lambda] : cases) {
    real_t w[3], g[3];
    gimp_axis_weights(xi, lambda, 1 / h, w, g);
    for (int a = 0; a < 3; ++a) {
      real_t ref_w, ref_g;
      gimp_weight_1d((xi - (a - 1)) * h, h, lambda * h, ref_w, ref_g);
      ASSERT_NEAR(w[a], ref_w, round_off(1e-13)) << "node " << a << " xi " << xi << " lambda " << lambda;
      ASSERT_NEAR(g[a] * h, ref_g * h, round_off(1e-12)) << "node " << a << " xi " << xi << " lambda " << lambda;
    }
  }
}

// The quadratic B-spline of the literature (Steffen, Kirby & Berzins 2008, eq. 8), node at distance
// d = x_p - x_i, spacing h; and its derivative d/dx_p.
void bspline_weight_1d(real_t d, real_t h, real_t& weight, real_t& gradient) {
  const real_t a = std::abs(d) / h;
  const real_t sign = d < 0 ? -1 : 1;
  if (a < 0.5) {
    weight = 0.75 - a * a;
    gradient = -2 * a * sign / h;
  } else if (a < 1.5) {
    weight = 0.5 * (1.5 - a) * (1.5 - a);
    gradient = -(1.5 - a) * sign / h;
  } else {
    weight = 0;
    gradient = 0;
  }
}

TEST(ShapeFunctions, BSplineWeightsEqualThePiecewiseFormAndGimpOverAWholeCell) {
  const real_t h = 0.37;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uxi(-0.5, 0.5);
  std::vector<double> positions = {-0.5, -0.25, 0.0, 0.25, 0.5};
  for (int k = 0; k < 20000; ++k) positions.push_back(uxi(rng));
  for (const double xi : positions) {
    real_t w[3], g[3], gimp_w[3], gimp_g[3];
    bspline_axis_weights(xi, 1 / h, w, g);
    gimp_axis_weights(xi, 0.5, 1 / h, gimp_w, gimp_g);
    for (int a = 0; a < 3; ++a) {
      real_t ref_w, ref_g;
      bspline_weight_1d((xi - (a - 1)) * h, h, ref_w, ref_g);
      ASSERT_NEAR(w[a], ref_w, round_off(1e-14)) << "node " << a << " xi " << xi;
      ASSERT_NEAR(g[a] * h, ref_g * h, round_off(1e-13)) << "node " << a << " xi " << xi;
      ASSERT_NEAR(w[a], gimp_w[a], round_off(1e-14)) << "node " << a << " xi " << xi;
      ASSERT_NEAR(g[a] * h, gimp_g[a] * h, round_off(1e-13)) << "node " << a << " xi " << xi;
    }
  }
}

TYPED_TEST(TransferKernels, G2PReproducesLinearNodalFieldAndGradientExactly) {
  const GridGeometry g = test_grid();
  const DeviceParticles d = to_device(g, random_particles(g, 400, 2));
  const auto shape = TypeParam::MakeShape::make(g, d.count);
  NodeFieldsView nodal("nodal", g.num_nodes(), 1);
  auto h = Kokkos::create_mirror_view(nodal);
  for (int j = 0; j < g.nodes_y; ++j)
    for (int i = 0; i < g.nodes_x; ++i) h(g.node_index(i, j), 0) = linear_field(g.node_x(i), g.node_y(j));
  Kokkos::deep_copy(nodal, h);

  RealView value("value", d.count), grad_x("grad_x", d.count), grad_y("grad_y", d.count);
  const auto all = all_of<typename TypeParam::Duplication>(d);
  g2p("test_g2p", shape, d.where, all, NodeColumn{nodal}, StoreValue{value});
  g2pd("test_g2pd", shape, d.where, all, NodeColumn{nodal}, StoreGradient{grad_x, grad_y});
  auto hv = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), value);
  auto hx = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), d.where.x);
  auto hy = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), d.where.y);
  auto hgx = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grad_x);
  auto hgy = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grad_y);
  for (index_t k = 0; k < d.count; ++k) {
    EXPECT_NEAR(hv(k), linear_field(hx(k), hy(k)), round_off(1e-13));
    EXPECT_NEAR(hgx(k), -2.0, round_off(1e-12));
    EXPECT_NEAR(hgy(k), 0.75, round_off(1e-12));
  }
  // The two in one pass: the same values and gradients.
  RealView both_value("both_value", d.count), both_x("both_x", d.count), both_y("both_y", d.count);
  g2p_and_g2pd("test_g2p_and_g2pd", shape, d.where, all, NodeColumn{nodal},
               StoreValueAndGradient<0>{both_value, both_x, both_y});
  auto bv = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), both_value);
  auto bx = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), both_x);
  auto by = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), both_y);
  for (index_t k = 0; k < d.count; ++k) {
    ASSERT_NEAR(bv(k), hv(k), round_off(1e-14)) << k;
    ASSERT_NEAR(bx(k), hgx(k), round_off(1e-13)) << k;
    ASSERT_NEAR(by(k), hgy(k), round_off(1e-13)) << k;
  }
  // The second of two node fields, 3 f - 1: its value and gradient, not the first's.
  g2p_and_g2pd("test_g2p_and_g2pd_second", shape, d.where, all, TwoLinearNodeFields{nodal},
               StoreValueAndGradient<1>{both_value, both_x, both_y});
  Kokkos::deep_copy(bv, both_value);
  Kokkos::deep_copy(bx, both_x);
  Kokkos::deep_copy(by, both_y);
  for (index_t k = 0; k < d.count; ++k) {
    ASSERT_NEAR(bv(k), 3 * linear_field(hx(k), hy(k)) - 1, round_off(1e-12)) << k;
    ASSERT_NEAR(bx(k), 3 * -2.0, round_off(1e-11)) << k;
    ASSERT_NEAR(by(k), 3 * 0.75, round_off(1e-11)) << k;
  }
}

// A G2P sink that adds its particle's interpolated value and velocity-divergence-like sum of
// gradients into its particle's cell, as numerics/cell_averaged_strain's cell divergence does.
template <class Access>
struct AddIntoTheParticlesCell {
  IndexView cell;
  Access cells;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, const real_t (&value)[1], const real_t (&gradient)[1][2]) const {
    const auto& access = cells.access();
    access(cell(p), 0) += value[0];
    access(cell(p), 1) += gradient[0][0] + gradient[0][1];
  }
};

// G2P with the particles grouped by cell (ColouredCells, the GPU path, here on the CPU: a thread a
// cell, walk_cells) and a sink adding into the particle's cell: each cell's sums are its own
// particles' values and gradients, each once (against the same interpolations taken particle by
// particle), over a field that varies from node to node.
template <class MakeShape>
void expect_g2p_by_cells_adds_each_particle_into_its_cell() {
  const GridGeometry g = test_grid();
  const DeviceParticles d = to_device(g, random_particles(g, 1000, 4));
  const auto shape = MakeShape::make(g, d.count);
  NodeFieldsView nodal("nodal", g.num_nodes(), 1);
  auto h = Kokkos::create_mirror_view(nodal);
  for (index_t n = 0; n < g.num_nodes(); ++n) h(n, 0) = std::sin(0.7 * double(n)) + 0.01 * double(n % 13);
  Kokkos::deep_copy(nodal, h);
  RealView value("value", d.count), grad_x("grad_x", d.count), grad_y("grad_y", d.count);
  g2p_and_g2pd("test_particle_by_particle", shape, d.where, d.count, NodeColumn{nodal},
               StoreValueAndGradient<0>{value, grad_x, grad_y});
  const auto t = ColouredTraversal<ColouredTeams>::of(g, d);
  NodeFieldsView cells("cells", g.num_cells(), 2);
  g2p_and_g2pd("test_by_cells", shape, d.where, t.cells, NodeColumn{nodal},
               AddIntoTheParticlesCell<DirectNodeAccess>{d.where.cell, DirectNodeAccess{cells}});
  const auto hv = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), value);
  const auto hx = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grad_x);
  const auto hy = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grad_y);
  const auto hc = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), d.where.cell);
  const auto sums = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), cells);
  std::vector<double> expected_value(static_cast<size_t>(g.num_cells()), 0.0), expected_divergence(expected_value);
  for (index_t p = 0; p < d.count; ++p) {
    expected_value[static_cast<size_t>(hc(p))] += hv(p);
    expected_divergence[static_cast<size_t>(hc(p))] += hx(p) + hy(p);
  }
  index_t cells_with_particles = 0;
  for (index_t c = 0; c < g.num_cells(); ++c) {
    cells_with_particles += expected_value[static_cast<size_t>(c)] != 0;
    EXPECT_NEAR(sums(c, 0), expected_value[static_cast<size_t>(c)], round_off(1e-12)) << MakeShape::name << " cell " << c;
    EXPECT_NEAR(sums(c, 1), expected_divergence[static_cast<size_t>(c)], round_off(1e-10)) << MakeShape::name << " cell " << c;
  }
  EXPECT_GT(cells_with_particles, g.num_cells() / 2) << "particles spread over the grid";
}

TEST(CellTraversal, G2PAddsEachParticleIntoItsCell) {
  expect_g2p_by_cells_adds_each_particle_into_its_cell<MakeLinear>();
  expect_g2p_by_cells_adds_each_particle_into_its_cell<MakeGimp>();
  expect_g2p_by_cells_adds_each_particle_into_its_cell<MakeBSpline>();
}

TYPED_TEST(TransferKernels, P2GConservesMass) {
  const GridGeometry g = test_grid();
  const HostParticles p = random_particles(g, 1000, 3);
  const DeviceParticles d = to_device(g, p);
  const auto shape = TypeParam::MakeShape::make(g, d.count);
  const NodeFieldsView fields = run_p2g<typename TypeParam::Duplication, false>(shape, d, 2, MassAndLinearField{d.mass, d.where.x, d.where.y});
  auto h = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), fields);
  double node_total = 0, particle_total = 0;
  for (int i = 0; i < g.num_nodes(); ++i) node_total += h(i, 0);
  for (double m : p.mass) particle_total += m;
  EXPECT_NEAR(node_total, particle_total, round_off(1e-12) * particle_total);
}

TYPED_TEST(TransferKernels, P2GAgreesWithTheDuplicatedScatterView) {
  // Every mode sums the same contributions, in its own order: equal to round-off.
  const GridGeometry g = test_grid();
  const DeviceParticles d = to_device(g, random_particles(g, 2000, 5));
  const auto shape = TypeParam::MakeShape::make(g, d.count);
  const MassAndLinearField f{d.mass, d.where.x, d.where.y};
  auto mine = Kokkos::create_mirror_view_and_copy(
      Kokkos::HostSpace(), run_p2g<typename TypeParam::Duplication, false>(shape, d, 2, f));
  auto reference = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), run_p2g<Dup, false>(shape, d, 2, f));
  double largest = 0;
  for (int i = 0; i < g.num_nodes(); ++i) largest = std::max<double>(largest, std::fabs(reference(i, 1)));
  ASSERT_GT(largest, 0);
  for (int i = 0; i < g.num_nodes(); ++i)
    for (int c = 0; c < 2; ++c) EXPECT_NEAR(mine(i, c), reference(i, c), round_off(1e-13) * largest) << "node " << i;
}

// For the fused kernel: keep the interpolated value and hand back mass x value for the P2G.
struct StoreValueAndWeighByMass {
  static constexpr int num_components = 1;
  RealView out, mass;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, const real_t (&v)[1], real_t (&carried)[1]) const {
    out(p) = v[0];
    carried[0] = mass(p) * v[0];
  }
};
struct MassTimes {  // P2G functor: M value(p)
  static constexpr int num_components = 1;
  RealView mass, value;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, real_t (&v)[1]) const { v[0] = mass(p) * value(p); }
};

TYPED_TEST(TransferKernels, FusedG2PThenP2GEqualsTheTwoKernels) {
  const GridGeometry g = test_grid();
  const DeviceParticles d = to_device(g, random_particles(g, 1500, 8));
  const auto shape = TypeParam::MakeShape::make(g, d.count);
  NodeFieldsView nodal("nodal", g.num_nodes(), 1);
  auto h = Kokkos::create_mirror_view(nodal);
  for (int j = 0; j < g.nodes_y; ++j)
    for (int i = 0; i < g.nodes_x; ++i) h(g.node_index(i, j), 0) = std::sin(1.0 + i) * std::cos(0.5 * j);
  Kokkos::deep_copy(nodal, h);

  // Separately: G2P into a particle View, then P2G of mass x that value.
  RealView separate_value("separate_value", d.count);
  g2p("test_g2p", shape, d.where, d.count, NodeColumn{nodal}, StoreValue{separate_value});
  const NodeFieldsView separate =
      run_p2g<typename TypeParam::Duplication, false>(shape, d, 1, MassTimes{d.mass, separate_value});

  // Fused, with the same accumulation mode.
  RealView fused_value("fused_value", d.count);
  NodeFieldsView fused("fused", g.num_nodes(), 1);
  const StoreValueAndWeighByMass update{fused_value, d.mass};
  if constexpr (is_coloured<typename TypeParam::Duplication>) {
    const auto t = ColouredTraversal<typename TypeParam::Duplication>::of(g, d);
    DirectNodeAccess direct{fused};
    g2p_then_p2g("test_fused", shape, d.where, t.cells, NodeColumn{nodal}, update, direct, 0);
  } else {
    using D = typename TypeParam::Duplication;
    NodeScatterView<DuplicationOf<D>> scatter(fused);
    p2g_begin(scatter, fused);
    g2p_then_p2g("test_fused", shape, d.where, all_of<D>(d), NodeColumn{nodal}, update, scatter, 0);
    p2g_end(scatter, fused);
  }

  auto sv = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), separate_value);
  auto fv = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), fused_value);
  // The same arithmetic, though the compiler may contract it into FMAs differently in the two
  // kernels: equal to round-off.
  for (index_t p = 0; p < d.count; ++p) EXPECT_NEAR(fv(p), sv(p), round_off(1e-14)) << "particle " << p;
  auto sn = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), separate);
  auto fn = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), fused);
  double largest = 0;
  for (int i = 0; i < g.num_nodes(); ++i) largest = std::max<double>(largest, std::fabs(sn(i, 0)));
  ASSERT_GT(largest, 0);
  for (int i = 0; i < g.num_nodes(); ++i) EXPECT_NEAR(fn(i, 0), sn(i, 0), round_off(1e-13) * largest) << "node " << i;
}

// The grouping is unique (the bins in order, each particle once, in index order within its bin),
// so both methods, the CPUs' counting sort and the GPUs' BinSort, built here on whatever back-end
// the tests run on, give the same order: by cell, and by group of cells (bin_of_cell, the tiles'
// map, where consecutive particles share a bin in runs). Built twice, the second time with more
// particles than the first's storage holds, and once with none.
TEST(CellOrder, GroupsParticlesByCellInIndexOrder) {
  const GridGeometry g = test_grid();
  const index_t num_groups = 5;
  IndexView group_of_cell("test_group_of_cell", g.num_cells());
  {
    auto host = Kokkos::create_mirror_view(group_of_cell);
    for (index_t c = 0; c < g.num_cells(); ++c) host(c) = (c / 7) % num_groups;  // runs of 7 cells
    Kokkos::deep_copy(group_of_cell, host);
  }
  for (const CellOrder::Method method : {CellOrder::Method::counting_sort, CellOrder::Method::bin_sort})
    for (const bool by_group : {false, true}) {
      SCOPED_TRACE(std::string(method == CellOrder::Method::counting_sort ? "counting sort" : "bin sort") +
                   (by_group ? ", by group of cells" : ", by cell"));
      CellOrder order(method);
      for (const index_t count : {1000, 3000, 0}) {
        SCOPED_TRACE(std::to_string(count) + " particles");
        const DeviceParticles d = to_device(g, random_particles(g, count, 6));
        const index_t num_bins = by_group ? num_groups : g.num_cells();
        if (by_group) order.build(d.where.cell, d.count, group_of_cell, num_groups);
        else order.build(d.where.cell, d.count, g.num_cells());
        auto offset = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), order.bin_offset());
        auto particle = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), order.particle());
        auto cell = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), d.where.cell);
        auto group = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), group_of_cell);
        ASSERT_EQ(offset(0), 0);
        ASSERT_EQ(offset(num_bins), d.count);
        std::vector<int> seen(d.count, 0);
        for (index_t b = 0; b < num_bins; ++b)
          for (index_t s = offset(b); s < offset(b + 1); ++s) {
            ASSERT_EQ(by_group ? group(cell(particle(s))) : cell(particle(s)), b) << "slot " << s;
            if (s > offset(b)) ASSERT_LT(particle(s - 1), particle(s));  // index order within the bin
            ++seen[particle(s)];
          }
        for (index_t p = 0; p < d.count; ++p) EXPECT_EQ(seen[p], 1) << "particle " << p;
      }
    }
}

// A grid's size for a test's trace: "<cells_x> x <cells_y> cells".
std::string cells_named(index_t cells_x, index_t cells_y) {
  return std::to_string(cells_x) + " x " + std::to_string(cells_y) + " cells";
}

// The walk's tiles for particles reordered by cell: strips of whole rows, the tallest that gives as
// many tiles a colour's pass as the rectangles (or enough_walk_tiles_a_pass); else the rectangles:
// the largest that leave at least min_walk_tiles tiles, else the smallest.
TEST(TileOrder, TakesStripsWhereTheyGiveAsManyTilesAPassElseTheLargestRectangle) {
  const auto expect_tile = [](index_t cells_x, index_t cells_y, index_t x, index_t y) {
    const TileExtent tile = walk_tile_for(cells_x, cells_y, ParticleOrder::reordered_by_cell);
    EXPECT_EQ(tile.x, x) << cells_x << " x " << cells_y << " cells";
    EXPECT_EQ(tile.y, y) << cells_x << " x " << cells_y << " cells";
  };
  expect_tile(448, 224, 448, 8);     // 28 strips, 14 a pass, as the 4 x 14 rectangles of 128 x 16
  expect_tile(256, 64, 256, 4);      // rectangles of 64 x 8 (4 x 8), 8 a pass: strips of 4 rows
  expect_tile(1024, 512, 1024, 4);   // rectangles of 128 x 16, 64 a pass: strips of 8 rows give 32
  expect_tile(10000, 5000, 10000, 8);  // 313 strips a pass, above enough_walk_tiles_a_pass
  expect_tile(1000, 20, 64, 8);      // wide and short: 3 strips (2 a pass) against 16 x 3 rectangles
  for (index_t cells_x : {10, 100, 300, 1000})
    for (index_t cells_y : {3, 40, 200, 900}) {
      SCOPED_TRACE(cells_named(cells_x, cells_y));
      const TileExtent rectangle = walk_rectangle_for(cells_x, cells_y);
      const bool smallest = rectangle.x == smallest_walk_tile.x && rectangle.y == smallest_walk_tile.y;
      EXPECT_TRUE(smallest || num_tiles(cells_x, cells_y, rectangle) >= min_walk_tiles);
      for (const TileExtent larger : walk_tiles_largest_first) {
        if (larger.x == rectangle.x && larger.y == rectangle.y) break;
        EXPECT_LT(num_tiles(cells_x, cells_y, larger), min_walk_tiles);
      }
      const index_t wanted =
          std::min(walk_tiles_a_pass(cells_x, cells_y, rectangle), enough_walk_tiles_a_pass);
      const TileExtent tile = walk_tile_for(cells_x, cells_y, ParticleOrder::reordered_by_cell);
      const bool strip = tile.x != rectangle.x || tile.y != rectangle.y;
      for (const index_t taller : walk_strip_heights) {  // (all of them when the rectangles stay)
        if (strip && tile.y == taller) break;
        EXPECT_LT(walk_tiles_a_pass(cells_x, cells_y, TileExtent{cells_x, taller}), wanted);
      }
      if (strip) {
        EXPECT_EQ(tile.x, cells_x);
        EXPECT_GE(walk_tiles_a_pass(cells_x, cells_y, tile), wanted);
      }
    }
}

// Particles never reordered drift out of cell order: the walk keeps the rectangles for them, on
// every grid.
TEST(TileOrder, TakesTheRectanglesForParticlesNeverReordered) {
  const TileExtent cylinder = walk_tile_for(448, 224, ParticleOrder::never_reordered);
  EXPECT_EQ(cylinder.x, 128);
  EXPECT_EQ(cylinder.y, 16);
  for (index_t cells_x : {10, 100, 300, 1000, 10000})
    for (index_t cells_y : {1, 3, 40, 200, 900, 5000}) {
      SCOPED_TRACE(cells_named(cells_x, cells_y));
      const TileExtent tile = walk_tile_for(cells_x, cells_y, ParticleOrder::never_reordered);
      const TileExtent rectangle = walk_rectangle_for(cells_x, cells_y);
      EXPECT_EQ(tile.x, rectangle.x);
      EXPECT_EQ(tile.y, rectangle.y);
    }
}

// numerics/p2g = automatic takes the sorted walk on CPUs where each colour's pass has at least two
// tiles a thread: at 448 x 224 cells (28 strips of 8 rows, or 4 x 14 rectangles of 128 x 16: 14 a
// pass either way) up to 7 threads; a 100 x 1 grid (one strip, or one rectangle) none. On a large
// grid the rectangles give more tiles a pass than the strips: at 10000 x 5000 cells 40 x 157 against
// 313 strips of 8 rows.
TEST(TileOrder, TheWalkKeepsThreadsBusyWithTwoTilesAThreadInEachColour) {
  for (const ParticleOrder order : {ParticleOrder::reordered_by_cell, ParticleOrder::never_reordered}) {
    SCOPED_TRACE(order == ParticleOrder::reordered_by_cell ? "reordered by cell" : "never reordered");
    EXPECT_TRUE(walk_keeps_threads_busy(448, 224, order, 1));
    EXPECT_TRUE(walk_keeps_threads_busy(448, 224, order, 7));
    EXPECT_FALSE(walk_keeps_threads_busy(448, 224, order, 8));
    EXPECT_FALSE(walk_keeps_threads_busy(100, 1, order, 1));
    EXPECT_TRUE(walk_keeps_threads_busy(1024, 512, order, 32));  // 128 strips of 4 rows, or 4 x 16 of 128 x 16
    EXPECT_FALSE(walk_keeps_threads_busy(1024, 512, order, 33));
  }
  EXPECT_TRUE(walk_keeps_threads_busy(10000, 5000, ParticleOrder::reordered_by_cell, 156));
  EXPECT_FALSE(walk_keeps_threads_busy(10000, 5000, ParticleOrder::reordered_by_cell, 157));
  EXPECT_TRUE(walk_keeps_threads_busy(10000, 5000, ParticleOrder::never_reordered, 3140));
  EXPECT_FALSE(walk_keeps_threads_busy(10000, 5000, ParticleOrder::never_reordered, 3141));
}

// Grouped by tile (the coloured traversal's on CPUs): each tile's particles, those of its cells,
// in index order; tiles numbered row of tiles by row of tiles. A grid of 3 x 3 tiles (of the
// smallest extent: too few for a larger one), the last row and column of them partial.
TEST(TileOrder, GroupsParticlesByTileInIndexOrder) {
  GridGeometry g = test_grid();
  const TileExtent tile = smallest_walk_tile;
  g.nodes_x = 2 * tile.x + 11;
  g.nodes_y = 2 * tile.y + 3;
  const DeviceParticles d = to_device(g, random_particles(g, 5000, 9));
  const index_t tiles_x = tiles_along_x(g.cells_x(), tile), tiles = num_tiles(g.cells_x(), g.cells_y(), tile);
  ASSERT_EQ(tiles, 9);
  TileOrder order(ParticleOrder::reordered_by_cell);  // (rectangles here either way)
  const ColouredTiles grouped = order.build(d.where.cell, d.count, g.cells_x(), g.cells_y());
  ASSERT_EQ(grouped.tile.x, tile.x);
  ASSERT_EQ(grouped.tile.y, tile.y);
  auto offset = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grouped.tile_offset);
  auto particle = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grouped.particle);
  auto cell = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), d.where.cell);
  ASSERT_EQ(offset(tiles), d.count);
  std::vector<int> seen(d.count, 0);
  for (index_t t = 0; t < tiles; ++t) {
    EXPECT_LT(offset(t), offset(t + 1)) << "tile " << t << " holds particles";
    for (index_t s = offset(t); s < offset(t + 1); ++s) {
      const index_t c = cell(particle(s)), ci = g.cell_i_of(c), cj = g.cell_j_of(c);
      EXPECT_EQ(ci / tile.x + tiles_x * (cj / tile.y), t) << "particle " << particle(s);
      if (s > offset(t)) EXPECT_LT(particle(s - 1), particle(s));  // index order within the tile
      ++seen[particle(s)];
    }
  }
  for (index_t p = 0; p < d.count; ++p) EXPECT_EQ(seen[p], 1) << "particle " << p;
}

// A grid of tiles, and particles in cell order of which every fifth was then moved a cell row up
// (into the next tile where it crosses a tile's edge): tiles holding runs of consecutive particles
// and listed ones, as the coloured traversal meets them once particles move. On the grids below
// the walk takes strips (three_rows_of_tiles) or rectangles (wide_and_short), as
// ColouredTiles.TheTestGridsWalkStripsAndRectangles checks.
struct TilesOfMovedParticles {
  GridGeometry g;
  DeviceParticles d;
  explicit TilesOfMovedParticles(const GridGeometry& grid = three_rows_of_tiles())
      : g(grid), d(to_device(g, moved_up(g, regular_particles(g, 3)))) {}
  // 11 x 14 cells: 4 strips of 4 rows, the last one partial.
  static GridGeometry three_rows_of_tiles() {
    GridGeometry g = test_grid();
    g.nodes_y = 3 * smallest_walk_tile.y + 3;
    return g;
  }
  // 1000 x 20 cells: 16 x 3 rectangles of 64 x 8 (strips would give too few a pass), the last
  // column and row of them partial.
  static GridGeometry wide_and_short() {
    GridGeometry g = test_grid();
    g.nodes_x = 1001;
    g.nodes_y = 21;
    return g;
  }
  static std::vector<GridGeometry> grids() { return {three_rows_of_tiles(), wide_and_short()}; }
  static HostParticles moved_up(const GridGeometry& g, HostParticles h) {
    for (size_t k = 0; k < h.y.size(); k += 5)
      if (h.y[k] + g.spacing_y < g.node_y(g.cells_y() - 1)) h.y[k] += g.spacing_y;
    return h;
  }
};

// The coloured traversal on CPUs takes a batch of consecutive particles as such and another as
// listed (TilesOfMovedParticles). Either way the sums are the reference traversal's, to round-off.
template <class Make>
void expect_coloured_runs_match_the_reference(const GridGeometry& grid) {
  const TilesOfMovedParticles moved(grid);
  const GridGeometry& g = moved.g;
  const DeviceParticles& d = moved.d;
  const auto shape = Make::make(g, d.count);
  const auto t = ColouredTraversal<Coloured>::of(g, d);
  // Both kinds of batch, as walk_tiles makes them.
  auto offset = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), t.cells.tile_offset);
  auto particle = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), t.cells.particle);
  int consecutive = 0, listed = 0;
  for (index_t tile = 0; tile + 1 < static_cast<index_t>(offset.extent(0)); ++tile)
    for (index_t s = offset(tile); s < offset(tile + 1);) {
      const TileBatch batch = next_tile_batch(particle.data(), s, offset(tile + 1));
      ++(batch.consecutive ? consecutive : listed);
      s += batch.count;
    }
  ASSERT_GT(consecutive, 0);
  ASSERT_GT(listed, 0);
  const MassAndLinearField f{d.mass, d.where.x, d.where.y};
  const NodeFieldsView coloured = run_p2g<Coloured, false>(shape, d, 2, f);
  const NodeFieldsView reference = run_p2g<Atomic, false>(shape, d, 2, f);
  auto c = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), coloured);
  auto r = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), reference);
  for (int k = 0; k < 2; ++k) {
    double largest = 0;
    for (int i = 0; i < g.num_nodes(); ++i) largest = std::max<double>(largest, std::fabs(r(i, k)));
    ASSERT_GT(largest, 0);
    for (int i = 0; i < g.num_nodes(); ++i)
      EXPECT_NEAR(c(i, k), r(i, k), round_off(1e-13) * largest) << "node " << i << ", column " << k;
  }
}
TEST(ColouredTiles, TheTestGridsWalkStripsAndRectangles) {
  const GridGeometry strips = TilesOfMovedParticles::three_rows_of_tiles();
  const TileExtent strip = walk_tile_for(strips.cells_x(), strips.cells_y(), ParticleOrder::reordered_by_cell);
  EXPECT_EQ(strip.x, strips.cells_x());
  EXPECT_EQ(strip.y, 4);
  const GridGeometry rectangles = TilesOfMovedParticles::wide_and_short();
  const TileExtent rectangle = walk_tile_for(rectangles.cells_x(), rectangles.cells_y(), ParticleOrder::reordered_by_cell);
  EXPECT_EQ(rectangle.x, 64);
  EXPECT_EQ(rectangle.y, 8);
}
TEST(ColouredTiles, ConsecutiveAndListedBatchesGiveTheReferenceSums) {
  for (const GridGeometry& grid : TilesOfMovedParticles::grids()) {
    SCOPED_TRACE(cells_named(grid.cells_x(), grid.cells_y()));
    expect_coloured_runs_match_the_reference<MakeLinear>(grid);
    expect_coloured_runs_match_the_reference<MakeGimp>(grid);
  }
}

// Each (node, column) of `actual` is the reference's to round-off (relative to the column's largest)
// in the columns written(column) names, and zero in the others.
void expect_node_columns_match(const NodeFieldsView& actual, const NodeFieldsView& reference,
                               const std::function<bool(int)>& written) {
  auto a = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), actual);
  auto r = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), reference);
  ASSERT_EQ(a.extent(0), r.extent(0));
  ASSERT_EQ(a.extent(1), r.extent(1));
  for (int k = 0; k < static_cast<int>(r.extent(1)); ++k) {
    double largest = 0;
    for (size_t i = 0; i < r.extent(0); ++i) largest = std::max<double>(largest, std::fabs(r(i, k)));
    if (written(k)) ASSERT_GT(largest, 0) << "column " << k;
    for (size_t i = 0; i < r.extent(0); ++i) {
      if (written(k))
        EXPECT_NEAR(a(i, k), r(i, k), round_off(1e-13) * largest) << "node " << i << ", column " << k;
      else
        EXPECT_EQ(a(i, k), 0) << "node " << i << ", column " << k;
    }
  }
}

// The sorted P2G of values and vectors together (P2GAndP2GDBody: the step's mass, momentum and
// force) on CPUs adds each tile's particles into a node-major window of its thread's, then the
// window into the node fields (walk_tiles_staged); with its columns further apart than a window
// is wide, straight into the node fields (walk_tiles). Either way the reference traversal's sums,
// to round-off, and nothing in the columns between (TilesOfMovedParticles: consecutive and listed
// batches; strips and rectangles, the last of them partial). Vectors of any direction (three node
// vectors a particle in a window), or each component along its own axis (one).
template <class Make, class Vectors>
void expect_staged_p2g_matches_the_reference(const GridGeometry& grid, int first_vector_column) {
  const TilesOfMovedParticles moved(grid);
  const GridGeometry& g = moved.g;
  const DeviceParticles& d = moved.d;
  const auto shape = Make::make(g, d.count);
  const auto t = ColouredTraversal<Coloured>::of(g, d);
  const MassAndLinearField values{d.mass, d.where.x, d.where.y};
  const Vectors vectors{d.mass, d.where.x, d.where.y};
  const int columns = first_vector_column + 2;
  NodeFieldsView staged("staged", g.num_nodes(), columns), reference("reference", g.num_nodes(), columns);
  DirectNodeAccess direct{staged};
  p2g_and_p2gd("test_staged", shape, d.where, t.cells, direct, 0, values, first_vector_column, vectors);
  NodeScatterView<Atomic> scatter(reference);
  p2g_begin(scatter, reference);
  p2g_and_p2gd("test_reference", shape, d.where, d.count, scatter, 0, values, first_vector_column, vectors);
  p2g_end(scatter, reference);
  expect_node_columns_match(staged, reference, [&](int k) { return k < 2 || k >= first_vector_column; });
}
template <class Vectors>
void expect_staged_p2g_matches_the_reference_for_each_shape() {
  for (const GridGeometry& grid : TilesOfMovedParticles::grids())
    for (int first_vector_column : {2, 3, NodeMajorWindow::width + 1}) {  // in a window (2, 3: a gap), or not
      SCOPED_TRACE(cells_named(grid.cells_x(), grid.cells_y()) + ", column " + std::to_string(first_vector_column));
      expect_staged_p2g_matches_the_reference<MakeLinear, Vectors>(grid, first_vector_column);
      expect_staged_p2g_matches_the_reference<MakeGimp, Vectors>(grid, first_vector_column);
      expect_staged_p2g_matches_the_reference<MakeBSpline, Vectors>(grid, first_vector_column);
    }
}
TEST(ColouredTiles, StagedValuesAndVectorsGiveTheReferenceSums) {
  using Body = P2GAndP2GDBody<DirectNodeAccess, MassAndLinearField, VaryingVectors>;
  static_assert(StagesInWindow<Body>::value, "the step's P2G stages its tiles on CPUs");
  static_assert(!Body::staged_body::one_node_vector, "vectors of any direction: three node vectors a particle");
  expect_staged_p2g_matches_the_reference_for_each_shape<VaryingVectors>();
}
// ... and with each vector component along its own axis, one node vector a particle, made in
// vector lanes for a batch of consecutive particles and particle by particle for a listed one.
// (Whether it makes them in lanes is asked where the walks are the CPU's only: a GPU build, which
// never calls the lanes' functions, would otherwise declare them unused.)
template <class Body>
constexpr bool prepares_in_lanes_on_cpus() {
  if constexpr (std::is_same<MemorySpace, Kokkos::HostSpace>::value)
    return Body::template prepares_in_lanes<stencil_batch_size>;
  else
    return true;
}
TEST(ColouredTiles, StagedValuesAndVectorsAlongTheirAxesGiveTheReferenceSums) {
  using Body = P2GAndP2GDBody<DirectNodeAccess, MassAndLinearField, PairedVectors>;
  static_assert(Body::staged_body::one_node_vector, "each component along its own axis: one node vector a particle");
  static_assert(prepares_in_lanes_on_cpus<Body::staged_body>(), "a consecutive batch's in vector lanes");
  expect_staged_p2g_matches_the_reference_for_each_shape<PairedVectors>();
}

// A body that stages its tiles in windows (StagesInWindow) and only counts, for each particle it is
// given in a window, whether the window starts on the boundary of a node's vector (W doubles): the
// node vectors of a window that does not are each split across two cache lines (walk_window_pass).
// (A template, as the check below: a GPU build compiles neither, the windows being the CPU walks'.)
template <class Window>
struct CountsWindowAlignment {
  using only_writes_nodes = std::true_type;  // (OnlyWritesNodes)
  DirectNodeAccess scatter;
  Kokkos::View<int[2]> counts;  // particles given in a window; of them, in a window not aligned
  int first_written_column() const { return 0; }
  int end_written_column() const { return Window::width; }
  struct InWindow {
    Window window;
    Kokkos::View<int[2]> counts;
    template <class StencilType>
    KOKKOS_INLINE_FUNCTION void operator()(index_t, const StencilType&) const {
      constexpr std::uintptr_t vector_bytes = Window::width * sizeof(real_t);
      Kokkos::atomic_add(&counts(0), 1);
      if (reinterpret_cast<std::uintptr_t>(window.data) % vector_bytes != 0) Kokkos::atomic_add(&counts(1), 1);
    }
  };
  KOKKOS_INLINE_FUNCTION InWindow through(const Window& window) const { return {window, counts}; }
  template <class StencilType>
  KOKKOS_INLINE_FUNCTION void operator()(index_t, const StencilType&) const {}  // (not in a window)
};
// The CPU walks' windows start on a node vector's boundary (Kokkos' team scratch is aligned to 8
// bytes only: with it the OpenMP windows began 48 bytes past a cache line, and P2G and G2PD took
// 7 % longer; docs/performance_history.md).
template <class Memory>
void expect_windows_start_on_a_node_vectors_boundary() {
  if constexpr (std::is_same<Memory, Kokkos::HostSpace>::value) {
    using Body = CountsWindowAlignment<NodeMajorWindow>;
    static_assert(StagesInWindow<Body>::value, "a body the walk stages in windows");
    for (const GridGeometry& grid : TilesOfMovedParticles::grids()) {
      SCOPED_TRACE(cells_named(grid.cells_x(), grid.cells_y()));
      const TilesOfMovedParticles moved(grid);
      const auto t = ColouredTraversal<Coloured>::of(moved.g, moved.d);
      const NodeFieldsView written("written", moved.g.num_nodes(), NodeMajorWindow::width);
      const Body body{DirectNodeAccess{written}, Kokkos::View<int[2]>("counts")};
      for_each_particle_stencil("test_window_alignment", MakeGimp::make(moved.g, moved.d.count), moved.d.where,
                                t.cells, body);
      auto counts = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), body.counts);
      EXPECT_EQ(counts(0), moved.d.count) << "every particle in a window";
      EXPECT_EQ(counts(1), 0) << "particles in a window not aligned";
    }
  }
}
TEST(ColouredTiles, WindowsStartOnANodeVectorsBoundary) {
  if (!cpu_code_paths) GTEST_SKIP() << "the windows are the CPU walks'";
  expect_windows_start_on_a_node_vectors_boundary<MemorySpace>();
}

// TilesOfMovedParticles with the shape of Make and the particles grouped by tile (ColouredTiles).
template <class Make>
struct MovedParticlesByTile : TilesOfMovedParticles {
  explicit MovedParticlesByTile(const GridGeometry& grid) : TilesOfMovedParticles(grid) {}
  decltype(Make::make(std::declval<const GridGeometry&>(), index_t(0))) shape = Make::make(g, d.count);
  ColouredTraversal<Coloured> by_tile = ColouredTraversal<Coloured>::of(g, d);
};

// Node columns 0 .. columns - 1 that differ from one another and from node to node.
NodeFieldsView varied_node_columns(const GridGeometry& g, int columns) {
  NodeFieldsView nodal("nodal", g.num_nodes(), columns);
  auto h = Kokkos::create_mirror_view(nodal);
  for (int j = 0; j < g.nodes_y; ++j)
    for (int i = 0; i < g.nodes_x; ++i)
      for (int k = 0; k < columns; ++k)
        h(g.node_index(i, j), k) = k + std::sin(0.7 * i + 1.3 * k) * std::cos(0.4 * j - k);
  Kokkos::deep_copy(nodal, h);
  return nodal;
}

// Components [0, N) of the interpolated values and gradients, into out(p, 3 c) (value), 3 c + 1 and
// 3 c + 2 (gradient along x, y).
template <int N>
struct StoreValuesAndGradients {
  using writes_only_its_particle = std::true_type;
  NodeFieldsView out;
  template <class Values, class Gradients>
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, Values v, Gradients g) const {
    for (int c = 0; c < N; ++c) {
      out(p, 3 * c) = v[c];
      out(p, 3 * c + 1) = g[c][0];
      out(p, 3 * c + 2) = g[c][1];
    }
  }
};

// The step's G2P and G2PD of N node columns on CPUs, with the particles grouped by tile: each
// tile's nodes copied into a node-major window of its thread's, the particles reading them from
// there (walk_tiles_through_windows). The reference traversal's values and gradients, to
// round-off, for node columns that differ from one another and from node to node, from the first
// or a later column of the node fields (TilesOfMovedParticles: consecutive and listed batches;
// strips and rectangles, the last of them partial). A sink that lists the interpolations it reads
// (reads_interpolations, which the walk alone stores into its lanes) gets those; it stores zeros in
// place of the others (StoreTheInterpolationsRead), and so does the reference; `columns_read` of
// the 3 N are compared.
template <class Make, int N, class Sink = StoreValuesAndGradients<N>>
void expect_windowed_g2p_and_g2pd_matches_the_reference(const GridGeometry& grid, int first_column,
                                                        int columns_read = 3 * N) {
  using Read = InterpolationsReadBy<Sink>;
  using Shape = decltype(Make::make(std::declval<const GridGeometry&>(), index_t(0)));
  static_assert(ReadsThroughWindow<G2PAndG2PDBody<NodeColumns<N>, Sink, Shape::stencil_width>>::value,
                "read through windows on CPUs");
  const MovedParticlesByTile<Make> moved(grid);
  const GridGeometry& g = moved.g;
  const DeviceParticles& d = moved.d;
  const NodeFieldsView nodal = varied_node_columns(g, first_column + N);
  NodeFieldsView windowed("windowed", d.count, 3 * N), reference("reference", d.count, 3 * N);
  g2p_and_g2pd("test_windowed", moved.shape, d.where, moved.by_tile.cells, NodeColumns<N>{nodal, first_column},
               Sink{windowed});
  g2p_and_g2pd("test_reference", moved.shape, d.where, d.count, NodeColumns<N>{nodal, first_column}, Sink{reference});
  auto w = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), windowed);
  auto r = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), reference);
  int compared = 0;
  for (int k = 0; k < 3 * N; ++k) {
    const int c = k / 3, part = k % 3;
    const bool read = part == 0 ? Read::value(c) : part == 1 ? Read::gradient_x(c) : Read::gradient_y(c);
    double largest = 0;
    for (index_t p = 0; p < d.count; ++p) largest = std::max<double>(largest, std::fabs(r(p, k)));
    if (!read) {
      ASSERT_EQ(largest, 0) << "column " << k << ", not read";
      continue;
    }
    ++compared;
    ASSERT_GT(largest, 0) << "column " << k;
    for (index_t p = 0; p < d.count; ++p)
      ASSERT_NEAR(w(p, k), r(p, k), round_off(1e-13) * largest) << "particle " << p << ", column " << k;
  }
  EXPECT_EQ(compared, columns_read);
}
// G2P then P2G's update for the windowed test: stores the N interpolated values, hands out M
// particle values made of them.
template <int N, int M>
struct StoreValuesAndCarry {
  using writes_only_its_particle = std::true_type;
  static constexpr int num_components = M;
  NodeFieldsView stored;
  RealView mass;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, const real_t (&value)[N], real_t (&out)[M]) const {
    for (int c = 0; c < N; ++c) stored(p, c) = value[c];
    for (int c = 0; c < M; ++c) out[c] = mass(p) * (value[c % N] + c);
  }
};

// The fused G2P + remap P2G on CPUs with the particles grouped by tile reads its N node columns
// through windows and adds its M columns into the windows' next ones, colour by colour
// (walk_tiles_through_windows): the reference traversal's values and sums, to round-off, and
// nothing in the target's other columns.
template <class Make, int N, int M>
void expect_windowed_g2p_then_p2g_matches_the_reference(const GridGeometry& grid, int first_read, int first_written) {
  using Update = StoreValuesAndCarry<N, M>;
  static_assert(ReadsThroughWindow<G2PThenP2GBody<NodeColumns<N>, Update, DirectNodeAccess>>::value,
                "read through windows on CPUs");
  const MovedParticlesByTile<Make> moved(grid);
  const GridGeometry& g = moved.g;
  const DeviceParticles& d = moved.d;
  const NodeFieldsView nodal = varied_node_columns(g, first_read + N);
  const int columns = first_written + M + 1;
  NodeFieldsView windowed_values("windowed_values", d.count, N), reference_values("reference_values", d.count, N);
  NodeFieldsView windowed("windowed", g.num_nodes(), columns), reference("reference", g.num_nodes(), columns);
  DirectNodeAccess direct{windowed};
  g2p_then_p2g("test_windowed", moved.shape, d.where, moved.by_tile.cells, NodeColumns<N>{nodal, first_read},
               Update{windowed_values, d.mass}, direct, first_written);
  NodeScatterView<Atomic> scatter(reference);
  p2g_begin(scatter, reference);
  g2p_then_p2g("test_reference", moved.shape, d.where, d.count, NodeColumns<N>{nodal, first_read},
               Update{reference_values, d.mass}, scatter, first_written);
  p2g_end(scatter, reference);
  auto wv = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), windowed_values);
  auto rv = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), reference_values);
  for (int k = 0; k < N; ++k)
    for (index_t p = 0; p < d.count; ++p)
      ASSERT_NEAR(wv(p, k), rv(p, k), round_off(1e-13) * (1 + std::fabs(rv(p, k)))) << "particle " << p << ", column " << k;
  expect_node_columns_match(windowed, reference, [&](int k) { return k >= first_written && k < first_written + M; });
}
TEST(ColouredTiles, WindowedG2PThenP2GGivesTheReferenceValuesAndSums) {
  for (const GridGeometry& grid : TilesOfMovedParticles::grids()) {
    SCOPED_TRACE(cells_named(grid.cells_x(), grid.cells_y()));
    expect_windowed_g2p_then_p2g_matches_the_reference<MakeLinear, 2, 2>(grid, 0, 0);  // the step's
    expect_windowed_g2p_then_p2g_matches_the_reference<MakeGimp, 2, 2>(grid, 0, 1);
    expect_windowed_g2p_then_p2g_matches_the_reference<MakeBSpline, 2, 2>(grid, 3, 1);
    expect_windowed_g2p_then_p2g_matches_the_reference<MakeGimp, 1, 3>(grid, 2, 0);
    expect_windowed_g2p_then_p2g_matches_the_reference<MakeGimp, 3, 5>(grid, 0, 2);  // a window of 8
  }
}

// A sink not marked as writing only its particle (one that adds to its particle's cell would be).
struct MayWriteBeyondItsParticle {
  template <class Values, class Gradients>
  KOKKOS_INLINE_FUNCTION void operator()(index_t, Values, Gradients) const {}
};
TEST(ColouredTiles, WindowedValuesAndGradientsAreTheReferenceOnes) {
  // Such a sink is not one whose tiles may be walked without colours.
  static_assert(!ReadsThroughWindow<G2PAndG2PDBody<NodeColumns<1>, MayWriteBeyondItsParticle, 3>>::value,
                "only sinks that write their own particle");
  static_assert(!ReadsThroughWindow<G2PAndG2PDBody<NodeColumn, StoreValueAndGradient<0>, 3>>::value,
                "only node columns can be copied into a window");
  for (const GridGeometry& grid : TilesOfMovedParticles::grids()) {
    SCOPED_TRACE(cells_named(grid.cells_x(), grid.cells_y()));
    expect_windowed_g2p_and_g2pd_matches_the_reference<MakeLinear, 5>(grid, 2);
    expect_windowed_g2p_and_g2pd_matches_the_reference<MakeGimp, 5>(grid, 2);
    expect_windowed_g2p_and_g2pd_matches_the_reference<MakeBSpline, 5>(grid, 2);
    expect_windowed_g2p_and_g2pd_matches_the_reference<MakeGimp, 1>(grid, 0);
    expect_windowed_g2p_and_g2pd_matches_the_reference<MakeGimp, NodeMajorWindow::width>(grid, 1);
  }
}

// A sink that reads only some of the interpolations and says so (reads_interpolations): those into
// out(p, 3 c) (value), 3 c + 1 and 3 c + 2 (gradient along x, y), as StoreValuesAndGradients, and
// zeros in place of the others.
template <int N, class Read>
struct StoreTheInterpolationsRead {
  using writes_only_its_particle = std::true_type;
  using reads_interpolations = Read;
  NodeFieldsView out;
  template <class Values, class Gradients>
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, Values v, Gradients g) const {
    for (int c = 0; c < N; ++c) {
      out(p, 3 * c) = Read::value(c) ? real_t(v[c]) : real_t(0);
      out(p, 3 * c + 1) = Read::gradient_x(c) ? real_t(g[c][0]) : real_t(0);
      out(p, 3 * c + 2) = Read::gradient_y(c) ? real_t(g[c][1]) : real_t(0);
    }
  }
};

// The windowed G2P and G2PD stores into a batch's lanes only the interpolations its sink reads: a
// sink that lists some gets the reference traversal's values for them, to round-off (as the step's
// update, the values of four of six columns and the diagonal of a gradient).
TEST(ColouredTiles, WindowedSinkReadingSomeInterpolationsGetsTheReferenceOnes) {
  for (const GridGeometry& grid : TilesOfMovedParticles::grids()) {
    SCOPED_TRACE(cells_named(grid.cells_x(), grid.cells_y()));
    using Read = InterpolationsRead<0b110011u, 0b000100u, 0b001000u>;
    expect_windowed_g2p_and_g2pd_matches_the_reference<MakeLinear, 6, StoreTheInterpolationsRead<6, Read>>(grid, 1, 6);
    expect_windowed_g2p_and_g2pd_matches_the_reference<MakeGimp, 6, StoreTheInterpolationsRead<6, Read>>(grid, 1, 6);
  }
}

// select_indices, into a buffer kept from call to call: the selected indices of [first, last) in
// increasing order. (A function, not a generic lambda: nvcc allows no device lambda launched from one.)
template <class Predicate>
void expect_selection(index_t first, index_t last, const Predicate& keep, IndexView& buffer, index_t expected_count) {
  std::vector<index_t> expected;
  for (index_t p = first; p < last; ++p)
    if (keep(p)) expected.push_back(p);
  ASSERT_EQ(static_cast<index_t>(expected.size()), expected_count);
  // Into the kept buffer by the back-end's method, and by the GPUs' scan on any back-end (and by the
  // CPUs' parts where the particles are in host memory, which the threads' ranges write through host
  // pointers), each of those into a buffer from empty.
  std::vector<IndexView> selections = {select_indices("test_select", first, last, keep, buffer)};
  IndexView scan_buffer, parts_buffer;
  selections.push_back(select_indices_by_scan("test_select", first, last, keep, scan_buffer));
  if constexpr (std::is_same<MemorySpace, Kokkos::HostSpace>::value)
    selections.push_back(select_indices_in_parts("test_select", first, last, keep, parts_buffer));
  for (const IndexView& selected : selections) {
    auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), selected);
    ASSERT_EQ(static_cast<index_t>(host.extent(0)), expected_count);
    for (index_t k = 0; k < expected_count; ++k) ASSERT_EQ(host(k), expected[k]) << "entry " << k;
  }
}

// Every third particle from `crowd` on, and every 97th before it.
struct CrowdedAtTheEnd {
  index_t crowd;
  KOKKOS_INLINE_FUNCTION bool operator()(index_t p) const { return p >= crowd ? p % 3 == 0 : p % 97 == 11; }
};
// Every `period`-th particle from `offset` (none where period is 0).
struct EveryNth {
  index_t period, offset;
  KOKKOS_INLINE_FUNCTION bool operator()(index_t p) const { return period > 0 && p % period == offset; }
};

// From an empty buffer, with the selections crowded into one end of the range (on CPUs, where each
// thread lists its range into its own part of the buffer, that part overflows and the buffer
// grows; more than the lists' floor, kept_list_minimum, so that it grows beyond it), then again
// into the grown buffer with fewer and with none selected. (Functors, not lambdas: nvcc allows no
// device lambda in a test's body, a private member function.)
TEST(ParticleCompaction, SelectIndicesListsTheSelectedInIncreasingOrder) {
  const index_t first = 5, last = 20000;
  IndexView buffer;
  // 1000 multiples of 3 from 17001 to 19998; 176 of 11 + 97 k below 17000.
  expect_selection(first, last, CrowdedAtTheEnd{17000}, buffer, 1000 + 176);
  const size_t grown = buffer.extent(0);
  EXPECT_GE(grown, size_t(1176));
  expect_selection(first, last, EveryNth{50, 7}, buffer, 400);
  EXPECT_EQ(buffer.extent(0), grown);  // kept
  expect_selection(first, last, EveryNth{0, 0}, buffer, 0);
}

// A kept list whose count rises a little every step, as splitting's and merging's do while a wake
// forms, is made again a number of times logarithmic in the count's range (grown_capacity: at
// least doubled, from a floor of kept_list_minimum entries), not at every quarter's growth; a
// count that falls to a few keeps the list until it is under a quarter of it, less the floor.
TEST(KeptBuffer, ACountRisingEveryStepRemakesItLogarithmicallyOften) {
  KeptBuffer<IndexView> kept;
  int made = 0;
  const auto hold = [&](size_t n) {
    const index_t* before = kept.device.data();
    kept.hold(n, "test_kept");
    made += kept.device.data() != before;
    ASSERT_GE(kept.device.extent(0), n);
    ASSERT_GE(kept.host.extent(0), n);
  };
  // From 10 to 100 000 by 2 % a step (467 holds): once to the floor, then doubled from 1024 past
  // 100 000 (seven times: 2048 .. 131072); grown by a quarter alone, it was made 39 times.
  double count = 10;
  while (count < 1e5) {
    hold(static_cast<size_t>(count));
    count *= 1.02;
  }
  hold(100000);
  EXPECT_EQ(made, 8);
  EXPECT_EQ(kept.device.extent(0), size_t(131072));
  // Down to 40 000 (more than a quarter of it, less the floor): kept; to 100: made again, smaller.
  made = 0;
  hold(40000);
  EXPECT_EQ(made, 0);
  hold(100);
  EXPECT_EQ(made, 1);
  EXPECT_EQ(kept.device.extent(0), kept_list_minimum);
  // grown_capacity: a quarter to spare, at least double, at least the floor.
  EXPECT_EQ(grown_capacity(0, 0), kept_list_minimum);
  EXPECT_EQ(grown_capacity(2000, 0), size_t(2500));
  EXPECT_EQ(grown_capacity(2000, 1900), size_t(3800));
  EXPECT_EQ(grown_capacity(4000, 1900), size_t(5000));
}

TYPED_TEST(TransferKernels, P2GThenG2PReproducesLinearFieldsExactly) {
  // With placement symmetric about each interior node, the mass-weighted nodal average of a
  // linear field equals its nodal value, and G2P then reproduces it at every particle whose cell
  // has only interior nodes.
  const GridGeometry g = test_grid();
  const int margin = TypeParam::MakeShape::inner_margin;
  const DeviceParticles d = to_device(g, regular_particles(g, 3));
  const auto shape = TypeParam::MakeShape::make(g, d.count);
  const NodeFieldsView fields = run_p2g<typename TypeParam::Duplication, false>(shape, d, 2, MassAndLinearField{d.mass, d.where.x, d.where.y});
  auto h = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), fields);
  for (int j = 0; j < g.nodes_y; ++j)
    for (int i = 0; i < g.nodes_x; ++i) {
      if (!is_inner_node(g, i, j, margin)) continue;
      const int n = g.node_index(i, j);
      EXPECT_NEAR(h(n, 1) / h(n, 0), linear_field(g.node_x(i), g.node_y(j)), round_off(1e-13)) << "node " << i << "," << j;
    }

  RealView value("value", d.count);
  g2p("test_g2p", shape, d.where, all_of<typename TypeParam::Duplication>(d), NodeColumnsRatio{fields},
      StoreValue{value});
  auto hv = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), value);
  auto hx = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), d.where.x);
  auto hy = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), d.where.y);
  const auto stencils = stencils_on_host(shape, d.where, d.count);
  int checked = 0;
  for (index_t k = 0; k < d.count; ++k) {
    if (!stencil_is_inner(stencils, g, margin, k)) continue;
    EXPECT_NEAR(hv(k), linear_field(hx(k), hy(k)), round_off(1e-13));
    ++checked;
  }
  // At least the particles nearest to the inner nodes whose neighbours are inner too (9 per node).
  EXPECT_GE(checked, (g.cells_x() - 2 * margin - 1) * (g.cells_y() - 2 * margin - 1) * 9);
}

TYPED_TEST(TransferKernels, P2GDOfConstantFieldSumsToZero) {
  const GridGeometry g = test_grid();
  {  // Random particles: the sum over all nodes vanishes (the gradients of a partition of unity).
    const DeviceParticles d = to_device(g, random_particles(g, 1000, 4));
    const auto shape = TypeParam::MakeShape::make(g, d.count);
    const NodeFieldsView f = run_p2g<typename TypeParam::Duplication, true>(shape, d, 2, ConstantStressTimesVolume{d.mass, 2.5});
    auto h = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), f);
    double sum_x = 0, sum_y = 0, scale = 0;
    for (int i = 0; i < g.num_nodes(); ++i) {
      sum_x += h(i, 0);
      sum_y += h(i, 1);
      scale += std::fabs(h(i, 0)) + std::fabs(h(i, 1));
    }
    EXPECT_GT(scale, 1.0);
    EXPECT_NEAR(sum_x, 0.0, round_off(1e-12) * scale);
    EXPECT_NEAR(sum_y, 0.0, round_off(1e-12) * scale);
  }
  {  // Regular particles: a uniform pressure exerts no force on any interior node.
    const DeviceParticles d = to_device(g, regular_particles(g, 3));
    const auto shape = TypeParam::MakeShape::make(g, d.count);
    const NodeFieldsView f = run_p2g<typename TypeParam::Duplication, true>(shape, d, 2, ConstantStressTimesVolume{d.mass, 2.5});
    auto h = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), f);
    double interior_sum = 0;
    int inner_nodes = 0;
    for (int j = 0; j < g.nodes_y; ++j)
      for (int i = 0; i < g.nodes_x; ++i) {
        if (!is_inner_node(g, i, j, TypeParam::MakeShape::inner_margin)) continue;
        const int n = g.node_index(i, j);
        EXPECT_NEAR(h(n, 0), 0.0, round_off(1e-12));
        EXPECT_NEAR(h(n, 1), 0.0, round_off(1e-12));
        interior_sum += h(n, 0) + h(n, 1);
        ++inner_nodes;
      }
    EXPECT_GE(inner_nodes, 20);
    EXPECT_NEAR(interior_sum, 0.0, round_off(1e-13) * inner_nodes);
    // ...while the nodes on the edge of the gas do feel it (the test is not vacuous).
    EXPECT_GT(std::fabs(h(g.node_index(1, 3), 0)), 1.0);
  }
}

}  // namespace
}  // namespace mpmflow
