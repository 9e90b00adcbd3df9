// Bed file I/O over the HDF5 C API (SPEC.md, "The bed file"). The C API is used rather
// than the C++ one because Debian's HDF5 C++ bindings are a separate package and the C
// API lets every failure be turned into one typed exception naming the file.
#include "voxpack/core/bed_file.hpp"

#include <hdf5.h>

#include <cmath>
#include <fstream>
#include <cstring>
#include <mutex>

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
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

struct Ctx {
  std::string file;
  [[noreturn]] void format(const std::string& what) const {
    throw FormatError(file + ": " + what);
  }
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

// Reads a rank-3 integer volume; `maxBytes` bounds the stored integer width.
template <class T>
Grid<T> readVolume(const Ctx& ctx, hid_t file, const char* path, const Lattice& lattice,
                   bool requireUint8) {
  Handle ds(H5Dopen2(file, path, H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) ctx.format(std::string(path) + " is not a dataset");
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
  Grid<T> g(lattice);
  if (g.size() > 0 &&
      H5Dread(ds.get(), nativeType<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, g.data()) < 0)
    ctx.io(std::string("cannot read ") + path + " (file truncated or corrupt?)");
  return g;
}

std::vector<double> readMatrix(const Ctx& ctx, hid_t file, const char* path, std::size_t cols,
                               std::size_t& rows) {
  Handle ds(H5Dopen2(file, path, H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) ctx.format(std::string(path) + " is not a dataset");
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  const H5T_class_t cls = H5Tget_class(type.get());
  if (cls != H5T_FLOAT && cls != H5T_INTEGER) ctx.format(std::string(path) + " must be numeric");
  const auto shape = datasetShape(ds.get());
  if (shape.size() != 2 || shape[1] != cols)
    ctx.format(std::string(path) + " must have shape [N," + std::to_string(cols) + "]");
  rows = shape[0];
  std::vector<double> v(rows * cols);
  if (!v.empty() &&
      H5Dread(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    ctx.io(std::string("cannot read ") + path);
  return v;
}

std::vector<std::string> readStrings(const Ctx& ctx, hid_t file, const char* path) {
  Handle ds(H5Dopen2(file, path, H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) ctx.format(std::string(path) + " is not a dataset");
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  const auto shape = datasetShape(ds.get());
  if (shape.size() != 1) ctx.format(std::string(path) + " must be one-dimensional");
  const std::size_t n = shape[0];
  std::vector<std::string> out(n);
  if (n == 0) return out;
  if (H5Tget_class(type.get()) != H5T_STRING) ctx.format(std::string(path) + " must hold strings");
  if (H5Tis_variable_str(type.get()) > 0) {
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem.get(), H5T_VARIABLE);
    H5Tset_cset(mem.get(), H5Tget_cset(type.get()));
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
  Handle ds(H5Dopen2(file, "/particles/shape", H5P_DEFAULT), H5Dclose);
  const auto shape = datasetShape(ds.get());
  if (shape.size() != 1) ctx.format("/particles/shape must be one-dimensional");
  rows = shape[0];
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
  Handle attr(H5Acreate2(obj, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT),
              H5Aclose);
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

hid_t chunkedPlist(int rank, const hsize_t* dims, const hsize_t* chunk,
                   const BedWriteOptions& o) {
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

template <class T>
void writeVolume(hid_t file, const char* path, const Grid<T>& g, hid_t fileType,
                 const BedWriteOptions& o) {
  const auto& d = g.lattice().dims;
  hsize_t dims[3] = {static_cast<hsize_t>(d[0]), static_cast<hsize_t>(d[1]),
                     static_cast<hsize_t>(d[2])};
  // ~256 KiB uint8 chunks: whole rows and planes compress well and stay cache-sized.
  hsize_t chunk[3] = {std::min<hsize_t>(dims[0], 16), std::min<hsize_t>(dims[1], 128),
                      std::min<hsize_t>(dims[2], 128)};
  Handle space(H5Screate_simple(3, dims, nullptr), H5Sclose);
  Handle plist(chunkedPlist(3, dims, chunk, o), H5Pclose);
  Handle ds(H5Dcreate2(file, path, fileType, space.get(), H5P_DEFAULT, plist.get(), H5P_DEFAULT),
            H5Dclose);
  if (!ds.ok() || H5Dwrite(ds.get(), nativeType<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, g.data()) < 0)
    throw IoError(std::string("cannot write ") + path);
}

void writeMatrix(hid_t file, const char* path, const std::vector<double>& v, hsize_t rows,
                 hsize_t cols, const BedWriteOptions& o) {
  hsize_t dims[2] = {rows, cols};
  hsize_t chunk[2] = {std::min<hsize_t>(std::max<hsize_t>(rows, 1), 4096), cols};
  Handle space(H5Screate_simple(2, dims, nullptr), H5Sclose);
  Handle plist(chunkedPlist(2, dims, chunk, o), H5Pclose);
  Handle ds(H5Dcreate2(file, path, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, plist.get(),
                       H5P_DEFAULT),
            H5Dclose);
  if (!ds.ok() ||
      (rows > 0 && H5Dwrite(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0))
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

Handle openForRead(const fs::path& path, const Ctx& ctx) {
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
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) ctx.io("cannot open as HDF5 (truncated or corrupt file?)");
  return file;
}

}  // namespace

void writeBed(const fs::path& path, const Bed& bed, const BedWriteOptions& options) {
  silenceHdf5();
  bed.validate();
  AtomicOutput out(path);
  {
    Handle file(H5Fcreate(out.tempPath().c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT),
                H5Fclose);
    if (!file.ok()) throw IoError(path.string() + ": cannot create file");
    const Lattice& l = bed.lattice();
    Handle root(H5Gopen2(file.get(), "/", H5P_DEFAULT), H5Gclose);
    writeStringAttr(root.get(), "format", "voxpack-bed");
    writeIntAttr(root.get(), "format_version", 1);
    writeDoubleAttr(root.get(), "spacing_mm", l.spacingMm.data(), 3);
    writeDoubleAttr(root.get(), "origin_mm", l.originMm.data(), 3);
    nlohmann::json prov = bed.provenance.is_object() ? bed.provenance : nlohmann::json::object();
    if (!prov.contains("voxpack_version")) prov["voxpack_version"] = versionString();
    writeStringAttr(root.get(), "provenance", prov.dump());

    writeVolume(file.get(), "/indicator", bed.indicator, H5T_STD_U8LE, options);
    if (bed.mask) writeVolume(file.get(), "/mask", *bed.mask, H5T_STD_U8LE, options);
    if (bed.labels) writeVolume(file.get(), "/labels", *bed.labels, H5T_STD_U32LE, options);
    const auto& p = bed.particles;
    if (!p.empty()) {
      Handle grp(H5Gcreate2(file.get(), "/particles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                 H5Gclose);
      std::vector<double> pos;
      pos.reserve(p.size() * 3);
      for (const Vec3& v : p.positionMm) pos.insert(pos.end(), {v.x(), v.y(), v.z()});
      writeMatrix(file.get(), "/particles/position_mm", pos, p.size(), 3, options);
      if (!p.orientation.empty()) {
        std::vector<double> q;
        q.reserve(p.size() * 4);
        for (const Quat& o : p.orientation) q.insert(q.end(), {o.w(), o.x(), o.y(), o.z()});
        writeMatrix(file.get(), "/particles/orientation", q, p.size(), 4, options);
      }
      if (!p.shape.empty()) writeStrings(file.get(), "/particles/shape", p.shape);
    }
    if (H5Fflush(file.get(), H5F_SCOPE_GLOBAL) < 0) throw IoError(path.string() + ": flush failed");
  }
  out.commit();
}

Bed readBed(const fs::path& path) {
  const Ctx ctx{path.string()};
  Handle file = openForRead(path, ctx);
  const hid_t f = file.get();
  Handle root(H5Gopen2(f, "/", H5P_DEFAULT), H5Gclose);
  if (!root.ok()) ctx.io("cannot open root group");

  if (H5Aexists(root.get(), "format") <= 0) ctx.format("root attribute 'format' is missing");
  const std::string fmt = readStringAttr(ctx, root.get(), "format");
  if (fmt != "voxpack-bed") ctx.format("root attribute format is '" + fmt + "', not 'voxpack-bed'");
  if (H5Aexists(root.get(), "format_version") <= 0)
    ctx.format("root attribute 'format_version' is missing");
  const auto ver = readDoubleAttr(ctx, root.get(), "format_version");
  if (ver.size() != 1 || ver[0] != 1.0)
    ctx.format("unsupported format_version (this voxpack reads version 1)");

  Lattice lattice;
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
    Handle ds(H5Dopen2(f, "/indicator", H5P_DEFAULT), H5Dclose);
    if (!ds.ok()) ctx.format("/indicator is not a dataset");
    const auto shape = datasetShape(ds.get());
    if (shape.size() != 3)
      ctx.format("/indicator must have rank 3 [nz,ny,nx], found rank " +
                 std::to_string(shape.size()));
    for (int a = 0; a < 3; ++a) {
      lattice.dims[static_cast<std::size_t>(a)] =
          static_cast<std::int64_t>(shape[static_cast<std::size_t>(a)]);
      if (shape[static_cast<std::size_t>(a)] == 0) ctx.format("/indicator has a zero dimension");
    }
  }
  Bed bed;
  bed.indicator = readVolume<std::uint8_t>(ctx, f, "/indicator", lattice, true);
  if (linkExists(f, "/mask")) bed.mask = readVolume<std::uint8_t>(ctx, f, "/mask", lattice, true);
  if (linkExists(f, "/labels"))
    bed.labels = readVolume<std::uint32_t>(ctx, f, "/labels", lattice, false);

  if (linkExists(f, "/particles/position_mm")) {
    std::size_t rows = 0;
    const auto pos = readMatrix(ctx, f, "/particles/position_mm", 3, rows);
    for (std::size_t r = 0; r < rows; ++r)
      bed.particles.positionMm.emplace_back(pos[3 * r], pos[3 * r + 1], pos[3 * r + 2]);
    if (linkExists(f, "/particles/orientation")) {
      std::size_t qr = 0;
      const auto q = readMatrix(ctx, f, "/particles/orientation", 4, qr);
      for (std::size_t r = 0; r < qr; ++r)
        bed.particles.orientation.emplace_back(q[4 * r], q[4 * r + 1], q[4 * r + 2], q[4 * r + 3]);
    }
    if (linkExists(f, "/particles/shape")) {
      Handle ds(H5Dopen2(f, "/particles/shape", H5P_DEFAULT), H5Dclose);
      Handle type(H5Dget_type(ds.get()), H5Tclose);
      bed.particles.shape = H5Tget_class(type.get()) == H5T_INTEGER
                                ? readShapeIndices(ctx, f)
                                : readStrings(ctx, f, "/particles/shape");
    }
  }

  if (H5Aexists(root.get(), "provenance") > 0) {
    const std::string text = readStringAttr(ctx, root.get(), "provenance");
    auto parsed = nlohmann::json::parse(text, nullptr, false);
    bed.provenance = parsed.is_discarded() ? nlohmann::json{{"text", text}} : parsed;
  }
  try {
    bed.validate();
  } catch (const FormatError& e) {
    ctx.format(e.what());
  }
  return bed;
}

std::vector<std::string> bedDatasets(const fs::path& path) {
  const Ctx ctx{path.string()};
  Handle file = openForRead(path, ctx);
  std::vector<std::string> out;
  for (const char* p : {"/indicator", "/mask", "/labels", "/particles/position_mm",
                        "/particles/orientation", "/particles/shape"})
    if (linkExists(file.get(), p)) out.emplace_back(p);
  return out;
}

}  // namespace voxpack
