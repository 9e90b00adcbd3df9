#pragma once
/// \file column.hpp
/// The container's inner cylinder fitted from a segmented volume (axis, possibly tilted,
/// and inner radius; the column may leave the field of view), refined to sub-voxel
/// accuracy on the grey image from the step at the wall, and its mask.

#include <cstdint>
#include <string>

#include "voxpack/core/grid.hpp"

namespace voxpack::ingest {

/// A fitted (or given) column: axis x(z) = axisXMm + slopeX (z - zRefMm), same for y.
struct ColumnFit {
  bool found = false;            ///< false when no column was seen (then no mask)
  double axisXMm = 0.0;          ///< axis x at z = zRefMm, mm (frame of the voxel centres)
  double axisYMm = 0.0;          ///< axis y at z = zRefMm, mm
  double slopeX = 0.0;           ///< dx/dz of the axis (dimensionless)
  double slopeY = 0.0;           ///< dy/dz of the axis
  double zRefMm = 0.0;           ///< reference height of axisX/YMm (mid-height of the image), mm
  double radiusMm = 0.0;         ///< inner radius, mm
  int slabs = 0;                 ///< slabs used in the fit
  double radiusSpreadMm = 0.0;   ///< max - min radius over the slabs, mm
  double radiusStdMm = 0.0;      ///< standard uncertainty of radiusMm (scatter / sqrt(n)), mm
  bool touchesBorder = false;    ///< the circle leaves the field of view
  bool refined = false;          ///< true when the grey-level wall step refined the fit
  double blurMm = 0.0;           ///< Gaussian sigma of the wall's edge-spread function, mm
  double wallThicknessMm = 0.0;  ///< wall thickness seen in the grey profile, mm (0: unknown)
  bool wallResolved = true;      ///< false: thinner than the fit resolves, thickness held
  int sectors = 0;               ///< slab x sector edge fits used by the refinement
  double wallLevel = 0.0;        ///< grey level of the wall (refined, grey-value fit; else 0)
  double outsideLevel = 0.0;     ///< grey level beyond the wall (refined, grey-value fit; else 0)
  std::string note;              ///< why none was found, or how it was set
};

/// Options of fitColumn.
struct ColumnFitOptions {
  int slabSlices = 32;  ///< slices per slab fitted on its own, >= 4 (whole image if fewer)
  double solidFraction =
      0.9;  ///< a pixel is "always solid" in a slab when solid in >= this fraction, (0.5, 1]
};

/// Fits the column on a segmentation: per slab, pixels solid through (almost) the whole
/// slab form the wall (and, in MRI, the signal-free outside); the column is the open
/// region they bound (enclosed, or cut by the image border). A robust circle fit to the
/// points between that region and the wall gives centre and radius per slab; the slab
/// centres give the axis (least squares in z), the median slab radius the radius.
ColumnFit fitColumn(const Grid<std::uint8_t>& indicator, const ColumnFitOptions& options = {});

/// Options of refineColumn.
struct ColumnRefineOptions {
  int slabSlices = 32;   ///< slices per slab, as in fitColumn
  int sectors = 16;      ///< angular sectors fitted on their own per slab, >= 6
  int iterations = 2;    ///< re-centre and re-fit passes, >= 1
  bool squared = false;  ///< fit M^2 (MRI magnitude, Rician noise, signal-free wall): unbiased
  /// > 0: the wall's thickness in mm, known (held in the grey fit; not used when squared,
  /// whose signal-free wall has no thickness to see); 0: fitted, >= 2.5 voxels.
  double wallThicknessMm = 0.0;
};

/// Sub-voxel refinement on the grey `image` (after denoising): the radial profile about
/// the axis is fitted with a blurred step at R between the bed (level + slope) and the
/// wall (and the outside beyond it): once over the whole column for R, blur and wall
/// thickness, then per slab and sector for R alone; a circle through the sector edges
/// re-centres each slab. Returns `rough` unchanged (refined = false) when the step is not
/// seen.
ColumnFit refineColumn(const Grid<float>& image, const ColumnFit& rough,
                       const ColumnRefineOptions& options = {});

/// How correctWallBlur divides the blurred wall out of the grey values next to it.
struct WallBlurCorrection {
  double blurMm = 0.0;           ///< Gaussian sigma of the wall's edge-spread function, mm
  bool rician = false;           ///< MRI magnitude and a signal-free wall (else grey levels, below)
  double noiseSigma = 0.0;       ///< rician: channel noise sigma (0: plain division by w)
  double wallLevel = 0.0;        ///< grey levels: the wall's level
  double outsideLevel = 0.0;     ///< grey levels: the level beyond the wall
  double wallThicknessMm = 0.0;  ///< grey levels: wall thickness (0: no outside term)
  double reachSigmas = 4.0;      ///< voxels within this many blur sigma of the wall are corrected
};

/// Voxels whose centre lies inside the column within reachSigmas x blur of the wall: the
/// blurred inside indicator of a planar wall at R, w = Phi((R - r) / blur) (> 0.5 there; the
/// column refinement's model), is divided out. Grey levels: I' = (I - L_wall (1 - w) -
/// (L_out - L_wall) Phi((r - R - T) / blur)) / w. Rician (signal A = w A_bed):
/// M'^2 = (M^2 - 2 sigma^2) / w^2 + 2 sigma^2, the mean square of a voxel of signal A_bed.
/// Returns the voxels changed (none when the column is not found or the blur is not > 0).
std::size_t correctWallBlur(Grid<float>& image, const ColumnFit& column,
                            const WallBlurCorrection& correction, int threads);

/// Recomputes `filtered` (the 7-point median of `source`, or the (2r+1)^3 box median when
/// `box`) at every voxel whose window holds a voxel correctWallBlur changes.
void refilterNearWall(Grid<float>& filtered, const Grid<float>& source, const ColumnFit& column,
                      const WallBlurCorrection& correction, int medianRadius, bool box,
                      int threads);

/// Mask of the voxels whose centre lies strictly inside the column (1 inside, 0 outside).
Grid<std::uint8_t> columnMask(const Lattice& lattice, const ColumnFit& column);

/// Mask of the voxels whose centre lies within radius - marginMm of the axis.
Grid<std::uint8_t> columnCoreMask(const Lattice& lattice, const ColumnFit& column, double marginMm);

}  // namespace voxpack::ingest
