#pragma once
// Shape functions of the Cartesian grid, as policies the transfer kernels are templated on.
//  - LinearShape: the Q1 (bilinear) basis at the particle position, 4 nodes (the paper's MPM).
//  - GimpShape:   contiguous-particle GIMP (Bardenhagen & Kober 2004; Wallstedt & Guilkey 2008):
//                 the same Q1 basis averaged over the particle's axis-aligned rectangular domain,
//                 3 x 3 nodes. The domain's half-sizes follow the particle's stretches (the
//                 diagonal of its deformation gradient), so particle domains stay contiguous as
//                 the gas expands or compresses. Its weight gradients are continuous when a
//                 particle crosses a cell face, which removes the grid-crossing force noise that
//                 keeps linear MPM from converging (Steffen, Kirby & Berzins 2008).
//  - BSplineShape: the quadratic B-spline basis (Steffen, Kirby & Berzins 2008; the paper's
//                 announced next step), 3 x 3 nodes. It is GIMP with every particle's domain a
//                 whole cell, whatever the particle's size: smoother weights (C1 everywhere) and
//                 no per-particle state, at the price of smoothing over a wider stencil.
// Each policy maps (p, cell, x, y) to a SeparableStencil: its nodes, phi_i(X_p), grad phi_i(X_p).
#include "kernels/grid_geometry.hpp"
#include "kernels/types.hpp"

namespace mpmflow {

// The nodes of a particle's stencil with phi_i(X_p) and grad phi_i(X_p). Both bases are tensor
// products, phi(a, b) = wx[a] wy[b] over K x K nodes, so a stencil stores the 1D factors and
// forms products on demand: 4K numbers instead of 3K^2 + K^2 node indices, and the transfer kernels
// sum row by row (sum over b of wy[b] times the sum over a of wx[a] F), about half the flops.
// Node k = a + K b is node (a, b) of the stencil; node(0, 0) is first_node.
template <int K>
struct SeparableStencil {
  static constexpr int width = K;
  static constexpr int size = K * K;
  index_t first_node;
  index_t row_stride;  // nodes_x: from node (a, b) to (a, b + 1)
  real_t wx[K], gx[K];  // 1D weights along x and their derivatives d/dx
  real_t wy[K], gy[K];

  KOKKOS_INLINE_FUNCTION index_t node(int a, int b) const { return first_node + a + b * row_stride; }
  KOKKOS_INLINE_FUNCTION index_t node(int k) const { return node(k % K, k / K); }
  KOKKOS_INLINE_FUNCTION real_t weight(int k) const { return wx[k % K] * wy[k / K]; }
  KOKKOS_INLINE_FUNCTION real_t grad_x(int k) const { return gx[k % K] * wy[k / K]; }
  KOKKOS_INLINE_FUNCTION real_t grad_y(int k) const { return wx[k % K] * gy[k / K]; }
};

// The grid as the shape policies use it: its geometry and the reciprocals of its spacings,
// computed once (a division per particle and kernel costs more than the rest of a linear stencil,
// and the compiler cannot hoist it: the kernels' stores might alias the captured spacing).
struct StencilGrid {
  GridGeometry geometry;
  real_t inv_spacing_x = 1, inv_spacing_y = 1;
  double inv_cells_x = 1;
  StencilGrid() = default;
  explicit StencilGrid(const GridGeometry& g)
      : geometry(g),
        inv_spacing_x(real_t(1) / g.spacing_x),
        inv_spacing_y(real_t(1) / g.spacing_y),
        inv_cells_x(1.0 / g.cells_x()) {}

