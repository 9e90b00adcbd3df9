#include "voxpack/stats/bed_stats.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "voxpack/core/errors.hpp"
#include "voxpack/stats/streamed.hpp"

namespace voxpack::stats {

CropOptions bedWindow(const Bed& bed, double d) {
  if (bed.particles.empty())
    throw InputError("--bed-window: " + std::string("the bed has no particle table"));
  const Lattice& l = bed.lattice();
  std::int64_t first = -1;
  const std::size_t plane = static_cast<std::size_t>(l.dims[1] * l.dims[2]);
  for (std::int64_t k = 0; k < l.dims[0] && first < 0; ++k)
    for (std::size_t o = 0; o < plane; ++o)
      if (!bed.mask || (*bed.mask)[static_cast<std::size_t>(k) * plane + o]) {
        first = k;
        break;
      }
  if (first < 0) throw InputError("--bed-window: the mask is empty");
  double top = -1e300;
  for (const Vec3& p : bed.particles.positionMm) top = std::max(top, p.z());
  const double z0 = l.originMm[0] + static_cast<double>(first) * l.spacingMm[0] + 2 * d;
  const double z1 = top - 2 * d;
  if (!(z1 > z0)) throw InputError("--bed-window: the bed is shallower than 4 particle diameters");
  CropOptions c;
  c.zMm = RangeMm{z0, z1};
  return c;
}

nlohmann::json computeBedStats(Bed bed, const StatsOptions& options, const BedStatsRequest& request,
                               Progress& progress) {
  nlohmann::json roiRecord = nullptr;
  if (request.roi) {
    CropBox box;
    // Assigning frees the uncropped bed: statistics then run on the ROI alone.
    bed = cropBed(bed, *request.roi, &box);
    roiRecord = roiJson(*request.roi, box);
  }
  if (request.bedWindow) {
    const CropOptions w = bedWindow(bed, options.particleDiameterMm);
    CropBox box;
    bed = cropBed(bed, w, &box);
    roiRecord = roiJson(w, box);
    roiRecord["bed_window_diameters"] = 2;
  }
  const PackedSlices packed = packedSlices(sliceCounts(bed));
  const bool apply = request.packedAuto && packed.found;
  const nlohmann::json packedRecord =
      packedRegionJson(packed, bed.lattice(), request.packedAuto ? "auto" : "off", apply);
  if (!request.packedAuto && packed.headspaceFraction > 0.10)
    progress.message("warning: " + request.inputName + ": " +
                     std::to_string(static_cast<int>(std::lround(100 * packed.headspaceFraction))) +
                     " % of the mask lies outside the packed region (headspace or end walls) "
                     "and is included; pass --packed-region auto to exclude it");
  if (apply) {
    const Lattice& l = bed.lattice();
    CropOptions z;
    z.zMm = RangeMm{l.originMm[0] + static_cast<double>(packed.firstSlice) * l.spacingMm[0],
                    l.originMm[0] + static_cast<double>(packed.lastSlice) * l.spacingMm[0]};
    bed = cropBed(bed, z);
  }
  nlohmann::json stats = computeStats(bed, options, progress);
  stats["roi_mm"] = roiRecord;
  stats["packed_region"] = packedRecord;
  return stats;
}

}  // namespace voxpack::stats
