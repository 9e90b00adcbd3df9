#include "voxel_choice.hpp"

#include <algorithm>
#include <cmath>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/packer/digitise.hpp"

namespace voxpack::app {

VoxelChoice chooseVoxelSize(const std::vector<std::string>& shapeSpecs,
                            const VoxelChoiceOptions& o) {
  if (!(o.targetVolumeError > 0 && o.targetVolumeError < 1))
    throw InputError("--target-volume-error must be in (0, 1), got " +
                     std::to_string(o.targetVolumeError));
  if (shapeSpecs.empty()) throw InputError("no shape to choose a voxel size for");
  std::vector<std::shared_ptr<const packer::Shape>> shapes;
  double diameter = 0;
  for (const auto& s : shapeSpecs) {
    shapes.push_back(packer::parseShape(s));
    // The smallest particle sets the resolution: it has the largest relative error.
    const double d = shapes.back()->characteristicDiameterMm();
    diameter = diameter == 0 ? d : std::min(diameter, d);
  }
  VoxelChoice out;
  // Geometric ladder, ~12 % per rung: fine enough that "coarsest meeting the target" is
  // within one rung of the true threshold, coarse enough to stay quick.
  for (double n = o.minVoxelsPerDiameter; n <= o.maxVoxelsPerDiameter * 1.0001; n *= 1.12) {
    VoxelChoiceRung rung;
    rung.voxelsPerDiameter = n;
    rung.voxelSizeMm = diameter / n;
    const Lattice lattice = Lattice::isotropic(1, 1, 1, rung.voxelSizeMm);
    double worstMean = 0, worstMax = 0;
    for (std::size_t s = 0; s < shapes.size(); ++s) {
      RandomStream rng(o.seed, s);
      double sum = 0, mx = 0;
      for (int p = 0; p < o.poses; ++p) {
        const Quat q = Quat(rng.normal(), rng.normal(), rng.normal(), rng.normal()).normalized();
        const Vec3 c = rung.voxelSizeMm * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
        const auto dp = packer::digitise(*shapes[s], c, q, lattice);
        const double err =
            std::abs(dp.volumeMm3() - shapes[s]->volumeMm3()) / shapes[s]->volumeMm3();
        sum += err;
        mx = std::max(mx, err);
      }
      worstMean = std::max(worstMean, sum / o.poses);
      worstMax = std::max(worstMax, mx);
    }
    rung.meanAbsError = worstMean;
    rung.maxAbsError = worstMax;
    out.ladder.push_back(rung);
    if (worstMean <= o.targetVolumeError) {
      out.voxelSizeMm = rung.voxelSizeMm;
      out.met = true;
      return out;
    }
  }
  out.voxelSizeMm = out.ladder.back().voxelSizeMm;
  return out;
}

}  // namespace voxpack::app