  // The column ci and row cj of a cell, cell = ci + cells_x cj, by a multiplication rather than an
  // integer division (which has no vector instruction, and would keep the batched stencils of
  // the CPU path scalar). Exact: (cell + 1/2) / cells_x = cj + (ci + 1/2) / cells_x lies at least
  // 1/(2 cells_x) from an integer, while the two roundings move it by under cell / cells_x 2^-52,
  // far less for any index_t cell.
  KOKKOS_FORCEINLINE_FUNCTION void column_and_row(index_t cell, index_t& ci, index_t& cj) const {
    cj = static_cast<index_t>((cell + 0.5) * inv_cells_x);
    ci = cell - cj * geometry.cells_x();
  }
};

// The stencils of a batch of L particles, structure of arrays: the CPU path computes them
// together, one particle per vector lane (for_each_particle_stencil), and the kernels take them
// one at a time (stencil(l)).
template <int K, int L>
struct StencilBatch {
  index_t first_node[L];
  real_t wx[K][L], gx[K][L];
  real_t wy[K][L], gy[K][L];
  KOKKOS_FORCEINLINE_FUNCTION SeparableStencil<K> stencil(int l, index_t row_stride) const {
    SeparableStencil<K> s;
    s.first_node = first_node[l];
    s.row_stride = row_stride;
    for (int a = 0; a < K; ++a) {
      s.wx[a] = wx[a][l];
      s.gx[a] = gx[a][l];
      s.wy[a] = wy[a][l];
      s.gy[a] = gy[a][l];
    }
    return s;
  }
};

// The particles of a batch: consecutive ones from `first`, or those of a list.
struct ConsecutiveParticles {
  index_t first;
  KOKKOS_FORCEINLINE_FUNCTION index_t operator()(int lane) const { return first + lane; }
};
struct ListedParticles {
  const index_t* list;
  KOKKOS_FORCEINLINE_FUNCTION index_t operator()(int lane) const { return list[lane]; }
};

// dest[l] = source[particle(l)] for the lanes of a batch (past count, the last particle's). A
// scalar loop of its own, before the vectorised one: vectorised, indirect loads become vector
// gathers, which cost more than scalar loads on CPUs (seen on AMD Zen 4: they took most of the
// sorted P2G's time).
template <int L, class Particles, class T>
KOKKOS_FORCEINLINE_FUNCTION void load_lanes(const Particles& particle, int count, const T* source, T (&dest)[L]) {
  for (int l = 0; l < L; ++l) {
    if (l == count) break;  // (a loop with an exit GCC does not vectorise)
    dest[l] = source[particle(l)];
  }
  for (int l = count; l < L; ++l) dest[l] = dest[count - 1];
}
// ... where the batch is whole and its particles consecutive (most of the sorted walks' batches): a
// plain copy, in vectors. (The loop above, which its exit keeps scalar, took 6 instructions a lane
// for each of the 3 to 5 fields a batch loads: twelve runs of the cylinder at 448 x 224 cells, median
// kernel times P2G 20.9 -> 19.1 ms a step, G2P + remap 15.3 -> 13.4, G2PD 15.4 -> 13.4;
// docs/performance_history.md.)
template <int L, class T>
KOKKOS_FORCEINLINE_FUNCTION void load_lanes(const ConsecutiveParticles& particle, int count, const T* source,
                                            T (&dest)[L]) {
  if (count < L) return load_lanes<L, ConsecutiveParticles, T>(particle, count, source, dest);
  const T* from = source + particle.first;
  MPMFLOW_VECTORISE
  for (int l = 0; l < L; ++l) dest[l] = from[l];
}

// The positions and cells of a batch's particles, one per lane.
template <int L>
struct BatchPositions {
  index_t cell[L];
  real_t x[L], y[L];
  template <class Particles>
  KOKKOS_FORCEINLINE_FUNCTION BatchPositions(const Particles& particle, int count, const index_t* cell_of,
                                             const real_t* x_of, const real_t* y_of) {
    load_lanes(particle, count, cell_of, cell);
    load_lanes(particle, count, x_of, x);
    load_lanes(particle, count, y_of, y);
  }
};

// 1D linear weights of a cell's two nodes for a particle at xi = (x_p - x_i) / h in [0, 1], and their
// derivatives d/dx_p.
KOKKOS_FORCEINLINE_FUNCTION void linear_axis_weights(real_t xi, real_t inv_h, real_t& weight_0, real_t& weight_1,
                                                     real_t& gradient_0, real_t& gradient_1) {
  weight_0 = 1 - xi;
  weight_1 = xi;
  gradient_0 = -inv_h;
  gradient_1 = inv_h;
}

// The first node of a particle's cell, (i, j), and the particle's local coordinates xi, eta in
// [0, 1] within the cell: what the bilinear basis needs (q1_stencil, LinearShape::fill_batch).
KOKKOS_FORCEINLINE_FUNCTION index_t q1_first_node(const StencilGrid& stencil_grid, index_t cell, real_t x, real_t y,
                                                  real_t& xi, real_t& eta) {
  const GridGeometry& grid = stencil_grid.geometry;
  index_t ci, cj;
  stencil_grid.column_and_row(cell, ci, cj);
  xi = (x - grid.node_x(ci)) * stencil_grid.inv_spacing_x;
  eta = (y - grid.node_y(cj)) * stencil_grid.inv_spacing_y;
  return grid.node_index(ci, cj);
}

// Bilinear basis in the particle's cell. Node order: (i,j), (i+1,j), (i,j+1), (i+1,j+1).
KOKKOS_INLINE_FUNCTION SeparableStencil<2> q1_stencil(const StencilGrid& stencil_grid, index_t cell, real_t x,
                                                      real_t y) {
  real_t xi, eta;
  SeparableStencil<2> s;
  s.first_node = q1_first_node(stencil_grid, cell, x, y, xi, eta);
  s.row_stride = stencil_grid.geometry.nodes_x;
  linear_axis_weights(xi, stencil_grid.inv_spacing_x, s.wx[0], s.wx[1], s.gx[0], s.gx[1]);
  linear_axis_weights(eta, stencil_grid.inv_spacing_y, s.wy[0], s.wy[1], s.gy[0], s.gy[1]);
  return s;
}

// min, max and clamp in the form compilers turn into single min/max instructions (no branch).
KOKKOS_FORCEINLINE_FUNCTION real_t min_real(real_t a, real_t b) { return a < b ? a : b; }
KOKKOS_FORCEINLINE_FUNCTION real_t max_real(real_t a, real_t b) { return a > b ? a : b; }
KOKKOS_FORCEINLINE_FUNCTION real_t clamp_real(real_t v, real_t lo, real_t hi) { return min_real(max_real(v, lo), hi); }

// 1D GIMP weight of a node at signed distance d = x_p - x_i, and its derivative d/dx_p, for a
// particle of half-length l <= h/2 (the hat function of width h averaged over [x_p - l, x_p + l]):
// the piecewise form of the literature, the reference gimp_axis_weights is tested against.
KOKKOS_INLINE_FUNCTION void gimp_weight_1d(real_t d, real_t h, real_t l, real_t& weight, real_t& gradient) {
  const real_t a = d < 0 ? -d : d;
  const real_t sign = d < 0 ? real_t(-1) : real_t(1);
  if (a < l) {
    weight = 1 - (d * d + l * l) / (2 * h * l);
    gradient = -d / (h * l);
  } else if (a < h - l) {
    weight = 1 - a / h;
    gradient = -sign / h;
  } else if (a < h + l) {
    const real_t r = h + l - a;
    weight = r * r / (4 * h * l);
    gradient = -sign * r / (2 * h * l);
  } else {
    weight = 0;
    gradient = 0;
  }
}

// The same weights for the three nodes n - 1, n, n + 1 around the particle's nearest node n, all
// at once and without branches (the piecewise form above mispredicts on randomly placed particles
// and costs more than the rest of a transfer kernel). xi = (x_p - x_n) / h in [-1/2, 1/2],
// lambda = l / h in (0, 1/2]; gradients are d/dx_p. The particle domain [xi - lambda, xi + lambda]
// lies within [-1, 1]: `up` and `down` are the lengths of it above and below x_n. The outer hat
// halves are linear there, so each outer weight is the integral of a linear function over the
// part of the domain on its side, and the middle weight is what the partition of unity leaves.
KOKKOS_FORCEINLINE_FUNCTION void gimp_axis_weights(real_t xi, real_t lambda, real_t inv_h, real_t& weight_0,
                                                   real_t& weight_1, real_t& weight_2, real_t& gradient_0,
                                                   real_t& gradient_1, real_t& gradient_2) {
  const real_t width = 2 * lambda;
  const real_t inv_2width = real_t(1) / (2 * width);  // 1 / (4 lambda)
  const real_t up = clamp_real(xi + lambda, 0, width);
  const real_t down = clamp_real(lambda - xi, 0, width);
  const real_t beyond_up = max_real(xi - lambda, 0);  // domain wholly above x_n
  const real_t beyond_down = max_real(-xi - lambda, 0);
  weight_0 = down * down * inv_2width + beyond_down;
  weight_2 = up * up * inv_2width + beyond_up;
  weight_1 = 1 - weight_0 - weight_2;
  gradient_0 = -2 * down * inv_2width * inv_h;
  gradient_2 = 2 * up * inv_2width * inv_h;
  gradient_1 = -(gradient_0 + gradient_2);
}
// The same into arrays. (The scalar form is what the batched CPU path vectorises: GCC keeps a
// loop with arrays local to its body scalar.)
KOKKOS_FORCEINLINE_FUNCTION void gimp_axis_weights(real_t xi, real_t lambda, real_t inv_h, real_t (&weight)[3],
                                                   real_t (&gradient)[3]) {
  gimp_axis_weights(xi, lambda, inv_h, weight[0], weight[1], weight[2], gradient[0], gradient[1], gradient[2]);
}

// Along one axis: the nearest node n to a particle at `offset` cell widths past the node of its
// cell (c), as n - c in {0, 1}, and the particle's position relative to it in cell widths.
KOKKOS_INLINE_FUNCTION index_t nearest_node(real_t offset, real_t& xi) {
  const bool upper = offset >= real_t(0.5);
  xi = upper ? offset - 1 : offset;
  return upper ? 1 : 0;
}

// The first node of the 3 x 3 nodes around the node nearest to a particle at (x, y) in `cell`;
// xi and eta are the particle's position relative to that nearest node in cell widths, in
// [-1/2, 1/2]. The grid's ghost layer holds the outer nodes for particles in boundary cells.
KOKKOS_FORCEINLINE_FUNCTION index_t centred_first_node(const StencilGrid& stencil_grid, index_t cell, real_t x, real_t y,
                                                       real_t& xi, real_t& eta) {
  const GridGeometry& grid = stencil_grid.geometry;
  index_t ci, cj;
  stencil_grid.column_and_row(cell, ci, cj);
  const index_t ni = ci + nearest_node((x - grid.node_x(ci)) * stencil_grid.inv_spacing_x, xi);
  const index_t nj = cj + nearest_node((y - grid.node_y(cj)) * stencil_grid.inv_spacing_y, eta);
  return grid.node_index(ni - 1, nj - 1);
}

// The same as a stencil, weights not yet set.
KOKKOS_FORCEINLINE_FUNCTION SeparableStencil<3> centred_stencil(const StencilGrid& stencil_grid, index_t cell,
                                                                real_t x, real_t y, real_t& xi, real_t& eta) {
  SeparableStencil<3> s;
  s.first_node = centred_first_node(stencil_grid, cell, x, y, xi, eta);
  s.row_stride = stencil_grid.geometry.nodes_x;
  return s;
}

// 1D quadratic B-spline weights of the nodes n - 1, n, n + 1 for a particle at xi = (x_p - x_n) / h
// in [-1/2, 1/2], and their derivatives d/dx_p. (GIMP's gimp_axis_weights at lambda = 1/2 gives the
// same: the hat function averaged over a whole cell is the quadratic B-spline.)
KOKKOS_FORCEINLINE_FUNCTION void bspline_axis_weights(real_t xi, real_t inv_h, real_t& weight_0, real_t& weight_1,
                                                      real_t& weight_2, real_t& gradient_0, real_t& gradient_1,
                                                      real_t& gradient_2) {
  const real_t below = real_t(0.5) - xi;
  const real_t above = real_t(0.5) + xi;
  weight_0 = real_t(0.5) * below * below;
  weight_1 = real_t(0.75) - xi * xi;
  weight_2 = real_t(0.5) * above * above;
  gradient_0 = -below * inv_h;
  gradient_1 = -2 * xi * inv_h;
  gradient_2 = above * inv_h;
}
KOKKOS_FORCEINLINE_FUNCTION void bspline_axis_weights(real_t xi, real_t inv_h, real_t (&weight)[3],
                                                      real_t (&gradient)[3]) {
  bspline_axis_weights(xi, inv_h, weight[0], weight[1], weight[2], gradient[0], gradient[1], gradient[2]);
}

struct LinearShape {
  static constexpr int stencil_size = 4;
  // Cells this far apart along an axis share no node (the stencil spans 2 node lines).
  static constexpr int colour_period = 2;
  static constexpr int stencil_width = 2;
  StencilGrid grid;
  LinearShape() = default;
  explicit LinearShape(const GridGeometry& g) : grid(g) {}
  KOKKOS_FORCEINLINE_FUNCTION SeparableStencil<2> operator()(index_t /*particle*/, index_t cell, real_t x, real_t y) const {
    return q1_stencil(grid, cell, x, y);
  }
  // The stencils of particles particle(0) .. particle(count - 1) (0 < count <= L;
  // ConsecutiveParticles or ListedParticles), as operator() gives them, into a batch, one particle
  // per vector lane (host memory; lanes past count repeat the last particle).
  template <int L, class Particles>
  KOKKOS_FORCEINLINE_FUNCTION void fill_batch(const Particles& particle, int count, const index_t* cell,
                                              const real_t* x, const real_t* y, StencilBatch<2, L>& b) const {
    const StencilGrid g = grid;  // a local copy: the loop's invariants stay in registers
    const BatchPositions<L> at(particle, count, cell, x, y);
    MPMFLOW_VECTORISE
    for (int l = 0; l < L; ++l) {
      real_t xi, eta;
      b.first_node[l] = q1_first_node(g, at.cell[l], at.x[l], at.y[l], xi, eta);
      linear_axis_weights(xi, g.inv_spacing_x, b.wx[0][l], b.wx[1][l], b.gx[0][l], b.gx[1][l]);
      linear_axis_weights(eta, g.inv_spacing_y, b.wy[0][l], b.wy[1][l], b.gy[0][l], b.gy[1][l]);
    }
  }
};

struct GimpShape {
  static constexpr int stencil_size = 9;
  // A particle of cell ci reaches node lines ci - 1 .. ci + 2: cells 4 apart share no node.
  static constexpr int colour_period = 4;
  static constexpr int stencil_width = 3;
  StencilGrid grid;
  // The particle's half-size at stretch 1, in cell widths along x and y.
  real_t initial_half_length_x = 0, initial_half_length_y = 0;
  RealView stretch_x;  // per particle: current length / initial length along x and y
  RealView stretch_y;

