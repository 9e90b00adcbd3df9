#include "voxpack/compare/compare.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <set>

#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"

namespace voxpack::compare {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A JSON number array as doubles; null (NaN written by json_util) stays NaN.
std::vector<double> numbers(const nlohmann::json& obj, const char* key) {
  std::vector<double> v;
  if (!obj.is_object()) return v;
  const auto it = obj.find(key);
  if (it == obj.end() || !it->is_array()) return v;
  v.reserve(it->size());
  for (const auto& e : *it) v.push_back(e.is_number() ? e.get<double>() : kNaN);
  return v;
}

double number(const nlohmann::json& obj, const char* key) {
  if (!obj.is_object()) return kNaN;
  const auto it = obj.find(key);
  return (it != obj.end() && it->is_number()) ? it->get<double>() : kNaN;
}

const nlohmann::json& block(const nlohmann::json& stats, const char* key) {
  static const nlohmann::json empty = nlohmann::json::object();
  if (!stats.is_object()) return empty;
  const auto it = stats.find(key);
  return (it != stats.end() && it->is_object()) ? *it : empty;
}

// Slice densities that enter the axial mean/std: stats lists in axial.density only the
// slices kept after trimming the bed ends (all slices are in axial.density_all).
std::vector<double> axialSample(const nlohmann::json& axial) {
  std::vector<double> out;
  for (double v : numbers(axial, "density"))
    if (std::isfinite(v)) out.push_back(v);
  return out;
}

double meanDensity(const nlohmann::json& stats) {
  const double m = number(block(stats, "axial"), "mean");
  return std::isfinite(m) ? m : number(stats, "packing_density");
}

}  // namespace

stats::StatsOptions defaultStatsOptions() {
  stats::StatsOptions o;
  o.only = {"axial", "radial", "s2", "mes"};
  return o;
}

PackedRegion packedRegion(const Bed& bed, double fraction) {
  const Lattice& l = bed.lattice();
  const std::size_t slice = static_cast<std::size_t>(l.ny() * l.nx());
  std::vector<double> d(static_cast<std::size_t>(l.nz()), kNaN);
  for (std::int64_t k = 0; k < l.nz(); ++k) {
    std::size_t m = 0, solid = 0;
    const std::size_t base = static_cast<std::size_t>(k) * slice;
    for (std::size_t o = base; o < base + slice; ++o) {
      if (bed.mask && (*bed.mask)[o] == 0) continue;
      ++m;
      solid += bed.indicator[o] == 0;
    }
    if (m > 0) d[static_cast<std::size_t>(k)] = static_cast<double>(solid) / static_cast<double>(m);
  }
  // A slice is "packing" when partly solid; a fully solid slice is an end wall or lid.
  auto packing = [](double v) { return std::isfinite(v) && v > 0.0 && v < 0.999; };
  std::vector<double> partly;
  for (double v : d)
    if (packing(v)) partly.push_back(v);
  PackedRegion r;
  r.lastSlice = l.nz() - 1;
  // The peak, not the median: in a tall container most slices may be empty headspace
  // with a few specks, and a median would then sit at the specks' level.
  if (!partly.empty()) r.peakDensity = *std::max_element(partly.begin(), partly.end());
  if (fraction > 0.0 && r.peakDensity > 0.0) {
    const double cut = fraction * r.peakDensity;
    std::int64_t lo = -1, hi = -1;
    for (std::int64_t k = 0; k < l.nz(); ++k) {
      const double v = d[static_cast<std::size_t>(k)];
      if (packing(v) && v >= cut) {
        if (lo < 0) lo = k;
        hi = k;
      }
    }
    if (lo >= 0) {
      r.firstSlice = lo;
      r.lastSlice = hi;
    }
  }
  r.cropped = r.firstSlice > 0 || r.lastSlice < l.nz() - 1;
  r.fromMm = l.originMm[0] + static_cast<double>(r.firstSlice) * l.spacingMm[0];
  r.toMm = l.originMm[0] + static_cast<double>(r.lastSlice) * l.spacingMm[0];
  return r;
}

