// computeStats: every statistic of a bed as one JSON object (docs/interfaces.md keys), and CSV
// export.
#include "voxpack/stats/stats.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "voxpack/core/atomic_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/spec.hpp"
#include "voxpack/core/version.hpp"
#include "voxpack/stats/profiles.hpp"
#include "voxpack/stats/s2.hpp"
#include "voxpack_stats_extra.hpp"

namespace voxpack::stats {
namespace {

using nlohmann::json;

json arr(const std::vector<double>& v) { return finiteArray(v); }

// Diameter (mm) of a particle from its shape spec: `d` when given, else the diameter of the
// sphere of equal volume; <= 0 when unknown (meshes).
double shapeDiameterMm(const std::string& spec) {
  try {
    const ParsedSpec s = parseSpec(spec, "particle shape");
    if (s.has("d")) return s.positive("d");
    if (s.name == "box")
      return std::cbrt(6 / M_PI * s.positive("x") * s.positive("y") * s.positive("z"));
    if (s.name == "ellipsoid")
      return 2 * std::cbrt(s.positive("a") * s.positive("b") * s.positive("c"));
  } catch (const InputError&) {
  }
  return 0;
}

}  // namespace

double inferDiameterMm(const ParticleTable& particles) {
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t p = 0; p < particles.shape.size() && p < 10000; ++p) {
    const double d = shapeDiameterMm(particles.shape[p]);
    if (d > 0) {
      sum += d;
      ++n;
    }
  }
  return n ? sum / static_cast<double>(n) : 0;
}

namespace {

json s2Curve(const S2Curve& c) {
  return {{"h_mm", arr(c.hMm)}, {"s2", arr(c.s2)}, {"pairs", arr(c.pairs)}};
}

json optionsJson(const StatsOptions& o, const std::set<std::string>& which) {
  return {{"only", std::vector<std::string>(which.begin(), which.end())},
          {"particle_diameter_mm", finiteOrNull(o.particleDiameterMm)},
          {"trim_mm", finiteOrNull(o.trimMm)},
          {"s2_max_lag_mm", finiteOrNull(o.s2MaxLagMm)},
          {"s2_precision", o.s2Float ? "float" : "double"},
          {"radial_bin_mm", finiteOrNull(o.radialBinMm)},
          {"mes_method", o.mesMethod},
          {"mes_samples", o.mesSamples},
          {"mes_directions", o.mesDirections},
          {"seed", o.seed},
          {"threads", o.threads}};
}

std::string csvNumber(const json& v) {
  if (!v.is_number()) return "";
  std::ostringstream s;
  s.precision(10);
  s << v.get<double>();
  return s.str();
}

// Writes columns (all the same length) from `obj` under `header` names; keys[i] is the
// JSON key of column i.
void writeColumns(const std::filesystem::path& path, const json& obj,
                  const std::vector<std::string>& header, const std::vector<std::string>& keys) {
  std::size_t rows = 0;
  for (const auto& k : keys)
    if (obj.contains(k) && obj[k].is_array()) rows = std::max(rows, obj[k].size());
  std::ostringstream s;
  for (std::size_t c = 0; c < header.size(); ++c) s << (c ? "," : "") << header[c];
  s << '\n';
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t c = 0; c < keys.size(); ++c) {
      const json& col = obj.contains(keys[c]) ? obj[keys[c]] : json();
      s << (c ? "," : "") << (col.is_array() && r < col.size() ? csvNumber(col[r]) : "");
    }
    s << '\n';
  }
  writeTextFileAtomic(path, s.str());
}

}  // namespace

const std::set<std::string>& statisticNames() {
  static const std::set<std::string> names{"axial",  "radial", "s2",           "mes",        "psd",
                                           "chords", "shadow", "coordination", "orientation"};
  return names;
}

