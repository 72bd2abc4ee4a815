#include "output.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "build_commit.hpp"
#include "gas_physics.hpp"
#include "geometry.hpp"
#include "hdf5_io.hpp"
#include "run_files.hpp"

namespace mpmflow {

void write_file_atomically(const std::string& path, const std::string& text) {
  // Written, flushed to disk and renamed, every call checked; on failure the temporary goes and
  // the file keeps its previous content.
  const std::string temporary = path + ".tmp";
  auto fail = [&](const std::string& what, int error) {
    ::unlink(temporary.c_str());
    throw std::runtime_error("writing " + path + " failed (" + what + "): " + std::strerror(error));
  };
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) fail("create " + temporary, errno);
  for (size_t done = 0; done < text.size();) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int error = errno;
      ::close(fd);
      fail("write", error);
    }
    done += static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0) {
    const int error = errno;
    ::close(fd);
    fail("flush to disk", error);
  }
  if (::close(fd) != 0) fail("close", errno);
  if (::rename(temporary.c_str(), path.c_str()) != 0) fail("rename to " + path, errno);
}

void DiagnosticsLog::append(long step, double time, const ConservationTotals& t, const BoundaryFluxes& fluxes,
                            const DiagnosticColumns& extra) {
  if (text_.empty()) {
    text_ = "step,time";
    t.for_each_total([&](const char* name, double) { text_ += std::string(",") + name; });
    text_ += ",total_energy";
    fluxes.for_each_flux([&](const std::string& name, double) { text_ += "," + name; });
    for (const auto& column : extra) text_ += "," + column.first;
    text_ += "\n";
  }
  std::ostringstream line;
  line << std::setprecision(17) << step << ',' << time;
  t.for_each_total([&](const char*, double value) { line << ',' << value; });
  line << ',' << t.total_energy();
  fluxes.for_each_flux([&](const std::string&, double value) { line << ',' << value; });
  for (const auto& column : extra) line << ',' << column.second;
  line << '\n';
  text_ += line.str();
  write_file_atomically(path_, text_);
}

void DiagnosticsLog::resume(long step) {
  std::ifstream in(path_);
  std::string line;
  text_.clear();
  for (long number = 1; std::getline(in, line); ++number) {
    const bool header = text_.empty() && line.rfind("step,", 0) == 0;
    if (!header) {
      const std::string first = line.substr(0, line.find(','));
      char* end = nullptr;
      const long row_step = std::strtol(first.c_str(), &end, 10);
      if (first.empty() || *end != '\0')
        throw std::runtime_error(path_ + ": line " + std::to_string(number) + ": expected a step number first; got '" +
                                 first + "' (remove or repair the file to restart)");
      if (row_step > step) break;
    }
    text_ += line + "\n";
  }
}