Bed cropSlices(const Bed& bed, std::int64_t first, std::int64_t last) {
  const Lattice& l = bed.lattice();
  first = std::max<std::int64_t>(first, 0);
  last = std::min<std::int64_t>(last, l.nz() - 1);
  if (last < first) throw InputError("compare: empty slice range to crop");
  Lattice c = l;
  c.dims[0] = last - first + 1;
  c.originMm[0] = l.originMm[0] + static_cast<double>(first) * l.spacingMm[0];
  const std::size_t slice = static_cast<std::size_t>(l.ny() * l.nx());
  const auto from = static_cast<std::ptrdiff_t>(static_cast<std::size_t>(first) * slice);
  const auto to = static_cast<std::ptrdiff_t>(static_cast<std::size_t>(last + 1) * slice);
  Bed out;
  out.indicator = Grid<std::uint8_t>(c);
  std::copy(bed.indicator.values().begin() + from, bed.indicator.values().begin() + to,
            out.indicator.values().begin());
  if (bed.mask) {
    out.mask = Grid<std::uint8_t>(c);
    std::copy(bed.mask->values().begin() + from, bed.mask->values().begin() + to,
              out.mask->values().begin());
  }
  if (bed.labels) {
    out.labels = Grid<std::uint32_t>(c);
    std::copy(bed.labels->values().begin() + from, bed.labels->values().begin() + to,
              out.labels->values().begin());
  }
  out.particles = bed.particles;
  out.provenance = bed.provenance;
  return out;
}

nlohmann::json calibrationBand(const nlohmann::json& calibration, double densityMean) {
  if (!calibration.is_object() || !std::isfinite(densityMean)) return nullptr;
  const auto bias = calibration.find("density_bias");
  if (bias == calibration.end() || !bias->is_number()) return nullptr;
  const double b = bias->get<double>();
  const auto sd = calibration.find("density_bias_std");
  const double s = sd != calibration.end() && sd->is_number() ? sd->get<double>() : 0.0;
  nlohmann::json j = calibration;
  j["density_mean"] = densityMean;
  j["density_corrected"] = densityMean - b;
  j["density_band"] = {densityMean - b - s, densityMean - b + s};
  j["note"] =
      "bias = segmented - true density on phantoms of the reference bed; the band is "
      "the reference's density minus the bias, +- one std";
  return j;
}

std::vector<double> wallDistanceMm(const nlohmann::json& radial) {
  std::vector<double> w = numbers(radial, "wall_distance_mm");
  const std::vector<double> r = numbers(radial, "r_mm");
  if (w.size() == r.size() && !w.empty()) return w;
  const double radius = number(radial, "radius_mm");
  w.assign(r.size(), kNaN);
  if (std::isfinite(radius))
    for (std::size_t k = 0; k < r.size(); ++k) w[k] = radius - r[k];
  return w;
}

Distances computeDistances(const nlohmann::json& referenceStats,
                           const nlohmann::json& candidateStats, const CompareOptions& options) {
  Distances d;
  const auto& ra = block(referenceStats, "axial");
  const auto& ca = block(candidateStats, "axial");
  const double refMean = meanDensity(referenceStats);
  d.densityMean = meanDensity(candidateStats);
  d.densityStd = number(ca, "std");
  d.densityRelDiff = (refMean > 0.0) ? (d.densityMean - refMean) / refMean : kNaN;
  if (d.densityMean == refMean) d.densityRelDiff = 0.0;  // exact zero on self-comparison
  d.axialKs = ksTwoSample(axialSample(ra), axialSample(ca), options.ks);

  const auto& rr = block(referenceStats, "radial");
  const auto& cr = block(candidateStats, "radial");
  d.radial = curveRmse(sortedCurve(wallDistanceMm(rr), numbers(rr, "density")),
                       sortedCurve(wallDistanceMm(cr), numbers(cr, "density")), options.radialGrid);

  const auto& rs = block(referenceStats, "s2");
  const auto& cs = block(candidateStats, "s2");
  d.s2 = curveRmse(sortedCurve(numbers(rs, "h_mm"), numbers(rs, "s2")),
                   sortedCurve(numbers(cs, "h_mm"), numbers(cs, "s2")), options.s2Grid);

  const auto& rm = block(referenceStats, "mes");
  const auto& cm = block(candidateStats, "mes");
  d.mesKs = distributionKs(numbers(rm, "bins_mm"), numbers(rm, "pdf"), numbers(cm, "bins_mm"),
                           numbers(cm, "pdf"));
  return d;
}

