#pragma once
/// \file bed.hpp
/// The bed model: indicator field I(x) (1 void, 0 solid), optional container mask,
/// optional particle labels and particle table, and provenance. Mirrors the bed file.

#include <Eigen/Geometry>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "voxpack/core/grid.hpp"

namespace voxpack {

/// Unit quaternion (w, x, y, z) for particle orientations.
using Quat = Eigen::Quaterniond;

/// Per-particle table of a packed bed.
struct ParticleTable {
  std::vector<Vec3> positionMm;    ///< centre (x, y, z) mm of each particle
  std::vector<Quat> orientation;   ///< unit quaternion of each particle
  std::vector<std::string> shape;  ///< shape spec of each particle (e.g. "cylinder:d=5.4,l=3.8")
  std::size_t size() const { return positionMm.size(); }  ///< number of particles
  bool empty() const { return positionMm.empty(); }       ///< true when no particle
};

/// A packed or imaged bed on one lattice.
struct Bed {
  Grid<std::uint8_t> indicator;               ///< 1 = void, 0 = solid
  std::optional<Grid<std::uint8_t>> mask;     ///< 1 = inside container/ROI; absent = all
  std::optional<Grid<std::uint32_t>> labels;  ///< particle id per voxel (1-based), 0 = none
  ParticleTable particles;                    ///< particle i has label i+1
  nlohmann::json provenance = nlohmann::json::object();  ///< version, command, seed, inputs

  const Lattice& lattice() const { return indicator.lattice(); }  ///< geometry
  /// Throws FormatError when mask/labels lattices differ from the indicator's, or
  /// indicator/mask hold values other than 0 and 1, the particle table is ragged, a
  /// position is not finite, or an orientation is not a finite unit quaternion.
  void validate() const;
};

/// Throws FormatError naming `row` unless `q` is finite and of unit norm (within 1e-6:
/// stored doubles are normalised; float32 storage rounds the norm by ~1e-7).
void checkUnitQuaternion(const Quat& q, std::size_t row);

/// Summary numbers of a bed, computed inside the mask.
struct BedSummary {
  std::size_t voxelsInMask = 0;  ///< voxels counted (mask == 1, or all)
  std::size_t voidVoxels = 0;    ///< void voxels inside the mask
  double porosity = 0.0;         ///< void / voxelsInMask (NaN-free: 0 when empty mask)
  double packingDensity = 0.0;   ///< 1 - porosity (0 when empty mask)
  bool emptyMask = false;        ///< true when the mask selects no voxel
};

/// Porosity and packing density inside the mask.
BedSummary summarize(const Bed& bed);

/// Adds the voxels of `indicator` (and `mask`, nullptr = all) to a running summary, so that
/// slab after slab gives the same counts as summarize() of the whole bed.
void accumulateSummary(BedSummary& sum, const Grid<std::uint8_t>& indicator,
                       const Grid<std::uint8_t>* mask);

/// Porosity and density of accumulated counts (emptyMask when no voxel was counted).
void finishSummary(BedSummary& sum);

}  // namespace voxpack
