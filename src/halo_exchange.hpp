#pragma once
// Sums of node contributions over the ranks whose slabs share the nodes.
//
// A slab's local nodes run from one ghost line below its first owned cell to one ghost line
// above its last (GridSlab). Neighbouring slabs therefore both hold the three node lines around
// their common face (global lines b - 1, b, b + 1), and a particle on either side may contribute
// to any of them. After a P2G each rank sends its partial sums on those lines to the neighbour and
// adds what it receives: both then hold the complete sums there (a + b on one side, b + a on the
// other: bitwise the same), which is also every value G2P reads from a neighbour's nodes, so no
// separate ghost refresh is needed. Slabs at least 3 cells wide (SlabDecomposition) share nodes
// with their two neighbours only.
#include "grid.hpp"
#include "parallel.hpp"

namespace mpmflow {

class HaloExchange {
 public:
  static constexpr int shared_lines = 2 * GridSlab::ghost_layers + 1;

  HaloExchange(const GridSlab& slab, const SlabDecomposition& decomposition, const ParallelContext& context,
               int max_components);

  // Columns [first_component, first_component + num_components) of `fields`.
  void sum_shared_nodes(const NodeFieldsView& fields, int first_component, int num_components);

  bool active() const { return lower_rank_ >= 0 || upper_rank_ >= 0; }

 private:
  GridGeometry geometry_;
  int axis_ = 0;
  index_t line_length_ = 0;  // nodes along one shared line
  int lower_rank_ = -1;      // neighbour below along the axis, or -1
  int upper_rank_ = -1;
  const ParallelContext* context_ = nullptr;
  // Device buffers and their host mirrors (the same Views on host back-ends) for host staging.
  struct Buffer {
    RealView device;
    RealView::HostMirror host;
    // What MPI reads or writes: the device buffer itself when MPI may touch device memory.
    real_t* mpi_data(bool direct) const { return direct ? device.data() : host.data(); }
  };
  Buffer send_lower_, send_upper_, receive_lower_, receive_upper_;
};

}  // namespace mpmflow