nlohmann::json distancesToJson(const std::string& name, const Distances& d) {
  nlohmann::json j;
  j["name"] = name;
  j["density_mean"] = finiteOrNull(d.densityMean);
  j["density_std"] = finiteOrNull(d.densityStd);
  j["density_rel_diff"] = finiteOrNull(d.densityRelDiff);
  j["axial_ks_p"] = finiteOrNull(d.axialKs.pValue);
  j["radial_rmse"] = finiteOrNull(d.radial.rmse);
  j["s2_rmse"] = finiteOrNull(d.s2.rmse);
  j["mes_ks"] = finiteOrNull(d.mesKs);
  j["details"] = {
      {"axial_ks_statistic", finiteOrNull(d.axialKs.statistic)},
      {"axial_ks_method", ksMethodName(d.axialKs.method)},
      {"radial_grid_mm",
       {{"from", finiteOrNull(d.radial.fromMm)},
        {"to", finiteOrNull(d.radial.toMm)},
        {"step", finiteOrNull(d.radial.stepMm)},
        {"points", d.radial.points}}},
      {"s2_grid_mm",
       {{"from", finiteOrNull(d.s2.fromMm)},
        {"to", finiteOrNull(d.s2.toMm)},
        {"step", finiteOrNull(d.s2.stepMm)},
        {"points", d.s2.points}}},
  };
  return j;
}

Image2D shadowImage(const Bed& bed) {
  const Lattice& l = bed.lattice();
  Image2D img;
  img.rows = l.nz();
  img.cols = l.nx();
  img.rowAxis = "z";
  img.colAxis = "x";
  img.rowFromMm = l.originMm[0];
  img.rowToMm = l.originMm[0] + static_cast<double>(l.nz() - 1) * l.spacingMm[0];
  img.colFromMm = l.originMm[2];
  img.colToMm = l.originMm[2] + static_cast<double>(l.nx() - 1) * l.spacingMm[2];
  img.values.assign(static_cast<std::size_t>(img.rows * img.cols), kNaN);
  std::vector<std::int64_t> solid(static_cast<std::size_t>(l.nx()));
  std::vector<std::int64_t> count(static_cast<std::size_t>(l.nx()));
  for (std::int64_t k = 0; k < l.nz(); ++k) {
    std::fill(solid.begin(), solid.end(), 0);
    std::fill(count.begin(), count.end(), 0);
    for (std::int64_t j = 0; j < l.ny(); ++j) {
      const std::size_t row = l.offset(k, j, 0);
      for (std::int64_t i = 0; i < l.nx(); ++i) {
        const auto off = row + static_cast<std::size_t>(i);
        if (bed.mask && (*bed.mask)[off] == 0) continue;
        ++count[static_cast<std::size_t>(i)];
        if (bed.indicator[off] == 0) ++solid[static_cast<std::size_t>(i)];
      }
    }
    for (std::int64_t i = 0; i < l.nx(); ++i) {
      const auto c = count[static_cast<std::size_t>(i)];
      if (c > 0)
        img.values[static_cast<std::size_t>(k * img.cols + i)] =
            static_cast<double>(solid[static_cast<std::size_t>(i)]) / static_cast<double>(c);
    }
  }
  return img;
}

Image2D voidSlice(const Bed& bed) {
  const Lattice& l = bed.lattice();
  std::int64_t kLo = -1, kHi = -1;
  for (std::int64_t k = 0; k < l.nz(); ++k) {
    bool any = !bed.mask.has_value();
    if (!any) {
      const std::size_t base = l.offset(k, 0, 0);
      const std::size_t n = static_cast<std::size_t>(l.ny() * l.nx());
      for (std::size_t o = 0; o < n && !any; ++o) any = (*bed.mask)[base + o] != 0;
    }
    if (any) {
      if (kLo < 0) kLo = k;
      kHi = k;
    }
  }
  const std::int64_t k = (kLo < 0) ? l.nz() / 2 : (kLo + kHi) / 2;
  Image2D img;
  img.rows = l.ny();
  img.cols = l.nx();
  img.rowAxis = "y";
  img.colAxis = "x";
  img.rowFromMm = l.originMm[1];
  img.rowToMm = l.originMm[1] + static_cast<double>(l.ny() - 1) * l.spacingMm[1];
  img.colFromMm = l.originMm[2];
  img.colToMm = l.originMm[2] + static_cast<double>(l.nx() - 1) * l.spacingMm[2];
  img.values.assign(static_cast<std::size_t>(img.rows * img.cols), kNaN);
  for (std::int64_t j = 0; j < l.ny(); ++j)
    for (std::int64_t i = 0; i < l.nx(); ++i) {
      const std::size_t off = l.offset(k, j, i);
      if (bed.mask && (*bed.mask)[off] == 0) continue;
      img.values[static_cast<std::size_t>(j * img.cols + i)] = bed.indicator[off] ? 1.0 : 0.0;
    }
  return img;
}

