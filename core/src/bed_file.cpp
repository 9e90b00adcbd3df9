// Bed file I/O over the HDF5 C API (docs/interfaces.md, "The bed file"). The C API is used rather
// than the C++ one because Debian's HDF5 C++ bindings are a separate package and the C
// API lets every failure be turned into one typed exception naming the file.
#include "voxpack/core/bed_file.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <mutex>

#include "hdf5_guard.hpp"
#include "voxpack/core/atomic_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/version.hpp"

namespace voxpack {

namespace fs = std::filesystem;

namespace {

// HDF5 prints its error stack to stderr by default; we report errors ourselves.
void silenceHdf5() {
  static std::once_flag once;
  std::call_once(once, [] { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); });
}

// RAII for any hid_t with its close function.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle(Handle&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      if (id_ >= 0) close_(id_);
      id_ = o.id_;
      close_ = o.close_;
      o.id_ = -1;
    }
    return *this;
  }
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

struct Ctx {
  std::string file;
  bool mpio = false;  // opened through MPI-IO: file-level queries there are collective
  [[noreturn]] void format(const std::string& what) const { throw FormatError(file + ": " + what); }
  [[noreturn]] void io(const std::string& what) const { throw IoError(file + ": " + what); }
};

bool linkExists(hid_t loc, const char* path) {
  // H5Lexists on "a/b" needs "a" to exist first.
  std::string p(path);
  std::size_t pos = 0;
  while ((pos = p.find('/', pos + 1)) != std::string::npos) {
    if (H5Lexists(loc, p.substr(0, pos).c_str(), H5P_DEFAULT) <= 0) return false;
  }
  return H5Lexists(loc, path, H5P_DEFAULT) > 0;
}

std::vector<hsize_t> datasetShape(hid_t ds) {
  Handle space(H5Dget_space(ds), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  std::vector<hsize_t> dims(static_cast<std::size_t>(std::max(rank, 0)));
  if (rank > 0) H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  return dims;
}

std::string readStringAttr(const Ctx& ctx, hid_t obj, const char* name) {
  Handle attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  if (!attr.ok()) ctx.format(std::string("cannot open attribute ") + name);
  Handle type(H5Aget_type(attr.get()), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_STRING)
    ctx.format(std::string("attribute ") + name + " must be a string");
  Handle space(H5Aget_space(attr.get()), H5Sclose);
  if (H5Sget_simple_extent_npoints(space.get()) != 1)
    ctx.format(std::string("attribute ") + name + " must be a single string");
  if (H5Tis_variable_str(type.get()) > 0) {
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem.get(), H5T_VARIABLE);
    H5Tset_cset(mem.get(), H5Tget_cset(type.get()));
    hdf5guard::checkVlenStrings(obj, type.get(), ctx.file, std::string("attribute ") + name, 1,
                                [&](hid_t t, void* buf) { return H5Aread(attr.get(), t, buf); });
    char* s = nullptr;
    if (H5Aread(attr.get(), mem.get(), &s) < 0) ctx.format(std::string("cannot read ") + name);
    std::string out = s ? s : "";
    H5free_memory(s);
    return out;
  }
  const std::size_t n = H5Tget_size(type.get());
  std::string out(n, '\0');
  Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(mem.get(), n);
  if (H5Aread(attr.get(), mem.get(), out.data()) < 0)
    ctx.format(std::string("cannot read ") + name);
  out.resize(std::strlen(out.c_str()));
  return out;
}

std::vector<double> readDoubleAttr(const Ctx& ctx, hid_t obj, const char* name) {
  Handle attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  if (!attr.ok()) ctx.format(std::string("cannot open attribute ") + name);
  Handle type(H5Aget_type(attr.get()), H5Tclose);
  const H5T_class_t cls = H5Tget_class(type.get());
  if (cls != H5T_FLOAT && cls != H5T_INTEGER)
    ctx.format(std::string("attribute ") + name + " must be numeric");
  Handle space(H5Aget_space(attr.get()), H5Sclose);
  const auto n = H5Sget_simple_extent_npoints(space.get());
  std::vector<double> v(static_cast<std::size_t>(std::max<hssize_t>(n, 0)));
  if (n > 0 && H5Aread(attr.get(), H5T_NATIVE_DOUBLE, v.data()) < 0)
    ctx.format(std::string("cannot read attribute ") + name);
  return v;
}

template <class T>
hid_t nativeType();
template <>
hid_t nativeType<std::uint8_t>() {
  return H5T_NATIVE_UINT8;
}
template <>
hid_t nativeType<std::uint32_t>() {
  return H5T_NATIVE_UINT32;
}

