// XDMF sidecar and VTKHDF image: both describe the bed's 3-D datasets on its uniform grid.
// XDMF writes voxels as cells (the grid's points are the voxel corners, origin - s/2), so
// ParaView shows each voxel as a box; VTKHDF writes them as points at the voxel centres
// (origin = the bed's origin), the layout VTK 9.1's reader handles (see writeVtkHdf).
#include <hdf5.h>

#include <array>
#include <iomanip>
#include <sstream>

#include "voxpack/core/atomic_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/export/formats.hpp"

namespace voxpack::exporter {
namespace fs = std::filesystem;
namespace {

// Closes an HDF5 handle at scope exit.
struct H5Handle {
  hid_t id = -1;
  herr_t (*close)(hid_t) = nullptr;
  H5Handle(hid_t i, herr_t (*c)(hid_t)) : id(i), close(c) {}
  ~H5Handle() {
    if (id >= 0 && close) close(id);
  }
  H5Handle(const H5Handle&) = delete;
  H5Handle& operator=(const H5Handle&) = delete;
  operator hid_t() const { return id; }
};

struct DatasetInfo {
  std::string path;           // "/indicator"
  std::vector<hsize_t> dims;  // as stored
  std::string numberType;     // XDMF NumberType
  int precision = 1;          // bytes
};

struct BedLayout {
  std::array<hsize_t, 3> dims{};    // nz, ny, nx
  std::array<double, 3> spacing{};  // z, y, x
  std::array<double, 3> origin{};   // z, y, x (voxel centre)
  std::vector<DatasetInfo> fields;  // datasets on the lattice
};

herr_t visitDataset(hid_t obj, const char* name, const H5O_info_t* info, void* data) {
  if (info->type != H5O_TYPE_DATASET) return 0;
  auto* out = static_cast<std::vector<DatasetInfo>*>(data);
  H5Handle ds(H5Dopen2(obj, name, H5P_DEFAULT), H5Dclose);
  if (ds < 0) return 0;
  H5Handle space(H5Dget_space(ds), H5Sclose);
  H5Handle type(H5Dget_type(ds), H5Tclose);
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 3 || rank > 4) return 0;
  DatasetInfo d;
  d.path = std::string("/") + name;
  d.dims.resize(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(space, d.dims.data(), nullptr);
  const H5T_class_t cls = H5Tget_class(type);
  d.precision = static_cast<int>(H5Tget_size(type));
  if (cls == H5T_FLOAT) {
    d.numberType = "Float";
  } else if (cls == H5T_INTEGER) {
    const bool isSigned = H5Tget_sign(type) == H5T_SGN_2;
    d.numberType = d.precision == 1 ? (isSigned ? "Char" : "UChar") : (isSigned ? "Int" : "UInt");
  } else {
    return 0;
  }
  out->push_back(std::move(d));
  return 0;
}

void readAttribute(hid_t file, const char* name, std::array<double, 3>& out, const fs::path& path) {
  if (H5Aexists(file, name) <= 0)
    throw FormatError(path.string() + ": root attribute " + name + " missing");
  H5Handle a(H5Aopen(file, name, H5P_DEFAULT), H5Aclose);
  H5Handle space(H5Aget_space(a), H5Sclose);
  if (H5Sget_simple_extent_npoints(space) != 3 || H5Aread(a, H5T_NATIVE_DOUBLE, out.data()) < 0)
    throw FormatError(path.string() + ": root attribute " + name + " is not float64[3]");
}

BedLayout readLayout(const fs::path& bedPath) {
  H5E_auto2_t func = nullptr;
  void* clientData = nullptr;
  H5Eget_auto2(H5E_DEFAULT, &func, &clientData);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  struct Restore {
    H5E_auto2_t f;
    void* c;
    ~Restore() { H5Eset_auto2(H5E_DEFAULT, f, c); }
  } restore{func, clientData};
  if (!fs::exists(bedPath)) throw IoError(bedPath.string() + ": no such file");
  H5Handle file(H5Fopen(bedPath.string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (file < 0) throw IoError(bedPath.string() + ": cannot open as HDF5");
  BedLayout l;
  readAttribute(file, "spacing_mm", l.spacing, bedPath);
  readAttribute(file, "origin_mm", l.origin, bedPath);
  std::vector<DatasetInfo> all;
  H5Ovisit(file, H5_INDEX_NAME, H5_ITER_NATIVE, visitDataset, &all);
  const DatasetInfo* indicator = nullptr;
  for (const auto& d : all)
    if (d.path == "/indicator" && d.dims.size() == 3) indicator = &d;
  if (!indicator) throw FormatError(bedPath.string() + ": no 3-D /indicator dataset");
  for (int a = 0; a < 3; ++a) l.dims[a] = indicator->dims[a];
  for (const auto& d : all) {
    const bool onLattice =
        d.dims[0] == l.dims[0] && d.dims[1] == l.dims[1] && d.dims[2] == l.dims[2];
    const bool shapeOk = d.dims.size() == 3 || (d.dims.size() == 4 && d.dims[3] == 3);
    if (onLattice && shapeOk) l.fields.push_back(d);
  }
  return l;
}

std::string dimsText(const std::vector<hsize_t>& dims) {
  std::string s;
  for (std::size_t n = 0; n < dims.size(); ++n) s += (n ? " " : "") + std::to_string(dims[n]);
  return s;
}

std::string fieldName(const std::string& path) {
  std::string n = path.substr(1);
  for (char& c : n)
    if (c == '/') c = '_';
  return n;
}

}  // namespace

LatticeDatasets readLatticeDatasets(const fs::path& bedPath) {
  const BedLayout l = readLayout(bedPath);
  LatticeDatasets h;
  for (int a = 0; a < 3; ++a) h.dims[a] = l.dims[a];
  for (const auto& d : l.fields) {
    h.fields.push_back(d.path);
    std::uint64_t b = static_cast<std::uint64_t>(d.precision);
    for (hsize_t x : d.dims) b *= x;
    h.bytesOnLattice += b;
  }
  return h;
}

std::vector<std::string> writeXdmf(const fs::path& bedPath, const fs::path& out) {
  const BedLayout l = readLayout(bedPath);
  fs::path ref = fs::absolute(bedPath);
  std::error_code ec;
  const fs::path rel = fs::relative(fs::absolute(bedPath), fs::absolute(out).parent_path(), ec);
  if (!ec && !rel.empty()) ref = rel;
  std::ostringstream x;
  x << std::setprecision(17);
  x << "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
    << "<Xdmf Version=\"3.0\">\n  <Domain>\n    <Grid Name=\"bed\" GridType=\"Uniform\">\n"
    << "      <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"" << l.dims[0] + 1 << ' '
    << l.dims[1] + 1 << ' ' << l.dims[2] + 1 << "\"/>\n"
    << "      <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
    << "        <DataItem Name=\"Origin\" Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" "
       "Format=\"XML\">"
    << l.origin[0] - l.spacing[0] / 2 << ' ' << l.origin[1] - l.spacing[1] / 2 << ' '
    << l.origin[2] - l.spacing[2] / 2 << "</DataItem>\n"
    << "        <DataItem Name=\"Spacing\" Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" "
       "Format=\"XML\">"
    << l.spacing[0] << ' ' << l.spacing[1] << ' ' << l.spacing[2] << "</DataItem>\n"
    << "      </Geometry>\n";
  std::vector<std::string> paths;
  for (const auto& d : l.fields) {
    x << "      <Attribute Name=\"" << fieldName(d.path) << "\" AttributeType=\""
      << (d.dims.size() == 4 ? "Vector" : "Scalar") << "\" Center=\"Cell\">\n"
      << "        <DataItem Dimensions=\"" << dimsText(d.dims) << "\" NumberType=\"" << d.numberType
      << "\" Precision=\"" << d.precision << "\" Format=\"HDF\">" << ref.string() << ':' << d.path
      << "</DataItem>\n      </Attribute>\n";
    paths.push_back(d.path);
  }
  x << "    </Grid>\n  </Domain>\n</Xdmf>\n";
  writeTextFileAtomic(out, x.str());
  return paths;
}

std::vector<std::string> writeVtkHdf(const fs::path& bedPath, const fs::path& out,
                                     const VtkHdfOptions& options) {
  const BedLayout l = readLayout(bedPath);
  AtomicOutput atomic(out);
  std::vector<std::string> paths;
  {
    H5Handle src(H5Fopen(bedPath.string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    H5Handle dst(
        H5Fcreate(atomic.tempPath().string().c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT),
        H5Fclose);
    if (src < 0) throw IoError(bedPath.string() + ": cannot open");
    if (dst < 0) throw IoError(out.string() + ": cannot create");
    H5Handle root(H5Gcreate2(dst, "/VTKHDF", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    auto attr = [&](const char* name, hid_t memType, hsize_t n, const void* data) {
      H5Handle space(H5Screate_simple(1, &n, nullptr), H5Sclose);
      H5Handle a(
          H5Acreate2(root, name, memType == H5T_NATIVE_DOUBLE ? H5T_IEEE_F64LE : H5T_STD_I64LE,
                     space, H5P_DEFAULT, H5P_DEFAULT),
          H5Aclose);
      if (a < 0 || H5Awrite(a, memType, data) < 0)
        throw IoError(out.string() + ": cannot write attribute " + name);
    };
    const long long version[2] = {1, 0};
    attr("Version", H5T_NATIVE_LLONG, 2, version);
    // Point data on the voxel centres: VTK 9.1's vtkHDFReader reads CellData of an image
    // with the point counts (it fails on n+1-point extents), so voxels are points here.
    const long long extent[6] = {0, static_cast<long long>(l.dims[2]) - 1,
                                 0, static_cast<long long>(l.dims[1]) - 1,
                                 0, static_cast<long long>(l.dims[0]) - 1};
    attr("WholeExtent", H5T_NATIVE_LLONG, 6, extent);
    // VTK's order is (x, y, z); the bed's is (z, y, x). Points are voxel centres.
    const double origin[3] = {l.origin[2], l.origin[1], l.origin[0]};
    const double spacing[3] = {l.spacing[2], l.spacing[1], l.spacing[0]};
    const double direction[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    attr("Origin", H5T_NATIVE_DOUBLE, 3, origin);
    attr("Spacing", H5T_NATIVE_DOUBLE, 3, spacing);
    attr("Direction", H5T_NATIVE_DOUBLE, 9, direction);
    {
      // A fixed-length ASCII string, as VTK's own writers and h5py's np.bytes_ make it.
      const std::string type = "ImageData";
      H5Handle st(H5Tcopy(H5T_C_S1), H5Tclose);
      H5Tset_size(st, type.size());
      H5Tset_strpad(st, H5T_STR_NULLPAD);
      H5Handle space(H5Screate(H5S_SCALAR), H5Sclose);
      H5Handle a(H5Acreate2(root, "Type", st, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
      if (a < 0 || H5Awrite(a, st, type.data()) < 0)
        throw IoError(out.string() + ": cannot write attribute Type");
    }
    H5Handle cells(H5Gcreate2(root, "PointData", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    std::error_code ec;
    fs::path target = fs::relative(fs::absolute(bedPath), fs::absolute(out).parent_path(), ec);
    if (ec || target.empty()) target = fs::absolute(bedPath);
    for (const auto& d : l.fields) {
      const std::string name = fieldName(d.path);
      herr_t rc = options.link
                      ? H5Lcreate_external(target.string().c_str(), d.path.c_str(), cells,
                                           name.c_str(), H5P_DEFAULT, H5P_DEFAULT)
                      : H5Ocopy(src, d.path.c_str(), cells, name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
      if (rc < 0) throw IoError(out.string() + ": cannot write " + d.path);
      paths.push_back(d.path);
    }
  }
  atomic.commit();
  return paths;
}

}  // namespace voxpack::exporter
