#pragma once
// Particles grouped by cell: for the sorted P2G, and for reordering the particle arrays by cell
// (Algorithm 1, step xii), so that particles close in space are close in memory and the transfer
// kernels touch the grid in order.
#include <Kokkos_ScatterView.hpp>

#include <string>
#include <type_traits>
#include <utility>

#include "kernels/index_lanes.hpp"
#include "kernels/types.hpp"

namespace mpmflow {

// target(k) = source(permutation(k)) for k in [0, n).
template <class TargetView, class SourceView>
void gather_by_permutation(const TargetView& target, const SourceView& source, const IndexView& permutation,
                           index_t n) {
  Kokkos::parallel_for(
      "permute", Kokkos::RangePolicy<ExecutionSpace>(0, n),
      KOKKOS_LAMBDA(const index_t k) { target(k) = source(permutation(k)); });
}

// A View like `view` (its label and length) whose first n entries are view(permutation(k)), in
// place of `view`: the entries gathered straight into their new storage (then `view`'s is freed),
// not into a temporary copied back, which moved the fields' bytes twice as often. Past n the
// entries are unset (beyond the particle count, as the growth of the Views leaves them).
template <class ViewType>
ViewType permuted_particle_field(const ViewType& view, const IndexView& permutation, index_t n) {
  const ViewType permuted(Kokkos::view_alloc(Kokkos::WithoutInitializing, view.label()), view.extent(0));
  gather_by_permutation(permuted, view, permutation, n);
  return permuted;
}

// The same in place: view's first n entries gathered into `scratch` (as many bytes as view's
// entries take, at least) and copied back, the View kept. Twice the bytes moved, but one scratch
// serves every field of a reorder, where new storage was an allocation and a free a field: on a
// GPU each costs more than a copy, and a free waits for the device.
using PermutationScratch = Kokkos::View<double*, DeviceType>;
template <class ViewType>
void permute_particle_field_in_place(const ViewType& view, const IndexView& permutation, index_t n,
                                     const PermutationScratch& scratch) {
  using Value = typename ViewType::non_const_value_type;
  static_assert(sizeof(Value) <= sizeof(double) && alignof(Value) <= alignof(double),
                "a particle field's entries fit the scratch's");
  const Kokkos::View<Value*, DeviceType, Kokkos::MemoryTraits<Kokkos::Unmanaged>> gathered(
      reinterpret_cast<Value*>(scratch.data()), static_cast<size_t>(n));
  gather_by_permutation(gathered, view, permutation, n);
  Kokkos::deep_copy(ExecutionSpace(), Kokkos::subview(view, std::make_pair(index_t(0), n)), gathered);
}

// A particle's bin for CellOrder: its cell, or the group of cells its cell belongs to (a map from
// cell to bin: the coloured traversal's tiles on CPUs, kernels/transfer_kernels.hpp).
// in_long_runs: whether consecutive particles mostly share a bin (groups of many cells, once the
// particles are reordered by cell), so that the counting sort takes them run by run (below).
struct CellBin {
  static constexpr bool in_long_runs = false;
  IndexView cell;
  KOKKOS_INLINE_FUNCTION index_t operator()(index_t p) const { return cell(p); }
};
struct GroupOfCellBin {
  static constexpr bool in_long_runs = true;
  IndexView cell, bin_of_cell;
  KOKKOS_INLINE_FUNCTION index_t operator()(index_t p) const { return bin_of_cell(cell(p)); }
};

// Particles grouped by cell (or by group of cells), in increasing particle index within each bin:
// the same grouping for any thread count (the coloured P2G and deterministic reordering depend on
// it).
//  - In host memory (CPUs): a counting sort over chunks of consecutive particles, one per thread.
//    Each chunk counts its particles per bin; a bin's particles from chunk t go after those of
//    the chunks before it; each chunk then places its particles in index order. Three passes over
//    the cell map, and a counter per bin and chunk (at most 32 chunks).
//  - Elsewhere: a bin sort. The particles per bin are counted (an atomic ScatterView: integer sums,
//    exact in any order), each bin's first slot comes from a scan of the counts, and each particle
//    takes the next slot of its bin (an atomic counter a bin: an order that depends on thread
//    timing); each bin's particles are then sorted by index, which makes the result unique. (Kokkos'
//    BinSort, which did the same from keys (bin, particle index), made three Views, one of them the
//    particles' length, at each build: on a GPU an allocation and a free each, every step.)
// Either method runs on any back-end (the tests build both on CPUs and compare them); the default
// is the one for the back-end's memory.
class CellOrder {
 public:
  enum class Method { counting_sort, bin_sort };
  static constexpr Method default_method =
      cpu_code_paths ? Method::counting_sort : Method::bin_sort;