json statsHeaderJson(const Lattice& l, const StatsOptions& options,
                     const std::set<std::string>& which, const BedSummary& sum, double diameter) {
  json out;
  out["voxpack_version"] = versionString();
  out["options"] = optionsJson(options, which);
  out["lattice"] = {{"dims", {l.dims[0], l.dims[1], l.dims[2]}},
                    {"spacing_mm", {l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]}},
                    {"origin_mm", {l.originMm[0], l.originMm[1], l.originMm[2]}}};
  out["voxels_in_mask"] = sum.voxelsInMask;
  out["void_voxels"] = sum.voidVoxels;
  out["porosity"] = sum.emptyMask ? json(nullptr) : json(sum.porosity);
  out["packing_density"] = sum.emptyMask ? json(nullptr) : json(sum.packingDensity);
  out["particle_diameter_mm"] = diameter > 0 ? json(diameter) : json(nullptr);
  return out;
}

json axialJson(const AxialProfile& axial, double trim) {
  json a;
  a["z_mm"] = arr(axial.zMm);
  a["density"] = arr(axial.density);
  a["mean"] = finiteOrNull(axial.mean);
  a["std"] = finiteOrNull(axial.std);
  a["trim_mm"] = trim;
  a["slices_used"] = axial.density.size();
  a["z_all_mm"] = arr(axial.zMmAll);
  a["density_all"] = arr(axial.densityAll);
  a["histogram"] = {{"edges", arr(axial.histogramEdges)}, {"counts", arr(axial.histogramCounts)}};
  const auto& nt = axial.normality;
  a["normality"] = {{"test", "dagostino-pearson"},
                    {"statistic", nt.statistic >= 0 ? json(nt.statistic) : json(nullptr)},
                    {"p_value", nt.pValue >= 0 ? json(nt.pValue) : json(nullptr)},
                    {"skewness", nt.statistic >= 0 ? json(nt.skewness) : json(nullptr)},
                    {"excess_kurtosis", nt.statistic >= 0 ? json(nt.kurtosis) : json(nullptr)}};
  return a;
}

RadialOptions radialOptions(const StatsOptions& options, const AxialProfile& axial,
                            double diameter) {
  RadialOptions ro;
  ro.binWidthMm = options.radialBinMm;
  if (axial.lastSlice >= axial.firstSlice) {
    ro.firstSlice = axial.firstSlice;
    ro.lastSlice = axial.lastSlice;
  }
  if (diameter > 0) ro.coreMarginMm = 2 * diameter;
  return ro;
}

json radialJson(const RadialProfile& rp, double diameter) {
  json r;
  r["r_mm"] = arr(rp.rMm);
  r["density"] = arr(rp.density);
  r["wall_distance_mm"] = arr(rp.wallDistanceMm);
  if (diameter > 0) {
    std::vector<double> wd(rp.wallDistanceMm.size());
    for (std::size_t b = 0; b < wd.size(); ++b) wd[b] = rp.wallDistanceMm[b] / diameter;
    r["wall_distance_d"] = arr(wd);
  }
  r["area_mm2"] = arr(rp.areaMm2);
  r["axis_mm"] = {rp.axisMm[0], rp.axisMm[1]};
  r["radius_mm"] = rp.radiusMm;
  r["axis_fitted"] = true;
  r["core_radius_mm"] = finiteOrNull(rp.coreRadiusMm);
  r["core_density"] = finiteOrNull(rp.coreDensity);
  r["whole_density"] = finiteOrNull(rp.wholeDensity);
  return r;
}

S2Options s2Options(const StatsOptions& options) {
  S2Options so;
  so.maxLagMm = options.s2MaxLagMm;
  so.precision = options.s2Float ? FftPrecision::Float : FftPrecision::Double;
  so.threads = options.threads;
  so.tileVoxels = options.s2TileVoxels;
  return so;
}

json s2Json(const S2Result& s, const StatsOptions& options) {
  json j;
  if (s.emptyMask) {
    j = {{"h_mm", json::array()}, {"s2", json::array()}, {"phi", nullptr}};
  } else {
    j["h_mm"] = arr(s.radial.hMm);
    j["s2"] = arr(s.radial.s2);
    j["pairs"] = arr(s.radial.pairs);
    j["phi"] = finiteOrNull(s.phi);
    j["axial"] = s2Curve(s.axial);
    j["transverse"] = s2Curve(s.transverse);
    j["correlation_length_mm"] =
        s.correlationLengthMm >= 0 ? json(s.correlationLengthMm) : json(nullptr);
    j["specific_surface_per_mm"] =
        s.specificSurfacePerMm >= 0 ? json(s.specificSurfacePerMm) : json(nullptr);
  }
  j["max_lag_voxels"] = {s.maxLagVoxels[0], s.maxLagVoxels[1], s.maxLagVoxels[2]};
  j["fft_dims"] = {s.paddedDims[0], s.paddedDims[1], s.paddedDims[2]};
  j["precision"] = options.s2Float ? "float" : "double";
  return j;
}

