#include "output.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "hdf5_io.hpp"

namespace mpmflow {

void write_file_atomically(const std::string& path, const std::string& text) {
  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error("cannot write " + temporary);
    out << text;
    out.flush();
    if (!out) throw std::runtime_error("error while writing " + temporary);
  }
  std::filesystem::rename(temporary, path);
}

void DiagnosticsLog::append(long step, double time, const ConservationTotals& t, const BoundaryFluxes& fluxes) {
  if (text_.empty()) {
    text_ = "step,time";
    t.for_each_total([&](const char* name, double) { text_ += std::string(",") + name; });
    text_ += ",total_energy";
    fluxes.for_each_flux([&](const std::string& name, double) { text_ += "," + name; });
    text_ += "\n";
  }
  std::ostringstream line;
  line << std::setprecision(17) << step << ',' << time;
  t.for_each_total([&](const char*, double value) { line << ',' << value; });
  line << ',' << t.total_energy();
  fluxes.for_each_flux([&](const std::string&, double value) { line << ',' << value; });
  line << '\n';
  text_ += line.str();
  write_file_atomically(path_, text_);
}

void DiagnosticsLog::resume(long step) {
  std::ifstream in(path_);
  std::string line;
  text_.clear();
  while (std::getline(in, line)) {
    const bool header = text_.empty() && line.rfind("step,", 0) == 0;
    if (!header && std::stol(line.substr(0, line.find(','))) > step) break;
    text_ += line + "\n";
  }
}

#ifdef MPMFLOW_HAVE_HDF5
namespace {

using h5::Handle;

// The particle fields of a snapshot, each one dataset of /particles and one XDMF attribute:
// f(name, view) for each (the positions are the (N, 2) geometry, written apart).
template <class F>
void for_each_snapshot_particle_field(const ParticleState& pt, F&& f) {
  f("density", pt.density), f("pressure", pt.pressure), f("velocity_x", pt.velocity_x);
  f("velocity_y", pt.velocity_y), f("specific_energy", pt.specific_energy), f("mass", pt.mass), f("id", pt.id);
}

// One node of the grid output: the particles' mass and momentum projected on it, the node's share
// of the domain's area (a quarter cell per adjacent cell) and the mass below which it is empty.
struct NodeSample {
  real_t mass, momentum_x, momentum_y, area, mass_threshold;
};

// The grid fields of a snapshot, each one dataset of /grid and one XDMF attribute.
struct GridSnapshotField {
  const char* name;
  real_t (*value)(const NodeSample&);
};
constexpr GridSnapshotField grid_snapshot_fields[] = {
    {"node_density", [](const NodeSample& n) { return n.mass / n.area; }},
    {"node_mass", [](const NodeSample& n) { return n.mass; }},
    {"node_velocity_x",
     [](const NodeSample& n) { return n.mass > n.mass_threshold ? n.momentum_x / n.mass : real_t(0); }},
    {"node_velocity_y",
     [](const NodeSample& n) { return n.mass > n.mass_threshold ? n.momentum_y / n.mass : real_t(0); }},
};

// XDMF's NumberType of a dataset of T (its Precision is sizeof(T)).
template <class T>
const char* xdmf_number_type() {
  return std::is_integral<T>::value ? "Int" : "Float";
}

// A particle field of every rank, one dataset in rank order.
template <class ViewType>
void write_particle_field(hid_t group, const char* name, const ViewType& view, index_t count, hsize_t offset,
                          hsize_t total, const ParallelContext& context) {
  auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), view);
  h5::write_block(group, name, {total}, {offset}, {static_cast<hsize_t>(count)}, host.data(), context);
}

}  // namespace

SnapshotWriter::SnapshotWriter(std::string directory, std::string case_name, const ParallelContext& context)
    : directory_(std::move(directory)), case_name_(std::move(case_name)), context_(context) {
  h5::require_parallel_if_distributed(context_);
  if (context_.is_root()) std::filesystem::create_directories(directory_);
  context_.barrier();
}

std::string SnapshotWriter::particles_xdmf_path() const { return directory_ + "/" + case_name_ + "_particles.xmf"; }
std::string SnapshotWriter::grid_xdmf_path() const { return directory_ + "/" + case_name_ + "_grid.xmf"; }

std::string SnapshotWriter::file_name(int index) const {
  std::ostringstream name;
  name << case_name_ << '_' << std::setw(6) << std::setfill('0') << index << ".h5";
  return name.str();
}

