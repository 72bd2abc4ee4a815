#pragma once
// Sums of node contributions over the ranks whose slabs share the nodes.
//
// A slab's local nodes run from one ghost line below its first owned cell to one ghost line
// above its last (GridSlab). Neighbouring slabs therefore both hold the three node lines around
// their common face (global lines b - 1, b, b + 1: GridSlab::shared_node_space), and a particle
// on either side may contribute to any of them. After a P2G each rank sends its partial sums on
// those lines to the neighbour and adds what it receives: both then hold the complete sums there
// (a + b on one side, b + a on the other: bitwise the same), which is also every value G2P reads
// from a neighbour's nodes, so no separate ghost refresh is needed. Slabs at least 3 cells wide
// (SlabDecomposition) share nodes with their two neighbours only.
#include "grid.hpp"
#include "parallel.hpp"

namespace mpmflow {

class HaloExchange {
 public:
  // For the slab of rank `context.rank()`, whose neighbours along the slab axis are ranks
  // rank - 1 and rank + 1. Buffers for up to `max_components` node columns.
  HaloExchange(const GridSlab& slab, const ParallelContext& context, int max_components);

  // Columns [first_component, first_component + num_components) of `fields`. Collective with
  // the neighbours. Const: it changes `fields`, not the exchange (its buffers are scratch).
  void sum_shared_nodes(const NodeFieldsView& fields, int first_component, int num_components) const;

  bool active() const { return !lower_.nodes.empty() || !upper_.nodes.empty(); }

 private:
  // One neighbour: its rank, the shared node lines, and device buffers with their host mirrors
  // (the same Views on host back-ends) for host staging.
  struct Neighbour {
    int rank = -1;
    IndexRange2D nodes;  // local indices, empty without a neighbour
    RealView send, receive;
    RealView::HostMirror send_host, receive_host;
  };
  GridGeometry geometry_;
  ParallelContext context_;
  int max_components_ = 0;
  Neighbour lower_, upper_;
};

}  // namespace mpmflow