  explicit CellOrder(Method method = default_method) : method_(method) {}

  // By cell.
  void build(const IndexView& particle_cell, index_t num_particles, index_t num_cells) {
    build_bins(CellBin{particle_cell}, num_particles, num_cells);
  }
  // By group of cells: bin_of_cell(c) in [0, num_bins) is cell c's.
  void build(const IndexView& particle_cell, index_t num_particles, const IndexView& bin_of_cell, index_t num_bins) {
    build_bins(GroupOfCellBin{particle_cell, bin_of_cell}, num_particles, num_bins);
  }

  // A particle View in the grouped order (deterministic Algorithm 1 step xii): permuted_particle_field.
  template <class ViewType>
  ViewType apply(const ViewType& view) const {
    return permuted_particle_field(view, particle_, num_particles_);
  }
  // The same in place, through `scratch`: permute_particle_field_in_place.
  template <class ViewType>
  void apply_in_place(const ViewType& view, const PermutationScratch& scratch) const {
    permute_particle_field_in_place(view, particle_, num_particles_, scratch);
  }

  // The particles of bin b are particle(bin_offset(b)) .. particle(bin_offset(b + 1) - 1).
  const IndexView& bin_offset() const { return bin_offset_; }
  const IndexView& particle() const { return particle_; }
  size_t bytes() const {
    return (particle_.span() + bin_offset_.span() + bin_next_slot_.span() + chunk_start_.span()) * sizeof(index_t);
  }

  // (Public for nvcc, which allows device lambdas only in public member functions.)
  template <class BinOf>
  void build_bins(const BinOf& bin_of, index_t num_particles, index_t num_bins) {
    // Grown with an eighth to spare, as the particle Views are (a run whose particle count grows a
    // little every step, through inflow and splitting, reallocated it every step), and left
    // unfilled: the build writes every entry it uses.
    if (static_cast<index_t>(particle_.extent(0)) < num_particles) {
      const index_t capacity = num_particles + num_particles / 8;
      particle_ = IndexView(Kokkos::view_alloc(Kokkos::WithoutInitializing, "cell_order_particle"), capacity);
    }
    if (static_cast<index_t>(bin_offset_.extent(0)) != num_bins + 1) {
      bin_offset_ = IndexView("cell_order_offset", num_bins + 1);
      bin_next_slot_ = IndexView("cell_order_next_slot", method_ == Method::bin_sort ? num_bins : 0);
    }
    if (method_ == Method::counting_sort) build_by_counting(bin_of, num_particles, num_bins);
    else build_by_bin_sort(bin_of, num_particles, num_bins);
    num_particles_ = num_particles;
  }