void validateStatsOptions(const StatsOptions& options) {
  for (const auto& n : options.only)
    if (!statisticNames().count(n))
      throw InputError("stats: unknown statistic '" + n +
                       "' (known: axial, radial, s2, mes, psd, chords, shadow, coordination, "
                       "orientation)");
  if (options.threads < 1) throw InputError("stats: threads must be >= 1");
  if (!std::isfinite(options.particleDiameterMm) || !std::isfinite(options.trimMm) ||
      !std::isfinite(options.s2MaxLagMm) || !std::isfinite(options.radialBinMm))
    throw InputError("stats: options must be finite numbers");
  if (options.mesMethod != "lattice" && options.mesMethod != "isotropic" &&
      options.mesMethod != "both")
    throw InputError("stats: mes method must be lattice, isotropic or both, not '" +
                     options.mesMethod + "'");
  if (options.mesSamples < 1) throw InputError("stats: mes samples must be >= 1");
  if (options.mesDirections < 1) throw InputError("stats: mes directions must be >= 1");
}

json computeStats(const Bed& bed, const StatsOptions& options, Progress& progress) {
  validateStatsOptions(options);
  bed.lattice().validate("bed");
  const std::set<std::string> which = options.only.empty() ? statisticNames() : options.only;
  auto want = [&](const char* n) { return which.count(n) != 0; };

  const BedSummary sum = summarize(bed);
  const double diameter =
      options.particleDiameterMm > 0 ? options.particleDiameterMm : inferDiameterMm(bed.particles);
  json out = statsHeaderJson(bed.lattice(), options, which, sum, diameter);
  const double trim = options.trimMm >= 0 ? options.trimMm : (diameter > 0 ? 2 * diameter : 0);

  AxialProfile axial;
  const bool needAxial = want("axial") || want("radial");
  if (needAxial) {
    progress.report("axial profile", 0);
    AxialOptions ao;
    ao.trimMm = trim;
    axial = axialProfile(bed, ao);
  }
  if (want("axial")) out["axial"] = axialJson(axial, trim);
  if (want("radial")) {
    progress.report("radial profile", 0);
    const RadialProfile rp = radialProfile(bed, radialOptions(options, axial, diameter));
    out["radial"] = radialJson(rp, diameter);
  }
  if (want("s2")) {
    const S2Result s = twoPointProbability(bed.indicator, bed.mask ? &*bed.mask : nullptr,
                                           s2Options(options), progress);
    out["s2"] = s2Json(s, options);
  }
  addExtraStatistics(out, bed, options, which, diameter, progress);
  sanitizeNonFinite(out);
  return out;
}

void writeStatsCsv(const json& stats, const std::filesystem::path& dir, const std::string& prefix) {
  ensureWritableDirectory(dir, true);
  auto file = [&](const std::string& name) { return dir / (prefix + name); };
  if (stats.contains("axial"))
    writeColumns(file("axial.csv"), stats["axial"], {"z_mm", "density"}, {"z_mm", "density"});
  if (stats.contains("radial"))
    writeColumns(file("radial.csv"), stats["radial"], {"r_mm", "wall_distance_mm", "density"},
                 {"r_mm", "wall_distance_mm", "density"});
  if (stats.contains("s2")) {
    const json& s = stats["s2"];
    writeColumns(file("s2.csv"), s, {"h_mm", "s2"}, {"h_mm", "s2"});
    if (s.contains("axial"))
      writeColumns(file("s2_axial.csv"), s["axial"], {"h_mm", "s2"}, {"h_mm", "s2"});
    if (s.contains("transverse"))
      writeColumns(file("s2_transverse.csv"), s["transverse"], {"h_mm", "s2"}, {"h_mm", "s2"});
  }
  writeExtraCsv(stats, dir, prefix);
}

}  // namespace voxpack::stats
