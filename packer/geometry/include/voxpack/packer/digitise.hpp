#pragma once
/// \file digitise.hpp
/// Digitisation of an exact shape at a pose (centre + unit quaternion) on a lattice.

#include <array>
#include <cstdint>
#include <vector>

#include "voxpack/core/lattice.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::packer {

/// Face bits of a surface voxel: bit f set when face f is out-facing (its neighbour is
/// not in the particle). Face order: -x, +x, -y, +y, -z, +z.
enum FaceBit : std::uint8_t {
  kFaceMinusX = 1,
  kFacePlusX = 2,
  kFaceMinusY = 4,
  kFacePlusY = 8,
  kFaceMinusZ = 16,
  kFacePlusZ = 32
};

/// A voxel of a digital particle, absolute lattice index (may lie outside the lattice).
struct Voxel {
  std::int32_t k = 0, j = 0, i = 0;  ///< (z, y, x)
  bool operator==(const Voxel&) const = default;
  auto operator<=>(const Voxel&) const = default;
};

/// The half-open boundary rule shared by shapes, meshes, containers and masks: a sample
/// point p counts as inside when p + kBoundaryTieBreak * (sx, sy, sz) is inside the closed
/// solid. A face lying on a plane of sample points thus belongs to one side only (a solid
/// owns [min, max) along each axis), so a 4 mm box at 0.5 mm is 8 voxels across, not 9.
/// The shift (a fraction of a voxel) is far above coordinate rounding (~1e-13 voxel for
/// lattices of 1e3 voxels) and far below anything that changes a random pose: the mean
/// digitisation error over random poses is unchanged (docs/digitisation.md).
inline constexpr double kBoundaryTieBreak = 1e-7;

/// Options of digitise().
struct DigitiseOptions {
  /// Samples per axis per voxel (k^3 samples, solid when at least half inside). 1 = voxel
  /// centre test. Range 1..8.
  int supersample = 1;
};

/// The digital particle at one pose.
struct DigitalParticle {
  std::vector<Voxel> voxels;               ///< solid voxels, sorted by (k, j, i)
  std::vector<std::uint32_t> surface;      ///< indices into voxels with >= 1 out-facing face
  std::vector<std::uint8_t> surfaceFaces;  ///< FaceBit mask per entry of `surface`
  std::size_t faceCount = 0;               ///< number of out-facing faces
  Vec3 centreOfMassMm = Vec3::Zero();      ///< digital centre of mass (world mm)
  Eigen::Matrix3d inertiaPerDensity = Eigen::Matrix3d::Zero();  ///< digital, about COM, mm^5
  double voxelVolumeMm3 = 0;                                    ///< volume of one voxel
  /// Digital volume: voxel count * voxel volume.
  double volumeMm3() const { return static_cast<double>(voxels.size()) * voxelVolumeMm3; }
  /// Digital surface: out-facing faces * face areas (voxel-face surface, paper Fig. 2).
  double faceSurfaceMm2 = 0;
};

/// Digitises `shape` with its centre of mass at `centreMm` and orientation `q` (unit;
/// body -> world) on `lattice` (only spacing and origin are used; voxels outside the
/// lattice dims are kept). Boundary samples follow kBoundaryTieBreak. Throws InputError for a
/// non-unit/zero quaternion.
DigitalParticle digitise(const Shape& shape, const Vec3& centreMm, const Quat& q,
                         const Lattice& lattice, const DigitiseOptions& options = {});

/// Peak bytes of one digitise() of `shape` at voxel size `voxelMm` in any pose (its
/// bounding-sphere box bitmap plus the voxel and surface lists), for the memory budget.
std::uint64_t digitiseMemoryEstimateBytes(const Shape& shape, double voxelMm);

/// Normalises a user quaternion (w, x, y, z); InputError when its norm is ~0 or not finite.
Quat normalisedQuaternion(double w, double x, double y, double z);

}  // namespace voxpack::packer
