#pragma once
// Small HDF5 helpers shared by snapshots and checkpoints. One file is written (or read) by all
// ranks together: with MPI-IO and collective transfers when the run is distributed, so each rank
// writes its own block of every dataset and the file looks the same whatever the rank count.
#ifdef MPMFLOW_HAVE_HDF5
#include <hdf5.h>

#include <algorithm>
#include <cstdint>
#include <functional>
#include <string>
#include <type_traits>
#include <vector>

#include "parallel.hpp"

namespace mpmflow {
namespace h5 {

// HDF5's own reason for the last failed call ("No space left on device", "file signature not
// found"), from its error stack: the innermost entry's description. Empty when there is none.
std::string error_reason();

// HDF5 prints its error stack to stderr by default (8 to 1300 lines for one failure): off; its
// reason goes into the one-line errors mpmflow raises (error_reason).
void silence_error_printing();

// "HDF5: <what> failed[: <reason>]".
inline std::string failure(const std::string& what) {
  const std::string reason = error_reason();
  return "HDF5: " + what + " failed" + (reason.empty() ? "" : ": " + reason);
}

// Closes an HDF5 handle when it goes out of scope, and turns a failed call into an exception.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t), const std::string& what) : id_(id), close_(close) {
    if (id_ < 0) throw std::runtime_error(failure(what));
  }
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  operator hid_t() const { return id_; }
  // Closes now, checked: closing a file writes what HDF5 still holds of it, which can fail.
  void close(const std::string& what) {
    const herr_t status = close_(id_);
    id_ = -1;
    if (status < 0) throw std::runtime_error(failure(what));
  }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

// Writes the HDF5 file `path` of all ranks of `context` so that nothing is lost: `fill` writes its
// content into a temporary `path`.tmp, which is closed (checked), flushed to disk, checked by
// `verify` (rank 0 alone, given the temporary's path; optional), and renamed into place. A failure
// on any rank removes the temporary and throws CollectiveError on every rank, naming the file and
// the reason; the files written before are untouched. Collective.
//
// Across ranks the file is written through MPI-IO, where a write that fails on one rank can leave
// the others waiting: there, `expected_bytes` (the datasets' size) is checked against the free
// space first, and a file that would not fit is refused before anything is written.
void write_file_safely(const std::string& path, const ParallelContext& context,
                       const std::function<void(hid_t file)>& fill,
                       const std::function<void(const std::string& temporary)>& verify = {},
                       double expected_bytes = 0);

// Opens `path` read-only on this rank alone (a check of a file just written).
inline hid_t open_file_here(const std::string& path) { return H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT); }

template <class T>
hid_t type_of() {
  if (std::is_same<T, double>::value) return H5T_NATIVE_DOUBLE;
  if (std::is_same<T, float>::value) return H5T_NATIVE_FLOAT;
  if (std::is_same<T, std::int64_t>::value || std::is_same<T, long long>::value) return H5T_NATIVE_INT64;
  return H5T_NATIVE_INT;
}

// True when this HDF5 can write one file from several ranks.
constexpr bool is_parallel() {
#ifdef H5_HAVE_PARALLEL
  return true;
#else
  return false;
#endif
}

// Throws CollectiveError (on every rank) when the run is distributed and HDF5 is serial.
inline void require_parallel_if_distributed(const ParallelContext& context) {
  if (context.distributed() && !is_parallel())
    throw CollectiveError("this HDF5 library is serial, so a run on " + std::to_string(context.size()) +
                          " ranks cannot write output or checkpoints; rebuild against parallel HDF5 "
                          "(Debian: libhdf5-openmpi-dev) or set output/snapshots=0");
}

// File access for all ranks of `context`.
inline hid_t file_access(const ParallelContext& context) {
  hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
#if defined(H5_HAVE_PARALLEL) && defined(MPMFLOW_HAVE_MPI)
  if (context.distributed()) H5Pset_fapl_mpio(fapl, context.comm(), MPI_INFO_NULL);
#else
  (void)context;
#endif
  return fapl;
}

// Creates (or opens) `path` for all ranks of `context`; throws with HDF5's reason on failure
// (taken before the access list is closed, which clears HDF5's error stack).
inline hid_t create_file(const std::string& path, const ParallelContext& context) {
  const hid_t fapl = file_access(context);
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
  const std::string message = file < 0 ? failure("create " + path) : "";
  H5Pclose(fapl);
  if (file < 0) throw std::runtime_error(message);
  return file;
}

inline hid_t open_file(const std::string& path, const ParallelContext& context) {
  const hid_t fapl = file_access(context);
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl);
  const std::string message = file < 0 ? failure("open " + path) : "";
  H5Pclose(fapl);
  if (file < 0) throw std::runtime_error(message);
  return file;
}

