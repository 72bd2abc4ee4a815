#pragma once
// Loops over indices whose bodies run as vector lanes on CPUs: for_each_index_in_lanes (a body
// per index) for the passes over cells or particles that are not transfers (the relaxation, the
// cell map). The transfer kernels batch their particles the same way (transfer_kernels.hpp).
#include <type_traits>

#include "kernels/reductions.hpp"
#include "kernels/types.hpp"

namespace mpmflow {

// Indices a block: 32, four AVX-512 vectors of doubles (as a stencil batch's particles).
constexpr int index_block_size = 32;
// The blocks that cover n indices; the indices of the block from `begin` below `end` (the last
// block may hold fewer).
KOKKOS_INLINE_FUNCTION index_t index_blocks(index_t n) { return (n + index_block_size - 1) / index_block_size; }
KOKKOS_INLINE_FUNCTION int indices_in_block(index_t begin, index_t end) {
  return end - begin < index_block_size ? static_cast<int>(end - begin) : index_block_size;
}

// Runs body(i) for i in [0, n), where body(i) writes only what belongs to i (a cell's row, a
// particle's fields): on CPUs in blocks of index_block_size indices, each a loop marked for
// vectorisation (GCC keeps Kokkos' range loop scalar: it cannot tell that the iterations' View
// accesses are independent), so that the body's divisions and square roots run 8 at a time with
// AVX-512 (a body with a branch stays scalar: selects instead); one index per thread elsewhere
// (GPUs). (Both forms by name: the tests run each on any back-end.)
template <int L, class Body>
KOKKOS_FORCEINLINE_FUNCTION void run_block_in_lanes(const Body& body, index_t first, int count) {
  MPMFLOW_VECTORISE
  for (int l = 0; l < count; ++l) body(first + l);
}
template <class Body>
void for_each_index_in_blocks(const char* label, index_t n, const Body& body) {
  constexpr int L = index_block_size;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, index_blocks(n)), KOKKOS_LAMBDA(const index_t k) {
        run_block_in_lanes<L>(body, k * L, indices_in_block(k * L, n));
      });
}
template <class Body>
void for_each_index_one_by_one(const char* label, index_t n, const Body& body) {
  Kokkos::parallel_for(label, Kokkos::RangePolicy<ExecutionSpace>(0, n), body);
}
template <class Body>
void for_each_index_in_lanes(const char* label, index_t n, const Body& body) {
  if constexpr (cpu_code_paths)
    for_each_index_in_blocks(label, n, body);
  else
    for_each_index_one_by_one(label, n, body);
}

// A View of rows (index, column) set to `value`: a row (GPUs: a row a thread), or on CPUs a block
// of rows column by column, each column's stretch of the block vector stores (GCC leaves a row's
// loop over its columns scalar in for_each_index_in_lanes' vector lanes: `objdump -d`).
template <class ViewType>
struct FillRows {
  ViewType rows;
  typename ViewType::non_const_value_type value;
  int columns;
  KOKKOS_INLINE_FUNCTION void operator()(index_t i) const {
    for (int c = 0; c < columns; ++c) rows(i, c) = value;
  }
  KOKKOS_INLINE_FUNCTION void fill_block(index_t first, int count) const {
    for (int c = 0; c < columns; ++c) {
      MPMFLOW_VECTORISE
      for (int l = 0; l < count; ++l) rows(first + l, c) = value;
    }
  }
};