namespace {

void collectStrings(const nlohmann::json& j, std::vector<std::string>& out) {
  if (j.is_string()) {
    out.push_back(j.get<std::string>());
  } else if (j.is_structured()) {
    for (const auto& e : j) collectStrings(e, out);
  }
}

bool hasSyntheticFlag(const nlohmann::json& j) {
  if (j.is_object()) {
    const auto it = j.find("synthetic");
    if (it != j.end() && it->is_boolean() && it->get<bool>()) return true;
  }
  if (j.is_structured())
    for (const auto& e : j)
      if (hasSyntheticFlag(e)) return true;
  return false;
}

bool contains(const std::string& s, const char* w) { return s.find(w) != std::string::npos; }

// The first bytes of an image file named in the provenance: enough for an NRRD/MHA text
// header, which `voxpack phantom` marks.
std::string headerTextOfInputs(const nlohmann::json& provenance,
                               const std::filesystem::path& bedDir) {
  std::vector<std::string> strings;
  collectStrings(provenance, strings);
  std::string text;
  for (const auto& s : strings) {
    if (s.size() > 4096 || s.find('\n') != std::string::npos) continue;
    std::error_code ec;
    std::filesystem::path p(s);
    // Relative inputs are relative to where ingest ran: try here, then beside the bed.
    if (!std::filesystem::is_regular_file(p, ec) && p.is_relative()) p = bedDir / p;
    if (!std::filesystem::is_regular_file(p, ec) || p.extension() == ".h5") continue;
    std::ifstream f(p, std::ios::binary);
    std::string buf(16384, '\0');
    f.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    buf.resize(static_cast<std::size_t>(f.gcount()));
    text += buf;
  }
  return text;
}

std::string uniqueName(const std::filesystem::path& p,
                       const std::vector<std::filesystem::path>& all) {
  const std::string stem = p.stem().string();
  int same = 0;
  for (const auto& q : all)
    if (q.stem().string() == stem) ++same;
  if (same <= 1) return stem;
  const std::string parent = p.parent_path().filename().string();
  return parent.empty() ? stem : parent + "/" + stem;
}

}  // namespace

BedOrigin classifyOrigin(const nlohmann::json& provenance, const std::string& inputHeaderText) {
  BedOrigin o;
  const std::string all = provenance.dump();
  const bool phantom = hasSyntheticFlag(provenance) || contains(all, "phantom") ||
                       contains(inputHeaderText, "voxpack phantom") ||
                       contains(inputHeaderText, "voxpack_modality") ||
                       contains(inputHeaderText, "synthetic");
  std::string command;
  if (provenance.is_object()) {
    for (const char* key : {"command_line", "command", "commandLine"}) {
      const auto it = provenance.find(key);
      if (it != provenance.end() && it->is_string()) {
        command = it->get<std::string>();
        break;
      }
    }
  }
  if (contains(command, " ingest") || contains(all, "\"ingest\"")) {
    o.kind = phantom ? "synthetic image" : "imaged";
    o.detail = phantom ? "ingest of a voxpack phantom" : "ingest";
    o.synthetic = phantom;
  } else if (contains(command, " pack") || contains(all, "\"pack\"")) {
    o.kind = "simulated";
    std::string mode;
    if (provenance.is_object() && provenance.contains("mode") && provenance["mode"].is_string())
      mode = provenance["mode"].get<std::string>();
    const auto at = command.find("--mode");
    if (mode.empty() && at != std::string::npos) {
      std::size_t b = command.find_first_not_of(" =", at + 6);
      std::size_t e = command.find(' ', b == std::string::npos ? command.size() : b);
      if (b != std::string::npos) mode = command.substr(b, e == std::string::npos ? e : e - b);
    }
    o.detail = mode.empty() ? "pack" : "pack --mode " + mode;
    o.synthetic = true;
  } else if (phantom) {
    o.kind = "synthetic image";
    o.detail = "phantom";
    o.synthetic = true;
  } else {
    o.kind = "unknown";
    o.detail = "no provenance";
    o.synthetic = false;
  }
  return o;
}

