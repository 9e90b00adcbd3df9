#pragma once
/// \file bed_stats.hpp
/// The in-memory body of `voxpack stats`, shared by the CLI and the Python module so the two
/// cannot drift apart: the ROI crop, the bed window, the packed region, then computeStats.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/stats/crop.hpp"
#include "voxpack/stats/stats.hpp"

namespace voxpack::stats {

/// The crops asked of one in-memory stats run (the CLI's --roi-mm/--roi-box-mm,
/// --bed-window and --packed-region).
struct BedStatsRequest {
  std::optional<CropOptions> roi;  ///< crop to this box first (none = the whole bed)
  bool bedWindow = false;          ///< then crop to bedWindow(bed, particleDiameterMm)
  bool packedAuto = false;         ///< then crop to the packed slices (else only warn)
  std::string inputName;           ///< names the input in the headspace warning
};

/// [lowest mask slice + 2 d, highest particle centre - 2 d] in z: the interior of a poured
/// bed. Throws InputError without particles, with an empty mask or a bed shallower than 4 d.
CropOptions bedWindow(const Bed& bed, double particleDiameterMm);

/// Statistics of `bed` after the requested crops, with the `roi_mm` and `packed_region`
/// records; the headspace warning goes to progress.message.
nlohmann::json computeBedStats(Bed bed, const StatsOptions& options, const BedStatsRequest& request,
                               Progress& progress);

}  // namespace voxpack::stats