// `view` filled with `value` in the execution space's order, as a kernel launched there: Kokkos'
// deep_copy without an execution space fences before and after a fill (on a GPU two waits for the
// device, each leaving it idle while the host launches what comes next), this one does not. What the
// host reads after it comes through a deep_copy or a reduction, which wait for it.
// A View of rows (rank 2: the grid's columns, the relaxation's sums) is filled by blocks of
// index_block_size rows (FillRows), each thread the rows of its share of the blocks, as the kernels
// over nodes, cells or particles take their indices: so a thread writes the cache lines it last used
// itself. Kokkos' own fill of such a View (3.4: a tile of two whole columns a thread) had each
// thread write half its lines out of the other core's cache: on this 2-core VM the grid's reset of
// the cylinder (448 x 224 cells) took 0.48-0.73 ms a step in most runs, 0.15-0.24 row by row with
// scalar stores, 0.12-0.16 by blocks with vector stores (docs/performance_history.md, "Fills of
// rows").
template <class ViewType>
void fill_in_order(const ViewType& view, const typename ViewType::const_value_type& value) {
  if constexpr (ViewType::rank == 2) {
    static_assert(Kokkos::SpaceAccessibility<ExecutionSpace, typename ViewType::memory_space>::accessible,
                  "fill_in_order fills a View of rows the execution space can write (not a host mirror of a GPU's)");
    const index_t n = static_cast<index_t>(view.extent(0));
    const FillRows<ViewType> fill{view, value, static_cast<int>(view.extent(1))};
    if constexpr (cpu_code_paths) {
      constexpr int L = index_block_size;
      Kokkos::parallel_for(
          "mpmflow::fill_rows", Kokkos::RangePolicy<ExecutionSpace>(0, index_blocks(n)),
          KOKKOS_LAMBDA(const index_t k) { fill.fill_block(k * L, indices_in_block(k * L, n)); });
    } else {
      for_each_index_one_by_one("mpmflow::fill_rows", n, fill);
    }
  } else {
    Kokkos::deep_copy(ExecutionSpace(), view, value);
  }
}

// body(i, extra...) for the i of the block [begin, begin + count) where maybe(i): the test as vector
// lanes, then the selected indices one by one (the _in_blocks forms below).
template <int L, class Maybe, class Body, class... Extra>
KOKKOS_FORCEINLINE_FUNCTION void run_selected_in_block(const Maybe& maybe, const Body& body, index_t begin, int count,
                                                       Extra... extra) {
  real_t selected[L];  // 1 or 0 (a real: GCC vectorises a select on reals)
  MPMFLOW_VECTORISE
  for (int l = 0; l < count; ++l) selected[l] = maybe(begin + l) ? real_t(1) : real_t(0);
  for (int l = 0; l < count; ++l)
    if (selected[l] != 0) body(begin + l, extra...);
}

// Runs body(i) for the i in [first, last) where maybe(i), for passes in which few indices have
// work: on CPUs the test runs as vector lanes over blocks of index_block_size indices (a loop that
// tests and branches on each index stays scalar), then body takes the block's selected indices one
// by one (_in_blocks); elsewhere (GPUs) one index per thread (_one_by_one). maybe(i) reads, body(i)
// writes only what belongs to i or adds through a ScatterView. (Both forms by name: the tests run
// each on any back-end.)
template <class Maybe, class Body>
void for_each_index_where_in_blocks(const char* label, index_t first, index_t last, const Maybe& maybe,
                                    const Body& body) {
  if (first >= last) return;
  constexpr int L = index_block_size;
  const index_t n = last - first;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, index_blocks(n)), KOKKOS_LAMBDA(const index_t k) {
        const index_t begin = first + k * L;
        run_selected_in_block<L>(maybe, body, begin, indices_in_block(begin, last));
      });
}
template <class Maybe, class Body>
void for_each_index_where_one_by_one(const char* label, index_t first, index_t last, const Maybe& maybe,
                                     const Body& body) {
  if (first >= last) return;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(first, last), KOKKOS_LAMBDA(const index_t i) {
        if (maybe(i)) body(i);
      });
}
template <class Maybe, class Body>
void for_each_index_where(const char* label, index_t first, index_t last, const Maybe& maybe, const Body& body) {
  if constexpr (cpu_code_paths)
    for_each_index_where_in_blocks(label, first, last, maybe, body);
  else
    for_each_index_where_one_by_one(label, first, last, maybe, body);
}

