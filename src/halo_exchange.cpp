#include "halo_exchange.hpp"

namespace mpmflow {
namespace {

// Node of element (component c, line l, position k) of a packed buffer of shared lines.
struct SharedLines {
  GridGeometry geometry;
  int axis;
  index_t first_line;
  index_t line_length;
  KOKKOS_INLINE_FUNCTION index_t node(index_t l, index_t k) const {
    return axis == 0 ? geometry.node_index(first_line + l, k) : geometry.node_index(k, first_line + l);
  }
};

void pack(const SharedLines& lines, const NodeFieldsView& fields, int first, int count, const RealView& buffer) {
  const index_t per_component = HaloExchange::shared_lines * lines.line_length;
  Kokkos::parallel_for(
      "halo_pack", Kokkos::RangePolicy<ExecutionSpace>(0, per_component * count), KOKKOS_LAMBDA(const index_t s) {
        const index_t c = s / per_component, rest = s % per_component;
        buffer(s) = fields(lines.node(rest / lines.line_length, rest % lines.line_length), first + c);
      });
}

void add_unpacked(const SharedLines& lines, const NodeFieldsView& fields, int first, int count,
                  const RealView& buffer) {
  const index_t per_component = HaloExchange::shared_lines * lines.line_length;
  Kokkos::parallel_for(
      "halo_add", Kokkos::RangePolicy<ExecutionSpace>(0, per_component * count), KOKKOS_LAMBDA(const index_t s) {
        const index_t c = s / per_component, rest = s % per_component;
        fields(lines.node(rest / lines.line_length, rest % lines.line_length), first + c) += buffer(s);
      });
}

}  // namespace

HaloExchange::HaloExchange(const GridSlab& slab, const SlabDecomposition& decomposition,
                           const ParallelContext& context, int max_components)
    : geometry_(slab.geometry), axis_(decomposition.axis), context_(&context) {
  line_length_ = axis_ == 0 ? geometry_.nodes_y : geometry_.nodes_x;
  const int rank = context.rank(), ranks = decomposition.num_ranks();
  if (ranks > 1) {
    lower_rank_ = rank > 0 ? rank - 1 : -1;
    upper_rank_ = rank + 1 < ranks ? rank + 1 : -1;
  }
  const index_t size = shared_lines * line_length_ * max_components;
  auto make = [size](const char* label) {
    Buffer b;
    b.device = RealView(std::string(label), static_cast<size_t>(size));
    b.host = Kokkos::create_mirror_view(b.device);
    return b;
  };
  if (lower_rank_ >= 0) {
    send_lower_ = make("halo_send_lower");
    receive_lower_ = make("halo_receive_lower");
  }
  if (upper_rank_ >= 0) {
    send_upper_ = make("halo_send_upper");
    receive_upper_ = make("halo_receive_upper");
  }
}

void HaloExchange::sum_shared_nodes(const NodeFieldsView& fields, int first_component, int num_components) {
  if (!active()) return;
#ifdef MPMFLOW_HAVE_MPI
  const index_t nodes_along = axis_ == 0 ? geometry_.nodes_x : geometry_.nodes_y;
  const SharedLines lower{geometry_, axis_, 0, line_length_};
  const SharedLines upper{geometry_, axis_, nodes_along - shared_lines, line_length_};
  const int count = shared_lines * line_length_ * num_components;
  if (lower_rank_ >= 0) pack(lower, fields, first_component, num_components, send_lower_.device);
  if (upper_rank_ >= 0) pack(upper, fields, first_component, num_components, send_upper_.device);
  Kokkos::fence();

  // Host staging unless MPI may read device memory (host back-ends, or GPU-aware MPI asked for).
  const bool direct = context_->gpu_aware || Kokkos::SpaceAccessibility<Kokkos::HostSpace, MemorySpace>::accessible;
  if (!direct) {
    if (lower_rank_ >= 0) Kokkos::deep_copy(send_lower_.host, send_lower_.device);
    if (upper_rank_ >= 0) Kokkos::deep_copy(send_upper_.host, send_upper_.device);
  }
  const MPI_Datatype type = sizeof(real_t) == 8 ? MPI_DOUBLE : MPI_FLOAT;
  constexpr int to_upper = 1, to_lower = 2;
  MPI_Request requests[4];
  int n = 0;
  const MPI_Comm comm = context_->comm();
  if (lower_rank_ >= 0) {
    MPI_Irecv(receive_lower_.mpi_data(direct), count, type, lower_rank_, to_upper, comm, &requests[n++]);
    MPI_Isend(send_lower_.mpi_data(direct), count, type, lower_rank_, to_lower, comm, &requests[n++]);
  }
  if (upper_rank_ >= 0) {
    MPI_Irecv(receive_upper_.mpi_data(direct), count, type, upper_rank_, to_lower, comm, &requests[n++]);
    MPI_Isend(send_upper_.mpi_data(direct), count, type, upper_rank_, to_upper, comm, &requests[n++]);
  }
  MPI_Waitall(n, requests, MPI_STATUSES_IGNORE);

  if (lower_rank_ >= 0) {
    if (!direct) Kokkos::deep_copy(receive_lower_.device, receive_lower_.host);
    add_unpacked(lower, fields, first_component, num_components, receive_lower_.device);
  }
  if (upper_rank_ >= 0) {
    if (!direct) Kokkos::deep_copy(receive_upper_.device, receive_upper_.host);
    add_unpacked(upper, fields, first_component, num_components, receive_upper_.device);
  }
#else
  (void)fields;
  (void)first_component;
  (void)num_components;
#endif
}

}  // namespace mpmflow
