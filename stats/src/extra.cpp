// The statistics beyond the profiles and S2, as JSON and CSV (docs/stats.md).
#include <algorithm>
#include <cmath>
#include <sstream>

#include "voxpack/core/atomic_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/stats/mes.hpp"
#include "voxpack/stats/structure.hpp"
#include "voxpack_stats_extra.hpp"

namespace voxpack::stats {
namespace {

using nlohmann::json;

json lengthJson(const LengthDistribution& d) {
  json j;
  j["bins_mm"] = finiteArray(d.binsMm);
  j["pdf"] = finiteArray(d.pdf);
  j["bin_width_mm"] = finiteOrNull(d.binWidthMm);
  j["mean_mm"] = d.samples ? finiteOrNull(d.meanMm) : json(nullptr);
  j["std_mm"] = d.samples ? finiteOrNull(d.stdMm) : json(nullptr);
  j["lognormal"] = {{"mu", d.samples ? finiteOrNull(d.lognormalMu) : json(nullptr)},
                    {"sigma", d.samples ? finiteOrNull(d.lognormalSigma) : json(nullptr)}};
  j["samples"] = d.samples;
  return j;
}

json imageJson(const ShadowImage& img) {
  json rows = json::array();
  for (std::int64_t r = 0; r < img.rows; ++r) {
    std::vector<double> row(img.values.begin() + r * img.cols,
                            img.values.begin() + (r + 1) * img.cols);
    rows.push_back(finiteArray(row));
  }
  return {{"rows", img.rows}, {"cols", img.cols}, {"solid_fraction", rows}};
}

std::string num(const json& v) {
  if (!v.is_number()) return "";
  std::ostringstream s;
  s.precision(10);
  s << v.get<double>();
  return s.str();
}

void writePairs(const std::filesystem::path& path, const std::string& header, const json& a,
                const json& b) {
  std::ostringstream s;
  s << header << '\n';
  for (std::size_t r = 0; r < a.size(); ++r)
    s << num(a[r]) << ',' << (r < b.size() ? num(b[r]) : "") << '\n';
  writeTextFileAtomic(path, s.str());
}

}  // namespace

json mesJson(const MesResult& r, const char* method) {
  json j = lengthJson(r.distribution);
  // The distribution's own (minus-sampling weighted) mean; the lattice path reports as
  // mean_mm the lower-variance per-direction estimator of the same E[m] (docs/stats.md).
  j["voxel_mean_mm"] = j["mean_mm"];
  if (std::string(method) == "lattice-13" && r.distribution.samples)
    j["mean_mm"] = finiteOrNull(r.directionalMeanMm);
  j["method"] = method;
  j["directions"] = r.directions;
  j["void_voxels"] = r.voidVoxels;
  j["undefined_voxels"] = r.undefinedVoxels;
  j["window_cuts"] = "minus sampling (docs/stats.md)";
  if (r.sliceCutVoxels || r.sliceCutChords)
    j["slice_cuts"] = {{"voxels", r.sliceCutVoxels}, {"chords", r.sliceCutChords}};
  j["seconds"] = r.seconds;
  return j;
}

json chordsJson(const ChordLengths& c) {
  json j = lengthJson(c.all);
  j["z"] = lengthJson(c.perAxis[0]);
  j["y"] = lengthJson(c.perAxis[1]);
  j["x"] = lengthJson(c.perAxis[2]);
  return j;
}

void addExtraStatistics(json& out, const Bed& bed, const StatsOptions& options,
                        const std::set<std::string>& which, double diameterMm, Progress& progress) {
  auto want = [&](const char* n) { return which.count(n) != 0; };
  const bool explicitOnly = !options.only.empty();
  if (want("mes")) {
    json lattice, isotropic;
    if (options.mesMethod != "isotropic") {
      MesLatticeOptions mo;
      mo.threads = options.threads;
      lattice = mesJson(meanEmptySpaceLattice(bed, mo, progress), "lattice-13");
    }
    if (options.mesMethod != "lattice") {
      MesIsotropicOptions io;
      io.samples = options.mesSamples;
      io.directions = options.mesDirections;
      io.seed = options.seed;
      io.threads = options.threads;
      isotropic = mesJson(meanEmptySpaceIsotropic(bed, io, progress), "isotropic-cgal");
    }
    json m = options.mesMethod == "isotropic" ? isotropic : lattice;
    if (options.mesMethod == "both") {
      m["isotropic"] = isotropic;
      const json& a = lattice["mean_mm"];
      const json& b = isotropic["mean_mm"];
      m["lattice_vs_isotropic_mean_rel_diff"] =
          a.is_number() && b.is_number() && b.get<double>() > 0
              ? json(a.get<double>() / b.get<double>() - 1)
              : json(nullptr);
    }
    if (diameterMm > 0 && m["mean_mm"].is_number())
      m["mean_d"] = m["mean_mm"].get<double>() / diameterMm;
    out["mes"] = m;
  }
  if (want("psd")) {
    progress.report("pore sizes", 0);
    const PoreSizeDistribution p = poreSizeDistribution(bed, 0, options.threads);
    json j = lengthJson(p.distribution);
    j["ccdf_mm"] = finiteArray(p.ccdfMm);
    j["ccdf"] = finiteArray(p.ccdf);
    j["max_mm"] = p.maxMm;
    j["definition"] =
        "distance from each void voxel centre to the nearest solid or wall voxel centre";
    out["psd"] = j;
  }
  if (want("chords")) {
    progress.report("chord lengths", 0);
    out["chords"] = chordsJson(chordLengths(bed, 0));
  }
  if (want("shadow")) {
    progress.report("shadow images", 0);
    out["shadow"] = {{"z", imageJson(shadowImage(bed, 0))},
                     {"y", imageJson(shadowImage(bed, 1))},
                     {"x", imageJson(shadowImage(bed, 2))},
                     {"note",
                      "mean solid fraction inside the mask along the named axis; "
                      "z image is [y][x], y image [z][x], x image [z][y]"}};
  }
  if (want("coordination")) {
    if (bed.labels) {
      const Coordination c = coordinationNumbers(bed);
      std::vector<double> hist;
      for (double v : c.perParticle) {
        const auto b = static_cast<std::size_t>(v);
        if (b >= hist.size()) hist.resize(b + 1, 0.0);
        hist[b] += 1;
      }
      out["coordination"] = {{"mean", finiteOrNull(c.mean)},
                             {"particles", c.particles},
                             {"contacts", c.contacts},
                             {"histogram", finiteArray(hist)},
                             {"definition", "face-adjacent voxels of different labels"}};
    } else if (explicitOnly) {
      throw InputError("coordination: the bed has no /labels");
    } else {
      out["coordination"] = nullptr;
    }
  }
  if (want("orientation")) {
    if (!bed.particles.orientation.empty()) {
      const OrientationDistribution o = orientationDistribution(bed);
      out["orientation"] = {{"histogram_edges_deg", finiteArray(o.histogramEdgesDeg)},
                            {"histogram", finiteArray(o.histogram)},
                            {"mean_cos", o.meanCos},
                            {"order_parameter", o.orderParameter},
                            {"particles", o.anglesDeg.size()},
                            {"axis", "body z axis vs column axis z"}};
    } else if (explicitOnly) {
      throw InputError("orientation: the bed has no /particles/orientation");
    } else {
      out["orientation"] = nullptr;
    }
  }
}

void writeExtraCsv(const json& stats, const std::filesystem::path& dir, const std::string& prefix) {
  auto file = [&](const std::string& name) { return dir / (prefix + name); };
  auto dist = [&](const char* key, const char* name, const char* header) {
    if (stats.contains(key) && stats[key].is_object() && stats[key].contains("bins_mm"))
      writePairs(file(name), header, stats[key]["bins_mm"], stats[key]["pdf"]);
  };
  dist("mes", "mes.csv", "bin_mm,pdf");
  if (stats.contains("mes") && stats["mes"].is_object() && stats["mes"].contains("isotropic"))
    writePairs(file("mes_isotropic.csv"), "bin_mm,pdf", stats["mes"]["isotropic"]["bins_mm"],
               stats["mes"]["isotropic"]["pdf"]);
  dist("psd", "psd.csv", "bin_mm,pdf");
  dist("chords", "chords.csv", "bin_mm,pdf");
  if (stats.contains("shadow") && stats["shadow"].is_object()) {
    for (const char* axis : {"x", "y", "z"}) {
      const json& img = stats["shadow"][axis]["solid_fraction"];
      std::ostringstream s;
      for (const auto& row : img) {
        for (std::size_t c = 0; c < row.size(); ++c) s << (c ? "," : "") << num(row[c]);
        s << '\n';
      }
      writeTextFileAtomic(file(std::string("shadow_") + axis + ".csv"), s.str());
    }
  }
  if (stats.contains("orientation") && stats["orientation"].is_object()) {
    const json& o = stats["orientation"];
    std::ostringstream s;
    s << "angle_lo_deg,angle_hi_deg,fraction\n";
    for (std::size_t b = 0; b < o["histogram"].size(); ++b)
      s << num(o["histogram_edges_deg"][b]) << ',' << num(o["histogram_edges_deg"][b + 1]) << ','
        << num(o["histogram"][b]) << '\n';
    writeTextFileAtomic(file("orientation.csv"), s.str());
  }
  if (stats.contains("coordination") && stats["coordination"].is_object()) {
    std::ostringstream s;
    s << "coordination,particles\n";
    const json& h = stats["coordination"]["histogram"];
    for (std::size_t b = 0; b < h.size(); ++b) s << b << ',' << num(h[b]) << '\n';
    writeTextFileAtomic(file("coordination.csv"), s.str());
  }
}

void writeShadowPngs(const json& stats, const std::filesystem::path& dir,
                     const std::string& prefix) {
  if (!stats.contains("shadow") || !stats["shadow"].is_object()) return;
  ensureWritableDirectory(dir, true);
  for (const char* axis : {"x", "y", "z"}) {
    const json& j = stats["shadow"][axis];
    ShadowImage img;
    img.rows = j["rows"].get<std::int64_t>();
    img.cols = j["cols"].get<std::int64_t>();
    for (const auto& row : j["solid_fraction"])
      for (const auto& v : row)
        img.values.push_back(v.is_number() ? v.get<double>() : std::nan(""));
    // z points up in the side views (x and y projections): first image row = top slice.
    writeGreyPng(img, (dir / (prefix + "shadow_" + axis + ".png")).string(),
                 std::string(axis) != "z");
  }
}

}  // namespace voxpack::stats
