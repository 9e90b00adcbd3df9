#pragma once
/// \file segment.hpp
/// Two-phase segmentation of a grey volume into the indicator field (1 void, 0 solid):
/// global threshold (Otsu, two-class k-means or a given value), polarity, and clean-up of
/// specks and of small holes inside particles.

#include <algorithm>
#include <cstdint>

#include "voxpack/core/grid.hpp"

namespace voxpack::ingest {

/// Otsu's threshold (max between-class variance) over a `bins`-bin histogram of the range.
double otsuThreshold(const Grid<float>& image, int bins = 1024);

/// Two-class k-means (Ridler-Calvard isodata) threshold: t = mean of the two class means.
double kmeansThreshold(const Grid<float>& image);

/// Indicator from a threshold: void where value > t (voidBright) or value <= t (dark).
Grid<std::uint8_t> applyThreshold(const Grid<float>& image, double threshold, bool voidBright);

/// Flips face-connected components of `phase` (0 or 1) with at most `maxVoxels` voxels to
/// the other phase. Components touching the lattice border are kept (they may continue
/// outside the image). Returns the number of components flipped.
std::size_t removeSmallComponents(Grid<std::uint8_t>& indicator, std::uint8_t phase,
                                  std::size_t maxVoxels);

/// As above, counting only the flipped components whose first voxel (in C order) lies in
/// planes [countZ0, countZ1) (a slab's own planes when streamed). The search behind it
/// holds at most maxVoxels + 6 voxels, so its scratch is 1 B per voxel.
std::size_t removeSmallComponents(Grid<std::uint8_t>& indicator, std::uint8_t phase,
                                  std::size_t maxVoxels, std::int64_t countZ0,
                                  std::int64_t countZ1);

/// Bytes the search of removeSmallComponents holds at most on a grid of `voxels`: its stack
/// and member list, maxVoxels + 6 offsets each (the marks, 1 B per voxel, not included).
inline std::uint64_t cleanupSearchBytes(std::size_t maxVoxels, std::uint64_t voxels) {
  return 16 * (std::min<std::uint64_t>(voxels, maxVoxels) + 6);
}

}  // namespace voxpack::ingest
