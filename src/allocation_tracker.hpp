#pragma once
// Kokkos allocations counted as they happen, through the Kokkos Tools allocation callbacks: what
// the benchmark reports as memory per particle, and what the tests bound at a growth. Host code
// only, and one tracker at a time (the callbacks are global; none is set otherwise).
#include <Kokkos_Core.hpp>

#include <algorithm>
#include <cstdint>
#include <map>
#include <mutex>

namespace mpmflow {

class AllocationTracker {
 public:
  // Installs the callbacks: from now on every allocation and free is counted.
  AllocationTracker() {
    installed() = this;
    Kokkos::Tools::Experimental::set_allocate_data_callback(on_allocate);
    Kokkos::Tools::Experimental::set_deallocate_data_callback(on_deallocate);
  }
  ~AllocationTracker() {
    Kokkos::Tools::Experimental::set_allocate_data_callback(nullptr);
    Kokkos::Tools::Experimental::set_deallocate_data_callback(nullptr);
    installed() = nullptr;
  }
  AllocationTracker(const AllocationTracker&) = delete;
  AllocationTracker& operator=(const AllocationTracker&) = delete;

  // Bytes allocated since the tracker was installed, less those freed since: what was allocated
  // before and freed since counts against it (its size as the callback reports it), so this is the
  // change since the start, below zero where more went than came.
  long long current() const { return current_; }
  // The most `current` has been since the start or the last reset_peak.
  long long peak() const { return peak_; }
  void reset_peak() { peak_ = current_; }
  // While paused, allocations are not counted, and neither are their frees later (the benchmark's
  // own arrays).
  bool paused = false;

 private:
  static AllocationTracker*& installed() {
    static AllocationTracker* tracker = nullptr;
    return tracker;
  }
  static void on_allocate(Kokkos_Profiling_SpaceHandle, const char*, const void* ptr, std::uint64_t size) {
    AllocationTracker& t = *installed();
    const std::lock_guard<std::mutex> lock(t.mutex_);
    if (t.paused) {
      t.uncounted_[ptr] = size;
      return;
    }
    t.live_[ptr] = size;
    t.current_ += static_cast<long long>(size);
    t.peak_ = std::max(t.peak_, t.current_);
  }
  static void on_deallocate(Kokkos_Profiling_SpaceHandle, const char*, const void* ptr, std::uint64_t size) {
    AllocationTracker& t = *installed();
    const std::lock_guard<std::mutex> lock(t.mutex_);
    if (t.uncounted_.erase(ptr) > 0) return;
    const auto it = t.live_.find(ptr);
    t.current_ -= it != t.live_.end() ? static_cast<long long>(it->second) : static_cast<long long>(size);
    if (it != t.live_.end()) t.live_.erase(it);
  }

  std::map<const void*, std::uint64_t> live_, uncounted_;
  long long current_ = 0, peak_ = 0;
  // The callbacks come from whichever thread allocates: Kokkos' OpenMP back-end has its threads
  // allocate their own scratch ("[unlabeled]"), two at once was seen, and two insertions into
  // live_ at once had corrupted the heap now and then.
  std::mutex mutex_;
};

}  // namespace mpmflow
