#pragma once
/// \file column.hpp
/// The container's inner cylinder fitted from a segmented volume: axis (possibly tilted)
/// and inner radius, and its mask.

#include <cstdint>
#include <string>

#include "voxpack/core/grid.hpp"

namespace voxpack::ingest {

/// A fitted (or given) column: axis x(z) = axisXMm + slopeX (z - zRefMm), same for y.
struct ColumnFit {
  bool found = false;           ///< false when no enclosed column was seen (then no mask)
  double axisXMm = 0.0;         ///< axis x at z = zRefMm, mm (frame of the voxel centres)
  double axisYMm = 0.0;         ///< axis y at z = zRefMm, mm
  double slopeX = 0.0;          ///< dx/dz of the axis (dimensionless)
  double slopeY = 0.0;          ///< dy/dz of the axis
  double zRefMm = 0.0;          ///< reference height of axisX/YMm (mid-height of the image), mm
  double radiusMm = 0.0;        ///< inner radius, mm
  int slabs = 0;                ///< slabs used in the fit
  double radiusSpreadMm = 0.0;  ///< max - min radius over the slabs, mm
  std::string note;             ///< why none was found, or how it was set
};

/// Options of fitColumn.
struct ColumnFitOptions {
  int slabSlices = 32;  ///< slices per slab fitted on its own, >= 4 (whole image if fewer)
  double solidFraction =
      0.9;  ///< a pixel is "always solid" in a slab when solid in >= this fraction, (0.5, 1]
};

/// Fits the column: per slab, pixels solid through (almost) the whole slab form the wall
/// and the outside (MRI) or the wall alone (XMT, air outside); the column is what that
/// solid set encloses. The slab centroids give the axis (least squares in z), the median
/// slab radius sqrt(area/pi) the radius. found = false when nothing is enclosed.
ColumnFit fitColumn(const Grid<std::uint8_t>& indicator, const ColumnFitOptions& options = {});

/// Mask of the voxels whose centre lies strictly inside the column (1 inside, 0 outside).
Grid<std::uint8_t> columnMask(const Lattice& lattice, const ColumnFit& column);

}  // namespace voxpack::ingest
