#pragma once
// The MPI side of a run, kept behind two small types so that the solver has one code path:
//  - ParallelContext: the communicator (MPI_COMM_WORLD, or a single process when MPI is absent or
//    not initialised) and the few collectives the solver needs;
//  - SlabDecomposition: the global grid cut into slabs along one axis, one per rank.
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#ifdef MPMFLOW_HAVE_MPI
#include <mpi.h>
#endif

#include "case_config.hpp"
#include "kernels/types.hpp"

namespace mpmflow {

// An error that every rank raises together (the same on all of them), so every rank can stop
// cleanly and rank 0 alone reports it. Any other exception on one rank aborts the whole job.
struct CollectiveError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class ParallelContext {
 public:
  // MPI_COMM_WORLD when MPI is initialised; otherwise a single process.
  ParallelContext();
  // A single process, whatever MPI says (a solver that owns a slab on its own).
  static ParallelContext self() { return ParallelContext(0); }

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool is_root() const { return rank_ == 0; }
  bool distributed() const { return size_ > 1; }

  // Pass device pointers to MPI (GPU-aware MPI) instead of staging through host copies.
  bool gpu_aware = false;

  double max(double value) const;
  // Each of `values` the largest of the ranks', in one reduction.
  void max_in_place(double* values, int count) const;
  double min(double value) const;
  long long sum(long long value) const;
  void sum_in_place(double* values, int count) const;
  void sum_in_place(long long* values, int count) const;
  // Sum of `value` over the ranks below this one.
  long long exclusive_prefix_sum(long long value) const;
  std::vector<long long> all_gather(long long value) const;
  // Every rank's `values`, concatenated in rank order, on every rank.
  std::vector<long long> all_gather(const std::vector<long long>& values) const;
  // `text` of rank `root` on every rank.
  void broadcast(std::string& text, int root = 0) const;
  void broadcast(double* values, int count, int root = 0) const;
  void barrier() const;

#ifdef MPMFLOW_HAVE_MPI
  MPI_Comm comm() const { return comm_; }
#endif

 private:
  explicit ParallelContext(int) {}
  int rank_ = 0;
  int size_ = 1;
#ifdef MPMFLOW_HAVE_MPI
  MPI_Comm comm_ = MPI_COMM_SELF;
#endif
};

// The rank whose slab holds global cell `cell`, given the first cell of every slab (cell_begin[r],
// num_ranks + 1 entries): the last slab whose first cell is <= cell, by bisection. The host
// (SlabDecomposition::owner_of_cell) and the kernels (migration) call this one function.
KOKKOS_INLINE_FUNCTION int slab_owning_cell(const index_t* cell_begin, int num_ranks, index_t cell) {
  int lo = 0, hi = num_ranks;
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    if (cell_begin[mid] <= cell) lo = mid;
    else hi = mid;
  }
  return lo;
}

// The slabs: rank r owns global cells [cell_begin[r], cell_begin[r + 1]) along `axis` (0: x,
// 1: y) and every cell across it.
struct SlabDecomposition {
  // A slab must be at least as wide as the 3-node stencil of GIMP (and of a linear stencil
  // with its ghost layer): then only neighbouring slabs share nodes.
  static constexpr index_t min_cells_per_slab = 3;

  int axis = 0;
  std::vector<index_t> cell_begin;  // num_ranks + 1 entries, cell_begin.back() = cells along axis

  int num_ranks() const { return static_cast<int>(cell_begin.size()) - 1; }
  index_t cells_along_axis() const { return cell_begin.back(); }
  index_t begin(int rank) const { return cell_begin[rank]; }
  index_t end(int rank) const { return cell_begin[rank + 1]; }
  int owner_of_cell(index_t global_cell) const;
  // The slab starts in device memory, for owner_of_cell in kernels (particle migration).
  struct DeviceOwners {
    IndexView cell_begin;
    int num_ranks = 1;
    KOKKOS_INLINE_FUNCTION int owner_of_cell(index_t global_cell) const {
      return slab_owning_cell(cell_begin.data(), num_ranks, global_cell);
    }
  };
  DeviceOwners device_owners() const;

  // Equal slabs (the first ones one cell wider when the cells do not divide evenly). Throws
  // ConfigError, naming `config.source`, when the ranks are too many for the grid.
  static SlabDecomposition even(const CaseConfig& config, int num_ranks);
  // Slabs holding about equal numbers of particles, from the particle count of every cell
  // column (row for axis y), each slab at least min_cells_per_slab wide.
  static SlabDecomposition balanced(int axis, const std::vector<long long>& particles_per_column, int num_ranks);

  bool operator==(const SlabDecomposition& other) const {
    return axis == other.axis && cell_begin == other.cell_begin;
  }
  bool operator!=(const SlabDecomposition& other) const { return !(*this == other); }
};

// max over ranks / mean over ranks of the particle counts: 1 is perfect balance.
double imbalance(const std::vector<long long>& particles_per_rank);

}  // namespace mpmflow
