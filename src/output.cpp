#include "output.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#ifdef MPMFLOW_HAVE_HDF5
#include <hdf5.h>
#endif

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

void DiagnosticsLog::append(long step, double time, const ConservationTotals& t) {
  if (text_.empty())
    text_ = "step,time,mass,momentum_x,momentum_y,kinetic_energy,internal_energy,total_energy\n";
  std::ostringstream line;
  line << std::setprecision(17) << step << ',' << time << ',' << t.mass << ',' << t.momentum_x << ','
       << t.momentum_y << ',' << t.kinetic_energy << ',' << t.internal_energy << ',' << t.total_energy() << '\n';
  text_ += line.str();
  write_file_atomically(path_, text_);
}

#ifdef MPMFLOW_HAVE_HDF5
namespace {

// Closes an HDF5 handle when it goes out of scope, and turns a failed call into an exception.
class H5Handle {
 public:
  H5Handle(hid_t id, herr_t (*close)(hid_t), const std::string& what) : id_(id), close_(close) {
    if (id_ < 0) throw std::runtime_error("HDF5: " + what + " failed");
  }
  ~H5Handle() { close_(id_); }
  H5Handle(const H5Handle&) = delete;
  H5Handle& operator=(const H5Handle&) = delete;
  operator hid_t() const { return id_; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

template <class T>
hid_t h5_type() {
  if (std::is_same<T, double>::value) return H5T_NATIVE_DOUBLE;
  if (std::is_same<T, float>::value) return H5T_NATIVE_FLOAT;
  if (std::is_same<T, std::int64_t>::value) return H5T_NATIVE_INT64;
  return H5T_NATIVE_INT;
}

template <class T>
void write_dataset(hid_t parent, const char* name, const T* data, std::vector<hsize_t> dims) {
  H5Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose,
                 std::string("dataspace for ") + name);
  H5Handle set(H5Dcreate2(parent, name, h5_type<T>(), space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose,
               std::string("create dataset ") + name);
  if (H5Dwrite(set, h5_type<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    throw std::runtime_error(std::string("HDF5: write dataset ") + name + " failed");
}

void write_attribute(hid_t parent, const char* name, double value) {
  H5Handle space(H5Screate(H5S_SCALAR), H5Sclose, "scalar dataspace");
  H5Handle attr(H5Acreate2(parent, name, H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                std::string("create attribute ") + name);
  H5Awrite(attr, H5T_NATIVE_DOUBLE, &value);
}

void write_string_attribute(hid_t parent, const char* name, const std::string& value) {
  H5Handle type(H5Tcopy(H5T_C_S1), H5Tclose, "string type");
  H5Tset_size(type, value.size() + 1);
  H5Handle space(H5Screate(H5S_SCALAR), H5Sclose, "scalar dataspace");
  H5Handle attr(H5Acreate2(parent, name, type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                std::string("create attribute ") + name);
  H5Awrite(attr, type, value.c_str());
}

template <class ViewType>
void write_particle_field(hid_t group, const char* name, const ViewType& view, index_t count) {
  auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), view);
  write_dataset(group, name, host.data(), {static_cast<hsize_t>(count)});
}

}  // namespace

SnapshotWriter::SnapshotWriter(std::string directory, std::string case_name)
    : directory_(std::move(directory)), case_name_(std::move(case_name)) {
  std::filesystem::create_directories(directory_);
}

std::string SnapshotWriter::particles_xdmf_path() const { return directory_ + "/" + case_name_ + "_particles.xmf"; }
std::string SnapshotWriter::grid_xdmf_path() const { return directory_ + "/" + case_name_ + "_grid.xmf"; }

std::string SnapshotWriter::write(int index, long step, double time, Solver& solver,
                                  const ConservationTotals& totals) {
  solver.project_to_grid();
  std::ostringstream name;
  name << case_name_ << '_' << std::setw(6) << std::setfill('0') << index << ".h5";
  const std::string path = directory_ + "/" + name.str();
  const std::string temporary = path + ".tmp";
  const ParticleState& pt = solver.particles();
  const GridSlab& slab = solver.slab();
  const index_t n = pt.count;

  {
    H5Handle file(H5Fcreate(temporary.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose,
                  "create " + temporary);
    write_attribute(file, "time", time);
    write_attribute(file, "step", static_cast<double>(step));
    write_string_attribute(file, "case", case_name_);
    write_string_attribute(file, "layout",
                           "particles: one 1D dataset per field, position is (N, 2) [x, y]; "
                           "grid: (ny, nx) row-major node arrays, x fastest, physical nodes only");

    {
      H5Handle diag(H5Gcreate2(file, "diagnostics", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                    "create group diagnostics");
      write_attribute(diag, "total_mass", totals.mass);
      write_attribute(diag, "momentum_x", totals.momentum_x);
      write_attribute(diag, "momentum_y", totals.momentum_y);
      write_attribute(diag, "kinetic_energy", totals.kinetic_energy);
      write_attribute(diag, "internal_energy", totals.internal_energy);
      write_attribute(diag, "total_energy", totals.total_energy());
    }

    {
      H5Handle group(H5Gcreate2(file, "particles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                     "create group particles");
      auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.position_x);
      auto y = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), pt.position_y);
      std::vector<real_t> xy(2 * static_cast<size_t>(n));
      for (index_t k = 0; k < n; ++k) {
        xy[2 * k] = x(k);
        xy[2 * k + 1] = y(k);
      }
      write_dataset(group, "position", xy.data(), {static_cast<hsize_t>(n), 2});
      write_particle_field(group, "velocity_x", pt.velocity_x, n);
      write_particle_field(group, "velocity_y", pt.velocity_y, n);
      write_particle_field(group, "density", pt.density, n);
      write_particle_field(group, "pressure", pt.pressure, n);
      write_particle_field(group, "specific_energy", pt.specific_energy, n);
      write_particle_field(group, "mass", pt.mass, n);
      write_particle_field(group, "id", pt.id, n);
    }

    {
      // Grid: the slab's physical nodes (ghosts dropped), with nodal velocity and a nodal density
      // (node mass over the node's share of cell area: a quarter cell per adjacent cell).
      const GridGeometry& geo = slab.geometry;
      const index_t i0 = slab.local_node_x(slab.owned_cell_begin_x);
      const index_t i1 = slab.local_node_x(slab.owned_cell_end_x);
      const index_t j0 = slab.local_node_y(0);
      const index_t j1 = slab.local_node_y(slab.global_cells_y);
      const index_t nx = i1 - i0 + 1, ny = j1 - j0 + 1;
      auto state = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), solver.grid_fields().state);
      std::vector<real_t> mass(nx * ny), vx(nx * ny), vy(nx * ny), density(nx * ny);
      const real_t threshold = solver.node_mass_threshold();
      for (index_t j = 0; j < ny; ++j)
        for (index_t i = 0; i < nx; ++i) {
          const index_t node = geo.node_index(i0 + i, j0 + j);
          const index_t out = i + nx * j;
          const real_t m = state(node, GridFields::mass);
          const bool edge_x = (i0 + i == slab.local_node_x(0)) || (i0 + i == slab.local_node_x(slab.global_cells_x));
          const bool edge_y = (j == 0) || (j == ny - 1);
          const real_t area = slab.cell_area() * (edge_x ? 0.5 : 1) * (edge_y ? 0.5 : 1);
          mass[out] = m;
          vx[out] = m > threshold ? state(node, GridFields::momentum_x) / m : 0;
          vy[out] = m > threshold ? state(node, GridFields::momentum_y) / m : 0;
          density[out] = m / area;
        }
      H5Handle group(H5Gcreate2(file, "grid", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                     "create group grid");
      const std::vector<hsize_t> dims = {static_cast<hsize_t>(ny), static_cast<hsize_t>(nx)};
      write_dataset(group, "node_mass", mass.data(), dims);
      write_dataset(group, "node_velocity_x", vx.data(), dims);
      write_dataset(group, "node_velocity_y", vy.data(), dims);
      write_dataset(group, "node_density", density.data(), dims);
      grid_nodes_x_ = nx;
      grid_nodes_y_ = ny;
      grid_origin_x_ = geo.node_x(i0);
      grid_origin_y_ = geo.node_y(j0);
      grid_spacing_x_ = geo.spacing_x;
      grid_spacing_y_ = geo.spacing_y;
      write_attribute(group, "origin_x", grid_origin_x_);
      write_attribute(group, "origin_y", grid_origin_y_);
      write_attribute(group, "spacing_x", grid_spacing_x_);
      write_attribute(group, "spacing_y", grid_spacing_y_);
    }
  }
  std::filesystem::rename(temporary, path);

  records_.push_back({name.str(), time, static_cast<long>(n)});
  write_xdmf();
  return path;
}

void SnapshotWriter::write_xdmf() const {
  const char* precision = sizeof(real_t) == 8 ? "8" : "4";
  std::ostringstream particles, grid;
  const char* header =
      "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n<Xdmf Version=\"2.0\">\n <Domain>\n";
  particles << header << "  <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  grid << header << "  <Grid Name=\"grid\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const Record& r : records_) {
    particles << std::setprecision(15) << "   <Grid Name=\"particles\" GridType=\"Uniform\">\n"
              << "    <Time Value=\"" << r.time << "\"/>\n"
              << "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << r.num_particles << "\"/>\n"
              << "    <Geometry GeometryType=\"XY\">\n"
              << "     <DataItem Dimensions=\"" << r.num_particles << " 2\" NumberType=\"Float\" Precision=\""
              << precision << "\" Format=\"HDF\">" << r.file << ":/particles/position</DataItem>\n"
              << "    </Geometry>\n";
    for (const char* field : {"density", "pressure", "velocity_x", "velocity_y", "specific_energy", "mass"})
      particles << "    <Attribute Name=\"" << field << "\" AttributeType=\"Scalar\" Center=\"Node\">\n"
                << "     <DataItem Dimensions=\"" << r.num_particles << "\" NumberType=\"Float\" Precision=\""
                << precision << "\" Format=\"HDF\">" << r.file << ":/particles/" << field << "</DataItem>\n"
                << "    </Attribute>\n";
    particles << "   </Grid>\n";

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
    for (const char* field : {"node_density", "node_mass", "node_velocity_x", "node_velocity_y"})
      grid << "    <Attribute Name=\"" << field << "\" AttributeType=\"Scalar\" Center=\"Node\">\n"
           << "     <DataItem Dimensions=\"" << grid_nodes_y_ << " " << grid_nodes_x_
           << "\" NumberType=\"Float\" Precision=\"" << precision << "\" Format=\"HDF\">" << r.file << ":/grid/"
           << field << "</DataItem>\n"
           << "    </Attribute>\n";
    grid << "   </Grid>\n";
  }
  const char* footer = "  </Grid>\n </Domain>\n</Xdmf>\n";
  particles << footer;
  grid << footer;
  write_file_atomically(particles_xdmf_path(), particles.str());
  write_file_atomically(grid_xdmf_path(), grid.str());
}
#endif

}  // namespace mpmflow
