#include "parallel.hpp"

#include <algorithm>
#include <numeric>

namespace mpmflow {

ParallelContext::ParallelContext() {
#ifdef MPMFLOW_HAVE_MPI
  int initialised = 0, finalised = 0;
  MPI_Initialized(&initialised);
  MPI_Finalized(&finalised);
  if (initialised && !finalised) {
    comm_ = MPI_COMM_WORLD;
    MPI_Comm_rank(comm_, &rank_);
    MPI_Comm_size(comm_, &size_);
  }
#endif
}

double ParallelContext::max(double value) const {
#ifdef MPMFLOW_HAVE_MPI
  if (distributed()) MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MAX, comm_);
#endif
  return value;
}

void ParallelContext::max_in_place(double* values, int count) const {
#ifdef MPMFLOW_HAVE_MPI
  if (distributed()) MPI_Allreduce(MPI_IN_PLACE, values, count, MPI_DOUBLE, MPI_MAX, comm_);
#else
  (void)values;
  (void)count;
#endif
}

double ParallelContext::min(double value) const {
#ifdef MPMFLOW_HAVE_MPI
  if (distributed()) MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MIN, comm_);
#endif
  return value;
}

long long ParallelContext::sum(long long value) const {
  sum_in_place(&value, 1);
  return value;
}

void ParallelContext::sum_in_place(double* values, int count) const {
#ifdef MPMFLOW_HAVE_MPI
  if (distributed()) MPI_Allreduce(MPI_IN_PLACE, values, count, MPI_DOUBLE, MPI_SUM, comm_);
#else
  (void)values;
  (void)count;
#endif
}

void ParallelContext::sum_in_place(long long* values, int count) const {
#ifdef MPMFLOW_HAVE_MPI
  if (distributed()) MPI_Allreduce(MPI_IN_PLACE, values, count, MPI_LONG_LONG, MPI_SUM, comm_);
#else
  (void)values;
  (void)count;
#endif
}

long long ParallelContext::exclusive_prefix_sum(long long value) const {
  long long below = 0;
#ifdef MPMFLOW_HAVE_MPI
  if (distributed()) MPI_Exscan(&value, &below, 1, MPI_LONG_LONG, MPI_SUM, comm_);
  if (rank_ == 0) below = 0;  // MPI_Exscan leaves rank 0's result undefined
#else
  (void)value;
#endif
  return below;
}

std::vector<long long> ParallelContext::all_gather(long long value) const {
  std::vector<long long> values(size_, value);
#ifdef MPMFLOW_HAVE_MPI
  if (distributed()) MPI_Allgather(&value, 1, MPI_LONG_LONG, values.data(), 1, MPI_LONG_LONG, comm_);
#endif
  return values;
}

std::vector<long long> ParallelContext::all_gather(const std::vector<long long>& values) const {
  if (!distributed()) return values;
  std::vector<long long> result;
#ifdef MPMFLOW_HAVE_MPI
  const std::vector<long long> counts = all_gather(static_cast<long long>(values.size()));
  std::vector<int> sizes(size_), offsets(size_);
  long long total = 0;
  for (int r = 0; r < size_; ++r) {
    sizes[r] = static_cast<int>(counts[r]);
    offsets[r] = static_cast<int>(total);
    total += counts[r];
  }
  if (total == 0) return result;  // (every rank knows it: no second exchange)
  result.resize(static_cast<size_t>(total));
  MPI_Allgatherv(values.data(), static_cast<int>(values.size()), MPI_LONG_LONG, result.data(), sizes.data(),
                 offsets.data(), MPI_LONG_LONG, comm_);
#endif
  return result;
}

void ParallelContext::broadcast(std::string& text, int root) const {
#ifdef MPMFLOW_HAVE_MPI
  if (!distributed()) return;
  unsigned long long length = text.size();
  MPI_Bcast(&length, 1, MPI_UNSIGNED_LONG_LONG, root, comm_);
  text.resize(length);
  if (length > 0) MPI_Bcast(&text[0], static_cast<int>(length), MPI_CHAR, root, comm_);
#else
  (void)text;
  (void)root;
#endif
}

void ParallelContext::broadcast(double* values, int count, int root) const {
#ifdef MPMFLOW_HAVE_MPI
  if (distributed()) MPI_Bcast(values, count, MPI_DOUBLE, root, comm_);
#else
  (void)values;
  (void)count;
  (void)root;
#endif
}