// Opens the dataset at `path`. A compact dataset keeps its data in its object header, and
// libhdf5 1.10 copies points x element bytes out of it whatever it holds (a fuzzed bed's
// /particles/shape held 0 bytes for its one 16-byte element: a memcpy from NULL in H5Dread),
// so the stored size must be exactly that.
Handle openDataset(const Ctx& ctx, hid_t file, const char* path) {
  Handle ds(H5Dopen2(file, path, H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) ctx.format(std::string(path) + " is not a dataset");
  Handle dcpl(H5Dget_create_plist(ds.get()), H5Pclose);
  if (!dcpl.ok()) ctx.format(std::string("cannot read the storage of ") + path);
  if (H5Pget_layout(dcpl.get()) != H5D_COMPACT) return ds;
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  Handle space(H5Dget_space(ds.get()), H5Sclose);
  const hssize_t points = H5Sget_simple_extent_npoints(space.get());
  std::size_t element = H5Tget_size(type.get());
  // H5Dget_type gives the in-memory size of a variable-length element; the file stores a
  // length, a collection address and an index.
  if (H5Tis_variable_str(type.get()) > 0 || H5Tget_class(type.get()) == H5T_VLEN) {
    Handle f(H5Iget_file_id(ds.get()), H5Fclose);
    Handle fcpl(f.ok() ? H5Fget_create_plist(f.get()) : -1, H5Pclose);
    size_t sizeofAddr = 0, sizeofSize = 0;
    if (!fcpl.ok() || H5Pget_sizes(fcpl.get(), &sizeofAddr, &sizeofSize) < 0)
      ctx.format("cannot read the file's address sizes");
    element = 8 + sizeofAddr;
  }
  const hsize_t stored = H5Dget_storage_size(ds.get());
  if (points < 0 || element == 0 || stored != static_cast<hsize_t>(points) * element)
    ctx.format(std::string(path) + " is compact with " + std::to_string(stored) +
               " bytes stored for " + std::to_string(points) + " values of " +
               std::to_string(element) + " bytes");
  return ds;
}

// Opens a rank-3 integer volume and checks its type and shape against `lattice`.
Handle openVolume(const Ctx& ctx, hid_t file, const char* path, const Lattice& lattice,
                  bool requireUint8) {
  Handle ds = openDataset(ctx, file, path);
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_INTEGER)
    ctx.format(std::string(path) + " must be an integer dataset (" +
               (requireUint8 ? "uint8" : "uint32") + ")");
  if (requireUint8 && H5Tget_size(type.get()) != 1)
    ctx.format(std::string(path) + " must be uint8, found a " +
               std::to_string(H5Tget_size(type.get()) * 8) + "-bit integer");
  if (!requireUint8 && H5Tget_size(type.get()) > 4)
    ctx.format(std::string(path) + " must be uint32 (found a 64-bit integer)");
  const auto shape = datasetShape(ds.get());
  if (shape.size() != 3)
    ctx.format(std::string(path) + " must have rank 3 [nz,ny,nx], found rank " +
               std::to_string(shape.size()));
  for (int a = 0; a < 3; ++a)
    if (static_cast<std::int64_t>(shape[static_cast<std::size_t>(a)]) != lattice.dims[a])
      ctx.format(std::string(path) + " shape differs from /indicator shape");
  return ds;
}

