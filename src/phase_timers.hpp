#pragma once
// Wall-clock time per named phase, each phase also a Kokkos profiling region so the standard
// Kokkos tools (space-time stack, kernel timer, nsys/rocprof connectors) see the same names.
#include <map>
#include <string>
#include <vector>

#include <Kokkos_Core.hpp>

namespace mpmflow {

class PhaseTimers {
 public:
  struct Entry {
    double seconds = 0;
    long calls = 0;
  };

  // Scoped phase: a profiling region and a timer. The fence at the end makes the time belong to
  // this phase even on asynchronous back-ends.
  class Scope {
   public:
    Scope(PhaseTimers& timers, const char* name) : timers_(timers), name_(name) {
      Kokkos::Profiling::pushRegion(name_);
    }
    ~Scope() {
      Kokkos::fence();
      Kokkos::Profiling::popRegion();
      timers_.add(name_, timer_.seconds());
    }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    PhaseTimers& timers_;
    const char* name_;
    Kokkos::Timer timer_;
  };

  Scope scope(const char* name) { return Scope(*this, name); }

  void add(const std::string& name, double seconds) {
    auto it = entries_.find(name);
    if (it == entries_.end()) {
      order_.push_back(name);
      it = entries_.emplace(name, Entry{}).first;
    }
    it->second.seconds += seconds;
    it->second.calls += 1;
  }

  const std::vector<std::string>& names() const { return order_; }
  const Entry& entry(const std::string& name) const { return entries_.at(name); }
  double total_seconds() const {
    double total = 0;
    for (const auto& kv : entries_) total += kv.second.seconds;
    return total;
  }

 private:
  std::map<std::string, Entry> entries_;
  std::vector<std::string> order_;  // first-seen order, which is the order of the step
};

}  // namespace mpmflow