  template <class BinOf>
  void build_by_counting(const BinOf& bin_of, index_t num_particles, index_t num_bins) {
    // One chunk per thread, at most 32: the counters take 4 B per bin and chunk.
    const index_t chunks = ExecutionSpace().concurrency() < 32 ? ExecutionSpace().concurrency() : 32;
    if (chunk_start_.extent(0) != static_cast<size_t>(num_bins) || chunk_start_.extent(1) != static_cast<size_t>(chunks))
      chunk_start_ = Kokkos::View<index_t**, Kokkos::LayoutRight, DeviceType>("cell_order_chunk_start", num_bins, chunks);
    const auto start = chunk_start_;
    const IndexView particle = particle_, offset = bin_offset_;
    fill_in_order(start, 0);
    Kokkos::parallel_for(
        "cell_order_count", Kokkos::RangePolicy<ExecutionSpace>(0, chunks), KOKKOS_LAMBDA(const index_t t) {
          // (The bounds in locals: in the loop's condition, the division ran for every particle,
          // since the loop's stores might alias what it reads them from.)
          const index_t begin = range_part_begin(num_particles, chunks, t);
          const index_t end = range_part_begin(num_particles, chunks, t + 1);
          if (BinOf::in_long_runs) {
            // Run by run: one particle's count no longer waits on the previous one's store to the
            // same counter (the bins of long runs are few, and each particle's is the last one's).
            if (begin == end) return;
            index_t run_bin = bin_of(begin), run = 0;
            for (index_t p = begin; p < end; ++p) {
              const index_t bin = bin_of(p);
              if (bin != run_bin) {
                start(run_bin, t) += run;
                run_bin = bin;
                run = 0;
              }
              ++run;
            }
            start(run_bin, t) += run;
          } else {
            for (index_t p = begin; p < end; ++p) ++start(bin_of(p), t);
          }
        });
    // Each bin's first slot (offset) and, per chunk, the slot its first particle of the bin takes.
    Kokkos::parallel_scan(
        "cell_order_offsets", Kokkos::RangePolicy<ExecutionSpace>(0, num_bins + 1),
        KOKKOS_LAMBDA(const index_t c, index_t& running, const bool final) {
          if (final) offset(c) = running;
          if (c == num_bins) return;
          index_t slot = running;
          for (index_t t = 0; t < chunks; ++t) {
            const index_t count = start(c, t);
            if (final) start(c, t) = slot;
            slot += count;
          }
          running = slot;
        });
    Kokkos::parallel_for(
        "cell_order_place", Kokkos::RangePolicy<ExecutionSpace>(0, chunks), KOKKOS_LAMBDA(const index_t t) {
          const index_t begin = range_part_begin(num_particles, chunks, t);
          const index_t end = range_part_begin(num_particles, chunks, t + 1);
          if (BinOf::in_long_runs) {  // run by run, the next slot in a register
            if (begin == end) return;
            index_t run_bin = bin_of(begin), slot = start(run_bin, t);
            for (index_t p = begin; p < end; ++p) {
              const index_t bin = bin_of(p);
              if (bin != run_bin) {
                start(run_bin, t) = slot;
                run_bin = bin;
                slot = start(bin, t);
              }
              particle(slot++) = p;
            }
            start(run_bin, t) = slot;
          } else {
            for (index_t p = begin; p < end; ++p) particle(start(bin_of(p), t)++) = p;
          }
        });
  }

  template <class BinOf>
  void build_by_bin_sort(const BinOf& bin_of, index_t num_particles, index_t num_bins) {
    const IndexView particle = particle_, offset = bin_offset_, next = bin_next_slot_;
    fill_in_order(next, 0);
    {
      // Atomic: no copy of the counters made (and freed) at each build where ScatterView would
      // otherwise duplicate them (on CPUs).
      Kokkos::Experimental::ScatterView<index_t*, Kokkos::LayoutLeft, DeviceType, Kokkos::Experimental::ScatterSum,
                                        Kokkos::Experimental::ScatterNonDuplicated, Kokkos::Experimental::ScatterAtomic>
          counts(next);
      Kokkos::parallel_for(
          "cell_order_count", Kokkos::RangePolicy<ExecutionSpace>(0, num_particles), KOKKOS_LAMBDA(const index_t p) {
            auto access = counts.access();
            access(bin_of(p)) += 1;
          });
    }
    // Each bin's first slot (offset), which is also the next slot its particles take (next).
    Kokkos::parallel_scan(
        "cell_order_offsets", Kokkos::RangePolicy<ExecutionSpace>(0, num_bins + 1),
        KOKKOS_LAMBDA(const index_t c, index_t& running, const bool final) {
          if (final) offset(c) = running;
          if (c == num_bins) return;
          const index_t count = next(c);
          if (final) next(c) = running;
          running += count;
        });
    Kokkos::parallel_for(
        "cell_order_place", Kokkos::RangePolicy<ExecutionSpace>(0, num_particles),
        KOKKOS_LAMBDA(const index_t p) { particle(Kokkos::atomic_fetch_add(&next(bin_of(p)), index_t(1))) = p; });
    // Each bin's particles in index order (an insertion sort: a cell's few particles, placed by
    // threads that took them mostly in order).
    Kokkos::parallel_for(
        "cell_order_sort_bins", Kokkos::RangePolicy<ExecutionSpace>(0, num_bins), KOKKOS_LAMBDA(const index_t b) {
          const index_t begin = offset(b), end = offset(b + 1);
          for (index_t s = begin + 1; s < end; ++s) {
            const index_t p = particle(s);
            index_t t = s;
            for (; t > begin && particle(t - 1) > p; --t) particle(t) = particle(t - 1);
            particle(t) = p;
          }
        });
  }

 private:
  Method method_;
  // bin_next_slot_ (the bin sort's): each bin's particle count, then the next slot its particles take.
  IndexView particle_, bin_offset_, bin_next_slot_;
  // (Counting sort) per bin and chunk: its particles of the bin, then the next slot they take.
  Kokkos::View<index_t**, Kokkos::LayoutRight, DeviceType> chunk_start_;
  index_t num_particles_ = 0;
};

}  // namespace mpmflow
