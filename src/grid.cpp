#include "grid.hpp"

#include <algorithm>

namespace mpmflow {

GridSlab make_grid_slab(const DomainConfig& domain, int axis, index_t cell_begin, index_t cell_end) {
  GridSlab slab;
  slab.global_cells_x = domain.cells_x;
  slab.global_cells_y = domain.cells_y;
  slab.domain_x_min = domain.x_min;
  slab.domain_x_max = domain.x_max;
  slab.domain_y_min = domain.y_min;
  slab.domain_y_max = domain.y_max;
  slab.axis = axis;
  slab.owned_cell_begin_x = axis == 0 ? cell_begin : 0;
  slab.owned_cell_end_x = axis == 0 ? cell_end : domain.cells_x;
  slab.owned_cell_begin_y = axis == 1 ? cell_begin : 0;
  slab.owned_cell_end_y = axis == 1 ? cell_end : domain.cells_y;

  const int g = GridSlab::ghost_layers;
  slab.node_offset_x = slab.owned_cell_begin_x - g;
  slab.node_offset_y = slab.owned_cell_begin_y - g;

  GridGeometry& geo = slab.geometry;
  geo.spacing_x = (domain.x_max - domain.x_min) / domain.cells_x;
  geo.spacing_y = (domain.y_max - domain.y_min) / domain.cells_y;
  geo.origin_x = domain.x_min + geo.spacing_x * slab.node_offset_x;
  geo.origin_y = domain.y_min + geo.spacing_y * slab.node_offset_y;
  geo.nodes_x = (slab.owned_cell_end_x - slab.owned_cell_begin_x) + 1 + 2 * g;
  geo.nodes_y = (slab.owned_cell_end_y - slab.owned_cell_begin_y) + 1 + 2 * g;
  geo.ghost_cells = g;
  return slab;
}

IndexRange2D GridSlab::index_space(Ownership ownership, Entity entity, Indexing indexing) const {
  IndexRange2D range;
  if (ownership == Ownership::owned) {
    // Cells: those of the slab. Nodes: the lower-left node of each owned cell, and the domain's
    // last node line on the slab that reaches it, so that every node of the domain has one owner.
    const bool nodes = entity == Entity::node;
    range.begin_x = owned_cell_begin_x;
    range.end_x = owned_cell_end_x + (nodes && owned_cell_end_x == global_cells_x ? 1 : 0);
    range.begin_y = owned_cell_begin_y;
    range.end_y = owned_cell_end_y + (nodes && owned_cell_end_y == global_cells_y ? 1 : 0);
    if (indexing == Indexing::global) return range;
    return {range.begin_x - node_offset_x, range.end_x - node_offset_x, range.begin_y - node_offset_y,
            range.end_y - node_offset_y};
  }
  const index_t extra = entity == Entity::node ? 0 : 1;  // cells_x = nodes_x - 1
  range = {0, geometry.nodes_x - extra, 0, geometry.nodes_y - extra};
  if (indexing == Indexing::local) return range;
  return {range.begin_x + node_offset_x, range.end_x + node_offset_x, range.begin_y + node_offset_y,
          range.end_y + node_offset_y};
}

IndexRange2D GridSlab::owned_nodes_with_outer_ghosts() const {
  IndexRange2D range = index_space(Ownership::owned, Entity::node, Indexing::global);
  if (range.begin_x == 0) range.begin_x -= ghost_layers;
  if (range.end_x == global_cells_x + 1) range.end_x += ghost_layers;
  if (range.begin_y == 0) range.begin_y -= ghost_layers;
  if (range.end_y == global_cells_y + 1) range.end_y += ghost_layers;
  auto clamp = [](index_t v, index_t n) { return v < 0 ? index_t(0) : (v > n ? n : v); };
  return {clamp(range.begin_x - node_offset_x, geometry.nodes_x), clamp(range.end_x - node_offset_x, geometry.nodes_x),
          clamp(range.begin_y - node_offset_y, geometry.nodes_y), clamp(range.end_y - node_offset_y, geometry.nodes_y)};
}

IndexRange2D GridSlab::shared_node_space(int direction) const {
  const IndexRange2D owned = index_space(Ownership::owned, Entity::cell, Indexing::global);
  const bool has_neighbour = direction < 0 ? owned.begin(axis) > 0 : owned.end(axis) < global_cells(axis);
  if (!has_neighbour) return {};
  const index_t nodes_along = axis == 0 ? geometry.nodes_x : geometry.nodes_y;
  const index_t first = direction < 0 ? 0 : nodes_along - shared_lines;
  if (axis == 0) return {first, first + shared_lines, 0, geometry.nodes_y};
  return {0, geometry.nodes_x, first, first + shared_lines};
}

IndexRange2D GridSlab::boundary_node_line(Side side, int layer) const {
  if (side == left_side || side == right_side) {
    const index_t i = local_node_x(side == left_side ? -layer : global_cells_x + layer);
    if (i < 0 || i >= geometry.nodes_x) return {};
    return {i, i + 1, 0, geometry.nodes_y};
  }
  const index_t j = local_node_y(side == bottom_side ? -layer : global_cells_y + layer);
  if (j < 0 || j >= geometry.nodes_y) return {};
  return {0, geometry.nodes_x, j, j + 1};
}

IndexRange2D GridSlab::domain_node_space() const {
  return {std::max<index_t>(0, local_node_x(0)), std::min<index_t>(geometry.nodes_x, local_node_x(global_cells_x) + 1),
          std::max<index_t>(0, local_node_y(0)), std::min<index_t>(geometry.nodes_y, local_node_y(global_cells_y) + 1)};
}

}  // namespace mpmflow
