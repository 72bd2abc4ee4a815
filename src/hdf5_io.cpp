#include "hdf5_io.hpp"

#ifdef MPMFLOW_HAVE_HDF5
#include <fcntl.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <vector>

namespace mpmflow {
namespace h5 {
namespace {

// The walk goes from the API call down to the failing system call; the last entry names the
// cause ("... errno = 28, error message = 'No space left on device' ...").
herr_t innermost_description(unsigned, const H5E_error2_t* error, void* reason) {
  if (error->desc && *error->desc) *static_cast<std::string*>(reason) = error->desc;
  return 0;
}

// Flushes a written file (or a directory: the rename in it) to the disk: a rename must not reach
// the disk before the data it names.
void flush_to_disk(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) throw std::runtime_error("cannot open " + path + " to flush it: " + std::strerror(errno));
  const int status = ::fsync(fd);
  const int error = errno;
  ::close(fd);
  // A directory on a file system that cannot sync directories answers EINVAL: nothing to do there.
  if (status != 0 && error != EINVAL) throw std::runtime_error("cannot flush " + path + " to disk: " + std::strerror(error));
}

// The error of the lowest rank that has one, on every rank (empty when none has). Collective.
std::string first_error(const std::string& error, const ParallelContext& context) {
  const std::vector<long long> failed = context.all_gather(error.empty() ? 0 : 1);
  for (int rank = 0; rank < context.size(); ++rank) {
    if (!failed[static_cast<size_t>(rank)]) continue;
    std::string message = error;
    context.broadcast(message, rank);
    if (context.distributed()) message = "rank " + std::to_string(rank) + ": " + message;
    return message;
  }
  return "";
}

// Writes `size` bytes to `path` (created or truncated), every call checked.
void write_bytes(const std::string& path, const char* data, size_t size) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) throw std::runtime_error("cannot create " + path + ": " + std::strerror(errno));
  for (size_t done = 0; done < size;) {
    const ssize_t n = ::write(fd, data + done, size - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int error = errno;
      ::close(fd);
      throw std::runtime_error("cannot write " + path + ": " + std::strerror(error));
    }
    done += static_cast<size_t>(n);
  }
  if (::close(fd) != 0) throw std::runtime_error("cannot close " + path + ": " + std::strerror(errno));
}

// The memory of HDF5's core driver, held here through its file image callbacks, so that the
// finished file is written to disk straight from it. The driver grows it by realloc and frees it
// when the file closes: it is freed with this object instead, after the file is closed. (A core
// file created without an initial image calls no other callback; the others are HDF5's defaults.)
struct CoreImage {
  void* memory = nullptr;
  size_t size = 0;  // bytes held
  H5FD_file_image_callbacks_t callbacks{};

  CoreImage() {
    callbacks.image_malloc = [](size_t bytes, H5FD_file_image_op_t, void* self) {
      return static_cast<CoreImage*>(self)->resize(nullptr, bytes);
    };
    callbacks.image_realloc = [](void* block, size_t bytes, H5FD_file_image_op_t, void* self) {
      return static_cast<CoreImage*>(self)->resize(block, bytes);
    };
    callbacks.image_free = [](void* block, H5FD_file_image_op_t, void* self) -> herr_t {
      if (block != static_cast<CoreImage*>(self)->memory) std::free(block);  // (not the driver's: not ours to keep)
      return 0;
    };
    // The property lists copy the callbacks' user data with them: the same object throughout.
    callbacks.udata_copy = [](void* self) { return self; };
    callbacks.udata_free = [](void*) -> herr_t { return 0; };
    callbacks.udata = this;
  }
  ~CoreImage() { std::free(memory); }
  CoreImage(const CoreImage&) = delete;
  CoreImage& operator=(const CoreImage&) = delete;

  void* resize(void* block, size_t bytes) {
    // (Never to 0 bytes: realloc would free the block and answer null, which HDF5 takes for a
    // failure, and `memory` would name freed memory.)
    void* resized = std::realloc(block, bytes > 0 ? bytes : 1);
    if (!resized) return nullptr;  // (HDF5 reports the failed allocation; `memory` is still valid)
    memory = resized;
    size = bytes;
    return resized;
  }
};

}  // namespace