inline hid_t transfer(const ParallelContext& context) {
  hid_t dxpl = H5Pcreate(H5P_DATASET_XFER);
#if defined(H5_HAVE_PARALLEL) && defined(MPMFLOW_HAVE_MPI)
  if (context.distributed()) H5Pset_dxpl_mpio(dxpl, H5FD_MPIO_COLLECTIVE);
#else
  (void)context;
#endif
  return dxpl;
}

// Dataset `name` of `global_dims`; this rank writes the block at `offset` of size `block`
// (possibly empty). Collective.
template <class T>
void write_block(hid_t parent, const char* name, const std::vector<hsize_t>& global_dims,
                 const std::vector<hsize_t>& offset, const std::vector<hsize_t>& block, const T* data,
                 const ParallelContext& context) {
  const int rank = static_cast<int>(global_dims.size());
  Handle file_space(H5Screate_simple(rank, global_dims.data(), nullptr), H5Sclose, std::string("dataspace of ") + name);
  Handle set(H5Dcreate2(parent, name, type_of<T>(), file_space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose,
             std::string("create dataset ") + name);
  hsize_t elements = 1;
  for (hsize_t b : block) elements *= b;
  Handle memory_space(H5Screate_simple(rank, block.data(), nullptr), H5Sclose, "memory dataspace");
  if (elements == 0) {
    H5Sselect_none(file_space);
    H5Sselect_none(memory_space);
  } else {
    H5Sselect_hyperslab(file_space, H5S_SELECT_SET, offset.data(), nullptr, block.data(), nullptr);
  }
  Handle dxpl(transfer(context), H5Pclose, "transfer list");
  if (H5Dwrite(set, type_of<T>(), memory_space, file_space, dxpl, data) < 0)
    throw std::runtime_error(failure(std::string("write dataset ") + name));
}

// Dataset `name` of `global_rows` rows of `components` values (1: a 1D dataset), holding a 2D
// array of rows `row_length` long flattened row after row; this rank writes a rectangle of it:
// `num_runs` runs of `run_length` rows from row `first`, one run every `row_length` rows (x
// fastest). The k-th row of the rectangle (k from 0, run after run) is made by row(k, values),
// through a buffer of at most `piece_rows` rows (whole runs, at least one), piece after piece: a
// table made from several fields (the particles' positions, the grid's averages) is never copied
// out whole. Each rank writes as many pieces as the rank with the most (the others' last are
// empty): the writes are collective.
template <class T, class RowValues>
void write_rectangle_in_pieces(hid_t parent, const char* name, hsize_t global_rows, hsize_t components,
                               hsize_t first, hsize_t run_length, hsize_t num_runs, hsize_t row_length,
                               const RowValues& row, const ParallelContext& context, hsize_t piece_rows = 1 << 16) {
  const int rank = components > 1 ? 2 : 1;
  const hsize_t global_dims[2] = {global_rows, components};
  Handle file_space(H5Screate_simple(rank, global_dims, nullptr), H5Sclose, std::string("dataspace of ") + name);
  Handle set(H5Dcreate2(parent, name, type_of<T>(), file_space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose,
             std::string("create dataset ") + name);
  Handle dxpl(transfer(context), H5Pclose, "transfer list");
  if (run_length == 0) num_runs = 0;
  const hsize_t runs_a_piece = std::max<hsize_t>(1, piece_rows / std::max<hsize_t>(1, run_length));
  const double my_pieces = double((num_runs + runs_a_piece - 1) / runs_a_piece);
  const hsize_t pieces = static_cast<hsize_t>(context.max(my_pieces));
  std::vector<T> buffer(
      static_cast<size_t>(std::max<hsize_t>(1, std::min(num_runs, runs_a_piece) * run_length) * components));
  for (hsize_t piece = 0; piece < pieces; ++piece) {
    const hsize_t run_begin = std::min(num_runs, piece * runs_a_piece);
    const hsize_t run_end = std::min(num_runs, run_begin + runs_a_piece);
    const hsize_t elements[2] = {(run_end - run_begin) * run_length, components};
    Handle memory_space(H5Screate_simple(rank, elements, nullptr), H5Sclose, "memory dataspace");
    if (elements[0] == 0) {
      H5Sselect_none(file_space);
      H5Sselect_none(memory_space);
    } else {
      const hsize_t k_begin = run_begin * run_length;
      for (hsize_t k = k_begin; k < run_end * run_length; ++k)
        row(k, &buffer[static_cast<size_t>((k - k_begin) * components)]);
      // (Runs that follow each other, as rows of one value each do, HDF5 takes as one block.)
      const hsize_t start[2] = {first + run_begin * row_length, 0}, stride[2] = {row_length, 1},
                    count[2] = {run_end - run_begin, 1}, block[2] = {run_length, components};
      if (H5Sselect_hyperslab(file_space, H5S_SELECT_SET, start, stride, count, block) < 0)
        throw std::runtime_error(failure(std::string("select rows of dataset ") + name));
    }
    if (H5Dwrite(set, type_of<T>(), memory_space, file_space, dxpl, buffer.data()) < 0)
      throw std::runtime_error(failure(std::string("write dataset ") + name));
  }
}

// The same for consecutive rows (runs of one row, one a row): this rank writes rows [first, first
// + count), row k's values (k from 0) made by row(k, values).
template <class T, class RowValues>
void write_rows_in_pieces(hid_t parent, const char* name, hsize_t global_rows, hsize_t components, hsize_t first,
                          hsize_t count, const RowValues& row, const ParallelContext& context,
                          hsize_t piece_rows = 1 << 16) {
  write_rectangle_in_pieces<T>(parent, name, global_rows, components, first, 1, count, 1, row, context, piece_rows);
}

// A dataset written whole by every rank alike (small: attributes-like arrays).
template <class T>
void write_replicated(hid_t parent, const char* name, const std::vector<T>& values, const ParallelContext& context) {
  const std::vector<hsize_t> dims = {values.size()};
  const bool root = context.is_root();
  write_block(parent, name, dims, {0}, {root ? values.size() : 0}, values.data(), context);
}

// Reads rows [offset, offset + count) of a 1D dataset. Collective.
template <class T>
std::vector<T> read_rows(hid_t parent, const char* name, hsize_t offset, hsize_t count, const ParallelContext& context) {
  Handle set(H5Dopen2(parent, name, H5P_DEFAULT), H5Dclose, std::string("open dataset ") + name);
  Handle file_space(H5Dget_space(set), H5Sclose, std::string("dataspace of ") + name);
  Handle memory_space(H5Screate_simple(1, &count, nullptr), H5Sclose, "memory dataspace");
  std::vector<T> values(count);
  if (count == 0) {
    H5Sselect_none(file_space);
    H5Sselect_none(memory_space);
  } else {
    H5Sselect_hyperslab(file_space, H5S_SELECT_SET, &offset, nullptr, &count, nullptr);
  }
  Handle dxpl(transfer(context), H5Pclose, "transfer list");
  if (H5Dread(set, type_of<T>(), memory_space, file_space, dxpl, values.data()) < 0)
    throw std::runtime_error(failure(std::string("read dataset ") + name));
  return values;
}

inline hsize_t dataset_length(hid_t parent, const char* name) {
  Handle set(H5Dopen2(parent, name, H5P_DEFAULT), H5Dclose, std::string("open dataset ") + name);
  Handle space(H5Dget_space(set), H5Sclose, std::string("dataspace of ") + name);
  hsize_t dims[2] = {0, 0};
  H5Sget_simple_extent_dims(space, dims, nullptr);
  return dims[0];
}

inline void write_attribute(hid_t parent, const char* name, double value) {
  Handle space(H5Screate(H5S_SCALAR), H5Sclose, "scalar dataspace");
  Handle attr(H5Acreate2(parent, name, H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
              std::string("create attribute ") + name);
  if (H5Awrite(attr, H5T_NATIVE_DOUBLE, &value) < 0) throw std::runtime_error(failure(std::string("write attribute ") + name));
}

inline void write_string_attribute(hid_t parent, const char* name, const std::string& value) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose, "string type");
  H5Tset_size(type, value.size() + 1);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose, "scalar dataspace");
  Handle attr(H5Acreate2(parent, name, type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
              std::string("create attribute ") + name);
  if (H5Awrite(attr, type, value.c_str()) < 0) throw std::runtime_error(failure(std::string("write attribute ") + name));
}

inline double read_attribute(hid_t parent, const char* name) {
  Handle attr(H5Aopen(parent, name, H5P_DEFAULT), H5Aclose, std::string("open attribute ") + name);
  double value = 0;
  if (H5Aread(attr, H5T_NATIVE_DOUBLE, &value) < 0) throw std::runtime_error(failure(std::string("read attribute ") + name));
  return value;
}

inline std::string read_string_attribute(hid_t parent, const char* name) {
  Handle attr(H5Aopen(parent, name, H5P_DEFAULT), H5Aclose, std::string("open attribute ") + name);
  Handle type(H5Aget_type(attr), H5Tclose, "attribute type");
  std::string value(H5Tget_size(type), '\0');
  if (H5Aread(attr, type, &value[0]) < 0) throw std::runtime_error(failure(std::string("read attribute ") + name));
  return value.substr(0, value.find('\0'));
}

}  // namespace h5
}  // namespace mpmflow
#endif
