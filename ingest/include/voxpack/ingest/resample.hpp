#pragma once
/// \file resample.hpp
/// Resampling a grey volume onto an isotropic lattice covering the same physical box.

#include "voxpack/core/grid.hpp"

namespace voxpack::ingest {

/// The isotropic lattice of voxel `voxelMm` covering the same box (voxel faces) as `from`:
/// n = max(1, round(extent / voxelMm)) per axis, first centre half a voxel inside the box.
Lattice resampledLattice(const Lattice& from, double voxelMm);

/// Trilinear interpolation of `image` at the voxel centres of `to` (edges clamped). When
/// coarsening, the image is first box-averaged so no input voxel is skipped.
Grid<float> resampleLinear(const Grid<float>& image, const Lattice& to, int threads);

/// Nearest-neighbour resampling of a binary/label field onto `to`.
Grid<std::uint8_t> resampleNearest(const Grid<std::uint8_t>& field, const Lattice& to);

}  // namespace voxpack::ingest