#ifdef MPMFLOW_HAVE_HDF5
namespace {

using h5::Handle;

// The particles' pressure, which they do not store: made from their density and specific energy
// as it is written (write_particle_field), a particle-sized View never held for it.
struct SnapshotPressure {
  using non_const_value_type = real_t;  // (the dataset's type, as a View's)
  RealView density, specific_energy;
  real_t gamma;
};

// The scalar particle fields of a snapshot, each one dataset of /particles and one XDMF
// attribute: f(name, field) for each, a View or the pressure. The positions (the (N, 2) geometry),
// the velocity (an (N, 3) vector, z = 0, as ParaView's glyphs and stream tracers want) and the
// vertex connectivity are written apart.
template <class F>
void for_each_snapshot_particle_field(const ParticleState& pt, real_t gamma, F&& f) {
  f("density", pt.density), f("pressure", SnapshotPressure{pt.density, pt.specific_energy, gamma});
  f("specific_energy", pt.specific_energy), f("mass", pt.mass), f("id", pt.id);
}

// One node of the grid output: the particles' state projected on it (GridFields::ProjectionColumn),
// the mass below which it is empty, and gamma.
struct NodeSample {
  real_t mass, momentum_x, momentum_y, mass_density, mass_pressure, mass_energy, mass_threshold, gamma;
  bool empty() const { return !(mass > mass_threshold); }
  // The mass-weighted average on the node of a particle field whose column holds mass x field.
  real_t average(real_t mass_times_field) const { return empty() ? real_t(0) : mass_times_field / mass; }
};

// The scalar grid fields of a snapshot, each one dataset of /grid and one XDMF attribute; the
// velocity vector is written apart.
struct GridSnapshotField {
  const char* name;
  real_t (*value)(const NodeSample&);
};
constexpr GridSnapshotField grid_snapshot_fields[] = {
    {"density", [](const NodeSample& n) { return n.average(n.mass_density); }},
    {"pressure", [](const NodeSample& n) { return n.average(n.mass_pressure); }},
    {"specific_energy", [](const NodeSample& n) { return n.average(n.mass_energy); }},
    {"mach_number",
     [](const NodeSample& n) {
       const real_t rho = n.average(n.mass_density), p = n.average(n.mass_pressure);
       if (n.empty() || !(rho > 0) || !(p > 0)) return real_t(0);
       const real_t vx = n.momentum_x / n.mass, vy = n.momentum_y / n.mass;
       return std::sqrt((vx * vx + vy * vy) * rho / (n.gamma * p));
     }},
    {"mass", [](const NodeSample& n) { return n.mass; }},
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

// A dataset of every rank made from two particle fields, one (N, components) table in rank order:
// row k from a(k) and b(k) by make_row(a, b, row), piece by piece (h5::write_rows_in_pieces). A
// table made whole first had held its 8 to 24 B a particle more while the file was built.
template <class MakeRow>
void write_rows_of_two_fields(hid_t group, const char* name, hsize_t components, const RealView& a_field,
                              const RealView& b_field, const MakeRow& make_row, index_t count, hsize_t offset,
                              hsize_t total, const ParallelContext& context) {
  const auto a = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), a_field);
  const auto b = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), b_field);
  h5::write_rows_in_pieces<real_t>(
      group, name, total, components, offset, static_cast<hsize_t>(count),
      [&](hsize_t k, real_t* row) { make_row(a(k), b(k), row); }, context);
}

void write_particle_field(hid_t group, const char* name, const SnapshotPressure& pressure, index_t count,
                          hsize_t offset, hsize_t total, const ParallelContext& context) {
  const real_t gamma = pressure.gamma;
  write_rows_of_two_fields(
      group, name, 1, pressure.density, pressure.specific_energy,
      [gamma](real_t rho, real_t e, real_t* row) { row[0] = perfect_gas_pressure(gamma, rho, e); }, count, offset,
      total, context);
}

// A particle vector from its two fields: rows [x, y, 0 ...].
void write_particle_vectors(hid_t group, const char* name, hsize_t components, const RealView& x_field,
                            const RealView& y_field, index_t count, hsize_t offset, hsize_t total,
                            const ParallelContext& context) {
  write_rows_of_two_fields(
      group, name, components, x_field, y_field,
      [components](real_t x, real_t y, real_t* row) {
        row[0] = x;
        row[1] = y;
        for (hsize_t c = 2; c < components; ++c) row[c] = 0;
      },
      count, offset, total, context);
}

}  // namespace

