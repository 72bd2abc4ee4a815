#include "boundary_conditions.hpp"

namespace mpmflow {
namespace {

// Zeroes `column` on local node column i (all rows), if the slab holds it.
void zero_node_column(const GridGeometry& geo, const NodeFieldsView& fields, index_t i, int column) {
  if (i < 0 || i >= geo.nodes_x) return;
  Kokkos::parallel_for(
      "slip_wall_column", Kokkos::RangePolicy<ExecutionSpace>(0, geo.nodes_y),
      KOKKOS_LAMBDA(const index_t j) { fields(geo.node_index(i, j), column) = 0; });
}

// Zeroes `column` on local node row j (all columns), if the slab holds it.
void zero_node_row(const GridGeometry& geo, const NodeFieldsView& fields, index_t j, int column) {
  if (j < 0 || j >= geo.nodes_y) return;
  Kokkos::parallel_for(
      "slip_wall_row", Kokkos::RangePolicy<ExecutionSpace>(0, geo.nodes_x),
      KOKKOS_LAMBDA(const index_t i) { fields(geo.node_index(i, j), column) = 0; });
}

}  // namespace

void apply_slip_walls(const GridSlab& slab, const BoundaryConfig& boundaries, const NodeFieldsView& fields,
                      int column_x, int column_y) {
  // The wall line and the ghost nodes beyond it: GIMP stencils reach one node past the wall.
  const GridGeometry& geo = slab.geometry;
  const int g = GridSlab::ghost_layers;
  for (int k = 0; k <= g; ++k) {
    if (boundaries.left == BoundaryType::slip_wall) zero_node_column(geo, fields, slab.local_node_x(-k), column_x);
    if (boundaries.right == BoundaryType::slip_wall)
      zero_node_column(geo, fields, slab.local_node_x(slab.global_cells_x + k), column_x);
    if (boundaries.bottom == BoundaryType::slip_wall) zero_node_row(geo, fields, slab.local_node_y(-k), column_y);
    if (boundaries.top == BoundaryType::slip_wall)
      zero_node_row(geo, fields, slab.local_node_y(slab.global_cells_y + k), column_y);
  }
}

}  // namespace mpmflow
