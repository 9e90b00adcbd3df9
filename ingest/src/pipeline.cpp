// The ingest pipeline and its provenance record.
#include <chrono>
#include <cmath>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/version.hpp"
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
  return t == ThresholdMethod::Otsu ? "otsu" : t == ThresholdMethod::KMeans ? "kmeans" : "manual";
}
const char* name(ColumnMode c) {
  return c == ColumnMode::Auto ? "auto" : c == ColumnMode::None ? "none" : "explicit";
}

nlohmann::json latticeJson(const Lattice& l) {
  return {{"dims", {l.dims[0], l.dims[1], l.dims[2]}},
          {"spacing_mm", {l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]}},
          {"origin_mm", {l.originMm[0], l.originMm[1], l.originMm[2]}}};
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
  }
  return j;
}

double seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

IngestResult segmentVolume(Volume volume, const IngestOptions& o, int threads, Progress& progress) {
  if (o.maxSpeckVoxels > (std::size_t{1} << 40) || o.maxHoleVoxels > (std::size_t{1} << 40))
    throw UsageError("speck/hole sizes are out of range");
  nlohmann::json timing = nlohmann::json::object();
  IngestResult res;
  Grid<float>& img = volume.image;
  const Lattice inputLattice = img.lattice();

  // Polarity: the user's word, else the header key a voxpack phantom writes, else XMT's
  // convention (pores are air, the darkest phase).
  bool voidBright = false;
  std::string polaritySource = "option";
  if (o.voidPolarity == VoidPolarity::Auto) {
    const auto it = volume.info.metadata.find("voxpack_void");
    if (it != volume.info.metadata.end() && (it->second == "bright" || it->second == "dark")) {
      voidBright = it->second == "bright";
      polaritySource = "file header voxpack_void";
    } else {
      polaritySource = "default (dark, as in XMT)";
      progress.message("void phase assumed dark (XMT); pass --void bright for MRI water");
    }
  } else {
    voidBright = o.voidPolarity == VoidPolarity::Bright;
  }

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
    n4Ratio = n4BiasCorrection(img, o.n4Options, threads, progress);
  }
  timing["n4_s"] = seconds(t0);

  t0 = std::chrono::steady_clock::now();
  if (o.resampleMm > 0.0) {
    progress.report("resample", 0.0);
    img = resampleLinear(img, resampledLattice(img.lattice(), o.resampleMm), threads);
  }
  timing["resample_s"] = seconds(t0);

  t0 = std::chrono::steady_clock::now();
  progress.report("threshold", 0.0);
  double t = o.thresholdValue;
  if (o.threshold == ThresholdMethod::Otsu) t = otsuThreshold(img);
  if (o.threshold == ThresholdMethod::KMeans) t = kmeansThreshold(img);
  if (!std::isfinite(t)) throw UsageError("--threshold must be a finite number");
  Grid<std::uint8_t> ind = applyThreshold(img, t, voidBright);
  img = Grid<float>();  // the grey image is no longer needed: free it before clean-up
  const std::size_t specks = removeSmallComponents(ind, 0, o.maxSpeckVoxels);
  const std::size_t holes = removeSmallComponents(ind, 1, o.maxHoleVoxels);
  timing["segment_s"] = seconds(t0);

  t0 = std::chrono::steady_clock::now();
  ColumnFit column;
  if (o.column == ColumnMode::Auto) {
    progress.report("column fit", 0.0);
    column = fitColumn(ind, o.columnFit);
    if (!column.found) progress.message("no column found: " + column.note + "; no mask written");
  } else if (o.column == ColumnMode::Explicit) {
    if (!(o.columnRadiusMm > 0.0) || !std::isfinite(o.columnXMm) || !std::isfinite(o.columnYMm))
      throw UsageError("--column CX,CY,R needs finite CX, CY (mm) and R > 0 (mm)");
    column.found = true;
    column.axisXMm = o.columnXMm;
    column.axisYMm = o.columnYMm;
    column.radiusMm = o.columnRadiusMm;
    column.zRefMm = ind.lattice().originMm[0];
    column.note = "given on the command line";
  }
  Bed& bed = res.bed;
  if (column.found) bed.mask = columnMask(ind.lattice(), column);
  timing["column_s"] = seconds(t0);

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
                    {"max_speck_voxels", o.maxSpeckVoxels},
                    {"max_hole_voxels", o.maxHoleVoxels},
                    {"column", name(o.column)},
                    {"labels", o.labels}};
  rep["threshold"] = {{"method", name(o.threshold)},
                      {"value", finiteOrNull(t)},
                      {"void", voidBright ? "bright" : "dark"},
                      {"void_from", polaritySource}};
  rep["cleanup"] = {{"specks_removed", specks}, {"holes_filled", holes}};
  if (o.n4) rep["n4"] = {{"field_max_over_min", finiteOrNull(n4Ratio)}};
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
