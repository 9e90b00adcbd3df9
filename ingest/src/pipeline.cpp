// The ingest pipeline and its provenance record.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include "heap.hpp"
#include "phase_reading.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/version.hpp"
#include "voxpack/ingest/column.hpp"
#include "voxpack/ingest/filters.hpp"
#include "voxpack/ingest/ingest.hpp"
#include "voxpack/ingest/resample.hpp"
#include "voxpack/ingest/segment.hpp"

namespace voxpack::ingest {
namespace {

const char* name(DenoiseMethod d) {
  switch (d) {
    case DenoiseMethod::None:
      return "none";
    case DenoiseMethod::Median:
      return "median";
    case DenoiseMethod::MedianBox:
      return "median-box";
    case DenoiseMethod::Curvature:
      return "curvature";
  }
  return "?";
}
const char* name(ThresholdMethod t) {
  switch (t) {
    case ThresholdMethod::Auto:
      return "auto";
    case ThresholdMethod::Volume:
      return "volume";
    case ThresholdMethod::Otsu:
      return "otsu";
    case ThresholdMethod::KMeans:
      return "kmeans";
    case ThresholdMethod::Manual:
      return "manual";
  }
  return "?";
}
const char* name(ColumnMode c) {
  return c == ColumnMode::Auto ? "auto" : c == ColumnMode::None ? "none" : "explicit";
}

nlohmann::json latticeJson(const Lattice& l) {
  return {{"dims", {l.dims[0], l.dims[1], l.dims[2]}},
          {"spacing_mm", {l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]}},
          {"origin_mm", {l.originMm[0], l.originMm[1], l.originMm[2]}}};
}

double seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

std::string noColumnWarning(const ColumnFit& column) {
  return "warning: no column found (" + column.note +
         "); no mask written, the whole box is counted. If the image shows a column, give it: "
         "--column CX,CY,R (mm)";
}

nlohmann::json columnJson(const ColumnFit& c, ColumnMode mode) {
  nlohmann::json j = {{"mode", name(mode)}, {"found", c.found}, {"note", c.note}};
  if (c.found) {
    j["axis_x_mm"] = finiteOrNull(c.axisXMm);
    j["axis_y_mm"] = finiteOrNull(c.axisYMm);
    j["axis_z_ref_mm"] = finiteOrNull(c.zRefMm);
    j["slope_x"] = finiteOrNull(c.slopeX);
    j["slope_y"] = finiteOrNull(c.slopeY);
    j["radius_mm"] = finiteOrNull(c.radiusMm);
    j["slabs"] = c.slabs;
    j["radius_spread_mm"] = finiteOrNull(c.radiusSpreadMm);
    j["radius_std_mm"] = finiteOrNull(c.radiusStdMm);
    j["touches_border"] = c.touchesBorder;
    j["refined"] = c.refined;
    if (c.refined) {
      j["blur_mm"] = finiteOrNull(c.blurMm);
      j["wall_thickness_mm"] = finiteOrNull(c.wallThicknessMm);
      j["wall_resolved"] = c.wallResolved;
      j["sector_edges"] = c.sectors;
    }
  }
  return j;
}

bool resolveVoidBright(VoidPolarity polarity, const std::map<std::string, std::string>& metadata,
                       std::string* source) {
  auto say = [&](const char* why) {
    if (source) *source = why;
  };
  if (polarity != VoidPolarity::Auto) {
    say("option");
    return polarity == VoidPolarity::Bright;
  }
  const auto it = metadata.find("voxpack_void");
  if (it != metadata.end() && (it->second == "bright" || it->second == "dark")) {
    say("file header voxpack_void");
    return it->second == "bright";
  }
  say("default (dark, as in XMT)");
  return false;
}

PhaseReading readPhaseLevels(const Grid<float>& raw, const Grid<std::uint8_t>& prelim,
                             const Grid<std::uint8_t>* region, double blurVox, bool voidBright,
                             NoiseModel model, bool tail, int threads) {
  PhaseReading r;
  // The noise sigma comes from a homogeneous region (deep in the void phase); the
  // histogram's flanks read it 10-35 % high under blur (docs/ingest.md).
  r.interiorSigma = phaseInteriorStats(raw, prelim, region, 1).sigma;
  // Each phase's level is read deep inside it, where the blurred interfaces do not reach
  // (a Euclidean ball of 3 blur sigma, at least 3.5 voxels, so that the necks of pellets
  // fused by the blur stay out): the histogram's peaks are pulled towards each other by
  // the partial-volume voxels (docs/ingest.md, "The phase levels"). An MRI signal-free
  // phase has no level to read there but sigma sqrt(pi/2); a phase without enough deep
  // voxels keeps its peak.
  PhaseHints hints;
  hints.noiseSigma = r.interiorSigma;
  for (std::uint8_t phase : {std::uint8_t{0}, std::uint8_t{1}}) {
    DeepLevelOptions dl;
    dl.radius = std::clamp(3.0 * blurVox, 3.5, 15.0);
    dl.upper = (phase == 1) == voidBright;
    dl.oneSided = tail;
    dl.fallbackSigma = r.interiorSigma;
    dl.threads = threads;
    r.deep[phase] = phaseDeepLevel(raw, prelim, region, phase, dl);
    if (r.deep[phase].radius > 0.0)
      (phase ? hints.voidMean : hints.solidMean) = r.deep[phase].level;
  }
  // The deep voxels' samples (per-slice vectors, ~12 B per deep voxel, in the threads'
  // heaps) are freed, but the heap keeps their pages: the value copy below would land on
  // top of them (256^3: peak 8 % over the estimate). Hand them back first.
  releaseFreedHeap();
  r.levels = fitPhaseLevels(raw, region, voidBright, model, &hints);
  return r;
}

IngestResult segmentVolume(Volume volume, const IngestOptions& o, int threads, Progress& progress) {
  if (o.maxSpeckVoxels > (std::size_t{1} << 40) || o.maxHoleVoxels > (std::size_t{1} << 40))
    throw UsageError("speck/hole sizes are out of range");
  nlohmann::json timing = nlohmann::json::object();
  IngestResult res;
  Grid<float>& img = volume.image;
  const Lattice inputLattice = img.lattice();

  // Polarity: the user's word, else the header key a voxpack phantom writes, else XMT's
  // convention (pores are air, the darkest phase).
  std::string polaritySource;
  const bool voidBright = resolveVoidBright(o.voidPolarity, volume.info.metadata, &polaritySource);
  if (polaritySource.rfind("default", 0) == 0)
    progress.message("void phase assumed dark (XMT); pass --void bright for MRI water");

  const bool wantVolume =
      o.threshold == ThresholdMethod::Auto || o.threshold == ThresholdMethod::Volume;
  // The mean-intensity void fraction is read on the image before denoising: the median
  // is not linear, blur and noise are (Gaussian) or are modelled (Rician).
  // MRI magnitude (Rician): the wall step is fitted on the squared raw image, whose mean
  // is linear in the squared signal (column_refine.cpp), so the raw copy is kept for it too.
  const NoiseModel model =
      o.noise == NoiseChoice::Rician || (o.noise == NoiseChoice::Auto && voidBright)
          ? NoiseModel::Rician
          : NoiseModel::Gaussian;
  const bool squaredWall =
      model == NoiseModel::Rician && o.column != ColumnMode::None && o.refineColumn;
  // The image quality (noise, SNR) is read from the raw image's phases; --calibrate images
  // a phantom at that quality, so it needs them whatever the threshold.
  const bool wantLevels = wantVolume || o.calibrationRuns > 0;
  Grid<float> raw;
  if (wantLevels || squaredWall) raw = img;

  auto t0 = std::chrono::steady_clock::now();
  if (o.denoise == DenoiseMethod::Median) {
    progress.report("denoise (median)", 0.0);
    img = crossMedianFilter(img, threads);
  } else if (o.denoise == DenoiseMethod::MedianBox) {
    progress.report("denoise (median box)", 0.0);
    img = medianFilter(img, o.medianRadiusVoxels, threads);
  } else if (o.denoise == DenoiseMethod::Curvature) {
    progress.report("denoise (curvature diffusion)", 0.0);
    curvatureDiffusion(img, o.curvature, threads);
  }
  timing["denoise_s"] = seconds(t0);

  double n4Ratio = 1.0;
  t0 = std::chrono::steady_clock::now();
  if (o.n4) {
    if (!voidBright)
      progress.message("warning: N4 fits the bright phase; with --void dark that is the solid");
    Grid<float> before;
    if (!raw.empty()) before = img;
    n4Ratio = n4BiasCorrection(img, o.n4Options, threads, progress);
    // The same field divides the raw image (field = before / after).
    if (!raw.empty())
      for (std::size_t n = 0; n < img.size(); ++n)
        if (before[n] > 0.0f && img[n] > 0.0f) raw[n] *= img[n] / before[n];
  }
  timing["n4_s"] = seconds(t0);

  t0 = std::chrono::steady_clock::now();
  if (o.resampleMm > 0.0) {
    progress.report("resample", 0.0);
    const Lattice to = resampledLattice(img.lattice(), o.resampleMm);
    img = resampleLinear(img, to, threads);
    if (!raw.empty()) raw = resampleLinear(raw, to, threads);
  }
  timing["resample_s"] = seconds(t0);
  const Lattice lat = img.lattice();  // a copy: img is freed before the mask is made

  // Preliminary segmentation (Otsu): the column fit and the interface density need one.
  t0 = std::chrono::steady_clock::now();
  progress.report("threshold", 0.0);
  double tOtsu = otsuThreshold(img);
  Grid<std::uint8_t> prelim = applyThreshold(img, tOtsu, voidBright);
  removeSmallComponents(prelim, 0, o.maxSpeckVoxels);
  removeSmallComponents(prelim, 1, o.maxHoleVoxels);
  timing["prelim_s"] = seconds(t0);

  t0 = std::chrono::steady_clock::now();
  // The wall step: on M^2 of the raw image for a signal-free (MRI) wall, else on the image.
  const auto refine = [&](const ColumnFit& c) {
    const ColumnRefineOptions ro{.slabSlices = o.columnFit.slabSlices,
                                 .squared = squaredWall,
                                 .wallThicknessMm = o.columnWallMm};
    return refineColumn(squaredWall ? raw : img, c, ro);
  };
  ColumnFit column;
  if (o.column == ColumnMode::Auto) {
    progress.report("column fit", 0.0);
    column = fitColumn(prelim, o.columnFit);
    if (column.found && o.refineColumn) column = refine(column);
    if (!column.found) progress.message(noColumnWarning(column));
  } else if (o.column == ColumnMode::Explicit) {
    if (!(o.columnRadiusMm > 0.0) || !std::isfinite(o.columnXMm) || !std::isfinite(o.columnYMm))
      throw UsageError("--column CX,CY,R needs finite CX, CY (mm) and R > 0 (mm)");
    column.found = true;
    column.axisXMm = o.columnXMm;
    column.axisYMm = o.columnYMm;
    column.radiusMm = o.columnRadiusMm;
    column.zRefMm = lat.originMm[0];
    column.note = "given on the command line";
    // The geometry is given; the wall step still tells the blur (the Rician edge
    // correction needs it) and the wall's grey levels. Only those are taken from the
    // refinement.
    if (o.refineColumn) {
      const ColumnFit seen = refine(column);
      if (seen.refined) {
        column.blurMm = seen.blurMm;
        column.wallThicknessMm = seen.wallThicknessMm;
        // The grey-level wall correction (XMT) needs the wall's and the outside's levels:
        // without them it divided the bed next to the wall as if both were 0 (+0.027
        // density on the XMT 20/d fidelity test with the true column given, +0.020..0.053 on
        // the fidelity benchmark).
        column.wallLevel = seen.wallLevel;
        column.outsideLevel = seen.outsideLevel;
        column.refined = true;
        column.note += "; blur from the wall step";
      }
    }
  }
  timing["column_s"] = seconds(t0);

  // Deconvolution sharpens the image the threshold cuts, with the blur seen at the wall
  // (or given). The mean-intensity porosity stays on the raw image: blur keeps the mean.
  nlohmann::json deconvolution = nullptr;
  if (o.deconvolveIterations > 0) {
    t0 = std::chrono::steady_clock::now();
    const double sigma = o.psfSigmaMm > 0.0 ? o.psfSigmaMm : (column.refined ? column.blurMm : 0.0);
    if (sigma > 0.0) {
      progress.report("deconvolution (Richardson-Lucy)", 0.0);
      const std::size_t clipped = richardsonLucy(img, sigma, o.deconvolveIterations, threads);
      tOtsu = otsuThreshold(img);
      deconvolution = {{"method", "richardson-lucy"},
                       {"iterations", o.deconvolveIterations},
                       {"psf", "gaussian"},
                       {"psf_sigma_mm", sigma},
                       {"psf_from", o.psfSigmaMm > 0.0 ? "--psf-sigma-mm"
                                                       : "edge-spread fit at the column wall"},
                       {"clipped_negative_voxels", clipped}};
    } else {
      progress.message(
          "warning: --deconvolve: no blur was measured (no column wall seen); pass "
          "--psf-sigma-mm; the image is not deconvolved");
      deconvolution = {{"method", "none"}, {"note", "no blur measured; pass --psf-sigma-mm"}};
    }
    timing["deconvolve_s"] = seconds(t0);
  }

  // Phase statistics over the column's core: far enough from the wall that its blurred
  // step does not reach in (3 blur sigma + 2 voxels).
  t0 = std::chrono::steady_clock::now();
  const double voxel = lat.spacingMm[2];
  const double blurVox = column.refined ? column.blurMm / voxel : 0.0;
  std::optional<Grid<std::uint8_t>> core;
  if (column.found) {
    const double margin = (3.0 * std::max(blurVox, 1.0) + 2.0) * voxel;
    core = columnCoreMask(lat, column, margin);
    std::size_t in = 0;
    for (std::uint8_t m : core->values()) in += m;
    if (in < 64) core.reset();
  }
  const Grid<std::uint8_t>* region = core ? &*core : nullptr;
  std::string regionName = region ? "column core" : "whole image";
  PhaseLevels levels;
  DeepLevel deepLevels[2];  // solid, void
  double interiorSigma = 0.0;
  MeanVoidFraction mvf;
  bool volumeUsed = false;
  std::string method = name(o.threshold);
  double t = o.thresholdValue;
  std::optional<Grid<std::uint8_t>> mask;
  std::optional<Grid<std::uint8_t>> packed;  // the bed's slices when there is no column
  bool maskCut = false;                      // mask holds the bed's slices only
  nlohmann::json bedSlicesJson = nullptr;
  nlohmann::json wallJson = nullptr;
  bool medianSkipped = false;
  std::string medianNote;
  if (wantLevels) {
    PhaseReading pr =
        readPhaseLevels(raw, prelim, region, blurVox, voidBright, model, o.phaseLevelTail, threads);
    levels = pr.levels;
    interiorSigma = pr.interiorSigma;
    deepLevels[0] = pr.deep[0];
    deepLevels[1] = pr.deep[1];
  }
  if (wantVolume) {
    // The 7-point median closes void throats one or two voxels wide: on coarse images
    // (measured: +0.016 density at 10 voxels per d) the threshold cuts the raw image instead.
    if (levels.clear && o.denoise == DenoiseMethod::Median && o.medianMinVoxelsPerD > 0.0) {
      const double vpd = voxelsPerDiameter(prelim, region);
      if (vpd > 0.0 && vpd < o.medianMinVoxelsPerD) {
        medianSkipped = true;
        medianNote = "median not used for the threshold: " + std::to_string(vpd) +
                     " voxels per particle diameter < " + std::to_string(o.medianMinVoxelsPerD);
      }
    }
    // The wall's blur darkens (MRI) or brightens (XMT) the bed next to it: divided out of
    // the raw and the denoised image, after which the porosity is aimed over the whole
    // column instead of its core (docs/ingest.md, "Wall-blur correction").
    if (levels.clear && column.found && column.refined && column.blurMm > 0.0 &&
        o.wallBlurCorrection) {
      WallBlurCorrection wc;
      wc.blurMm = column.blurMm;
      wc.rician = model == NoiseModel::Rician;
      wc.noiseSigma = interiorSigma > 0.0 ? interiorSigma : levels.noiseSigma;
      wc.wallLevel = column.wallLevel;
      wc.outsideLevel = column.outsideLevel;
      wc.wallThicknessMm = column.wallThicknessMm;
      const std::size_t changed = correctWallBlur(raw, column, wc, threads);
      std::string imgHow;
      if (o.deconvolveIterations > 0) {
        imgHow = "not applied to the deconvolved image";
      } else if (medianSkipped) {
        imgHow = "the threshold cuts the corrected raw image";
      } else if (o.resampleMm > 0.0 || o.denoise == DenoiseMethod::Curvature || o.n4) {
        WallBlurCorrection wi = wc;
        wi.noiseSigma = 0.0;  // a filtered image: plain division
        correctWallBlur(img, column, wi, threads);
        imgHow = "divided in the denoised image";
      } else if (o.denoise == DenoiseMethod::None) {
        refilterNearWall(img, raw, column, wc, 0, false, threads);
        imgHow = "copied from the corrected raw image";
      } else {
        refilterNearWall(img, raw, column, wc, o.medianRadiusVoxels,
                         o.denoise == DenoiseMethod::MedianBox, threads);
        imgHow = "median recomputed from the corrected raw image";
      }
      core.reset();
      mask = columnMask(lat, column);
      region = &*mask;
      regionName = "column";
      wallJson = {{"applied", true},
                  {"voxels", changed},
                  {"blur_mm", column.blurMm},
                  {"reach_mm", wc.reachSigmas * wc.blurMm},
                  {"model", wc.rician ? "rician (signal-free wall)" : "grey levels"},
                  {"denoised_image", imgHow}};
    }
    if (medianSkipped && o.deconvolveIterations == 0) img = raw;
    // A global threshold reproduces the porosity only over the region it is aimed at: the
    // bed's interfaces bias each voxel by the local blur and curvature, the headspace's do
    // not, so aimed over the whole column it leaves the bed too solid (+0.02 at 10 voxels
    // per d, docs/ingest.md "Aimed over the bed's slices").
    if (levels.clear && o.volumeOverBedSlices) {
      auto [k0, k1] = bedSlices(prelim, region);
      // Its end slices are left out: a floor (or lid) reads as the solid phase (MRI) or
      // brighter than the void (XMT), and its blur reaches 3 sigma into the bed, where the
      // mean intensity counts it as solid (-0.011 void fraction over the bed's slices at 10
      // voxels per d, blur 1 voxel: docs/ingest.md "Aimed over the bed's slices").
      const std::int64_t trim =
          std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil(3.0 * blurVox)));
      if (k0 >= 0 && (k1 - k0 + 1) - 2 * trim >= std::max<std::int64_t>(4, (k1 - k0 + 1) / 2)) {
        k0 += trim;
        k1 -= trim;
      }
      if (k0 > 0 || (k1 >= 0 && k1 + 1 < lat.nz())) {
        // The slices are cut out of the region in place (no copy: this stage is the
        // pipeline's peak); a column mask cut so is made again for the bed file below.
        Grid<std::uint8_t>* target = nullptr;
        if (mask && region == &*mask) {
          target = &*mask;
          maskCut = true;
        } else if (core && region == &*core) {
          target = &*core;
        } else {  // no column: the whole box (the core's byte of the estimate is free)
          packed = Grid<std::uint8_t>(lat, 1);
          target = &*packed;
        }
        const auto plane = static_cast<std::size_t>(lat.ny() * lat.nx());
        for (std::int64_t k = 0; k < lat.nz(); ++k)
          if (k < k0 || k > k1)
            std::fill_n(target->values().begin() +
                            static_cast<std::ptrdiff_t>(k) * static_cast<std::ptrdiff_t>(plane),
                        plane, std::uint8_t{0});
        region = target;
        regionName += ", bed slices";
        bedSlicesJson = {{"first", k0},
                         {"last", k1},
                         {"z_mm",
                          {lat.originMm[0] + static_cast<double>(k0) * lat.spacingMm[0],
                           lat.originMm[0] + static_cast<double>(k1) * lat.spacingMm[0]}}};
      }
    }
    if (levels.clear) mvf = meanVoidFraction(raw, region, levels, blurVox, prelim);
    // A mean-intensity porosity far from Otsu's means the two-peak model does not hold
    // (e.g. a real image whose grey levels are not two blurred phases): keep Otsu.
    const double otsuPhi = regionVoidFraction(prelim, region);
    if (levels.clear && std::abs(mvf.phi - otsuPhi) > 0.1) {
      levels.clear = false;
      levels.note = "mean-intensity porosity " + std::to_string(mvf.phi) +
                    " is more than 0.1 from Otsu's " + std::to_string(otsuPhi);
    }
    if (levels.clear) {
      t = volumeThreshold(img, region, mvf.phi, voidBright);
      volumeUsed = true;
      method = "volume";
    } else {
      if (o.threshold == ThresholdMethod::Volume)
        progress.message("warning: --threshold volume: " + levels.note + "; using Otsu");
      t = tOtsu;
      method = "otsu";
    }
  }
  raw = Grid<float>();
  prelim = Grid<std::uint8_t>();
  if (o.threshold == ThresholdMethod::Otsu) t = tOtsu;
  if (o.threshold == ThresholdMethod::KMeans) t = kmeansThreshold(img);
  if (!std::isfinite(t)) throw UsageError("--threshold must be a finite number");
  Grid<std::uint8_t> ind = applyThreshold(img, t, voidBright);
  std::size_t specks = removeSmallComponents(ind, 0, o.maxSpeckVoxels);
  std::size_t holes = removeSmallComponents(ind, 1, o.maxHoleVoxels);
  double achieved = regionVoidFraction(ind, region);
  const double aimed = mvf.phi;
  // MRI: the edge correction's interface density is read again on this segmentation, and
  // the larger of the two is used. Both undercount (a segmentation under blur closes gaps
  // and smooths corners; its specks are cleaned up), the preliminary one most where the
  // threshold cuts the raw image: it is median-filtered, so it misses the gaps the blur
  // closed, where the Rician floor lifts the signal most (S_V 0.183 per voxel against the
  // truth's 0.235 on the cylinder bed at 15 voxels per d, SNR 10, blur 1; this one 0.216):
  // docs/ingest.md, "The phase levels". Only while noise moves an interface crossing by at
  // most surfaceRereadMaxJitter voxels (sd = sigma over the steepest slope of the blurred
  // step, the voxel's own width included): beyond it the segmentation's interfaces are
  // rough with noise (S_V 0.377 for the truth's 0.342 at SNR 5, blur 1).
  const double surfacePrelim = mvf.surfacePerVoxel;
  const double noise = interiorSigma > 0.0 ? interiorSigma : levels.noiseSigma;
  const double contrast = std::abs(levels.voidSignal - levels.solidSignal);
  const double jitter = noise > 0.0 && contrast > 0.0
                            ? std::sqrt(2.0 * std::numbers::pi) *
                                  std::sqrt(blurVox * blurVox + 1.0 / 12.0) * noise / contrast
                            : std::numeric_limits<double>::infinity();
  const bool reread = volumeUsed && mvf.edgeBiasVoxels != 0.0 && jitter <= o.surfaceRereadMaxJitter;
  if (reread) {
    mvf.surfacePerVoxel = std::max(surfacePrelim, surfaceDensityPerVoxel(ind, region));
    mvf.phi = std::clamp(mvf.raw - mvf.edgeBiasVoxels * mvf.surfacePerVoxel, 0.0, 1.0);
  }
  // Clean-up moves the void fraction off the aim: aim once more, by the difference (and at
  // the corrected target).
  if (volumeUsed && std::abs(achieved - mvf.phi) > 1e-4) {
    const double t2 = volumeThreshold(
        img, region, std::clamp(mvf.phi - (achieved - aimed), 0.0, 1.0), voidBright);
    Grid<std::uint8_t> ind2 = applyThreshold(img, t2, voidBright);
    const std::size_t sp2 = removeSmallComponents(ind2, 0, o.maxSpeckVoxels);
    const std::size_t ho2 = removeSmallComponents(ind2, 1, o.maxHoleVoxels);
    const double a2 = regionVoidFraction(ind2, region);
    if (std::abs(a2 - mvf.phi) < std::abs(achieved - mvf.phi)) {
      ind = std::move(ind2);
      t = t2;
      specks = sp2;
      holes = ho2;
      achieved = a2;
    }
  }
  img = Grid<float>();  // the grey image is no longer needed
  timing["segment_s"] = seconds(t0);

  Bed& bed = res.bed;
  const bool maskIsRegion = mask.has_value();
  if (mask && !maskCut) bed.mask = std::move(*mask);
  mask.reset();  // a mask cut to the bed's slices is freed first, then made whole again
  if (!bed.mask && column.found) bed.mask = columnMask(lat, column);
  if (maskIsRegion) region = &*bed.mask;

  ImageQuality q;
  q.voxelMm = voxel;
  if (levels.noiseSigma > 0) {
    q.noiseSigma = interiorSigma > 0.0 ? interiorSigma : levels.noiseSigma;
    q.snr = std::abs(levels.voidSignal - levels.solidSignal) / q.noiseSigma;
  }
  q.blurMeasured = column.refined;
  q.blurMm = column.refined ? column.blurMm : 0.0;
  q.voxelsPerDiameter = voxelsPerDiameter(ind, region);
  res.quality = q;

  std::size_t labelCount = 0;
  t0 = std::chrono::steady_clock::now();
  if (o.labels) {
    progress.report("labels (watershed)", 0.0);
    bed.labels = watershedLabels(ind, o.labelMarkerDepthVoxels, threads, &labelCount);
  }
  timing["labels_s"] = seconds(t0);
  bed.indicator = std::move(ind);

  const BedSummary summary = summarize(bed);
  nlohmann::json rep;
  rep["input"] = volume.info.files.empty() ? std::string() : volume.info.files.front();
  rep["reader"] = {{"source", volume.info.source},
                   {"image_io", volume.info.imageIO},
                   {"component_type", volume.info.componentType},
                   {"files", volume.info.files.size()},
                   {"spacing_from_file", volume.info.spacingFromFile},
                   {"lattice", latticeJson(inputLattice)}};
  rep["options"] = {{"voxel_size_mm", o.read.voxelSizeMm},
                    {"denoise", name(o.denoise)},
                    {"median_radius_voxels", o.medianRadiusVoxels},
                    {"curvature_iterations", o.curvature.iterations},
                    {"curvature_conductance", o.curvature.conductance},
                    {"n4", o.n4},
                    {"n4_shrink_factor", o.n4Options.shrinkFactor},
                    {"n4_fitting_levels", o.n4Options.fittingLevels},
                    {"resample_mm", o.resampleMm},
                    {"threshold", name(o.threshold)},
                    {"noise", o.noise == NoiseChoice::Auto     ? "auto"
                              : o.noise == NoiseChoice::Rician ? "rician"
                                                               : "gaussian"},
                    {"refine_column", o.refineColumn},
                    {"column_wall_mm", o.columnWallMm},
                    {"wall_blur_correction", o.wallBlurCorrection},
                    {"volume_over_bed_slices", o.volumeOverBedSlices},
                    {"phase_level", o.phaseLevelTail ? "tail" : "mean"},
                    {"median_min_voxels_per_d", o.medianMinVoxelsPerD},
                    {"surface_reread_max_jitter", o.surfaceRereadMaxJitter},
                    {"max_speck_voxels", o.maxSpeckVoxels},
                    {"max_hole_voxels", o.maxHoleVoxels},
                    {"column", name(o.column)},
                    {"labels", o.labels}};
  rep["threshold"] = {{"method", method},
                      {"requested", name(o.threshold)},
                      {"value", finiteOrNull(t)},
                      {"otsu_value", finiteOrNull(tOtsu)},
                      {"void", voidBright ? "bright" : "dark"},
                      {"void_from", polaritySource},
                      {"region", regionName},
                      {"bed_slices", bedSlicesJson},
                      {"porosity_segmented_region", finiteOrNull(achieved)}};
  if (wantLevels) {
    rep["phases"] = {{"clear", levels.clear},
                     {"model", levels.model == NoiseModel::Rician ? "rician" : "gaussian"},
                     {"void_level", finiteOrNull(levels.voidLevel)},
                     {"solid_level", finiteOrNull(levels.solidLevel)},
                     {"void_signal", finiteOrNull(levels.voidSignal)},
                     {"solid_signal", finiteOrNull(levels.solidSignal)},
                     {"noise_sigma", finiteOrNull(levels.noiseSigma)},
                     {"note", levels.note}};
    for (std::uint8_t phase : {std::uint8_t{0}, std::uint8_t{1}}) {
      const DeepLevel& d = deepLevels[phase];
      rep["phases"][phase ? "void_deep" : "solid_deep"] = {{"level", finiteOrNull(d.level)},
                                                           {"mean", finiteOrNull(d.mean)},
                                                           {"sigma", finiteOrNull(d.sigma)},
                                                           {"ball_radius_voxels", d.radius},
                                                           {"voxels", d.voxels},
                                                           {"dip_excluded", d.dipExcluded},
                                                           {"slice_stride", d.sliceStride}};
    }
    if (volumeUsed)
      rep["threshold"]["mean_intensity_porosity"] = {
          {"mean_intensity", finiteOrNull(mvf.meanIntensity)},
          {"raw", finiteOrNull(mvf.raw)},
          {"edge_bias_voxels", finiteOrNull(mvf.edgeBiasVoxels)},
          {"surface_per_voxel", finiteOrNull(mvf.surfacePerVoxel)},
          {"surface_per_voxel_preliminary", finiteOrNull(surfacePrelim)},
          {"surface_reread", reread},
          {"edge_jitter_voxels", finiteOrNull(jitter)},
          {"porosity", finiteOrNull(mvf.phi)},
          {"voxels", mvf.voxels}};
  }
  rep["quality"] = {{"noise_sigma", finiteOrNull(q.noiseSigma)},
                    {"snr", finiteOrNull(q.snr)},
                    {"blur_mm", q.blurMeasured ? finiteOrNull(q.blurMm) : nlohmann::json(nullptr)},
                    {"blur_from", q.blurMeasured ? "edge-spread fit at the column wall"
                                                 : "not measured (no wall seen)"},
                    {"voxel_mm", finiteOrNull(q.voxelMm)},
                    {"voxels_per_diameter", finiteOrNull(q.voxelsPerDiameter)},
                    {"diameter_from", "sphere-equivalent 6V/S = 1.5 x mean solid chord"}};
  rep["cleanup"] = {{"specks_removed", specks}, {"holes_filled", holes}};
  if (o.n4) rep["n4"] = {{"field_max_over_min", finiteOrNull(n4Ratio)}};
  if (o.deconvolveIterations > 0) rep["deconvolution"] = deconvolution;
  if (medianSkipped) rep["options"]["denoise_note"] = medianNote;
  if (wantVolume)
    rep["wall_blur_correction"] =
        wallJson.is_null() ? nlohmann::json{{"applied", false}} : wallJson;
  rep["column"] = columnJson(column, o.column);
  if (o.labels)
    rep["labels"] = {{"count", labelCount}, {"marker_depth_voxels", o.labelMarkerDepthVoxels}};
  rep["output_lattice"] = latticeJson(bed.lattice());
  rep["porosity"] = summary.emptyMask ? nlohmann::json(nullptr) : finiteOrNull(summary.porosity);
  rep["timing_s"] = timing;
  sanitizeNonFinite(rep);
  bed.provenance = {{"voxpack_version", versionString()}, {"command", "ingest"}, {"ingest", rep}};
  res.thresholdUsed = t;
  res.voidBright = voidBright;
  res.column = column;
  res.report = rep;
  if (o.calibrationRuns > 0) {
    const auto tc = std::chrono::steady_clock::now();
    const nlohmann::json cal = calibrateDensityBias(res, o, threads, progress);
    res.report["calibration"] = cal;
    res.report["timing_s"]["calibration_s"] = seconds(tc);
    res.bed.provenance["ingest"] = res.report;
    res.bed.provenance["calibration"] = cal;
  }
  return res;
}

IngestResult ingestVolume(const std::filesystem::path& input, const IngestOptions& o, int threads,
                          Progress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  Volume v = readVolume(input, o.read, progress);
  const double readS = seconds(t0);
  IngestResult r = segmentVolume(std::move(v), o, threads, progress);
  r.report["timing_s"]["read_s"] = readS;
  r.report["input"] = input.string();
  r.bed.provenance["ingest"] = r.report;
  return r;
}

}  // namespace voxpack::ingest