// Reads `box` of an open volume by hyperslab into a grid on the box's sub-lattice.
template <class T>
Grid<T> readBox(const Ctx& ctx, hid_t ds, const char* path, const Lattice& lattice,
                const VoxelBox& box) {
  for (int a = 0; a < 3; ++a)
    if (box.first[a] < 0 || box.dims[a] < 0 || box.first[a] + box.dims[a] > lattice.dims[a])
      throw InternalError(ctx.file + ": " + path + ": box outside the lattice");
  Grid<T> g(subLattice(lattice, box));
  if (g.size() == 0) return g;
  hsize_t start[3], count[3];
  for (int a = 0; a < 3; ++a) {
    start[a] = static_cast<hsize_t>(box.first[a]);
    count[a] = static_cast<hsize_t>(box.dims[a]);
  }
  // voxpack decodes deflate/shuffle chunks itself, each checked to inflate to its size.
  if (hdf5guard::readChunksChecked(ds, nativeType<T>(), 3, start, count, g.data(), ctx.mpio,
                                   ctx.file, path))
    return g;
  Handle fileSpace(H5Dget_space(ds), H5Sclose);
  Handle memSpace(H5Screate_simple(3, count, nullptr), H5Sclose);
  if (H5Sselect_hyperslab(fileSpace.get(), H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
      H5Dread(ds, nativeType<T>(), memSpace.get(), fileSpace.get(), H5P_DEFAULT, g.data()) < 0) {
    const std::string filter = hdf5guard::unavailableFilter(ds);
    if (!filter.empty())
      ctx.format(std::string(path) + " is compressed with the HDF5 filter " + filter +
                 ", which this libhdf5 cannot decode; rewrite it with gzip (h5py: "
                 "compression='gzip')");
    ctx.io(std::string("cannot read ") + path + " (file truncated or corrupt?)");
  }
  return g;
}

template <class T>
Grid<T> readVolume(const Ctx& ctx, hid_t file, const char* path, const Lattice& lattice,
                   bool requireUint8) {
  Handle ds = openVolume(ctx, file, path, lattice, requireUint8);
  return readBox<T>(ctx, ds.get(), path, lattice, VoxelBox{{0, 0, 0}, lattice.dims});
}

// Values other than 0 and 1 in a binary field read by box, reported in whole-lattice indices.
void checkBinaryBox(const Ctx& ctx, const Grid<std::uint8_t>& g, const char* path,
                    const VoxelBox& box) {
  for (std::size_t n = 0; n < g.size(); ++n)
    if (g[n] > 1) {
      const Index3 ix = g.lattice().indexOf(n);
      ctx.format(std::string(path) + " holds value " + std::to_string(g[n]) + " at [" +
                 std::to_string(ix.k + box.first[0]) + "," + std::to_string(ix.j + box.first[1]) +
                 "," + std::to_string(ix.i + box.first[2]) + "] (only 0 and 1 allowed)");
    }
}

std::vector<double> readMatrix(const Ctx& ctx, hid_t file, const char* path, std::size_t cols,
                               std::size_t& rows) {
  Handle ds = openDataset(ctx, file, path);
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  const H5T_class_t cls = H5Tget_class(type.get());
  if (cls != H5T_FLOAT && cls != H5T_INTEGER) ctx.format(std::string(path) + " must be numeric");
  const auto shape = datasetShape(ds.get());
  if (shape.size() != 2 || shape[1] != cols)
    ctx.format(std::string(path) + " must have shape [N," + std::to_string(cols) + "]");
  rows = shape[0];
  if (rows > kMaxBedParticles)
    ctx.format(std::string(path) + " declares " + std::to_string(rows) + " rows (limit " +
               std::to_string(kMaxBedParticles) + ")");
  std::vector<double> v(static_cast<std::size_t>(
      checkedProduct({rows, cols, sizeof(double)}, ctx.file + ": " + path) / sizeof(double)));
  if (v.empty()) return v;
  const hsize_t start[2] = {0, 0}, count[2] = {rows, cols};
  if (hdf5guard::readChunksChecked(ds.get(), H5T_NATIVE_DOUBLE, 2, start, count, v.data(), ctx.mpio,
                                   ctx.file, path))
    return v;
  if (H5Dread(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    ctx.io(std::string("cannot read ") + path);
  return v;
}

std::vector<std::string> readStrings(const Ctx& ctx, hid_t file, const char* path) {
  Handle ds = openDataset(ctx, file, path);
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  const auto shape = datasetShape(ds.get());
  if (shape.size() != 1) ctx.format(std::string(path) + " must be one-dimensional");
  const std::size_t n = shape[0];
  if (n > kMaxBedParticles)
    ctx.format(std::string(path) + " declares " + std::to_string(n) + " rows (limit " +
               std::to_string(kMaxBedParticles) + ")");
  std::vector<std::string> out(n);
  if (n == 0) return out;
  if (H5Tget_class(type.get()) != H5T_STRING) ctx.format(std::string(path) + " must hold strings");
  if (H5Tis_variable_str(type.get()) > 0) {
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem.get(), H5T_VARIABLE);
    H5Tset_cset(mem.get(), H5Tget_cset(type.get()));
    hdf5guard::checkVlenStrings(file, type.get(), ctx.file, path, n, [&](hid_t t, void* buf) {
      return H5Dread(ds.get(), t, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
    });
    std::vector<char*> ptrs(n, nullptr);
    if (H5Dread(ds.get(), mem.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0)
      ctx.io(std::string("cannot read ") + path);
    for (std::size_t r = 0; r < n; ++r) out[r] = ptrs[r] ? ptrs[r] : "";
    Handle space(H5Dget_space(ds.get()), H5Sclose);
    H5Dvlen_reclaim(mem.get(), space.get(), H5P_DEFAULT, ptrs.data());
  } else {
    const std::size_t w = H5Tget_size(type.get());
    std::vector<char> buf(n * w);
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem.get(), w);
    if (H5Dread(ds.get(), mem.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0)
      ctx.io(std::string("cannot read ") + path);
    for (std::size_t r = 0; r < n; ++r) {
      const char* s = buf.data() + r * w;
      out[r].assign(s, strnlen(s, w));
    }
  }
  return out;
}

// Particle shapes stored as an integer index into /particles/shape_table.
std::vector<std::string> readShapeIndices(const Ctx& ctx, hid_t file) {
  std::size_t rows = 0;
  Handle ds = openDataset(ctx, file, "/particles/shape");
  const auto shape = datasetShape(ds.get());
  if (shape.size() != 1) ctx.format("/particles/shape must be one-dimensional");
  rows = shape[0];
  if (rows > kMaxBedParticles) ctx.format("/particles/shape declares too many rows");
  std::vector<std::int64_t> idx(rows);
  if (rows && H5Dread(ds.get(), H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, idx.data()) < 0)
    ctx.io("cannot read /particles/shape");
  if (!linkExists(file, "/particles/shape_table"))
    ctx.format("/particles/shape holds indices but /particles/shape_table is missing");
  const auto table = readStrings(ctx, file, "/particles/shape_table");
  std::vector<std::string> out(rows);
  for (std::size_t r = 0; r < rows; ++r) {
    if (idx[r] < 0 || static_cast<std::size_t>(idx[r]) >= table.size())
      ctx.format("/particles/shape index out of range of /particles/shape_table");
    out[r] = table[static_cast<std::size_t>(idx[r])];
  }
  return out;
}

// ---- writing ----

void writeStringAttr(hid_t obj, const char* name, const std::string& value) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), H5T_VARIABLE);
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attr(H5Acreate2(obj, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  const char* p = value.c_str();
  if (!attr.ok() || H5Awrite(attr.get(), type.get(), &p) < 0)
    throw IoError(std::string("cannot write attribute ") + name);
}

void writeDoubleAttr(hid_t obj, const char* name, const double* v, hsize_t n) {
  Handle space(H5Screate_simple(1, &n, nullptr), H5Sclose);
  Handle attr(H5Acreate2(obj, name, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT),
              H5Aclose);
  if (!attr.ok() || H5Awrite(attr.get(), H5T_NATIVE_DOUBLE, v) < 0)
    throw IoError(std::string("cannot write attribute ") + name);
}

void writeIntAttr(hid_t obj, const char* name, long long v) {
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attr(H5Acreate2(obj, name, H5T_STD_I64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT),
              H5Aclose);
  if (!attr.ok() || H5Awrite(attr.get(), H5T_NATIVE_LLONG, &v) < 0)
    throw IoError(std::string("cannot write attribute ") + name);
}

hid_t chunkedPlist(int rank, const hsize_t* dims, const hsize_t* chunk, const BedWriteOptions& o) {
  hid_t plist = H5Pcreate(H5P_DATASET_CREATE);
  bool nonEmpty = true;
  for (int a = 0; a < rank; ++a) nonEmpty = nonEmpty && dims[a] > 0;
  if (nonEmpty) {
    H5Pset_chunk(plist, rank, chunk);
    if (o.shuffle) H5Pset_shuffle(plist);
    if (o.compressionLevel > 0) H5Pset_deflate(plist, static_cast<unsigned>(o.compressionLevel));
  }
  return plist;
}

Handle createVolume(hid_t file, const char* path, const Lattice& l, hid_t fileType,
                    const BedWriteOptions& o);

// A whole volume in one write, through the same chunked layout as the slab writer.
template <class T>
void writeVolume(hid_t file, const char* path, const Grid<T>& g, hid_t fileType,
                 const BedWriteOptions& o) {
  Handle ds = createVolume(file, path, g.lattice(), fileType, o);
  if (H5Dwrite(ds.get(), nativeType<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, g.data()) < 0)
    throw IoError(std::string("cannot write ") + path);
}

void writeMatrix(hid_t file, const char* path, const std::vector<double>& v, hsize_t rows,
                 hsize_t cols, const BedWriteOptions& o) {
  hsize_t dims[2] = {rows, cols};
  hsize_t chunk[2] = {std::min<hsize_t>(std::max<hsize_t>(rows, 1), 4096), cols};
  Handle space(H5Screate_simple(2, dims, nullptr), H5Sclose);
  Handle plist(chunkedPlist(2, dims, chunk, o), H5Pclose);
  Handle ds(
      H5Dcreate2(file, path, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, plist.get(), H5P_DEFAULT),
      H5Dclose);
  if (!ds.ok() || (rows > 0 && H5Dwrite(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT,
                                        v.data()) < 0))
    throw IoError(std::string("cannot write ") + path);
}

void writeStrings(hid_t file, const char* path, const std::vector<std::string>& s) {
  hsize_t n = s.size();
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), H5T_VARIABLE);
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  Handle space(H5Screate_simple(1, &n, nullptr), H5Sclose);
  Handle ds(H5Dcreate2(file, path, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
            H5Dclose);
  std::vector<const char*> ptrs;
  ptrs.reserve(s.size());
  for (const auto& x : s) ptrs.push_back(x.c_str());
  if (!ds.ok() ||
      (n > 0 && H5Dwrite(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0))
    throw IoError(std::string("cannot write ") + path);
}

Handle openForRead(const fs::path& path, const Ctx& ctx, bool parallel = false) {
  silenceHdf5();
  std::error_code ec;
  if (!fs::exists(path, ec)) ctx.io("no such file");
  if (fs::is_directory(path, ec)) ctx.io("is a directory, not a bed file");
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) ctx.io("cannot open for reading");
  }
  const htri_t is = H5Fis_hdf5(path.c_str());
  if (is <= 0) ctx.io("not an HDF5 file");
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
#ifdef VOXPACK_HDF5_PARALLEL
  // Every rank opens the file through MPI-IO and reads its own slabs independently.
  if (parallel) H5Pset_fapl_mpio(fapl.get(), MPI_COMM_WORLD, MPI_INFO_NULL);
#else
  (void)parallel;
#endif
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.get()), H5Fclose);
  if (!file.ok()) ctx.io("cannot open as HDF5 (truncated or corrupt file?)");
  return file;
}

