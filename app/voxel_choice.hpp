#pragma once
/// \file voxel_choice.hpp
/// Picks the coarsest voxel size whose digitisation volume error meets a target, from an
/// error model measured on the spot for the scene's own shapes (random poses).

#include <cstdint>
#include <string>
#include <vector>

namespace voxpack::app {

/// One rung of the measured error ladder.
struct VoxelChoiceRung {
  double voxelsPerDiameter = 0;  ///< characteristic diameter / voxel size
  double voxelSizeMm = 0;        ///< the voxel size tried
  double meanAbsError = 0;       ///< mean |V_digital - V_exact| / V_exact over the poses
  double maxAbsError = 0;        ///< worst pose
};

/// Result of chooseVoxelSize.
struct VoxelChoice {
  double voxelSizeMm = 0;               ///< chosen (coarsest meeting the target)
  bool met = false;                     ///< false when even the finest rung misses the target
  std::vector<VoxelChoiceRung> ladder;  ///< every rung measured, coarse to fine
};

/// Options of chooseVoxelSize.
struct VoxelChoiceOptions {
  double targetVolumeError = 0.01;   ///< relative volume error to meet (0 < t < 1)
  int poses = 24;                    ///< random orientations + sub-voxel offsets per rung
  std::uint64_t seed = 1;            ///< seed of the poses
  double minVoxelsPerDiameter = 4;   ///< coarsest rung
  double maxVoxelsPerDiameter = 60;  ///< finest rung
};

/// Measures the mean relative volume error of every shape in `shapeSpecs` over random
/// poses on a ladder of voxel sizes (coarse to fine) and returns the coarsest one whose
/// worst shape meets the target. Throws InputError on a bad target.
VoxelChoice chooseVoxelSize(const std::vector<std::string>& shapeSpecs,
                            const VoxelChoiceOptions& options);

}  // namespace voxpack::app
