#pragma once
// Conservation diagnostics over the particles, computed with Kokkos Kernels' BLAS-1 routines.
#include <string>

#include "particles.hpp"

namespace mpmflow {

struct ConservationTotals {
  double mass = 0;
  double momentum_x = 0;
  double momentum_y = 0;
  double kinetic_energy = 0;
  double internal_energy = 0;
  double total_energy() const { return kinetic_energy + internal_energy; }
  ConservationTotals& operator+=(const ConservationTotals& o) {
    mass += o.mass, momentum_x += o.momentum_x, momentum_y += o.momentum_y;
    kinetic_energy += o.kinetic_energy, internal_energy += o.internal_energy;
    return *this;
  }

  // Calls f(name, value) for every total: the one list for the sums over ranks, diagnostics.csv,
  // the snapshots' and the checkpoints' attributes.
  template <class F>
  void for_each_total(F&& f) {
    visit(*this, f);
  }
  template <class F>
  void for_each_total(F&& f) const {
    visit(*this, f);
  }

 private:
  template <class Self, class F>
  static void visit(Self& self, F& f) {
    f("mass", self.mass), f("momentum_x", self.momentum_x), f("momentum_y", self.momentum_y);
    f("kinetic_energy", self.kinetic_energy), f("internal_energy", self.internal_energy);
  }
};

// The conservation totals of the particles that entered and of those that left through the open
// sides so far (this rank's share, summed over the ranks for output). With them the mass balance
// mass(t) = mass(0) + entered - left closes to round-off.
struct BoundaryFluxes {
  ConservationTotals entered;
  ConservationTotals left;

  // Calls f(name, value) for every flux: "<total>_in" and "<total>_out" for every conservation
  // total: the one list for the sums over ranks, diagnostics.csv, snapshots and checkpoints.
  template <class F>
  void for_each_flux(F&& f) {
    visit(*this, f);
  }
  template <class F>
  void for_each_flux(F&& f) const {
    visit(*this, f);
  }

 private:
  template <class Self, class F>
  static void visit(Self& self, F& f) {
    self.entered.for_each_total([&](const char* name, auto&& value) { f(std::string(name) + "_in", value); });
    self.left.for_each_total([&](const char* name, auto&& value) { f(std::string(name) + "_out", value); });
  }
};

class DiagnosticsCalculator {
 public:
  explicit DiagnosticsCalculator(index_t capacity) : scratch_("diagnostics_scratch", capacity) {}
  ConservationTotals compute(const ParticleState& particles);

 private:
  RealView scratch_;  // M .* V, reused by every call
};

}  // namespace mpmflow