// The totals[0 .. count) of what body(i, sums) adds to sums[0 .. count) for the i in [0, n) where
// maybe(i): for_each_index_where with totals (the particle rules, which few particles reach in a
// step: the energy they take out and each obstacle's impulse), in the same two forms by name. One
// array reduction (Kokkos' value_type double[]): the host waits once for all the totals, which are
// summed in the same order from run to run on any back-end (a ScatterView's atomic additions on a
// GPU are not), and on CPUs on any thread count (sum_in_fixed_chunks). `totals`: count entries of
// host memory, all 0 for n = 0.
template <class Maybe, class Body>
struct SumsWhereInBlocks {
  using value_type = double[];
  unsigned value_count;  // (Kokkos' name: the length of an array reduction)
  index_t n;
  Maybe maybe;
  Body body;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t k, value_type sums) const {
    constexpr int L = index_block_size;
    const index_t begin = k * L;
    run_selected_in_block<L>(maybe, body, begin, indices_in_block(begin, n), sums);
  }
};
template <class Maybe, class Body>
struct SumsWhereOneByOne {
  using value_type = double[];
  unsigned value_count;
  Maybe maybe;
  Body body;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t i, value_type sums) const {
    if (maybe(i)) body(i, sums);
  }
};
template <class Maybe, class Body>
void sums_over_indices_where_in_blocks(const char* label, index_t n, int count, const Maybe& maybe, const Body& body,
                                       double* totals) {
  // (In chunks of fixed_order_chunk indices: the same bits on any thread count.)
  sum_in_fixed_chunks(label, index_blocks(n), fixed_order_chunk / index_block_size,
                      SumsWhereInBlocks<Maybe, Body>{static_cast<unsigned>(count), n, maybe, body}, totals);
}
template <class Maybe, class Body>
void sums_over_indices_where_one_by_one(const char* label, index_t n, int count, const Maybe& maybe,
                                        const Body& body, double* totals) {
  sum_in_kokkos(label, n, SumsWhereOneByOne<Maybe, Body>{static_cast<unsigned>(count), maybe, body}, totals);
}
template <class Maybe, class Body>
void sums_over_indices_where(const char* label, index_t n, int count, const Maybe& maybe, const Body& body,
                             double* totals) {
  if constexpr (cpu_code_paths)
    sums_over_indices_where_in_blocks(label, n, count, maybe, body, totals);
  else
    sums_over_indices_where_one_by_one(label, n, count, maybe, body, totals);
}

// The largest value_of(i) for i in [0, n) (Kokkos::Max's identity, the lowest real, for n = 0); a
// NaN counts as `nan_counts_as` (the caller's mark for a broken state, which must win). On CPUs
// value_of runs as vector lanes over blocks of index_block_size indices (its divisions and square
// roots 8 at a time), and each block's values are then compared one by one (_in_blocks); elsewhere
// one index per thread (_one_by_one). (Both by name, as above.)
KOKKOS_INLINE_FUNCTION void keep_larger(real_t value, real_t& so_far, real_t nan_counts_as) {
  if (!(value <= so_far)) so_far = value == value ? value : nan_counts_as;
}
template <class ValueOf>
real_t largest_over_indices_in_blocks(const char* label, index_t n, real_t nan_counts_as, const ValueOf& value_of) {
  real_t largest = 0;
  constexpr int L = index_block_size;
  Kokkos::parallel_reduce(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, index_blocks(n)),
      KOKKOS_LAMBDA(const index_t k, real_t& local) {
        const index_t first = k * L;
        const int count = indices_in_block(first, n);
        real_t value[L];
        MPMFLOW_VECTORISE
        for (int l = 0; l < count; ++l) value[l] = value_of(first + l);
        for (int l = 0; l < count; ++l) keep_larger(value[l], local, nan_counts_as);
      },
      Kokkos::Max<real_t>(largest));
  return largest;
}
template <class ValueOf>
real_t largest_over_indices_one_by_one(const char* label, index_t n, real_t nan_counts_as, const ValueOf& value_of) {
  real_t largest = 0;
  Kokkos::parallel_reduce(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, n),
      KOKKOS_LAMBDA(const index_t i, real_t& local) { keep_larger(value_of(i), local, nan_counts_as); },
      Kokkos::Max<real_t>(largest));
  return largest;
}
template <class ValueOf>
real_t largest_over_indices(const char* label, index_t n, real_t nan_counts_as, const ValueOf& value_of) {
  if constexpr (cpu_code_paths)
    return largest_over_indices_in_blocks(label, n, nan_counts_as, value_of);
  else
    return largest_over_indices_one_by_one(label, n, nan_counts_as, value_of);
}

}  // namespace mpmflow
