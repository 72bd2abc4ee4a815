#include "slab_state.hpp"

#include <algorithm>

namespace mpmflow {
namespace {

// The decomposition a lone slab stands for: itself, along its axis.
SlabDecomposition single_slab(const GridSlab& slab) {
  SlabDecomposition d;
  d.axis = slab.axis;
  d.cell_begin = {0, slab.global_cells(slab.axis)};
  return d;
}

}  // namespace

SlabState::SlabState(const CaseConfig& config, const ParallelContext& context,
                     const SlabDecomposition& decomposition)
    : SlabState(config, context, decomposition,
                make_grid_slab(config.domain, decomposition.axis, decomposition.begin(context.rank()),
                               decomposition.end(context.rank()))) {}

SlabState::SlabState(const CaseConfig& config, const GridSlab& slab)
    : SlabState(config, ParallelContext::self(), single_slab(slab), slab) {}

SlabState::SlabState(const CaseConfig& config, const ParallelContext& context, const SlabDecomposition& decomposition,
                     const GridSlab& slab)
    : context_(context),
      decomposition_(decomposition),
      slab_(slab),
      fields_(slab.geometry),
      // The widest node fields summed over slabs: the step's state, or the output projection.
      halo_(slab, context, std::max<int>(GridFields::num_state_columns, GridFields::num_projection_columns)),
      obstacles_(make_obstacle_grid(config.obstacles, slab, acting_boundaries(config), config.numerics.shape_function)),
      grid_boundaries_(config, slab, obstacles_),
      particle_boundaries_(config, slab, obstacles_) {
  fields_.set_conditioned_nodes(grid_boundaries_.conditioned_nodes(slab.owned_nodes_with_outer_ghosts()));
}

}  // namespace mpmflow