// Rows of a particle dataset (its first dimension), checked against the limit.
std::uint64_t particleRows(const Ctx& ctx, hid_t file, const char* path, int rank, hsize_t cols) {
  Handle ds = openDataset(ctx, file, path);
  const auto shape = datasetShape(ds.get());
  if (static_cast<int>(shape.size()) != rank || (rank == 2 && shape[1] != cols))
    ctx.format(std::string(path) + (rank == 2 ? " must have shape [N," + std::to_string(cols) + "]"
                                              : std::string(" must be one-dimensional")));
  if (shape[0] > kMaxBedParticles)
    ctx.format(std::string(path) + " declares " + std::to_string(shape[0]) +
               " rows, more than the limit of " + std::to_string(kMaxBedParticles));
  checkedProduct({shape[0], rank == 2 ? cols : 1, sizeof(double)}, ctx.file + ": " + path);
  return shape[0];
}

BedHeader readHeaderFrom(const Ctx& ctx, hid_t f) {
  Handle root(H5Gopen2(f, "/", H5P_DEFAULT), H5Gclose);
  if (!root.ok()) ctx.io("cannot open root group");
  // Every attribute call decodes all of the root's attribute messages: check them first.
  hdf5guard::checkAttributeMessages(root.get(), ctx.file, "root group");

  if (H5Aexists(root.get(), "format") <= 0) ctx.format("root attribute 'format' is missing");
  const std::string fmt = readStringAttr(ctx, root.get(), "format");
  if (fmt != "voxpack-bed") ctx.format("root attribute format is '" + fmt + "', not 'voxpack-bed'");
  if (H5Aexists(root.get(), "format_version") <= 0)
    ctx.format("root attribute 'format_version' is missing");
  const auto ver = readDoubleAttr(ctx, root.get(), "format_version");
  if (ver.size() != 1 || ver[0] != 1.0)
    ctx.format("unsupported format_version (this voxpack reads version 1)");

  BedHeader h;
  Lattice& lattice = h.lattice;
  for (const char* name : {"spacing_mm", "origin_mm"}) {
    if (H5Aexists(root.get(), name) <= 0)
      ctx.format(std::string("root attribute '") + name + "' is missing");
    const auto v = readDoubleAttr(ctx, root.get(), name);
    if (v.size() != 3) ctx.format(std::string(name) + " must hold 3 values (z, y, x)");
    for (int a = 0; a < 3; ++a) {
      const double x = v[static_cast<std::size_t>(a)];
      if (!std::isfinite(x)) ctx.format(std::string(name) + " holds a non-finite value");
      if (name[0] == 's' && x <= 0) ctx.format("spacing_mm must be > 0, got " + std::to_string(x));
      (name[0] == 's' ? lattice.spacingMm : lattice.originMm)[static_cast<std::size_t>(a)] = x;
    }
  }

  if (!linkExists(f, "/indicator")) ctx.format("dataset /indicator is missing");
  {
    Handle ds = openDataset(ctx, f, "/indicator");
    const auto shape = datasetShape(ds.get());
    if (shape.size() != 3)
      ctx.format("/indicator must have rank 3 [nz,ny,nx], found rank " +
                 std::to_string(shape.size()));
    for (int a = 0; a < 3; ++a)
      if (shape[static_cast<std::size_t>(a)] == 0) ctx.format("/indicator has a zero dimension");
    // The product is checked before anything is sized from it: a hostile header may
    // declare 2^21 per axis (2^63 voxels) in a file of a few KB.
    long double voxels = 1;
    for (hsize_t d : shape) voxels *= static_cast<long double>(d);
    if (voxels > static_cast<long double>(kMaxBedVoxels))
      ctx.format("/indicator declares " + std::to_string(shape[0]) + " x " +
                 std::to_string(shape[1]) + " x " + std::to_string(shape[2]) +
                 " voxels, more than the limit of 2^44 voxels");
    for (int a = 0; a < 3; ++a)
      lattice.dims[static_cast<std::size_t>(a)] =
          static_cast<std::int64_t>(shape[static_cast<std::size_t>(a)]);
  }
  // Types and shapes of the volumes, without reading them.
  openVolume(ctx, f, "/indicator", lattice, true);
  h.hasMask = linkExists(f, "/mask");
  if (h.hasMask) openVolume(ctx, f, "/mask", lattice, true);
  h.hasLabels = linkExists(f, "/labels");
  if (h.hasLabels) openVolume(ctx, f, "/labels", lattice, false);

  if (linkExists(f, "/particles/position_mm")) {
    h.particles = particleRows(ctx, f, "/particles/position_mm", 2, 3);
    h.hasOrientation = linkExists(f, "/particles/orientation");
    if (h.hasOrientation) {
      const auto rows = particleRows(ctx, f, "/particles/orientation", 2, 4);
      if (rows != h.particles)
        ctx.format("/particles/orientation has " + std::to_string(rows) + " rows, position has " +
                   std::to_string(h.particles));
    }
    h.hasShape = linkExists(f, "/particles/shape");
    if (h.hasShape) {
      const auto rows = particleRows(ctx, f, "/particles/shape", 1, 1);
      if (rows != h.particles)
        ctx.format("/particles/shape has " + std::to_string(rows) + " rows, position has " +
                   std::to_string(h.particles));
    }
  }
  for (const char* p : {"/indicator", "/mask", "/labels", "/particles/position_mm",
                        "/particles/orientation", "/particles/shape"})
    if (linkExists(f, p)) h.datasets.emplace_back(p);
  if (H5Aexists(root.get(), "provenance") > 0) {
    const std::string text = readStringAttr(ctx, root.get(), "provenance");
    auto parsed = nlohmann::json::parse(text, nullptr, false);
    h.provenance = parsed.is_discarded() ? nlohmann::json{{"text", text}} : parsed;
  }
  return h;
}