void SnapshotWriter::resume(int num_written) {
  // The snapshots an interrupted run wrote before its checkpoint: their times and particle counts
  // for the XDMF series (read by every rank alike; the files are small to open).
  records_.clear();
  for (int index = 0; index < num_written; ++index) {
    const std::string name = file_name(index);
    const std::string path = directory_ + "/" + name;
    if (!std::filesystem::exists(path)) continue;
    Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, "open " + path);
    Handle group(H5Gopen2(file, "particles", H5P_DEFAULT), H5Gclose, "open group particles in " + path);
    records_.push_back({name, h5::read_attribute(file, "time"), static_cast<long>(h5::dataset_length(group, "id"))});
  }
}

std::string SnapshotWriter::write(int index, long step, double time, const Solver& solver,
                                  const ConservationTotals& totals, const BoundaryFluxes& fluxes) {
  const NodeFieldsView projection = solver.grid_projection();
  const std::string name = file_name(index);
  const std::string path = directory_ + "/" + name;
  const std::string temporary = path + ".tmp";
  const ParticleState& pt = solver.particles();
  const GridSlab& slab = solver.slab();
  const index_t n = pt.count;
  const hsize_t offset = static_cast<hsize_t>(context_.exclusive_prefix_sum(n));
  const hsize_t total = static_cast<hsize_t>(context_.sum(n));

  {
    Handle file(h5::create_file(temporary, context_), H5Fclose, "create " + temporary);
    h5::write_attribute(file, "time", time);
    h5::write_attribute(file, "step", static_cast<double>(step));
    h5::write_attribute(file, "num_ranks", static_cast<double>(context_.size()));
    h5::write_string_attribute(file, "case", case_name_);
    h5::write_string_attribute(file, "layout",
                               "particles: one 1D dataset per field, position is (N, 2) [x, y]; "
                               "grid: (ny, nx) row-major node arrays, x fastest, physical nodes only");

    {
      Handle diag(H5Gcreate2(file, "diagnostics", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                  "create group diagnostics");
      totals.for_each_total([&](const char* name, double value) { h5::write_attribute(diag, name, value); });
      h5::write_attribute(diag, "total_energy", totals.total_energy());
      fluxes.for_each_flux([&](const std::string& name, double value) { h5::write_attribute(diag, name.c_str(), value); });
    }

    {
      Handle group(H5Gcreate2(file, "particles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                   "create group particles");
      auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.position_x);
      auto y = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.position_y);
      std::vector<real_t> xy(2 * static_cast<size_t>(n));
      for (index_t k = 0; k < n; ++k) {
        xy[2 * k] = x(k);
        xy[2 * k + 1] = y(k);
      }
      h5::write_block(group, "position", {total, 2}, {offset, 0}, {static_cast<hsize_t>(n), 2}, xy.data(), context_);
      for_each_snapshot_particle_field(pt, [&](const char* name, const auto& view) {
        write_particle_field(group, name, view, n, offset, total, context_);
      });
    }

    {
      // Grid: the nodes this slab owns (each node of the domain is written by one rank).
      const GridGeometry& geo = slab.geometry;
      const IndexRange2D owned = slab.index_space(Ownership::owned, Entity::node, Indexing::global);
      const index_t nx = owned.extent_x(), ny = owned.extent_y();
      auto state = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), projection);
      const size_t num_fields = sizeof(grid_snapshot_fields) / sizeof(grid_snapshot_fields[0]);
      std::vector<std::vector<real_t>> values(num_fields, std::vector<real_t>(static_cast<size_t>(nx) * ny));
      const real_t threshold = solver.node_mass_threshold();
      for (index_t j = 0; j < ny; ++j)
        for (index_t i = 0; i < nx; ++i) {
          const index_t gi = owned.begin_x + i, gj = owned.begin_y + j;
          const index_t node = geo.node_index(slab.local_node_x(gi), slab.local_node_y(gj));
          const bool edge_x = gi == 0 || gi == slab.global_cells_x;
          const bool edge_y = gj == 0 || gj == slab.global_cells_y;
          const NodeSample sample{state(node, GridFields::mass), state(node, GridFields::momentum_x),
                                  state(node, GridFields::momentum_y),
                                  slab.cell_area() * (edge_x ? real_t(0.5) : 1) * (edge_y ? real_t(0.5) : 1), threshold};
          for (size_t f = 0; f < num_fields; ++f) values[f][i + nx * j] = grid_snapshot_fields[f].value(sample);
        }
      Handle group(H5Gcreate2(file, "grid", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                   "create group grid");
      const std::vector<hsize_t> dims = {static_cast<hsize_t>(slab.global_cells_y + 1),
                                         static_cast<hsize_t>(slab.global_cells_x + 1)};
      const std::vector<hsize_t> start = {static_cast<hsize_t>(owned.begin_y), static_cast<hsize_t>(owned.begin_x)};
      const std::vector<hsize_t> block = {static_cast<hsize_t>(ny), static_cast<hsize_t>(nx)};
      for (size_t f = 0; f < num_fields; ++f)
        h5::write_block(group, grid_snapshot_fields[f].name, dims, start, block, values[f].data(), context_);
      grid_nodes_x_ = slab.global_cells_x + 1;
      grid_nodes_y_ = slab.global_cells_y + 1;
      grid_origin_x_ = slab.domain_x_min;
      grid_origin_y_ = slab.domain_y_min;
      grid_spacing_x_ = geo.spacing_x;
      grid_spacing_y_ = geo.spacing_y;
      h5::write_attribute(group, "origin_x", grid_origin_x_);
      h5::write_attribute(group, "origin_y", grid_origin_y_);
      h5::write_attribute(group, "spacing_x", grid_spacing_x_);
      h5::write_attribute(group, "spacing_y", grid_spacing_y_);
    }
  }
  // Every rank has closed the file before rank 0 renames it.
  context_.barrier();
  if (context_.is_root()) std::filesystem::rename(temporary, path);

  records_.push_back({name, time, static_cast<long>(total)});
  if (context_.is_root()) write_xdmf(pt);
  return path;
}

