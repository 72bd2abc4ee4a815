#pragma once
// Boundary conditions on grid nodal vectors (Algorithm 1, steps 4 and 9).
#include "case_config.hpp"
#include "grid.hpp"

namespace mpmflow {

// Slip wall: the wall-normal component of a nodal vector (momentum or force) is removed on the
// nodes of the wall line; the tangential component is free.
void apply_slip_walls(const GridSlab& slab, const BoundaryConfig& boundaries, const NodeFieldsView& fields,
                      int column_x, int column_y);

}  // namespace mpmflow
