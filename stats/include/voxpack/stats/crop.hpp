#pragma once
/// \file crop.hpp
/// Region-of-interest cropping of a bed before its statistics (docs/stats.md, "ROI"):
/// keep the voxels whose centres lie in an axis-aligned box given in mm (lattice world
/// coordinates), with the same spacing and an origin shifted so world coordinates are kept.

#include <array>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "voxpack/core/bed.hpp"

namespace voxpack::stats {

/// A closed interval [lo, hi] in mm along one axis.
struct RangeMm {
  double lo = -std::numeric_limits<double>::infinity();  ///< lower bound (mm), <= hi
  double hi = std::numeric_limits<double>::infinity();   ///< upper bound (mm), >= lo
};

/// Options of cropBed: the ROI box. An axis left unbounded keeps every voxel along it.
struct CropOptions {
  std::optional<RangeMm> xMm;  ///< x range (mm), absent = whole lattice along x
  std::optional<RangeMm> yMm;  ///< y range (mm), absent = whole lattice along y
  std::optional<RangeMm> zMm;  ///< z range (mm), absent = whole lattice along z
  /// Tolerance (in voxels, >= 0) by which a centre may miss a bound and still count as
  /// inside; it absorbs the round-off of origin + k * spacing against a bound typed in mm.
  double toleranceVoxels = 1e-9;
};

/// What cropBed kept: the voxel box in the input lattice.
struct CropBox {
  std::array<std::int64_t, 3> first{0, 0, 0};      ///< first kept voxel (k, j, i)
  std::array<std::int64_t, 3> dims{0, 0, 0};       ///< kept voxels (nz, ny, nx), each >= 1
  std::array<std::int64_t, 3> inputDims{0, 0, 0};  ///< dims of the uncropped lattice
};

/// Voxel box of `lattice` whose centres lie in the ROI. Throws InputError on NaN/Inf or
/// reversed bounds, and when no voxel centre lies inside.
CropBox cropBox(const Lattice& lattice, const CropOptions& options);

/// The sub-bed of `bed` inside the ROI: indicator, mask and labels cropped to cropBox();
/// spacing kept, origin moved to the first kept voxel centre (world coordinates unchanged).
/// With labels and a particle table, the table keeps the particles with at least one voxel
/// in the crop and labels are renumbered (in their old order) to match; without labels,
/// the particles whose centre lies in the ROI box (same bounds and tolerance). Provenance
/// is copied. Throws as cropBox().
Bed cropBed(const Bed& bed, const CropOptions& options, CropBox* box = nullptr);

/// Parses "Z0:Z1" (`--roi-mm`) into a z-only CropOptions. Throws InputError on a malformed
/// or non-finite number, or Z1 < Z0.
CropOptions parseRoiZ(const std::string& text);

/// Parses "X0:X1,Y0:Y1,Z0:Z1" (`--roi-box-mm`); an empty range (e.g. "X0:X1,,Z0:Z1" or
/// ":") leaves that axis whole. Throws InputError as parseRoiZ().
CropOptions parseRoiBox(const std::string& text);

/// JSON record of a crop for the stats output key `roi_mm`: `{x, y, z}` each `[lo, hi]` or
/// null (axis not cropped), `first_voxel` (k, j, i), `dims` and `input_dims` (nz, ny, nx).
nlohmann::json roiJson(const CropOptions& options, const CropBox& box);

}  // namespace voxpack::stats
