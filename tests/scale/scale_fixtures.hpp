#pragma once
// Beds for the scale tests: a sphere bed in a cylinder, with headspace and anisotropic
// spacing when asked, and hostile bed files written with the HDF5 C API (tiny files whose
// headers ask for huge work).
#include <hdf5.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/random.hpp"

namespace voxpack::test {

/// Options of sphereColumn.
struct ColumnBed {
  std::int64_t nz = 40, ny = 30, nx = 28;          ///< lattice
  std::array<double, 3> spacingMm{0.2, 0.2, 0.2};  ///< (z, y, x)
  double radiusVox = 3.2;                          ///< sphere radius (x voxels)
  std::int64_t packedPlanes = -1;                  ///< spheres only below this plane (-1: all)
  bool mask = true;                                ///< cylinder mask
  bool taperedMask = false;                        ///< mask radius changes with z (not a prism)
  bool labels = false;                             ///< /labels
  std::uint64_t seed = 5;                          ///< sphere centres
};

/// Overlapping spheres at random in a cylinder (void 1, solid 0), with their table.
inline Bed sphereColumn(const ColumnBed& o) {
  Bed bed;
  Lattice l;
  l.dims = {o.nz, o.ny, o.nx};
  l.spacingMm = o.spacingMm;
  l.originMm = {0.1, -0.5 * o.ny * o.spacingMm[1], -0.5 * o.nx * o.spacingMm[2]};
  bed.indicator = Grid<std::uint8_t>(l, 1);
  if (o.labels) bed.labels = Grid<std::uint32_t>(l, 0);
  const double cx = 0.5 * (o.nx - 1), cy = 0.5 * (o.ny - 1);
  auto maskRadius = [&](std::int64_t k) {
    const double r = 0.5 * static_cast<double>(std::min(o.nx, o.ny)) - 1;
    return o.taperedMask ? r * (0.75 + 0.25 * static_cast<double>(k) / static_cast<double>(o.nz))
                         : r;
  };
  if (o.mask) {
    bed.mask = Grid<std::uint8_t>(l, 0);
    for (std::int64_t k = 0; k < o.nz; ++k)
      for (std::int64_t j = 0; j < o.ny; ++j)
        for (std::int64_t i = 0; i < o.nx; ++i) {
          const double dx = (i - cx) * o.spacingMm[2], dy = (j - cy) * o.spacingMm[1];
          const double r = maskRadius(k) * o.spacingMm[2];
          (*bed.mask)(k, j, i) = dx * dx + dy * dy <= r * r;
        }
  }
  RandomStream rng(o.seed, 0);
  const std::int64_t top = o.packedPlanes < 0 ? o.nz : o.packedPlanes;
  const double rMm = o.radiusVox * o.spacingMm[2];
  const int count =
      static_cast<int>(0.35 * static_cast<double>(top * o.ny * o.nx) * o.spacingMm[0] *
                       o.spacingMm[1] * o.spacingMm[2] / (4.18879 * rMm * rMm * rMm));
  for (int p = 0; p < count; ++p) {
    const Vec3 c(rng.uniform(0, o.nx - 1) * o.spacingMm[2],
                 rng.uniform(0, o.ny - 1) * o.spacingMm[1],
                 rng.uniform(0, static_cast<double>(top - 1)) * o.spacingMm[0]);
    // Only the sphere's bounding box of voxels (fixtures of 10^7 voxels stay fast).
    auto range = [&](double centre, double s, std::int64_t n, std::int64_t& lo, std::int64_t& hi) {
      lo = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor((centre - rMm) / s)));
      hi = std::min<std::int64_t>(n - 1, static_cast<std::int64_t>(std::ceil((centre + rMm) / s)));
    };
    std::int64_t k0, k1, j0, j1, i0, i1;
    range(c.z(), o.spacingMm[0], top, k0, k1);
    range(c.y(), o.spacingMm[1], o.ny, j0, j1);
    range(c.x(), o.spacingMm[2], o.nx, i0, i1);
    for (std::int64_t k = k0; k <= k1; ++k)
      for (std::int64_t j = j0; j <= j1; ++j)
        for (std::int64_t i = i0; i <= i1; ++i) {
          const Vec3 x(i * o.spacingMm[2], j * o.spacingMm[1], k * o.spacingMm[0]);
          if ((x - c).squaredNorm() <= rMm * rMm) {
            bed.indicator(k, j, i) = 0;
            if (bed.labels) (*bed.labels)(k, j, i) = static_cast<std::uint32_t>(p + 1);
          }
        }
    const Vec3 origin(l.originMm[2], l.originMm[1], l.originMm[0]);
    bed.particles.positionMm.push_back(origin + c);
    bed.particles.orientation.push_back(Quat::Identity());
    bed.particles.shape.push_back("sphere:d=" + std::to_string(2 * rMm));
  }
  bed.provenance = {{"test", "sphereColumn"}};
  return bed;
}

