#pragma once
// Private pieces of the streamed ingest path (stream_*.cpp), shared between its files.
#include <cstdint>
#include <vector>

#include "voxpack/core/grid.hpp"

namespace voxpack::ingest::stream_detail {

/// Planes [from, to) of `g` (local indices) as their own grid, origin moved along.
Grid<std::uint8_t> cropPlanes(const Grid<std::uint8_t>& g, std::int64_t from, std::int64_t to);
/// Planes [from, to) of a float grid.
Grid<float> cropPlanes(const Grid<float>& g, std::int64_t from, std::int64_t to);

/// Solid-chord sums of voxelsPerDiameter (quality.cpp), accumulated slab by slab.
struct ChordSums {
  double total = 0;                ///< sum of chord lengths, voxels (an integer)
  double count = 0;                ///< chords (an integer)
  std::vector<std::int64_t> run;   ///< z: open run length per (j, i)
  std::vector<std::uint8_t> open;  ///< z: run began after a void voxel inside the region
  /// Chords along x and y of the planes of `ind` (a slab's own planes).
  void addInPlane(const Grid<std::uint8_t>& ind, const Grid<std::uint8_t>* region);
  /// Chords along z, continuing the runs of the previous slab; call for slabs in z order.
  void addAlongZ(const Grid<std::uint8_t>& ind, const Grid<std::uint8_t>* region);
  /// 1.5 x the mean chord (0 without chords), as voxelsPerDiameter.
  double diameter() const { return count > 0 ? 1.5 * total / count : 0.0; }
};

}  // namespace voxpack::ingest::stream_detail
