#include "grid.hpp"

namespace mpmflow {

GridSlab make_grid_slab(const DomainConfig& domain, index_t cell_begin_x, index_t cell_end_x) {
  return make_grid_slab(domain, 0, cell_begin_x, cell_end_x);
}

GridSlab make_grid_slab(const DomainConfig& domain, int axis, index_t cell_begin, index_t cell_end) {
  const index_t cell_begin_x = axis == 0 ? cell_begin : 0;
  const index_t cell_end_x = axis == 0 ? cell_end : domain.cells_x;
  const index_t cell_begin_y = axis == 1 ? cell_begin : 0;
  const index_t cell_end_y = axis == 1 ? cell_end : domain.cells_y;
  GridSlab slab;
  slab.global_cells_x = domain.cells_x;
  slab.global_cells_y = domain.cells_y;
  slab.domain_x_min = domain.x_min;
  slab.domain_x_max = domain.x_max;
  slab.domain_y_min = domain.y_min;
  slab.domain_y_max = domain.y_max;
  slab.owned_cell_begin_x = cell_begin_x;
  slab.owned_cell_end_x = cell_end_x;
  slab.owned_cell_begin_y = cell_begin_y;
  slab.owned_cell_end_y = cell_end_y;

  const int g = GridSlab::ghost_layers;
  slab.node_offset_x = cell_begin_x - g;
  slab.node_offset_y = cell_begin_y - g;

  GridGeometry& geo = slab.geometry;
  geo.spacing_x = (domain.x_max - domain.x_min) / domain.cells_x;
  geo.spacing_y = (domain.y_max - domain.y_min) / domain.cells_y;
  geo.origin_x = domain.x_min + geo.spacing_x * slab.node_offset_x;
  geo.origin_y = domain.y_min + geo.spacing_y * slab.node_offset_y;
  geo.nodes_x = (cell_end_x - cell_begin_x) + 1 + 2 * g;
  geo.nodes_y = (cell_end_y - cell_begin_y) + 1 + 2 * g;
  geo.ghost_cells = g;
  return slab;
}

}  // namespace mpmflow