ParticleTable readParticlesFrom(const Ctx& ctx, hid_t f, const BedHeader& h) {
  ParticleTable t;
  if (h.particles == 0 && !linkExists(f, "/particles/position_mm")) return t;
  std::size_t rows = 0;
  const auto pos = readMatrix(ctx, f, "/particles/position_mm", 3, rows);
  t.positionMm.reserve(rows);
  for (std::size_t r = 0; r < rows; ++r)
    t.positionMm.emplace_back(pos[3 * r], pos[3 * r + 1], pos[3 * r + 2]);
  if (h.hasOrientation) {
    std::size_t qr = 0;
    const auto q = readMatrix(ctx, f, "/particles/orientation", 4, qr);
    t.orientation.reserve(qr);
    for (std::size_t r = 0; r < qr; ++r)
      t.orientation.emplace_back(q[4 * r], q[4 * r + 1], q[4 * r + 2], q[4 * r + 3]);
  }
  if (h.hasShape) {
    Handle ds = openDataset(ctx, f, "/particles/shape");
    Handle type(H5Dget_type(ds.get()), H5Tclose);
    t.shape = H5Tget_class(type.get()) == H5T_INTEGER ? readShapeIndices(ctx, f)
                                                      : readStrings(ctx, f, "/particles/shape");
  }
  return t;
}

