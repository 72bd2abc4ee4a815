#pragma once
// Reordering of particle arrays by cell (Algorithm 1, step xii) with Kokkos::BinSort, so that
// particles close in space are close in memory and the transfer kernels touch the grid in order.
#include <Kokkos_Sort.hpp>

#include "kernels/types.hpp"

namespace mpmflow {

// A permutation of [0, num_particles) grouping particles by cell, applied to any number of
// particle Views (the cell View last or among them: the permutation is computed first).
class CellSorter {
 public:
  using BinOp = Kokkos::BinOp1D<IndexView>;

  CellSorter(const IndexView& particle_cell, index_t num_particles, index_t num_cells)
      : sorter_(particle_cell, 0, num_particles, BinOp(num_cells, 0, num_cells),
                /*sort_within_bins=*/false) {
    sorter_.create_permute_vector();
  }

  template <class... ParticleViews>
  void apply(const ParticleViews&... views) const {
    (sorter_.sort(views), ...);
  }

 private:
  Kokkos::BinSort<IndexView, BinOp> sorter_;
};

}  // namespace mpmflow
