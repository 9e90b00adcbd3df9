#pragma once
// Geometry shared by the column mask and the wall-blur correction (not public).
#include <cstdint>

#include "voxpack/ingest/column.hpp"

namespace voxpack::ingest::column_detail {

/// Calls f(j, i, r2) for every voxel centre of plane k, r2 its squared distance (mm^2) from
/// the column's (possibly tilted) axis at that plane's height.
template <class F>
void forEachInPlane(const Lattice& l, const ColumnFit& c, std::int64_t k, F&& f) {
  const double z = l.originMm[0] + static_cast<double>(k) * l.spacingMm[0];
  const double ax = c.axisXMm + c.slopeX * (z - c.zRefMm);
  const double ay = c.axisYMm + c.slopeY * (z - c.zRefMm);
  for (std::int64_t j = 0; j < l.ny(); ++j) {
    const double dy = l.originMm[1] + static_cast<double>(j) * l.spacingMm[1] - ay;
    for (std::int64_t i = 0; i < l.nx(); ++i) {
      const double dx = l.originMm[2] + static_cast<double>(i) * l.spacingMm[2] - ax;
      f(j, i, dx * dx + dy * dy);
    }
  }
}

}  // namespace voxpack::ingest::column_detail