/// Writes a bed file by hand: root attributes, and datasets of the given shapes that are
/// chunked and never written (the file stays a few KB whatever the shapes declare).
class HostileFile {
 public:
  explicit HostileFile(const std::filesystem::path& path) {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    file_ = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    const hid_t root = H5Gopen2(file_, "/", H5P_DEFAULT);
    hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, 11);
    hid_t space = H5Screate(H5S_SCALAR);
    hid_t a = H5Acreate2(root, "format", type, space, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(a, type, "voxpack-bed");
    H5Aclose(a);
    const long long one = 1;
    a = H5Acreate2(root, "format_version", H5T_STD_I64LE, space, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(a, H5T_NATIVE_LLONG, &one);
    H5Aclose(a);
    H5Sclose(space);
    H5Tclose(type);
    const hsize_t three = 3;
    const double spacing[3] = {0.1, 0.1, 0.1}, origin[3] = {0, 0, 0};
    space = H5Screate_simple(1, &three, nullptr);
    for (auto [name, v] : {std::pair{"spacing_mm", spacing}, std::pair{"origin_mm", origin}}) {
      a = H5Acreate2(root, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT);
      H5Awrite(a, H5T_NATIVE_DOUBLE, v);
      H5Aclose(a);
    }
    H5Sclose(space);
    H5Gclose(root);
  }
  ~HostileFile() { H5Fclose(file_); }
  /// A chunked dataset of `dims` (not written: reads give the fill value 0).
  void empty(const char* path, std::vector<hsize_t> dims, hid_t type) {
    std::vector<hsize_t> chunk(dims.size());
    for (std::size_t a = 0; a < dims.size(); ++a) chunk[a] = std::min<hsize_t>(dims[a], 16);
    const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
    const hid_t plist = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(plist, static_cast<int>(chunk.size()), chunk.data());
    const hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    H5Pset_create_intermediate_group(lcpl, 1);
    const hid_t ds = H5Dcreate2(file_, path, type, space, lcpl, plist, H5P_DEFAULT);
    H5Dclose(ds);
    H5Pclose(lcpl);
    H5Pclose(plist);
    H5Sclose(space);
  }
  /// A dataset written from `data` (C order, `dims`).
  template <class T>
  void full(const char* path, std::vector<hsize_t> dims, hid_t fileType, hid_t memType,
            const std::vector<T>& data) {
    const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
    const hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    H5Pset_create_intermediate_group(lcpl, 1);
    const hid_t ds = H5Dcreate2(file_, path, fileType, space, lcpl, H5P_DEFAULT, H5P_DEFAULT);
    H5Dwrite(ds, memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data());
    H5Dclose(ds);
    H5Pclose(lcpl);
    H5Sclose(space);
  }

 private:
  hid_t file_ = -1;
};

}  // namespace voxpack::test
