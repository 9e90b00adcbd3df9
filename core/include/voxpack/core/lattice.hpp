#pragma once
/// \file lattice.hpp
/// The voxel lattice: dimensions, spacing and origin, and the index <-> mm mapping.
///
/// Arrays are C-order [z][y][x] (k, j, i); z is the column axis (up). Spacing and origin
/// are stored in (z, y, x) order as in the bed file; physical points (Eigen::Vector3d)
/// are (x, y, z) in mm. origin is the centre of voxel [0,0,0] (ITK convention).

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>

namespace voxpack {

/// A physical point or vector in mm, (x, y, z).
using Vec3 = Eigen::Vector3d;

/// Lattice index (k, j, i) = (z, y, x).
struct Index3 {
  std::int64_t k = 0;  ///< z index
  std::int64_t j = 0;  ///< y index
  std::int64_t i = 0;  ///< x index
  bool operator==(const Index3&) const = default;
};

/// Geometry of a voxel lattice: sizes, spacing and origin, all (z, y, x).
struct Lattice {
  std::array<std::int64_t, 3> dims{0, 0, 0};     ///< (nz, ny, nx)
  std::array<double, 3> spacingMm{1.0, 1.0, 1.0};  ///< (sz, sy, sx), > 0
  std::array<double, 3> originMm{0.0, 0.0, 0.0};   ///< centre of voxel [0,0,0], (z, y, x)

  /// Lattice of the given dims with isotropic spacing and origin at the first voxel centre.
  static Lattice isotropic(std::int64_t nz, std::int64_t ny, std::int64_t nx, double voxelMm,
                           const Vec3& originXyzMm = Vec3::Zero());

  /// Number of voxels nz*ny*nx.
  std::size_t size() const {
    return static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1]) *
           static_cast<std::size_t>(dims[2]);
  }
  std::int64_t nz() const { return dims[0]; }  ///< voxels along z
  std::int64_t ny() const { return dims[1]; }  ///< voxels along y
  std::int64_t nx() const { return dims[2]; }  ///< voxels along x

  /// Linear offset of (k, j, i) in C order.
  std::size_t offset(std::int64_t k, std::int64_t j, std::int64_t i) const {
    return (static_cast<std::size_t>(k) * static_cast<std::size_t>(dims[1]) +
            static_cast<std::size_t>(j)) *
               static_cast<std::size_t>(dims[2]) +
           static_cast<std::size_t>(i);
  }
  /// Inverse of offset().
  Index3 indexOf(std::size_t offset) const;
  /// True when (k, j, i) lies inside the lattice.
  bool contains(std::int64_t k, std::int64_t j, std::int64_t i) const {
    return k >= 0 && j >= 0 && i >= 0 && k < dims[0] && j < dims[1] && i < dims[2];
  }
  /// Centre of voxel (k, j, i) in mm, (x, y, z).
  Vec3 centerMm(std::int64_t k, std::int64_t j, std::int64_t i) const {
    return {originMm[2] + static_cast<double>(i) * spacingMm[2],
            originMm[1] + static_cast<double>(j) * spacingMm[1],
            originMm[0] + static_cast<double>(k) * spacingMm[0]};
  }
  /// Continuous index (x, y, z order, i.e. (i, j, k)) of a physical point; voxel centres
  /// are integers.
  Vec3 continuousIndex(const Vec3& pMm) const {
    return {(pMm.x() - originMm[2]) / spacingMm[2], (pMm.y() - originMm[1]) / spacingMm[1],
            (pMm.z() - originMm[0]) / spacingMm[0]};
  }
  /// Nearest voxel index of a physical point (may lie outside; check contains()).
  Index3 nearestIndex(const Vec3& pMm) const;
  /// Physical extent (x, y, z) in mm covered by the voxels (n * spacing).
  Vec3 extentMm() const {
    return {static_cast<double>(dims[2]) * spacingMm[2],
            static_cast<double>(dims[1]) * spacingMm[1],
            static_cast<double>(dims[0]) * spacingMm[0]};
  }
  /// Volume of one voxel in mm^3.
  double voxelVolumeMm3() const { return spacingMm[0] * spacingMm[1] * spacingMm[2]; }
  /// True when all three spacings agree to 1e-9 relative.
  bool isIsotropic() const;
  /// Throws InputError unless dims >= 1 and spacing finite and > 0, origin finite.
  void validate(const char* what = "lattice") const;
  bool operator==(const Lattice&) const = default;
};

}  // namespace voxpack
