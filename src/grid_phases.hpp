#pragma once
// The node-by-node phases of an MPM step (Algorithm 1, steps 2 and 5, and the remapped velocity
// step 10 interpolates): one kernel each over the slab's nodes.
#include "grid.hpp"

namespace mpmflow {

// 2. Zeroes the columns the step's P2Gs accumulate into.
void reset_grid(const GridFields& fields);

// 5. The momentum equation on the grid, (mv)' = mv + dt f; then, per unit node mass, the
// velocity V-bar = (mv)' / m and the acceleration A = f / m that step 6 interpolates. Nodes with
// no more mass than `mass_threshold` count as empty: no velocity, no acceleration.
void update_grid_momentum(const GridFields& fields, real_t dt, real_t mass_threshold);

// The remapped momentum (step 8) per unit node mass, which step 10 differentiates.
void compute_remap_velocity(const GridFields& fields, real_t mass_threshold);

}  // namespace mpmflow