std::string error_reason() {
  std::string reason;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, innermost_description, &reason);
  // A system call's failure: its message alone ("No space left on device").
  const std::string marker = "error message = '";
  const size_t start = reason.find(marker);
  if (start != std::string::npos) {
    const size_t end = reason.find('\'', start + marker.size());
    return reason.substr(start + marker.size(), end == std::string::npos ? std::string::npos : end - start - marker.size());
  }
  // Otherwise its first line.
  const size_t first = reason.find_first_not_of("\n ,");
  if (first == std::string::npos) return "";
  return reason.substr(first, reason.find('\n', first) == std::string::npos ? std::string::npos
                                                                              : reason.find('\n', first) - first);
}

void silence_error_printing() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

void write_file_safely(const std::string& path, const ParallelContext& context,
                       const std::function<void(hid_t file)>& fill,
                       const std::function<void(const std::string& temporary)>& verify, double expected_bytes) {
  const std::string temporary = path + ".tmp";
  std::string error;
  if (context.distributed() && expected_bytes > 0) {
    // 10 % and 1 MB more than the datasets, for HDF5's own structures.
    if (context.is_root()) {
      const std::string directory =
          std::filesystem::path(path).parent_path().empty() ? "." : std::filesystem::path(path).parent_path().string();
      struct statvfs space {};
      if (::statvfs(directory.c_str(), &space) == 0) {
        const double free_bytes = double(space.f_bavail) * double(space.f_frsize);
        const double needed = 1.1 * expected_bytes + 1e6;
        if (free_bytes < needed)
          error = "not enough free space in " + directory + ": about " + std::to_string(static_cast<long long>(needed)) +
                  " bytes needed, " + std::to_string(static_cast<long long>(free_bytes)) + " free (" +
                  std::strerror(ENOSPC) + ")";
      }
    }
    context.broadcast(error);
    if (!error.empty()) throw CollectiveError("writing " + path + " failed (earlier files are kept): " + error);
  }
  if (!context.distributed()) {
    // One rank: the file is built in memory (HDF5's core driver) and written with plain, checked
    // system calls. A full disk is then an error of write(2), never one of HDF5's own closing
    // writes, which leave HDF5 holding a broken file that it crashes on at exit.
    try {
      CoreImage image;
      const hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
      H5Pset_fapl_core(fapl, 1 << 20, /*backing_store=*/0);
      const herr_t kept = H5Pset_file_image_callbacks(fapl, &image.callbacks);
      const hid_t created = kept < 0 ? -1 : H5Fcreate(temporary.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
      const std::string message = created < 0 ? failure("create " + temporary + " in memory") : "";
      H5Pclose(fapl);
      if (created < 0) throw std::runtime_error(message);
      Handle file(created, H5Fclose, "create " + temporary);
      fill(file);
      if (H5Fflush(file, H5F_SCOPE_GLOBAL) < 0) throw std::runtime_error(failure("flush " + temporary));
      // The file's length; closed, its bytes are the first `size` of the driver's memory, the same
      // as H5Fget_file_image copies out of the open file (whose copy had held a second image of the
      // file, as large as the particles' fields, while the first was still held).
      const ssize_t size = H5Fget_file_image(file, nullptr, 0);
      if (size < 0) throw std::runtime_error(failure("image of " + temporary));
      file.close("close " + temporary);
      if (static_cast<size_t>(size) > image.size)
        throw std::runtime_error("HDF5: image of " + temporary + ": " + std::to_string(size) + " bytes, of which " +
                                 std::to_string(image.size) + " held");
      write_bytes(temporary, static_cast<const char*>(image.memory), static_cast<size_t>(size));
    } catch (const std::exception& e) {
      error = e.what();
    }
  } else {
    hid_t file = -1;
    try {
      file = create_file(temporary, context);
      fill(file);
      const herr_t closed = H5Fclose(file);
      file = -1;
      if (closed < 0) throw std::runtime_error(failure("close " + temporary));
    } catch (const std::exception& e) {
      error = e.what();
    }
    if (file >= 0) H5Fclose(file);
  }
  error = first_error(error, context);
  if (error.empty() && context.is_root()) {
    try {
      flush_to_disk(temporary);
      if (verify) verify(temporary);
      std::filesystem::rename(temporary, path);
      flush_to_disk(std::filesystem::path(path).parent_path().empty() ? "."
                                                                      : std::filesystem::path(path).parent_path().string());
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  context.broadcast(error);
  if (error.empty()) return;
  if (context.is_root()) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
  }
  throw CollectiveError("writing " + path + " failed (earlier files are kept): " + error);
}

}  // namespace h5
}  // namespace mpmflow
#endif
