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

  KOKKOS_INLINE_FUNCTION index_t cells_x() const { return nodes_x - 1; }
  KOKKOS_INLINE_FUNCTION index_t cells_y() const { return nodes_y - 1; }
  KOKKOS_INLINE_FUNCTION index_t num_nodes() const { return nodes_x * nodes_y; }
  KOKKOS_INLINE_FUNCTION index_t num_cells() const { return cells_x() * cells_y(); }
  KOKKOS_INLINE_FUNCTION index_t node_index(index_t i, index_t j) const { return i + nodes_x * j; }
  KOKKOS_INLINE_FUNCTION real_t node_x(index_t i) const { return origin_x + spacing_x * i; }
  KOKKOS_INLINE_FUNCTION real_t node_y(index_t j) const { return origin_y + spacing_y * j; }

  // Cell containing (x, y); a point on a cell face belongs to the cell on its upper side.
  // Callers guarantee the point lies inside the local slab.
  KOKKOS_INLINE_FUNCTION index_t cell_of(real_t x, real_t y) const {
    index_t ci = static_cast<index_t>((x - origin_x) / spacing_x);
    index_t cj = static_cast<index_t>((y - origin_y) / spacing_y);
    ci = ci < 0 ? 0 : (ci >= cells_x() ? cells_x() - 1 : ci);
    cj = cj < 0 ? 0 : (cj >= cells_y() ? cells_y() - 1 : cj);
    return ci + cells_x() * cj;
  }
};

}  // namespace mpmflow