void ParallelContext::barrier() const {
#ifdef MPMFLOW_HAVE_MPI
  if (distributed()) MPI_Barrier(comm_);
#endif
}

int SlabDecomposition::owner_of_cell(index_t global_cell) const {
  return slab_owning_cell(cell_begin.data(), num_ranks(), global_cell);
}

SlabDecomposition::DeviceOwners SlabDecomposition::device_owners() const {
  DeviceOwners owners;
  owners.cell_begin = IndexView("slab_cell_begin", cell_begin.size());
  auto host = host_mirror(owners.cell_begin);
  for (size_t r = 0; r < cell_begin.size(); ++r) host(r) = cell_begin[r];
  Kokkos::deep_copy(owners.cell_begin, host);
  owners.num_ranks = num_ranks();
  return owners;
}

SlabDecomposition SlabDecomposition::even(const CaseConfig& config, int num_ranks) {
  SlabDecomposition d;
  d.axis = config.decomposition.axis;
  const index_t cells = d.axis == 0 ? config.domain.cells_x : config.domain.cells_y;
  // (One rank shares no nodes with another: any grid is one slab, as a shock tube one cell wide
  // across the decomposition axis.)
  if (num_ranks > 1 && cells < min_cells_per_slab * num_ranks) {
    const index_t most_ranks = std::max<index_t>(1, cells / min_cells_per_slab);
    const index_t other_cells = d.axis == 0 ? config.domain.cells_y : config.domain.cells_x;
    const std::string other_axis =
        other_cells >= min_cells_per_slab * num_ranks
            ? std::string(", or /decomposition/axis \"") + (d.axis == 0 ? "y" : "x") + "\" (its " +
                  std::to_string(other_cells) + " cells)"
            : std::string();
    throw ConfigError(config.source + ": /domain/" + (d.axis == 0 ? "cells_x" : "cells_y") + ": " +
                      std::to_string(cells) + " cells along the decomposition axis cannot be split among " +
                      std::to_string(num_ranks) + " ranks; expected at least " +
                      std::to_string(min_cells_per_slab) + " cells per rank (the width of the particle stencil), "
                      "i.e. at most " + std::to_string(most_ranks) + (most_ranks == 1 ? " rank" : " ranks") +
                      ", or a finer grid" + other_axis);
  }
  d.cell_begin.resize(num_ranks + 1);
  for (int r = 0; r <= num_ranks; ++r) {
    const index_t base = cells / num_ranks, extra = cells % num_ranks;
    d.cell_begin[r] = r * base + std::min<index_t>(r, extra);
  }
  return d;
}

SlabDecomposition SlabDecomposition::balanced(int axis, const std::vector<long long>& particles_per_column,
                                              int num_ranks) {
  SlabDecomposition d;
  d.axis = axis;
  const index_t cells = static_cast<index_t>(particles_per_column.size());
  d.cell_begin.assign(num_ranks + 1, cells);
  d.cell_begin[0] = 0;
  const long long total = std::accumulate(particles_per_column.begin(), particles_per_column.end(), 0LL);
  long long before = 0;  // particles in the columns already given out
  index_t c = 0;
  for (int r = 1; r < num_ranks; ++r) {
    // Cut where the running count first reaches r / num_ranks of the total, leaving room for
    // the minimum widths of this slab and of the slabs still to come.
    const long long target = total * r / num_ranks;
    const index_t earliest = d.cell_begin[r - 1] + min_cells_per_slab;
    const index_t latest = cells - (num_ranks - r) * min_cells_per_slab;
    while (c < earliest) before += particles_per_column[c++];
    while (c < latest && before + particles_per_column[c] / 2 < target) before += particles_per_column[c++];
    d.cell_begin[r] = c;
  }
  return d;
}

double imbalance(const std::vector<long long>& particles_per_rank) {
  if (particles_per_rank.empty()) return 1;
  const long long total = std::accumulate(particles_per_rank.begin(), particles_per_rank.end(), 0LL);
  const long long largest = *std::max_element(particles_per_rank.begin(), particles_per_rank.end());
  return total > 0 ? double(largest) * particles_per_rank.size() / double(total) : 1.0;
}

}  // namespace mpmflow
