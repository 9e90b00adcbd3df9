// The raw bytes of an HDF5 file as libhdf5 addresses them, for the checks of hdf5_guard.cpp
// and hdf5_vlen.cpp that parse file structures before libhdf5 may trust them (internal to
// voxpack_core).
#pragma once

#include <hdf5.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "voxpack/core/errors.hpp"

namespace voxpack::hdf5guard::detail {

// The little-endian unsigned integer of `n` bytes at `p`.
inline std::uint64_t le(const unsigned char* p, std::size_t n) {
  std::uint64_t v = 0;
  for (std::size_t k = n; k-- > 0;) v = (v << 8) | p[k];
  return v;
}

// Releases an hid_t on scope exit.
struct Id {
  hid_t id;
  herr_t (*close)(hid_t);
  ~Id() {
    if (id >= 0) close(id);
  }
  bool ok() const { return id >= 0; }
};

// The bytes of the file an object lives in, addressed as libhdf5 addresses them.
class RawFile {
 public:
  RawFile(hid_t obj, const std::string& file) : file_(file) {
    Id f{H5Iget_file_id(obj), H5Fclose};
    Id fcpl{f.ok() ? H5Fget_create_plist(f.id) : -1, H5Pclose};
    hsize_t size = 0;
    if (!fcpl.ok() || H5Pget_sizes(fcpl.id, &sizeofAddr_, &sizeofSize_) < 0 ||
        H5Pget_userblock(fcpl.id, &base_) < 0 || H5Fget_filesize(f.id, &size) < 0)
      fail("cannot read the file's address sizes");
    if (sizeofAddr_ < 2 || sizeofAddr_ > 8 || sizeofSize_ < 2 || sizeofSize_ > 8)
      fail("unsupported HDF5 address or length size");
    size_ = size;
    const ssize_t n = H5Fget_name(f.id, nullptr, 0);
    std::string name(static_cast<std::size_t>(std::max<ssize_t>(n, 0)), '\0');
    if (n <= 0 || H5Fget_name(f.id, name.data(), name.size() + 1) < 0)
      throw IoError(file_ + ": cannot name the open file");
    in_.open(name, std::ios::binary);
    if (!in_) throw IoError(file_ + ": cannot open for reading");
  }

  // `n` bytes at address `addr` (relative to the superblock), which must lie in the file.
  std::vector<unsigned char> read(std::uint64_t addr, std::uint64_t n, const std::string& what) {
    if (addr > size_ || base_ > size_ - addr || n > size_ - addr - base_)
      fail(what + " lies outside the file");
    std::vector<unsigned char> b(static_cast<std::size_t>(n));
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(base_ + addr));
    in_.read(reinterpret_cast<char*>(b.data()), static_cast<std::streamsize>(n));
    if (!in_) throw IoError(file_ + ": cannot read " + what);
    return b;
  }

  [[noreturn]] void fail(const std::string& what) const { throw FormatError(file_ + ": " + what); }
  std::size_t sizeofAddr() const { return sizeofAddr_; }
  std::size_t sizeofSize() const { return sizeofSize_; }
  std::uint64_t size() const { return size_; }

 private:
  std::string file_;
  std::ifstream in_;
  size_t sizeofAddr_ = 0, sizeofSize_ = 0;
  hsize_t base_ = 0;
  std::uint64_t size_ = 0;
};

}  // namespace voxpack::hdf5guard::detail
