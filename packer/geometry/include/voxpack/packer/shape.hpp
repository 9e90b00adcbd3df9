#pragma once
/// \file shape.hpp
/// Exact particle shapes ("master shapes"). Body frame: origin at the centre of mass,
/// symmetry axis of axisymmetric shapes along +z (a cylinder's axis is z at identity).
/// Rotations are always applied to the exact shape, never to a voxel set.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>

#include "voxpack/core/bed.hpp"

namespace voxpack::packer {

/// Axis-aligned bounds in mm.
struct BoundsMm {
  Vec3 min = Vec3::Zero();  ///< lower corner (x, y, z)
  Vec3 max = Vec3::Zero();  ///< upper corner (x, y, z)
};

/// An exact solid shape in its body frame (mm).
class Shape {
 public:
  virtual ~Shape() = default;
  /// Canonical spec text, e.g. "cylinder:d=5.4,l=3.8".
  virtual std::string spec() const = 0;
  /// Exact volume in mm^3.
  virtual double volumeMm3() const = 0;
  /// Exact surface area in mm^2.
  virtual double surfaceMm2() const = 0;
  /// Radius of the smallest origin-centred sphere containing the shape (mm).
  virtual double boundingRadiusMm() const = 0;
  /// Inside test of a body-frame point (mm); the boundary counts as inside.
  virtual bool inside(const Vec3& pBodyMm) const = 0;
  /// Signed distance (mm) of a body-frame point: < 0 inside, > 0 outside. Exact where
  /// cheap, otherwise a conservative estimate whose sign is exact and whose magnitude is
  /// exact within `boundingRadius * 1e-3` near the surface (used for sub-voxel overlap).
  virtual double signedDistanceMm(const Vec3& pBodyMm) const = 0;
  /// Outward unit normal at the surface point nearest to pBodyMm (body frame).
  virtual Vec3 normal(const Vec3& pBodyMm) const;
  /// Inertia tensor about the centre of mass per unit density (mm^5), body frame.
  virtual Eigen::Matrix3d inertiaPerDensity() const = 0;
  /// Diameter of the sphere of equal volume (mm).
  double volumeEquivalentDiameterMm() const;
  /// Largest extent used for "particle diameter" in statistics (mm): e.g. d for cylinders.
  virtual double characteristicDiameterMm() const = 0;
  /// Axis-aligned bounds of the shape in its body frame (mm); default +-boundingRadius.
  virtual BoundsMm bodyBoundsMm() const;
  /// Inside flags of the n body-frame points p0 + s * step (s = 0..n-1): out[s] = 1 when
  /// inside (as inside(), except possibly for points within rounding of the surface).
  /// The digitiser's inner loop: one virtual call per row, not per voxel.
  virtual void insideRow(const Vec3& p0, const Vec3& step, int n, std::uint8_t* out) const;
};

/// Parses a shape SPEC (docs/interfaces.md: sphere, cylinder, ring, box, ellipsoid, trilobe,
/// mesh:FILE.stl[,scale=S]). Throws InputError on unknown shapes or bad sizes, IoError
/// on unreadable mesh files.
std::shared_ptr<const Shape> parseShape(const std::string& spec);

/// A closed triangle mesh read from an ASCII or binary STL file, scaled by `scale` and
/// shifted so its centre of mass is the body origin. Throws IoError (unreadable) or
/// InputError (garbage, empty, open or non-manifold mesh), naming the file.
std::shared_ptr<const Shape> meshShape(const std::string& stlPath, double scale = 1.0);

/// Shortest decimal text that reads back to `v` (used in canonical spec texts).
std::string formatNumber(double v);

}  // namespace voxpack::packer
