#pragma once
// A ScatterView over a one-dimensional View of sums, kept from call to call by whoever adds into
// those sums every step (as KeptBuffer, kernels/types.hpp, keeps a View). A duplicated ScatterView
// (the CPU default) allocates a copy of its target per thread when it is made: made in each call,
// the volume gradients' two were two allocations a step, against the rule that a step allocates
// nothing once its buffers have grown (on a GPU an allocation and its free cost more than a small
// kernel, and a free may wait for the device).
#include <Kokkos_ScatterView.hpp>

#include <utility>

#include "kernels/types.hpp"

namespace mpmflow {

template <class T>
class KeptScatterView {
 public:
  using Target = Kokkos::View<T*, DeviceType>;
  // The back-end's default: duplicated and non-atomic on CPUs, atomic on GPUs.
  using Scatter = decltype(Kokkos::Experimental::create_scatter_view(std::declval<Target>()));

  // The ScatterView for additions into `target` (zeroed by the caller, or holding sums to add to),
  // its copies cleared: the kept one, or a new one where `target` is another View than the last
  // call's (an atomic ScatterView writes into the View it was made for). The last target is held,
  // so that its memory is not reused by another View while it is compared against.
  Scatter& into(const Target& target) {
    if (target_.data() != target.data() || target_.extent(0) != target.extent(0)) {
      target_ = target;
      scatter_ = Kokkos::Experimental::create_scatter_view(target);  // (made cleared)
    } else {
      scatter_.reset_except(target);
    }
    return scatter_;
  }
  // The additions made through `into(target)`'s ScatterView summed into `target` (nothing to do
  // where the ScatterView is atomic).
  void contribute_into(const Target& target) { scatter_.contribute_into(target); }

 private:
  Target target_;
  Scatter scatter_;
};

}  // namespace mpmflow
