// Error budget of an ingest: the ingested bed re-imaged at the measured quality and
// segmented the same way (docs/ingest.md, "Calibration").
#include <cmath>
#include <limits>

#include "voxpack/core/errors.hpp"
#include "voxpack/ingest/ingest.hpp"
#include "voxpack/ingest/phantom.hpp"

namespace voxpack::ingest {
namespace {

// Packing density of `bed` over slices k0..k1 inside its mask.
double densityOverSlices(const Bed& bed, std::int64_t k0, std::int64_t k1) {
  const Lattice& l = bed.lattice();
  const auto plane = static_cast<std::size_t>(l.ny() * l.nx());
  double in = 0, solid = 0;
  for (std::int64_t k = std::max<std::int64_t>(0, k0); k <= std::min(k1, l.nz() - 1); ++k)
    for (std::size_t p = 0; p < plane; ++p) {
      const std::size_t o = static_cast<std::size_t>(k) * plane + p;
      if (bed.mask && !(*bed.mask)[o]) continue;
      in += 1;
      solid += bed.indicator[o] == 0;
    }
  return in > 0 ? solid / in : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

nlohmann::json calibrateDensityBias(const IngestResult& res, const IngestOptions& o, int threads,
                                    Progress& progress, std::int64_t trimPlanes) {
  const int runs = o.calibrationRuns;
  if (runs < 1 || runs > 50) throw UsageError("--calibrate: the number of runs must be 1..50");
  const ImageQuality& q = res.quality;
  PhantomOptions po;
  po.modality = res.voidBright ? Modality::Mri : Modality::Xmt;
  po.snr = q.snr > 0 && std::isfinite(q.snr) ? std::min(q.snr, 1e6) : 1e6;
  po.blurMm = q.blurMeasured ? q.blurMm : 0.0;
  po.wallThicknessMm = res.column.refined ? res.column.wallThicknessMm : 0.0;
  IngestOptions co = o;
  co.calibrationRuns = 0;
  co.labels = false;
  co.resampleMm = 0.0;  // the bed is already on the output lattice
  co.voidPolarity = res.voidBright ? VoidPolarity::Bright : VoidPolarity::Dark;
  std::int64_t k0 = 0, k1 = -1;
  double truth = packedRegionDensity(res.bed, &k0, &k1);
  if (trimPlanes > 0 && k1 - k0 + 1 > 2 * trimPlanes) {
    k0 += trimPlanes;
    k1 -= trimPlanes;
    truth = densityOverSlices(res.bed, k0, k1);
  }
  nlohmann::json biases = nlohmann::json::array();
  double sum = 0, sum2 = 0;
  int done = 0;
  for (int r = 0; r < runs; ++r) {
    if (progress.cancelled()) throw Cancelled("calibration cancelled");
    progress.report("calibration", static_cast<double>(r) / runs);
    po.seed = o.calibrationSeed + static_cast<std::uint64_t>(r);
    Volume v;
    v.image = makePhantom(res.bed, po, threads);
    v.info.source = "calibration phantom";
    const IngestResult c = segmentVolume(std::move(v), co, threads);
    const double b = densityOverSlices(c.bed, k0, k1) - truth;
    biases.push_back(std::isfinite(b) ? nlohmann::json(b) : nlohmann::json(nullptr));
    if (!std::isfinite(b)) continue;
    sum += b;
    sum2 += b * b;
    ++done;
  }
  progress.report("calibration", 1.0);
  const double mean = done ? sum / done : std::numeric_limits<double>::quiet_NaN();
  const double sd = done > 1 ? std::sqrt(std::max(0.0, (sum2 - done * mean * mean) / (done - 1)))
                             : std::numeric_limits<double>::quiet_NaN();
  auto num = [](double x) {
    return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
  };
  return {{"density_bias", num(mean)},
          {"density_bias_std", num(sd)},
          {"n", done},
          {"snr", num(po.snr)},
          {"blur_mm", num(po.blurMm)},
          {"voxel_mm", num(q.voxelMm)},
          {"modality", po.modality == Modality::Mri ? "mri" : "xmt"},
          {"wall_mm", num(po.wallThicknessMm)},
          {"truth_density", num(truth)},
          {"slices", {k0, k1}},
          {"biases", biases},
          {"seed", o.calibrationSeed},
          {"method",
           "the ingested bed imaged by voxpack phantom at the measured SNR, blur and voxel size, "
           "segmented with the same options; bias = segmented - known density over the packed "
           "slices"}};
}

}  // namespace voxpack::ingest