  GimpShape() = default;
  // initial_half_length_x, _y: the particle's half-size at stretch 1, in lengths.
  GimpShape(const GridGeometry& g, real_t initial_half_length_x_, real_t initial_half_length_y_,
            const RealView& stretch_x_, const RealView& stretch_y_)
      : grid(g),
        initial_half_length_x(initial_half_length_x_ / g.spacing_x),
        initial_half_length_y(initial_half_length_y_ / g.spacing_y),
        stretch_x(stretch_x_),
        stretch_y(stretch_y_) {}

  // Half-size along one axis in cell widths: the stretched initial size (in cell widths), kept
  // within [1e-3, 1/2] so the domain never reaches past the 3-node stencil.
  KOKKOS_INLINE_FUNCTION static real_t half_length_in_cells(real_t initial_in_cells, real_t stretch) {
    return clamp_real(initial_in_cells * stretch, real_t(1e-3), real_t(0.5));
  }

  KOKKOS_FORCEINLINE_FUNCTION SeparableStencil<3> operator()(index_t p, index_t cell, real_t x, real_t y) const {
    real_t xi, eta;
    SeparableStencil<3> s = centred_stencil(grid, cell, x, y, xi, eta);
    gimp_axis_weights(xi, half_length_in_cells(initial_half_length_x, stretch_x(p)), grid.inv_spacing_x, s.wx, s.gx);
    gimp_axis_weights(eta, half_length_in_cells(initial_half_length_y, stretch_y(p)), grid.inv_spacing_y, s.wy, s.gy);
    return s;
  }
  // As LinearShape::fill_batch.
  template <int L, class Particles>
  KOKKOS_FORCEINLINE_FUNCTION void fill_batch(const Particles& particle, int count, const index_t* cell,
                                              const real_t* x, const real_t* y, StencilBatch<3, L>& b) const {
    const StencilGrid g = grid;
    const real_t half_x = initial_half_length_x, half_y = initial_half_length_y;
    const BatchPositions<L> at(particle, count, cell, x, y);
    real_t sx[L], sy[L];
    load_lanes(particle, count, stretch_x.data(), sx);
    load_lanes(particle, count, stretch_y.data(), sy);
    MPMFLOW_VECTORISE
    for (int l = 0; l < L; ++l) {
      real_t xi, eta;
      b.first_node[l] = centred_first_node(g, at.cell[l], at.x[l], at.y[l], xi, eta);
      gimp_axis_weights(xi, half_length_in_cells(half_x, sx[l]), g.inv_spacing_x, b.wx[0][l], b.wx[1][l], b.wx[2][l],
                        b.gx[0][l], b.gx[1][l], b.gx[2][l]);
      gimp_axis_weights(eta, half_length_in_cells(half_y, sy[l]), g.inv_spacing_y, b.wy[0][l], b.wy[1][l],
                        b.wy[2][l], b.gy[0][l], b.gy[1][l], b.gy[2][l]);
    }
  }
};

struct BSplineShape {
  static constexpr int stencil_size = 9;
  // The same 3 x 3 stencil as GIMP's: cells 4 apart share no node.
  static constexpr int colour_period = 4;
  static constexpr int stencil_width = 3;
  StencilGrid grid;
  BSplineShape() = default;
  explicit BSplineShape(const GridGeometry& g) : grid(g) {}
  KOKKOS_FORCEINLINE_FUNCTION SeparableStencil<3> operator()(index_t /*particle*/, index_t cell, real_t x,
                                                             real_t y) const {
    real_t xi, eta;
    SeparableStencil<3> s = centred_stencil(grid, cell, x, y, xi, eta);
    bspline_axis_weights(xi, grid.inv_spacing_x, s.wx, s.gx);
    bspline_axis_weights(eta, grid.inv_spacing_y, s.wy, s.gy);
    return s;
  }
  // As LinearShape::fill_batch.
  template <int L, class Particles>
  KOKKOS_FORCEINLINE_FUNCTION void fill_batch(const Particles& particle, int count, const index_t* cell,
                                              const real_t* x, const real_t* y, StencilBatch<3, L>& b) const {
    const StencilGrid g = grid;
    const BatchPositions<L> at(particle, count, cell, x, y);
    MPMFLOW_VECTORISE
    for (int l = 0; l < L; ++l) {
      real_t xi, eta;
      b.first_node[l] = centred_first_node(g, at.cell[l], at.x[l], at.y[l], xi, eta);
      bspline_axis_weights(xi, g.inv_spacing_x, b.wx[0][l], b.wx[1][l], b.wx[2][l], b.gx[0][l], b.gx[1][l],
                           b.gx[2][l]);
      bspline_axis_weights(eta, g.inv_spacing_y, b.wy[0][l], b.wy[1][l], b.wy[2][l], b.gy[0][l], b.gy[1][l],
                           b.gy[2][l]);
    }
  }
};

// The node lines a particle's stencil may hold beyond its cell, for every shape: a particle of cell
// ci reaches nodes ci - r + 1 .. ci + r (r = colour_period / 2: ci .. ci + 1 for the linear shape,
// ci - 1 .. ci + 2 for the 3 x 3 ones, whose first node depends on the half of the cell it is in),
// so node i is reached from cells i - r .. i + r - 1 at most. What a mark by cell of the particles
// that may reach a node must allow (BoundaryVolumeGradients::cell_reach).
constexpr int widest_stencil_reach = 2;
static_assert(LinearShape::colour_period / 2 <= widest_stencil_reach && GimpShape::colour_period / 2 <= widest_stencil_reach &&
                  BSplineShape::colour_period / 2 <= widest_stencil_reach,
              "a shape reaches further than widest_stencil_reach");

}  // namespace mpmflow
