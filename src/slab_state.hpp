#pragma once
// The owner of everything that depends on where this rank's slab lies: the slab and its index
// spaces, the grid fields on it, the halo exchange with the neighbouring slabs, the obstacles on
// its nodes and cells, and the boundary conditions of the domain's sides. Built from the
// decomposition and rebuilt whole when the slabs change (load balancing).
#include "boundary_conditions.hpp"
#include "case_config.hpp"
#include "geometry.hpp"
#include "grid.hpp"
#include "halo_exchange.hpp"
#include "parallel.hpp"

namespace mpmflow {

class SlabState {
 public:
  // The slab of rank `context.rank()` under `decomposition`.
  SlabState(const CaseConfig& config, const ParallelContext& context, const SlabDecomposition& decomposition);
  // One process alone on `slab` (the whole grid, or a part of it in tests): no neighbours.
  SlabState(const CaseConfig& config, const GridSlab& slab);

  const ParallelContext& context() const { return context_; }
  const SlabDecomposition& decomposition() const { return decomposition_; }
  const GridSlab& slab() const { return slab_; }
  const GridGeometry& geometry() const { return slab_.geometry; }
  GridFields& fields() { return fields_; }
  const GridFields& fields() const { return fields_; }
  const HaloExchange& halo() const { return halo_; }
  const ObstacleGrid& obstacles() const { return obstacles_; }
  const GridBoundaryConditions& grid_boundaries() const { return grid_boundaries_; }
  const ParticleBoundaries& particle_boundaries() const { return particle_boundaries_; }

 private:
  SlabState(const CaseConfig& config, const ParallelContext& context, const SlabDecomposition& decomposition,
            const GridSlab& slab);

  ParallelContext context_;
  SlabDecomposition decomposition_;
  GridSlab slab_;
  GridFields fields_;
  HaloExchange halo_;
  ObstacleGrid obstacles_;
  GridBoundaryConditions grid_boundaries_;
  ParticleBoundaries particle_boundaries_;
};

}  // namespace mpmflow
