#pragma once
// The geometry of one local grid slab as the kernels see it: a trivially copyable value that a
// device lambda captures. Local node (0,0) is the first ghost node; nodes are numbered x-fastest.
#include "kernels/types.hpp"

namespace mpmflow {

struct GridGeometry {
  real_t origin_x = 0;  // coordinate of local node (0, 0)
  real_t origin_y = 0;
  real_t spacing_x = 1;
  real_t spacing_y = 1;
  index_t nodes_x = 0;  // local node counts, ghost layers included
  index_t nodes_y = 0;
  // Ghost cell layers on each side. A particle belongs to a non-ghost cell: cell_of clamps to
  // them, so a particle that round-off puts a hair outside its slab still has its whole stencil
  // on local nodes.
  index_t ghost_cells = 0;

  KOKKOS_INLINE_FUNCTION index_t cells_x() const { return nodes_x - 1; }
  KOKKOS_INLINE_FUNCTION index_t cells_y() const { return nodes_y - 1; }
  KOKKOS_INLINE_FUNCTION index_t num_nodes() const { return nodes_x * nodes_y; }
  KOKKOS_INLINE_FUNCTION index_t num_cells() const { return cells_x() * cells_y(); }
  KOKKOS_INLINE_FUNCTION index_t node_index(index_t i, index_t j) const { return i + nodes_x * j; }
  // The column i and row j of local node n = node_index(i, j), and of local cell c (numbered
  // x-fastest too, as cell_of numbers them).
  KOKKOS_INLINE_FUNCTION index_t node_i_of(index_t n) const { return n % nodes_x; }
  KOKKOS_INLINE_FUNCTION index_t node_j_of(index_t n) const { return n / nodes_x; }
  KOKKOS_INLINE_FUNCTION index_t cell_i_of(index_t c) const { return c % cells_x(); }
  KOKKOS_INLINE_FUNCTION index_t cell_j_of(index_t c) const { return c / cells_x(); }
  KOKKOS_INLINE_FUNCTION real_t node_x(index_t i) const { return origin_x + spacing_x * i; }
  KOKKOS_INLINE_FUNCTION real_t node_y(index_t j) const { return origin_y + spacing_y * j; }

  // Cell containing (x, y); a point on a cell face belongs to the cell on its upper side.
  // Clamped to the non-ghost cells, or to all local cells with include_ghosts (a particle that has
  // just moved into a neighbour's slab and is not yet migrated).
  KOKKOS_INLINE_FUNCTION index_t cell_of(real_t x, real_t y, bool include_ghosts = false) const {
    return cell_of(x, y, inverse_spacing(0), inverse_spacing(1), include_ghosts);
  }
  // The same with the reciprocals of the spacings given, inverse_spacing (ParticleLocator keeps
  // them, so that locating a particle takes multiplications, not two divisions): the same cells.
  KOKKOS_INLINE_FUNCTION index_t cell_of(real_t x, real_t y, real_t inverse_spacing_x, real_t inverse_spacing_y,
                                         bool include_ghosts = false) const {
    const index_t g = include_ghosts ? 0 : ghost_cells;
    index_t ci = cell_along(0, x, inverse_spacing_x);
    index_t cj = cell_along(1, y, inverse_spacing_y);
    ci = ci < g ? g : (ci >= cells_x() - g ? cells_x() - 1 - g : ci);
    cj = cj < g ? g : (cj >= cells_y() - g ? cells_y() - 1 - g : cj);
    return ci + cells_x() * cj;
  }
  // 1 / spacing along `along` (0: x, 1: y): every cell computation multiplies by this one value.
  KOKKOS_INLINE_FUNCTION real_t inverse_spacing(int along) const {
    return real_t(1) / (along == 0 ? spacing_x : spacing_y);
  }
  // The cell index along `along` of a coordinate on that axis, not clamped (cell_of clamps it; the
  // slabs' global cells shift it), given inverse_spacing(along).
  KOKKOS_INLINE_FUNCTION index_t cell_along(int along, real_t coordinate, real_t inverse_spacing_along) const {
    return static_cast<index_t>(floor_real((coordinate - (along == 0 ? origin_x : origin_y)) * inverse_spacing_along));
  }

  // floor(q), as a real (no <cmath> in device code needed).
  KOKKOS_INLINE_FUNCTION static real_t floor_real(real_t q) {
    const real_t t = static_cast<real_t>(static_cast<long long>(q));
    return t > q ? t - 1 : t;
  }
  // floor(a / b) for b > 0.
  KOKKOS_INLINE_FUNCTION static real_t floor_div(real_t a, real_t b) { return floor_real(a / b); }
};

}  // namespace mpmflow
