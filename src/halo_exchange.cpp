#include "halo_exchange.hpp"

#include <stdexcept>
#include <string>

namespace mpmflow {
#ifdef MPMFLOW_HAVE_MPI
namespace {

// The nodes of an index rectangle, numbered row by row from its lower-left node
// (IndexRange2D::i_of, j_of): node k is element (component c, k) of a packed buffer.
struct PackedNodes {
  GridGeometry geometry;
  IndexRange2D nodes;
  KOKKOS_INLINE_FUNCTION index_t node(index_t k) const { return geometry.node_index(nodes.i_of(k), nodes.j_of(k)); }
};

void pack(const PackedNodes& lines, const NodeFieldsView& fields, int first, int count, const RealView& buffer) {
  const index_t per_component = lines.nodes.size();
  Kokkos::parallel_for(
      "halo_pack", Kokkos::RangePolicy<ExecutionSpace>(0, per_component * count), KOKKOS_LAMBDA(const index_t s) {
        buffer(s) = fields(lines.node(s % per_component), first + s / per_component);
      });
}

void add_unpacked(const PackedNodes& lines, const NodeFieldsView& fields, int first, int count,
                  const RealView& buffer) {
  const index_t per_component = lines.nodes.size();
  Kokkos::parallel_for(
      "halo_add", Kokkos::RangePolicy<ExecutionSpace>(0, per_component * count), KOKKOS_LAMBDA(const index_t s) {
        fields(lines.node(s % per_component), first + s / per_component) += buffer(s);
      });
}

}  // namespace
#endif

HaloExchange::HaloExchange(const GridSlab& slab, const ParallelContext& context, int max_components)
    : geometry_(slab.geometry), context_(context), max_components_(max_components) {
  auto connect = [&](Neighbour& neighbour, int direction, const char* send_label, const char* receive_label) {
    // A slab run alone (a single-process solver on part of the grid) has no one to share with.
    const int rank = context.rank() + direction;
    if (rank < 0 || rank >= context.size()) return;
    neighbour.nodes = slab.shared_node_space(direction);
    if (neighbour.nodes.empty()) return;
    neighbour.rank = rank;
    const size_t size = static_cast<size_t>(neighbour.nodes.size()) * max_components;
    neighbour.send = RealView(std::string(send_label), size);
    neighbour.receive = RealView(std::string(receive_label), size);
    neighbour.send_host = host_mirror(neighbour.send);
    neighbour.receive_host = host_mirror(neighbour.receive);
  };
  connect(lower_, -1, "halo_send_lower", "halo_receive_lower");
  connect(upper_, +1, "halo_send_upper", "halo_receive_upper");
}

void HaloExchange::sum_shared_nodes(const NodeFieldsView& fields, int first_component, int num_components) const {
  if (!active()) return;
  if (num_components > max_components_)
    throw std::logic_error("halo exchange: " + std::to_string(num_components) + " node columns asked for, buffers for " +
                           std::to_string(max_components_));
#ifdef MPMFLOW_HAVE_MPI
  const Neighbour* neighbours[2] = {&lower_, &upper_};
  for (const Neighbour* n : neighbours)
    if (n->rank >= 0) pack({geometry_, n->nodes}, fields, first_component, num_components, n->send);
  Kokkos::fence();

  // Host staging unless MPI may read device memory (host back-ends, or GPU-aware MPI asked for).
  const bool direct = context_.gpu_aware || host_uses_views_directly;
  const MPI_Datatype type = sizeof(real_t) == 8 ? MPI_DOUBLE : MPI_FLOAT;
  // Tags name the direction of travel, so that a slab's two messages to one rank never mix.
  constexpr int to_upper = 1, to_lower = 2;
  MPI_Request requests[4];
  int count = 0;
  for (const Neighbour* n : neighbours) {
    if (n->rank < 0) continue;
    if (!direct) Kokkos::deep_copy(n->send_host, n->send);
    const int size = n->nodes.size() * num_components;
    const bool is_lower = n == &lower_;
    MPI_Irecv(direct ? n->receive.data() : n->receive_host.data(), size, type, n->rank,
              is_lower ? to_upper : to_lower, context_.comm(), &requests[count++]);
    MPI_Isend(direct ? n->send.data() : n->send_host.data(), size, type, n->rank, is_lower ? to_lower : to_upper,
              context_.comm(), &requests[count++]);
  }
  MPI_Waitall(count, requests, MPI_STATUSES_IGNORE);
  for (const Neighbour* n : neighbours) {
    if (n->rank < 0) continue;
    if (!direct) Kokkos::deep_copy(n->receive, n->receive_host);
    add_unpacked({geometry_, n->nodes}, fields, first_component, num_components, n->receive);
  }
#else
  (void)fields;
  (void)first_component;
  (void)num_components;
#endif
}

}  // namespace mpmflow