void checkParticles(const Ctx& ctx, const ParticleTable& t) {
  try {
    for (std::size_t r = 0; r < t.orientation.size(); ++r) checkUnitQuaternion(t.orientation[r], r);
    for (const Vec3& p : t.positionMm)
      if (!p.allFinite()) throw FormatError("/particles/position_mm holds a non-finite value");
  } catch (const FormatError& e) {
    ctx.format(e.what());
  }
}

// Creates a chunked rank-3 volume dataset (~256 KiB uint8 chunks of 16 planes x 128 x 128:
// they compress well, stay cache-sized, and a z-slab read aligned to 16 planes decompresses
// each chunk once).
Handle createVolume(hid_t file, const char* path, const Lattice& l, hid_t fileType,
                    const BedWriteOptions& o) {
  const auto& d = l.dims;
  hsize_t dims[3] = {static_cast<hsize_t>(d[0]), static_cast<hsize_t>(d[1]),
                     static_cast<hsize_t>(d[2])};
  hsize_t chunk[3] = {std::min<hsize_t>(dims[0], 16), std::min<hsize_t>(dims[1], 128),
                      std::min<hsize_t>(dims[2], 128)};
  Handle space(H5Screate_simple(3, dims, nullptr), H5Sclose);
  Handle plist(chunkedPlist(3, dims, chunk, o), H5Pclose);
  Handle ds(H5Dcreate2(file, path, fileType, space.get(), H5P_DEFAULT, plist.get(), H5P_DEFAULT),
            H5Dclose);
  if (!ds.ok()) throw IoError(std::string("cannot create ") + path);
  return ds;
}