void SnapshotWriter::write_xdmf(const ParticleState& particles) const {
  const char* precision = sizeof(real_t) == 8 ? "8" : "4";
  std::ostringstream particles_xdmf, grid;
  const char* header =
      "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n<Xdmf Version=\"2.0\">\n <Domain>\n";
  particles_xdmf << header << "  <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  grid << header << "  <Grid Name=\"grid\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const Record& r : records_) {
    particles_xdmf << std::setprecision(15) << "   <Grid Name=\"particles\" GridType=\"Uniform\">\n"
              << "    <Time Value=\"" << r.time << "\"/>\n"
              << "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << r.num_particles << "\"/>\n"
              << "    <Geometry GeometryType=\"XY\">\n"
              << "     <DataItem Dimensions=\"" << r.num_particles << " 2\" NumberType=\"Float\" Precision=\""
              << precision << "\" Format=\"HDF\">" << r.file << ":/particles/position</DataItem>\n"
              << "    </Geometry>\n";
    for_each_snapshot_particle_field(particles, [&](const char* field, const auto& view) {
      using Value = typename std::decay_t<decltype(view)>::non_const_value_type;
      particles_xdmf << "    <Attribute Name=\"" << field << "\" AttributeType=\"Scalar\" Center=\"Node\">\n"
                     << "     <DataItem Dimensions=\"" << r.num_particles << "\" NumberType=\""
                     << xdmf_number_type<Value>() << "\" Precision=\"" << sizeof(Value) << "\" Format=\"HDF\">"
                     << r.file << ":/particles/" << field << "</DataItem>\n"
                     << "    </Attribute>\n";
    });
    particles_xdmf << "   </Grid>\n";

    grid << std::setprecision(15) << "   <Grid Name=\"grid\" GridType=\"Uniform\">\n"
         << "    <Time Value=\"" << r.time << "\"/>\n"
         << "    <Topology TopologyType=\"2DCoRectMesh\" Dimensions=\"" << grid_nodes_y_ << " " << grid_nodes_x_
         << "\"/>\n"
         << "    <Geometry GeometryType=\"ORIGIN_DXDY\">\n"
         << "     <DataItem Dimensions=\"2\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" << grid_origin_y_
         << " " << grid_origin_x_ << "</DataItem>\n"
         << "     <DataItem Dimensions=\"2\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" << grid_spacing_y_
         << " " << grid_spacing_x_ << "</DataItem>\n"
         << "    </Geometry>\n";
    for (const GridSnapshotField& field : grid_snapshot_fields)
      grid << "    <Attribute Name=\"" << field.name << "\" AttributeType=\"Scalar\" Center=\"Node\">\n"
           << "     <DataItem Dimensions=\"" << grid_nodes_y_ << " " << grid_nodes_x_
           << "\" NumberType=\"Float\" Precision=\"" << precision << "\" Format=\"HDF\">" << r.file << ":/grid/"
           << field.name << "</DataItem>\n"
           << "    </Attribute>\n";
    grid << "   </Grid>\n";
  }
  const char* footer = "  </Grid>\n </Domain>\n</Xdmf>\n";
  particles_xdmf << footer;
  grid << footer;
  write_file_atomically(particles_xdmf_path(), particles_xdmf.str());
  write_file_atomically(grid_xdmf_path(), grid.str());
}
#endif

}  // namespace mpmflow
