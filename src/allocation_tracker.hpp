#pragma once
// Kokkos allocations counted as they happen, through the Kokkos Tools allocation callbacks: what
// the benchmark reports as memory per particle, and what the tests bound at a growth. Host code
// only, and one tracker at a time (the callbacks are global; none is set otherwise).
#include <Kokkos_Core.hpp>

#include <cstdint>
#include <map>
#include <mutex>
#include <string>

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
  // Allocations counted since the start (on a GPU each costs more than a small kernel, and its
  // free may wait for the device: a step that allocates pays it every step).
  long long allocation_count() const { return allocation_count_; }
  // The same by label: where they come from.
  const std::map<std::string, long long>& allocation_count_by_label() const { return allocation_count_by_label_; }
  void reset_peak() {
    peak_ = current_;
    record_peak();
  }
  // The bytes of the allocations live at that peak, by label (the View's; a ScatterView's copies
  // and Kokkos' own temporaries have theirs): where the peak's memory went. Allocations made
  // before the tracker was installed are not in it, and those of them freed since count against it
  // under a label of their own, as they do against `current`.
  const std::map<std::string, long long>& peak_by_label() const { return peak_by_label_; }
  // While paused, allocations are not counted, and neither are their frees later (the benchmark's
  // own arrays).
  bool paused = false;

 private:
  static AllocationTracker*& installed() {
    static AllocationTracker* tracker = nullptr;
    return tracker;
  }
  static void on_allocate(Kokkos_Profiling_SpaceHandle, const char* label, const void* ptr, std::uint64_t size) {
    AllocationTracker& t = *installed();
    const std::lock_guard<std::mutex> lock(t.mutex_);
    if (t.paused) {
      t.uncounted_[ptr] = size;
      return;
    }
    t.live_[ptr] = {size, label};
    ++t.allocation_count_;
    ++t.allocation_count_by_label_[label];
    t.current_ += static_cast<long long>(size);
    if (t.current_ > t.peak_) {
      t.peak_ = t.current_;
      t.record_peak();
    }
  }
  static void on_deallocate(Kokkos_Profiling_SpaceHandle, const char*, const void* ptr, std::uint64_t size) {
    AllocationTracker& t = *installed();
    const std::lock_guard<std::mutex> lock(t.mutex_);
    if (t.uncounted_.erase(ptr) > 0) return;
    const auto it = t.live_.find(ptr);
    if (it != t.live_.end()) {
      t.current_ -= static_cast<long long>(it->second.size);
      t.live_.erase(it);
    } else {
      t.current_ -= static_cast<long long>(size);
      t.freed_from_before_ += static_cast<long long>(size);
    }
  }

  // A new peak: the live allocations summed by label (a few hundred at most, and new peaks are
  // rare once a run has taken its memory).
  void record_peak() {
    peak_by_label_.clear();
    for (const auto& entry : live_) peak_by_label_[entry.second.label] += static_cast<long long>(entry.second.size);
    // What current() counted against the start: so that the labels sum to the peak.
    if (freed_from_before_ > 0) peak_by_label_["(allocated before the count began, freed since)"] = -freed_from_before_;
  }

  struct Allocation {
    std::uint64_t size;
    std::string label;
  };
  std::map<const void*, Allocation> live_;
  std::map<const void*, std::uint64_t> uncounted_;
  std::map<std::string, long long> peak_by_label_, allocation_count_by_label_;
  long long current_ = 0, peak_ = 0, freed_from_before_ = 0, allocation_count_ = 0;
  // The callbacks come from whichever thread allocates: Kokkos' OpenMP back-end has its threads
  // allocate their own scratch ("[unlabeled]"), two at once was seen, and two insertions into
  // live_ at once had corrupted the heap now and then.
  std::mutex mutex_;
};

}  // namespace mpmflow