SnapshotWriter::SnapshotWriter(std::string directory, std::string case_name, const ParallelContext& context,
                               std::string run_id)
    : directory_(std::move(directory)), case_name_(std::move(case_name)), run_id_(std::move(run_id)), context_(context) {
  h5::require_parallel_if_distributed(context_);
  if (context_.is_root()) create_output_directory(directory_);
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
                                  const ConservationTotals& totals, const BoundaryFluxes& fluxes,
                                  const DiagnosticColumns& extra) {
  const NodeFieldsView projection = solver.grid_projection();
  const std::string name = file_name(index);
  const std::string path = directory_ + "/" + name;
  const ParticleState& pt = solver.particles();
  const GridSlab& slab = solver.slab();
  const index_t n = pt.count;
  const hsize_t offset = static_cast<hsize_t>(context_.exclusive_prefix_sum(n));
  const hsize_t total = static_cast<hsize_t>(context_.sum(n));

  h5::write_file_safely(path, context_, [&](hid_t file) {
    h5::write_attribute(file, "time", time);
    h5::write_attribute(file, "step", static_cast<double>(step));
    h5::write_attribute(file, "num_ranks", static_cast<double>(context_.size()));
    h5::write_string_attribute(file, "case", case_name_);
    h5::write_string_attribute(file, "run_id", run_id_);
    h5::write_string_attribute(file, "mpmflow_build", build_identity());
    // The case as it ran (mpmflow case prints the same): what produced this file.
    h5::write_string_attribute(file, "effective_case", effective_case_json(solver.config()));
    h5::write_string_attribute(file, "layout",
                               "particles: one 1D dataset per scalar field, position (N, 2) [x, y], velocity "
                               "(N, 3) [vx, vy, 0], vertices (N) 0..N-1; grid: node arrays of nodes_x x nodes_y "
                               "(attributes) flattened with x fastest, physical nodes only, velocity (nodes, 3); grid "
                               "fields are the particles' mass-weighted averages on the nodes, mass their sum");

    {
      Handle diag(H5Gcreate2(file, "diagnostics", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                  "create group diagnostics");
      totals.for_each_total([&](const char* name, double value) { h5::write_attribute(diag, name, value); });
      h5::write_attribute(diag, "total_energy", totals.total_energy());
      fluxes.for_each_flux([&](const std::string& name, double value) { h5::write_attribute(diag, name.c_str(), value); });
      for (const auto& column : extra) h5::write_attribute(diag, column.first.c_str(), column.second);
    }

    if (!solver.config().obstacles.empty()) {
      // Each obstacle's outline, for plots: a closed polyline (M, 2) [x, y] (a circle sampled at
      // 360 points, a polygon's vertices), and its reference length.
      Handle group(H5Gcreate2(file, "obstacles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                   "create group obstacles");
      const std::vector<ObstacleConfig>& obstacles = solver.config().obstacles;
      for (size_t k = 0; k < obstacles.size(); ++k) {
        const ObstacleConfig& o = obstacles[k];
        std::vector<double> outline;
        if (o.shape == ObstacleShape::circle) {
          for (const Point& p : circle_outline(o.centre_x, o.centre_y, o.radius, 360)) {
            outline.push_back(p.x);
            outline.push_back(p.y);
          }
        } else {
          for (size_t v = 0; v < o.vertices_x.size(); ++v) {
            outline.push_back(o.vertices_x[v]);
            outline.push_back(o.vertices_y[v]);
          }
        }
        const std::string name = "outline_" + std::to_string(k);
        const hsize_t m = outline.size() / 2;
        h5::write_block(group, name.c_str(), {m, 2}, {0, 0}, {context_.is_root() ? m : 0, 2}, outline.data(), context_);
        h5::write_attribute(group, ("reference_length_" + std::to_string(k)).c_str(), o.reference_length);
      }
    }

    {
      Handle group(H5Gcreate2(file, "particles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                   "create group particles");
      // The positions (N, 2) and the velocities (N, 3, z = 0), and the vertices, made piece by piece.
      write_particle_vectors(group, "position", 2, pt.position_x, pt.position_y, n, offset, total, context_);
      write_particle_vectors(group, "velocity", 3, pt.velocity_x, pt.velocity_y, n, offset, total, context_);
      // Particle k is vertex cell k: without cells, ParaView's XDMF 3 reader shows no particles.
      h5::write_rows_in_pieces<long long>(
          group, "vertices", total, 1, offset, static_cast<hsize_t>(n),
          [&](hsize_t k, long long* row) { row[0] = static_cast<long long>(offset + k); }, context_);
      for_each_snapshot_particle_field(pt, solver.config().physics.gamma, [&](const char* name, const auto& field) {
        write_particle_field(group, name, field, n, offset, total, context_);
      });
    }

    {
      // Grid: the nodes this slab owns (each node of the domain is written by one rank).
      const GridGeometry& geo = slab.geometry;
      const IndexRange2D owned = slab.index_space(Ownership::owned, Entity::node, Indexing::global);
      const index_t nx = owned.extent_x(), ny = owned.extent_y();
      auto state = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), projection);
      const real_t threshold = solver.node_mass_threshold(), gamma = solver.config().physics.gamma;
      // The k-th node the slab owns (x fastest) as the datasets read it.
      const auto sample = [&](hsize_t k) {
        const index_t i = static_cast<index_t>(k % static_cast<hsize_t>(nx));
        const index_t j = static_cast<index_t>(k / static_cast<hsize_t>(nx));
        const index_t node = geo.node_index(slab.local_node_x(owned.begin_x + i), slab.local_node_y(owned.begin_y + j));
        return NodeSample{state(node, GridFields::projected_mass),
                          state(node, GridFields::projected_momentum_x),
                          state(node, GridFields::projected_momentum_y),
                          state(node, GridFields::projected_mass_density),
                          state(node, GridFields::projected_mass_pressure),
                          state(node, GridFields::projected_mass_energy),
                          threshold,
                          gamma};
      };
      Handle group(H5Gcreate2(file, "grid", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                   "create group grid");
      // Flat node arrays (x fastest), as XDMF readers without co-rectilinear meshes (meshio) need
      // them; nodes_x and nodes_y give the 2D shape. Each made piece by piece from the projection:
      // the tables made whole first had held 64 B a node while the file was built.
      const hsize_t global_x = static_cast<hsize_t>(slab.global_cells_x + 1);
      const hsize_t global_nodes = global_x * static_cast<hsize_t>(slab.global_cells_y + 1);
      const hsize_t first = static_cast<hsize_t>(owned.begin_x) + global_x * static_cast<hsize_t>(owned.begin_y);
      const auto write_nodes = [&](const char* name, hsize_t components, const auto& values) {
        h5::write_rectangle_in_pieces<real_t>(group, name, global_nodes, components, first, static_cast<hsize_t>(nx),
                                              static_cast<hsize_t>(ny), global_x,
                                              [&](hsize_t k, real_t* row) { values(sample(k), row); }, context_);
      };
      for (const GridSnapshotField& field : grid_snapshot_fields)
        write_nodes(field.name, 1, [&](const NodeSample& node, real_t* row) { row[0] = field.value(node); });
      write_nodes("velocity", 3, [](const NodeSample& node, real_t* row) {
        row[0] = node.average(node.momentum_x);
        row[1] = node.average(node.momentum_y);
        row[2] = 0;
      });
      h5::write_attribute(group, "nodes_x", static_cast<double>(slab.global_cells_x + 1));
      h5::write_attribute(group, "nodes_y", static_cast<double>(slab.global_cells_y + 1));
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
  }, {}, /*expected_bytes=*/8.0 * (11.0 * double(total) + 9.0 * double(slab.global_cells_x + 1) * (slab.global_cells_y + 1)));

  records_.push_back({name, time, static_cast<long>(total)});
  if (context_.is_root()) {
    if (!std::filesystem::exists(directory_ + "/" + mesh_file_name())) write_mesh_file();
    write_xdmf(pt);
  }
  return path;
}

namespace {

const char* const xdmf_header = "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n";
const char* const xdmf_footer = " </Domain>\n</Xdmf>\n";

// <DataItem> of an HDF5 dataset.
std::string hdf_item(const std::string& dimensions, const char* number_type, size_t precision,
                     const std::string& file, const std::string& path) {
  std::ostringstream item;
  item << "<DataItem Dimensions=\"" << dimensions << "\" NumberType=\"" << number_type << "\" Precision=\""
       << precision << "\" Format=\"HDF\">" << file << ":" << path << "</DataItem>";
  return item.str();
}

std::string attribute(const std::string& indent, const char* name, const char* type, const std::string& item) {
  return indent + "<Attribute Name=\"" + name + "\" AttributeType=\"" + type + "\" Center=\"Node\">\n" + indent +
         " " + item + "\n" + indent + "</Attribute>\n";
}

}  // namespace

// The particles of one snapshot as an XDMF uniform grid: vertex cells, the (x, y) geometry, the
// velocity vector and the scalar fields. `time` < 0 leaves out the <Time> element (meshio reads
// a file of one grid without one).
std::string SnapshotWriter::particles_grid_xml(const Record& r, const ParticleState& particles, bool with_time,
                                               const std::string& indent) const {
  const size_t real_size = sizeof(real_t);
  const std::string n = std::to_string(r.num_particles);
  std::ostringstream xml;
  xml << std::setprecision(15) << indent << "<Grid Name=\"particles\" GridType=\"Uniform\">\n";
  if (with_time) xml << indent << " <Time Value=\"" << r.time << "\"/>\n";
  xml << indent << " <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n << "\" NodesPerElement=\"1\">\n"
      << indent << "  " << hdf_item(n, "Int", 8, r.file, "/particles/vertices") << "\n"
      << indent << " </Topology>\n"
      << indent << " <Geometry GeometryType=\"XY\">\n"
      << indent << "  " << hdf_item(n + " 2", "Float", real_size, r.file, "/particles/position") << "\n"
      << indent << " </Geometry>\n";
  xml << attribute(indent + " ", "velocity", "Vector", hdf_item(n + " 3", "Float", real_size, r.file, "/particles/velocity"));
  for_each_snapshot_particle_field(particles, real_t(0), [&](const char* field, const auto& values) {
    using Value = typename std::decay_t<decltype(values)>::non_const_value_type;
    xml << attribute(indent + " ", field, "Scalar",
                     hdf_item(n, xdmf_number_type<Value>(), sizeof(Value), r.file, std::string("/particles/") + field));
  });
  xml << indent << "</Grid>\n";
  return xml.str();
}

// The grid of one snapshot. On a 3D co-rectilinear mesh one node thick, the (ny, nx) node arrays
// read as (z, y, x) = (1, ny, nx): ParaView and VisIt put it in the XY plane (a 2DCoRectMesh,
// read as (y, z), put it in the YZ plane, away from the particles). meshio knows no co-rectilinear
// mesh: `explicit_mesh` gives the nodes' coordinates and quadrilateral cells from the mesh file.
std::string SnapshotWriter::grid_grid_xml(const Record& r, bool explicit_mesh, const std::string& indent) const {
  const size_t real_size = sizeof(real_t);
  const std::string ny = std::to_string(grid_nodes_y_), nx = std::to_string(grid_nodes_x_);
  const std::string nodes = std::to_string(grid_nodes_x_ * grid_nodes_y_);
  const std::string cells = std::to_string((grid_nodes_x_ - 1) * (grid_nodes_y_ - 1));
  std::ostringstream xml;
  xml << std::setprecision(15) << indent << "<Grid Name=\"grid\" GridType=\"Uniform\">\n";
  std::string scalar_dims = "1 " + ny + " " + nx, vector_dims = "1 " + ny + " " + nx + " 3";
  if (explicit_mesh) {
    scalar_dims = nodes;
    vector_dims = nodes + " 3";
    xml << indent << " <Topology TopologyType=\"Quadrilateral\" NumberOfElements=\"" << cells << "\">\n"
        << indent << "  " << hdf_item(cells + " 4", "Int", 8, mesh_file_name(), "/cells") << "\n"
        << indent << " </Topology>\n"
        << indent << " <Geometry GeometryType=\"XY\">\n"
        << indent << "  " << hdf_item(nodes + " 2", "Float", 8, mesh_file_name(), "/points") << "\n"
        << indent << " </Geometry>\n";
  } else {
    xml << indent << " <Time Value=\"" << r.time << "\"/>\n"
        << indent << " <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"" << scalar_dims << "\"/>\n"
        << indent << " <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
        << indent << "  <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">0 "
        << grid_origin_y_ << " " << grid_origin_x_ << "</DataItem>\n"
        << indent << "  <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">1 "
        << grid_spacing_y_ << " " << grid_spacing_x_ << "</DataItem>\n"
        << indent << " </Geometry>\n";
  }
  xml << attribute(indent + " ", "velocity", "Vector", hdf_item(vector_dims, "Float", real_size, r.file, "/grid/velocity"));
  for (const GridSnapshotField& field : grid_snapshot_fields)
    xml << attribute(indent + " ", field.name, "Scalar",
                     hdf_item(scalar_dims, "Float", real_size, r.file, std::string("/grid/") + field.name));
  xml << indent << "</Grid>\n";
  return xml.str();
}

std::string SnapshotWriter::mesh_file_name() const { return case_name_ + "_grid_mesh.h5"; }

void SnapshotWriter::write_mesh_file() const {
  // The nodes' coordinates (x fastest, as the node arrays) and the cells' four nodes
  // counter-clockwise, for readers without co-rectilinear meshes; written by rank 0 alone.
  const std::string path = directory_ + "/" + mesh_file_name();
  std::vector<double> points;
  std::vector<long long> cells;
  points.reserve(static_cast<size_t>(2 * grid_nodes_x_ * grid_nodes_y_));
  for (long j = 0; j < grid_nodes_y_; ++j)
    for (long i = 0; i < grid_nodes_x_; ++i) {
      points.push_back(grid_origin_x_ + i * grid_spacing_x_);
      points.push_back(grid_origin_y_ + j * grid_spacing_y_);
    }
  for (long j = 0; j + 1 < grid_nodes_y_; ++j)
    for (long i = 0; i + 1 < grid_nodes_x_; ++i) {
      const long long a = i + grid_nodes_x_ * j;
      cells.insert(cells.end(), {a, a + 1, a + 1 + grid_nodes_x_, a + grid_nodes_x_});
    }
  const ParallelContext alone = ParallelContext::self();  // this rank alone: plain (serial) HDF5 access
  h5::write_file_safely(path, alone, [&](hid_t file) {
    const hsize_t num_points = static_cast<hsize_t>(points.size() / 2), num_cells = static_cast<hsize_t>(cells.size() / 4);
    h5::write_string_attribute(file, "run_id", run_id_);
    h5::write_block(file, "points", {num_points, 2}, {0, 0}, {num_points, 2}, points.data(), alone);
    h5::write_block(file, "cells", {num_cells, 4}, {0, 0}, {num_cells, 4}, cells.data(), alone);
  });
}

void SnapshotWriter::write_xdmf(const ParticleState& particles) const {
  // The time series that ParaView and VisIt open.
  std::ostringstream particles_series, grid_series;
  particles_series << xdmf_header << "  <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  grid_series << xdmf_header << "  <Grid Name=\"grid\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const Record& r : records_) {
    particles_series << particles_grid_xml(r, particles, /*with_time=*/true, "   ");
    grid_series << grid_grid_xml(r, /*explicit_mesh=*/false, "   ");
  }
  particles_series << "  </Grid>\n" << xdmf_footer;
  grid_series << "  </Grid>\n" << xdmf_footer;
  write_file_atomically(particles_xdmf_path(), particles_series.str());
  write_file_atomically(grid_xdmf_path(), grid_series.str());
  // The latest snapshot alone, one grid per file, as meshio reads XDMF.
  const Record& latest = records_.back();
  const std::string stem = directory_ + "/" + latest.file.substr(0, latest.file.size() - 3);
  write_file_atomically(stem + "_particles.xmf",
                        xdmf_header + particles_grid_xml(latest, particles, /*with_time=*/false, "  ") + xdmf_footer);
  write_file_atomically(stem + "_grid.xmf", xdmf_header + grid_grid_xml(latest, /*explicit_mesh=*/true, "  ") + xdmf_footer);
}
#endif

}  // namespace mpmflow
