#pragma once
/// \file dem_geometry.hpp
/// Glue between the DEM and the geometry module: exact shapes and containers as the DEM
/// sees them, and the labelled bed of a finished run.

#include <memory>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/dem.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::packer::dem {

/// A geometry shape seen by the DEM.
std::shared_ptr<const DemShape> demShape(std::shared_ptr<const Shape> shape);

/// A geometry container seen by the DEM, with an open top: above `topMm - marginMm` the
/// walls continue vertically (particles are poured in above the nominal top).
std::shared_ptr<const DemContainer> demContainer(std::shared_ptr<const Container> container,
                                                 double marginMm);

/// Digitises the particles of a run on the container's lattice (voxel `voxelMm`, extended
/// upwards to hold the highest particle): indicator, mask, labels, particle table.
/// A spec of `particles.shape` that `shapes` does not hold is parsed (a size distribution
/// gives every particle its own sphere). Threads over particles; the labels
/// are written in particle order, so a voxel shared by two overlapping particles goes to the
/// lower id whatever the thread count. Solid outside the mask (soft wall overlap) is clipped;
/// its volume (mm^3) goes to `clippedMm3` when given.
Bed demBed(const ParticleTable& particles, const std::vector<std::shared_ptr<const Shape>>& shapes,
           const Container& container, double voxelMm, int supersample, int threads,
           Progress& progress, double* clippedMm3 = nullptr);

}  // namespace voxpack::packer::dem
