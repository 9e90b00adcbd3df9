#pragma once
/// \file container.hpp
/// Containers: an exact inside test in world mm and their digitisation to a mask.
/// Frames: cylinder:d,h has its axis on x = y = 0 from z = 0 to z = h; box:x,y,z spans
/// [-x/2, x/2] x [-y/2, y/2] x [0, z]; mesh:FILE.stl uses the file's coordinates;
/// mask:FILE.h5 uses that bed's lattice and mask.

#include <memory>
#include <string>

#include "voxpack/core/grid.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::packer {

/// A container (the region particles must stay in).
class Container {
 public:
  virtual ~Container() = default;
  /// Canonical spec text.
  virtual std::string spec() const = 0;
  /// Exact inside test of a world point (mm).
  virtual bool inside(const Vec3& pMm) const = 0;
  /// Distance (mm) from an inside point to the wall (> 0 inside, < 0 outside).
  virtual double wallDistanceMm(const Vec3& pMm) const = 0;
  /// Inward unit normal of the wall nearest to pMm.
  virtual Vec3 inwardNormal(const Vec3& pMm) const = 0;
  /// Bounds of the interior.
  virtual BoundsMm boundsMm() const = 0;
  /// Interior volume in mm^3.
  virtual double volumeMm3() const = 0;
  /// Inside flags of the n world points p0 + s * step (s = 0..n-1), as inside() would give.
  virtual void insideRow(const Vec3& p0Mm, const Vec3& stepMm, int n, std::uint8_t* out) const;
  /// For a vertical cylinder: (x, y) of its axis and its radius; false otherwise.
  virtual bool cylinderAxis(double& cxMm, double& cyMm, double& radiusMm) const {
    (void)cxMm;
    (void)cyMm;
    (void)radiusMm;
    return false;
  }
};

/// Parses a container SPEC. Throws InputError / IoError.
std::shared_ptr<const Container> parseContainer(const std::string& spec);

/// A lattice of voxel size `voxelMm` covering the container bounds plus `marginVoxels`
/// voxels on each side (origin chosen so the bounds fall on voxel faces).
Lattice latticeForContainer(const Container& c, double voxelMm, int marginVoxels = 1);

/// The container interior on `lattice`: 1 where the voxel centre is inside (or, with
/// supersample k > 1, where at least half of k^3 samples are inside), else 0. Samples on
/// a wall follow the half-open rule of digitise.hpp (kBoundaryTieBreak).
Grid<std::uint8_t> containerMask(const Container& c, const Lattice& lattice, int supersample = 1);

/// Wall distance (mm, > 0 inside, < 0 outside) of every voxel centre of `lattice`: the
/// container's wall field, as float to halve its memory.
Grid<float> wallDistanceField(const Container& c, const Lattice& lattice);

}  // namespace voxpack::packer
