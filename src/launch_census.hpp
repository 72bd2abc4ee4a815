#pragma once
// Kernel launches, reductions and View copies counted as they happen, through the Kokkos Tools
// callbacks: what the benchmark reports a step (kernel_launches_per_step ...). On a GPU each launch
// costs some microseconds however little it does, and each reduction whose result the host reads,
// and each copy to the host, waits for the device: at small sizes a step is bound by these counts
// rather than by its bytes. Host code only, and one census at a time (the callbacks are global; the
// allocation tracker's are others, and both may be installed at once). While a census is installed
// Kokkos fences before every launch (its tools' default, which only a tool library loaded at
// initialisation can turn off): count steps that are not timed.
#include <Kokkos_Core.hpp>

#include <atomic>
#include <cstdint>
#include <cstring>
#include <map>
#include <mutex>
#include <string>

namespace mpmflow {

class LaunchCensus {
 public:
  // Installs the callbacks: from now on every launch and copy is counted (by its label too, where
  // by_label is set).
  explicit LaunchCensus(bool by_label = false) : by_label_(by_label) {
    installed() = this;
    Kokkos::Tools::Experimental::set_begin_parallel_for_callback(on_parallel_for);
    Kokkos::Tools::Experimental::set_begin_parallel_reduce_callback(on_reduction);
    Kokkos::Tools::Experimental::set_begin_parallel_scan_callback(on_reduction);
    Kokkos::Tools::Experimental::set_begin_deep_copy_callback(on_deep_copy);
  }
  ~LaunchCensus() {
    Kokkos::Tools::Experimental::set_begin_parallel_for_callback(nullptr);
    Kokkos::Tools::Experimental::set_begin_parallel_reduce_callback(nullptr);
    Kokkos::Tools::Experimental::set_begin_parallel_scan_callback(nullptr);
    Kokkos::Tools::Experimental::set_begin_deep_copy_callback(nullptr);
    installed() = nullptr;
  }
  LaunchCensus(const LaunchCensus&) = delete;
  LaunchCensus& operator=(const LaunchCensus&) = delete;

  // Kernels launched: parallel_for, parallel_reduce and parallel_scan (a View's fill or
  // initialisation is a parallel_for of Kokkos' own).
  long long launches() const { return launches_; }
  // Of those, the reductions and scans: each has a total, which the host mostly reads.
  long long reductions() const { return reductions_; }
  // deep_copy between two Views (not fills from a scalar: Kokkos fills with a kernel of its own,
  // counted as a launch, or a memset). Between host and device memory on a GPU, a transfer the
  // host waits for; on CPUs mostly a View onto itself (a mirror that is the View), counted all the
  // same, so that the count is the program's.
  long long view_copies() const { return view_copies_; }
  // Fills of a View from a value through deep_copy without an execution space (Kokkos names their
  // source "Scalar"; "(none)" where an execution space is given): Kokkos fences before and after
  // each, on a GPU two waits for the device (fill_in_order, kernels/index_lanes.hpp, fills without them).
  long long fenced_fills() const { return fenced_fills_; }
  // The counts by label ("copy DST <- SRC" for a copy), where by_label was set.
  const std::map<std::string, long long>& by_label() const { return by_label_counts_; }

 private:
  static LaunchCensus*& installed() {
    static LaunchCensus* census = nullptr;
    return census;
  }
  void count_label(const std::string& label) {
    const std::lock_guard<std::mutex> lock(mutex_);
    ++by_label_counts_[label];
  }
  static void on_parallel_for(const char* name, std::uint32_t, std::uint64_t*) {
    LaunchCensus& c = *installed();
    ++c.launches_;
    if (c.by_label_) c.count_label(name);
  }
  static void on_reduction(const char* name, std::uint32_t, std::uint64_t*) {
    LaunchCensus& c = *installed();
    ++c.launches_;
    ++c.reductions_;
    if (c.by_label_) c.count_label(name);
  }
  static void on_deep_copy(Kokkos_Profiling_SpaceHandle, const char* destination, const void*,
                           Kokkos_Profiling_SpaceHandle, const char* source, const void*, std::uint64_t) {
    LaunchCensus& c = *installed();
    // (Kokkos names the source of a fill "Scalar", or "(none)" where it was given an execution space.)
    if (std::strcmp(source, "Scalar") == 0) {
      ++c.fenced_fills_;
      if (c.by_label_) c.count_label(std::string("fenced fill ") + destination);
      return;
    }
    if (std::strcmp(source, "(none)") == 0) return;
    ++c.view_copies_;
    if (c.by_label_) c.count_label(std::string("copy ") + destination + " <- " + source);
  }

  const bool by_label_;
  // (Atomic: a View's initialisation may come from any thread that allocates, as the allocation
  // tracker found.)
  std::atomic<long long> launches_{0}, reductions_{0}, view_copies_{0}, fenced_fills_{0};
  std::map<std::string, long long> by_label_counts_;
  std::mutex mutex_;
};

}  // namespace mpmflow