Comparison compareBedFiles(const std::filesystem::path& reference,
                           const std::vector<std::filesystem::path>& candidates,
                           const CompareOptions& options, Progress& progress) {
  if (candidates.empty()) throw InputError("compare: no candidate bed given");
  std::vector<std::filesystem::path> all{reference};
  all.insert(all.end(), candidates.begin(), candidates.end());
  // Display names: file stems, with the parent folder when stems clash, and a counter
  // when even that clashes (a bed compared with itself).
  std::vector<std::string> names;
  for (const auto& p : all) {
    std::string n = uniqueName(p, all);
    const std::string base = n;
    for (int k = 2; std::find(names.begin(), names.end(), n) != names.end(); ++k)
      n = base + "#" + std::to_string(k);
    names.push_back(n);
  }
  Comparison c;
  // The reference is often an ingested image without a particle table, so its particle
  // diameter (which sets the end trimming of the axial statistics and the core margin of
  // the radial profile) cannot be inferred: the candidates go first and the first inferred
  // diameter is used for every bed after it, so all beds are trimmed alike.
  CompareOptions opt = options;
  auto load = [&](const std::filesystem::path& p, std::size_t index) {
    progress.report("compare: statistics of " + p.filename().string(),
                    static_cast<double>(index) / static_cast<double>(all.size()));
    const Bed whole = readBed(p);
    BedEntry e;
    e.region = packedRegion(whole, opt.bedRegionFraction);
    Bed cropped;
    if (e.region.cropped) cropped = cropSlices(whole, e.region.firstSlice, e.region.lastSlice);
    const Bed& bed = e.region.cropped ? cropped : whole;
    e.name = names[index];
    e.path = p;
    e.spacingMm = bed.lattice().spacingMm;
    e.origin = classifyOrigin(bed.provenance, headerTextOfInputs(bed.provenance, p.parent_path()));
    if (bed.provenance.is_object() && bed.provenance.contains("calibration") &&
        bed.provenance["calibration"].is_object())
      e.calibration = bed.provenance["calibration"];
    e.stats = stats::computeStats(bed, opt.stats, progress);
    e.shadow = shadowImage(bed);
    e.slice = voidSlice(bed);
    if (opt.flow.enabled) {
      progress.report("compare: flow through " + p.filename().string(),
                      static_cast<double>(index) / static_cast<double>(all.size()));
      CompareFlowOptions fo = opt.flow;
      if (!(fo.solver.particleDiameterMm > 0))
        fo.solver.particleDiameterMm = opt.stats.particleDiameterMm;
      e.flow = flowRecord(bed, fo, progress);
      if (e.flow["status"] != "converged")
        c.warnings.push_back(
            "flow through " + names[index] + ": " + e.flow["status"].get<std::string>() +
            (e.flow["status"] == "not_converged" ? " (raise --flow-max-steps or --flow-tolerance)"
                                                 : ""));
    }
    if (!(opt.stats.particleDiameterMm > 0)) {
      const double d = number(e.stats, "particle_diameter_mm");
      if (std::isfinite(d) && d > 0) {
        opt.stats.particleDiameterMm = d;
        c.warnings.push_back("particle diameter " + std::to_string(d) + " mm inferred from " +
                             e.name + " is used for every other bed (set --particle-diameter " +
                             "to choose it)");
      }
    }
    return e;
  };
  for (std::size_t n = 0; n < candidates.size(); ++n)
    c.candidates.push_back(load(candidates[n], n + 1));
  c.reference = load(reference, 0);
  for (const auto& e : c.candidates)
    c.distances.push_back(computeDistances(c.reference.stats, e.stats, opt));
  std::vector<const BedEntry*> entries{&c.reference};
  for (const auto& e : c.candidates) entries.push_back(&e);
  const std::pair<const char*, const char*> required[] = {
      {"axial", "density"}, {"radial", "density"}, {"s2", "s2"}, {"mes", "pdf"}};
  for (const auto& [key, field] : required)
    for (const auto* e : entries)
      if (!block(e->stats, key).contains(field))
        c.warnings.push_back(std::string("no ") + key + " statistics for " + e->name +
                             ": its distances are null");
  progress.report("compare: statistics", 1.0);
  return c;
}

}  // namespace voxpack::compare