template <class T>
void writePlanes(hid_t ds, const char* path, const Lattice& whole, std::int64_t z0,
                 const Grid<T>& slab) {
  const auto& sd = slab.lattice().dims;
  if (sd[1] != whole.dims[1] || sd[2] != whole.dims[2] || z0 < 0 || z0 + sd[0] > whole.dims[0])
    throw InternalError(std::string("BedSlabWriter: ") + path + " slab outside the lattice");
  if (slab.size() == 0) return;
  hsize_t start[3] = {static_cast<hsize_t>(z0), 0, 0};
  hsize_t count[3] = {static_cast<hsize_t>(sd[0]), static_cast<hsize_t>(sd[1]),
                      static_cast<hsize_t>(sd[2])};
  Handle fileSpace(H5Dget_space(ds), H5Sclose);
  Handle memSpace(H5Screate_simple(3, count, nullptr), H5Sclose);
  if (H5Sselect_hyperslab(fileSpace.get(), H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
      H5Dwrite(ds, nativeType<T>(), memSpace.get(), fileSpace.get(), H5P_DEFAULT, slab.data()) < 0)
    throw IoError(std::string("cannot write ") + path);
}

void writeRootAttributes(hid_t file, const Lattice& l) {
  Handle root(H5Gopen2(file, "/", H5P_DEFAULT), H5Gclose);
  writeStringAttr(root.get(), "format", "voxpack-bed");
  writeIntAttr(root.get(), "format_version", 1);
  writeDoubleAttr(root.get(), "spacing_mm", l.spacingMm.data(), 3);
  writeDoubleAttr(root.get(), "origin_mm", l.originMm.data(), 3);
}

void writeProvenance(hid_t file, const nlohmann::json& provenance) {
  Handle root(H5Gopen2(file, "/", H5P_DEFAULT), H5Gclose);
  nlohmann::json prov = provenance.is_object() ? provenance : nlohmann::json::object();
  if (!prov.contains("voxpack_version")) prov["voxpack_version"] = versionString();
  writeStringAttr(root.get(), "provenance", prov.dump());
}

void writeParticles(hid_t file, const ParticleTable& p, const BedWriteOptions& options) {
  if (p.empty()) return;
  Handle grp(H5Gcreate2(file, "/particles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  std::vector<double> pos;
  pos.reserve(p.size() * 3);
  for (const Vec3& v : p.positionMm) pos.insert(pos.end(), {v.x(), v.y(), v.z()});
  writeMatrix(file, "/particles/position_mm", pos, p.size(), 3, options);
  if (!p.orientation.empty()) {
    std::vector<double> q;
    q.reserve(p.size() * 4);
    for (const Quat& o : p.orientation) q.insert(q.end(), {o.w(), o.x(), o.y(), o.z()});
    writeMatrix(file, "/particles/orientation", q, p.size(), 4, options);
  }
  if (!p.shape.empty()) writeStrings(file, "/particles/shape", p.shape);
}

}  // namespace

Lattice subLattice(const Lattice& lattice, const VoxelBox& box) {
  Lattice l = lattice;
  l.dims = box.dims;
  for (int a = 0; a < 3; ++a)
    l.originMm[static_cast<std::size_t>(a)] +=
        static_cast<double>(box.first[static_cast<std::size_t>(a)]) *
        lattice.spacingMm[static_cast<std::size_t>(a)];
  return l;
}

void writeBed(const fs::path& path, const Bed& bed, const BedWriteOptions& options) {
  silenceHdf5();
  bed.validate();
  AtomicOutput out(path);
  {
    Handle file(H5Fcreate(out.tempPath().c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT),
                H5Fclose);
    if (!file.ok()) throw IoError(path.string() + ": cannot create file");
    const Lattice& l = bed.lattice();
    writeRootAttributes(file.get(), l);
    writeProvenance(file.get(), bed.provenance);
    writeVolume(file.get(), "/indicator", bed.indicator, H5T_STD_U8LE, options);
    if (bed.mask) writeVolume(file.get(), "/mask", *bed.mask, H5T_STD_U8LE, options);
    if (bed.labels) writeVolume(file.get(), "/labels", *bed.labels, H5T_STD_U32LE, options);
    writeParticles(file.get(), bed.particles, options);
    if (H5Fflush(file.get(), H5F_SCOPE_GLOBAL) < 0) throw IoError(path.string() + ": flush failed");
  }
  out.commit();
}

BedHeader readBedHeader(const fs::path& path) {
  const Ctx ctx{path.string(), false};
  Handle file = openForRead(path, ctx);
  return readHeaderFrom(ctx, file.get());
}

std::uint64_t particleTableBytes(const BedHeader& h) {
  // Vec3 24 B + Quat 32 B + a short std::string (32 B, SSO) per row, plus the read buffers
  // (8 B per stored double) that live while a table is converted.
  const std::uint64_t perRow = 24 + (h.hasOrientation ? 32 + 32 : 0) + (h.hasShape ? 48 : 0) + 24;
  return checkedProduct({h.particles, perRow}, "particle table");
}

std::uint64_t bedMemoryBytes(const BedHeader& h) {
  const std::uint64_t n = checkedProduct(
      {static_cast<std::uint64_t>(h.lattice.dims[0]), static_cast<std::uint64_t>(h.lattice.dims[1]),
       static_cast<std::uint64_t>(h.lattice.dims[2])},
      "bed volume");
  const std::uint64_t perVoxel = 1 + (h.hasMask ? 1 : 0) + (h.hasLabels ? 4 : 0);
  return checkedProduct({n, perVoxel}, "bed volume") + particleTableBytes(h);
}

namespace {
std::string dimsText(const Lattice& l) {
  return std::to_string(l.dims[0]) + " x " + std::to_string(l.dims[1]) + " x " +
         std::to_string(l.dims[2]);
}
}  // namespace

Bed readBed(const fs::path& path, const MemoryBudget& budget) {
  const Ctx ctx{path.string(), false};
  Handle file = openForRead(path, ctx);
  const hid_t f = file.get();
  const BedHeader h = readHeaderFrom(ctx, f);
  const Lattice& lattice = h.lattice;
  // The estimate comes before any allocation: a tiny file may declare a huge volume.
  requireWithinBudget(bedMemoryBytes(h), budget,
                      ctx.file + ": reading the bed (" + dimsText(lattice) + " voxels)");
  Bed bed;
  bed.indicator = readVolume<std::uint8_t>(ctx, f, "/indicator", lattice, true);
  if (h.hasMask) bed.mask = readVolume<std::uint8_t>(ctx, f, "/mask", lattice, true);
  if (h.hasLabels) bed.labels = readVolume<std::uint32_t>(ctx, f, "/labels", lattice, false);
  bed.particles = readParticlesFrom(ctx, f, h);
  bed.provenance = h.provenance;
  try {
    bed.validate();
  } catch (const FormatError& e) {
    ctx.format(e.what());
  }
  return bed;
}

Bed readBed(const fs::path& path) { return readBed(path, defaultMemoryBudget()); }

ParticleTable readBedParticles(const fs::path& path, const MemoryBudget& budget) {
  const Ctx ctx{path.string(), false};
  Handle file = openForRead(path, ctx);
  const BedHeader h = readHeaderFrom(ctx, file.get());
  requireWithinBudget(
      particleTableBytes(h), budget,
      ctx.file + ": reading the particle table (" + std::to_string(h.particles) + " rows)");
  ParticleTable t = readParticlesFrom(ctx, file.get(), h);
  checkParticles(ctx, t);
  return t;
}

std::vector<std::string> bedDatasets(const fs::path& path) {
  const Ctx ctx{path.string(), false};
  Handle file = openForRead(path, ctx);
  std::vector<std::string> out;
  for (const char* p : {"/indicator", "/mask", "/labels", "/particles/position_mm",
                        "/particles/orientation", "/particles/shape"})
    if (linkExists(file.get(), p)) out.emplace_back(p);
  return out;
}

// ---- slab reader ----

struct BedSlabReader::Impl {
  Ctx ctx;
  Handle file;
  BedHeader header;
  Handle indicator{-1, H5Dclose};
  Handle mask{-1, H5Dclose};
  Handle labels{-1, H5Dclose};
  Impl(const fs::path& path, bool parallel)
      : ctx{path.string(), parallel}, file(openForRead(path, ctx, parallel)) {
    header = readHeaderFrom(ctx, file.get());
    indicator = openVolume(ctx, file.get(), "/indicator", header.lattice, true);
    if (header.hasMask) mask = openVolume(ctx, file.get(), "/mask", header.lattice, true);
    if (header.hasLabels) labels = openVolume(ctx, file.get(), "/labels", header.lattice, false);
  }
};

BedSlabReader::BedSlabReader(const fs::path& path, bool parallel)
    : impl_(std::make_unique<Impl>(path, parallel)) {}
BedSlabReader::~BedSlabReader() = default;
const BedHeader& BedSlabReader::header() const { return impl_->header; }

Grid<std::uint8_t> BedSlabReader::indicator(const VoxelBox& box) const {
  auto g = readBox<std::uint8_t>(impl_->ctx, impl_->indicator.get(), "/indicator",
                                 impl_->header.lattice, box);
  checkBinaryBox(impl_->ctx, g, "/indicator", box);
  return g;
}

std::optional<Grid<std::uint8_t>> BedSlabReader::mask(const VoxelBox& box) const {
  if (!impl_->header.hasMask) return std::nullopt;
  auto g =
      readBox<std::uint8_t>(impl_->ctx, impl_->mask.get(), "/mask", impl_->header.lattice, box);
  checkBinaryBox(impl_->ctx, g, "/mask", box);
  return g;
}

std::optional<Grid<std::uint32_t>> BedSlabReader::labels(const VoxelBox& box) const {
  if (!impl_->header.hasLabels) return std::nullopt;
  return readBox<std::uint32_t>(impl_->ctx, impl_->labels.get(), "/labels", impl_->header.lattice,
                                box);
}

Grid<std::uint8_t> BedSlabReader::indicatorSlab(std::int64_t z0, std::int64_t z1) const {
  const Lattice& l = impl_->header.lattice;
  return indicator(VoxelBox{{z0, 0, 0}, {z1 - z0, l.dims[1], l.dims[2]}});
}

// ---- slab writer ----

struct BedSlabWriter::Impl {
  AtomicOutput out;
  Lattice lattice;
  BedWriteOptions options;
  Handle file{-1, H5Fclose};
  Handle indicator{-1, H5Dclose};
  Handle mask{-1, H5Dclose};
  Handle labels{-1, H5Dclose};
  Impl(const fs::path& path, const Lattice& l, const BedWriteOptions& o)
      : out(path), lattice(l), options(o) {}
};

BedSlabWriter::BedSlabWriter(const fs::path& path, const Lattice& lattice, bool withMask,
                             bool withLabels, const BedWriteOptions& options) {
  silenceHdf5();
  lattice.validate("bed lattice");
  impl_ = std::make_unique<Impl>(path, lattice, options);
  impl_->file = Handle(
      H5Fcreate(impl_->out.tempPath().c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
  if (!impl_->file.ok()) throw IoError(path.string() + ": cannot create file");
  writeRootAttributes(impl_->file.get(), lattice);
  impl_->indicator = createVolume(impl_->file.get(), "/indicator", lattice, H5T_STD_U8LE, options);
  if (withMask)
    impl_->mask = createVolume(impl_->file.get(), "/mask", lattice, H5T_STD_U8LE, options);
  if (withLabels)
    impl_->labels = createVolume(impl_->file.get(), "/labels", lattice, H5T_STD_U32LE, options);
}

BedSlabWriter::~BedSlabWriter() = default;

void BedSlabWriter::writeIndicator(std::int64_t z0, const Grid<std::uint8_t>& slab) {
  writePlanes(impl_->indicator.get(), "/indicator", impl_->lattice, z0, slab);
}
void BedSlabWriter::writeMask(std::int64_t z0, const Grid<std::uint8_t>& slab) {
  if (!impl_->mask.ok()) throw InternalError("BedSlabWriter: the bed was created without /mask");
  writePlanes(impl_->mask.get(), "/mask", impl_->lattice, z0, slab);
}
void BedSlabWriter::writeLabels(std::int64_t z0, const Grid<std::uint32_t>& slab) {
  if (!impl_->labels.ok())
    throw InternalError("BedSlabWriter: the bed was created without /labels");
  writePlanes(impl_->labels.get(), "/labels", impl_->lattice, z0, slab);
}

void BedSlabWriter::finish(const ParticleTable& particles, const nlohmann::json& provenance) {
  writeProvenance(impl_->file.get(), provenance);
  writeParticles(impl_->file.get(), particles, impl_->options);
  impl_->indicator = Handle(-1, H5Dclose);
  impl_->mask = Handle(-1, H5Dclose);
  impl_->labels = Handle(-1, H5Dclose);
  if (H5Fflush(impl_->file.get(), H5F_SCOPE_GLOBAL) < 0)
    throw IoError(impl_->out.target().string() + ": flush failed");
  impl_->file = Handle(-1, H5Fclose);
  impl_->out.commit();
}

}  // namespace voxpack
