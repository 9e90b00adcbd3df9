// The volume-preserving threshold on the streamed path (docs/scale.md, "Volume
// threshold, streamed"). The in-memory pipeline reads everything it needs from the whole
// image; here only additive sums and counts come from the whole volume, and the intensive
// quantities from a sample slab in the middle of the bed:
// - whole volume (pass 1): the raw grey sum per plane and distance from the wall, so the
//   mean intensity can be taken over the bed's slices and the column core whatever the
//   blur turns out to be; the denoised value counts (Otsu);
// - sample slab (read once, then once more): the phase levels (deep-voxel means, the noise
//   sigma), the wall blur, the interface density and the cleanup's shift;
// - whole volume (pass 2): the exact counts of the image the threshold cuts, over the bed's
//   slices and the core, whose order statistic at the aimed void fraction is the threshold.
// The levels, the blur and S_V are properties of the bed's material and the scanner, not of
// where in the bed they are read, so a slab of the bed reads them as the whole does.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "column_detail.hpp"
#include "heap.hpp"
#include "phase_reading.hpp"
#include "stream_detail.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/ingest/filters.hpp"
#include "voxpack/ingest/phases.hpp"
#include "voxpack/ingest/segment.hpp"

namespace voxpack::ingest::stream_detail {

void ValueCounts::add(float v) {
  lo = std::min(lo, v);
  hi = std::max(hi, v);
  if (v >= 0.0f && v < 65536.0f && v == std::floor(v)) {
    ++small[static_cast<std::size_t>(v)];
  } else if (!overflow) {
    ++other[v];
    if (other.size() > kMaxDistinct) {
      overflow = true;
      other = {};
    }
  }
}

void ValueCounts::reduce(const Communicator* comm) {
  if (!comm || comm->size() <= 1) return;
  // The integer grey values are summed over the ranks; other values are not gathered:
  // any of them on any rank means overflow (callers fall back to bins, which sum).
  comm->sum(small);
  lo = static_cast<float>(comm->min(static_cast<double>(lo)));
  hi = static_cast<float>(comm->max(static_cast<double>(hi)));
  if (!comm->allTrue(other.empty() && !overflow)) {
    overflow = true;
    other = {};
  }
}

std::vector<std::pair<float, std::uint64_t>> ValueCounts::sorted() const {
  std::vector<std::pair<float, std::uint64_t>> s;
  if (overflow) return s;
  s.assign(other.begin(), other.end());
  for (std::size_t v = 0; v < small.size(); ++v)
    if (small[v] > 0) s.emplace_back(static_cast<float>(v), small[v]);
  std::sort(s.begin(), s.end());
  return s;
}

namespace {
// The k smallest values form the lower class: solid when the void is bright.
std::uint64_t lowerCount(std::uint64_t n, double phi, bool voidBright) {
  const auto nv =
      static_cast<std::uint64_t>(std::llround(std::clamp(phi, 0.0, 1.0) * static_cast<double>(n)));
  return voidBright ? n - nv : nv;
}
}  // namespace

double quantileThreshold(const std::vector<std::pair<float, std::uint64_t>>& s, double phi,
                         bool voidBright) {
  std::uint64_t n = 0;
  for (const auto& [v, c] : s) n += c;
  if (n == 0) throw InputError("volume threshold: empty region");
  const std::uint64_t k = lowerCount(n, phi, voidBright);
  if (k == 0) return static_cast<double>(s.front().first) - 1.0;
  if (k == n) return s.back().first;
  std::uint64_t cum = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    cum += s[i].second;
    if (cum < k) continue;
    // The k-th smallest is s[i]; the (k+1)-th is s[i] too unless the count ends here.
    if (cum > k) return s[i].first;
    const double a = s[i].first, b = s[i + 1].first;
    return 0.5 * (a + b);
  }
  return s.back().first;
}

double quantileThresholdFromBins(const std::vector<double>& bins, float lo, float hi, double phi,
                                 bool voidBright) {
  double n = 0;
  for (double c : bins) n += c;
  if (!(n > 0)) throw InputError("volume threshold: empty region");
  if (!(hi > lo)) return lo;
  const auto k = static_cast<double>(lowerCount(static_cast<std::uint64_t>(n), phi, voidBright));
  const double width = (static_cast<double>(hi) - lo) / static_cast<double>(bins.size());
  double cum = 0;
  for (std::size_t b = 0; b < bins.size(); ++b) {
    if (cum + bins[b] >= k && bins[b] > 0)
      return lo + width * (static_cast<double>(b) + (k - cum) / bins[b]);
    cum += bins[b];
  }
  return hi;
}

std::vector<std::uint8_t> wallRings(const Lattice& l, const ColumnFit* column, std::int64_t k) {
  std::vector<std::uint8_t> ring(static_cast<std::size_t>(l.ny() * l.nx()), kRings);
  if (!column || !column->found) return ring;
  const double voxel = l.spacingMm[2];
  column_detail::forEachInPlane(l, *column, k, [&](std::int64_t j, std::int64_t i, double d2) {
    const double depth = (column->radiusMm - std::sqrt(d2)) / voxel;
    ring[static_cast<std::size_t>(j * l.nx() + i)] =
        depth <= 0.0 ? kOutside
                     : static_cast<std::uint8_t>(std::min<double>(kRings, std::floor(depth)));
  });
  return ring;
}

PlaneRings::PlaneRings(const Lattice& l, const ColumnFit* column) : l_(l) {
  if (column && column->found) {
    column_ = *column;
    upright_ = column->slopeX == 0.0 && column->slopeY == 0.0;
  }
  map_ = wallRings(l_, column_ ? &*column_ : nullptr, 0);
  at_ = 0;
}

const std::vector<std::uint8_t>& PlaneRings::operator()(std::int64_t k) {
  if (!upright_ && k != at_) {
    map_ = wallRings(l_, &*column_, k);
    at_ = k;
  }
  return map_;
}

void RingSums::reset(const Lattice& lattice, const ColumnFit* column) {
  rings.emplace(lattice, column);
  sum.assign(static_cast<std::size_t>(lattice.nz()) * (kOutside + 1), 0.0);
  count = sum;
}

void RingSums::add(const Grid<float>& raw, std::int64_t from, std::int64_t to, std::int64_t z) {
  const std::size_t plane = rings->plane(), stride = kOutside + 1;
  for (std::int64_t k = from; k < to; ++k) {
    const std::vector<std::uint8_t>& ring = (*rings)(z + k - from);
    double* s = sum.data() + static_cast<std::size_t>(z + k - from) * stride;
    double* c = count.data() + static_cast<std::size_t>(z + k - from) * stride;
    const float* v = raw.data() + static_cast<std::size_t>(k) * plane;
    for (std::size_t p = 0; p < plane; ++p) {
      s[ring[p]] += v[p];
      c[ring[p]] += 1.0;
    }
  }
}

void RingSums::reduce(const Communicator* comm) {
  if (!comm || comm->size() <= 1) return;
  comm->sum(sum);
  comm->sum(count);
}

std::int64_t volumeSamplePlanes(const Lattice& l) {
  const auto plane = static_cast<std::int64_t>(std::max<std::int64_t>(1, l.ny() * l.nx()));
  return std::min(l.nz(), std::clamp<std::int64_t>((std::int64_t{1} << 26) / plane, 16, 32));
}

namespace {

// Mask of the pixels at wall rings ring..kRings over `lat`, whose plane 0 is the volume's
// plane z0 (no column: nullopt, the whole image, whose pixels are all at kRings).
std::optional<Grid<std::uint8_t>> ringRegion(const Lattice& lat, std::int64_t z0, PlaneRings& rings,
                                             int ring, bool column) {
  if (!column) return std::nullopt;
  Grid<std::uint8_t> m(lat, 0);
  const std::size_t plane = rings.plane();
  for (std::int64_t k = 0; k < lat.nz(); ++k) {
    const std::vector<std::uint8_t>& r = rings(z0 + k);
    for (std::size_t p = 0; p < plane; ++p)
      m[static_cast<std::size_t>(k) * plane + p] = r[p] >= ring && r[p] <= kRings;
  }
  return m;
}

// Sum of `s` over planes [k0, k1] and rings ring..kRings; `count` gets the voxels.
double sumRange(const RingSums& s, std::int64_t k0, std::int64_t k1, int ring, double* count) {
  const std::size_t stride = kOutside + 1;
  double total = 0, n = 0;
  for (std::int64_t k = k0; k <= k1; ++k)
    for (int r = ring; r <= kRings; ++r) {
      total += s.sum[static_cast<std::size_t>(k) * stride + r];
      n += s.count[static_cast<std::size_t>(k) * stride + r];
    }
  *count = n;
  return total;
}

}  // namespace

StreamedVolume streamedVolumeThreshold(const VolumeHeader& h, const IngestOptions& o,
                                       const ColumnFit* column, bool voidBright, double tOtsu,
                                       double otsuVoidMean, double otsuSolidMean,
                                       const RingSums& sums, std::int64_t slabPlanes, int threads,
                                       Progress& progress, const Communicator* comm) {
  StreamedVolume out;
  const Lattice& lat = h.lattice;
  const std::int64_t nz = lat.nz();
  const double voxel = lat.spacingMm[2];
  const bool hasColumn = column && column->found;
  const NoiseModel model =
      o.noise == NoiseChoice::Rician || (o.noise == NoiseChoice::Auto && voidBright)
          ? NoiseModel::Rician
          : NoiseModel::Gaussian;
  out.cut = o.denoise;

  // The bed's slices: per plane, the solid share from the raw mean over the core (5 voxels
  // in from the wall) unmixed between Otsu's class means; bedSlices' rule on those shares.
  std::int64_t k0 = 0, k1 = nz - 1;
  if (o.volumeOverBedSlices) {
    std::vector<double> in(static_cast<std::size_t>(nz)), solid(in.size());
    for (std::int64_t k = 0; k < nz; ++k) {
      double n = 0;
      const double s = sumRange(sums, k, k, hasColumn ? 5 : 0, &n);
      const double share =
          n > 0 ? std::clamp((s / n - otsuVoidMean) / (otsuSolidMean - otsuVoidMean), 0.0, 1.0)
                : 0.0;
      in[static_cast<std::size_t>(k)] = n;
      solid[static_cast<std::size_t>(k)] = share * n;
    }
    const auto [a, b] = bedSlicesFromCounts(in, solid);
    if (a >= 0) {
      k0 = a;
      k1 = b;
    }
  }

  // The sample slab. In memory the levels are read over the whole column, where a
  // headspace of liquid (MRI) or air gives the void's deep voxels that a bed at 10 voxels
  // per d hardly has (no ball of 3.5 voxels fits its pores). So with a headspace the sample
  // straddles the bed's end next to the longer one, a quarter of it (at least 8 planes) in
  // the headspace; else it is centred in the bed. The interface density, the voxels per d
  // and the clean-up's shift are read on its bed planes only.
  const std::int64_t want = volumeSamplePlanes(lat), above = nz - 1 - k1, below = k0;
  const std::int64_t head =
      std::min({std::max<std::int64_t>(8, want / 4), want / 2, std::max(above, below)});
  const std::int64_t inBed = std::min(want - head, k1 - k0 + 1);
  std::int64_t s0 = 0, s1 = 0;
  if (head > 0 && above >= below) {
    s0 = k1 + 1 - inBed;
    s1 = k1 + 1 + head;
  } else if (head > 0) {
    s0 = k0 - head;
    s1 = k0 + inBed;
  } else {
    s0 = std::clamp<std::int64_t>((k0 + k1 + 1) / 2 - inBed / 2, 0, nz - inBed);
    s1 = s0 + inBed;
  }
  const std::int64_t S = s1 - s0;
  const Lattice sl = subLattice(lat, {{s0, 0, 0}, {S, lat.ny(), lat.nx()}});
  PlaneRings rings(lat, hasColumn ? column : nullptr);
  progress.report("ingest: volume threshold, sample slab", 0.0);
  // The bed's end slices are left out (a floor or lid's blur reaches 3 sigma in).
  auto trimBed = [&](double blur) {
    if (!o.volumeOverBedSlices || (k0 == 0 && k1 + 1 == nz)) return;
    const std::int64_t trim =
        std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil(3.0 * blur)));
    if ((k1 - k0 + 1) - 2 * trim >= std::max<std::int64_t>(4, (k1 - k0 + 1) / 2)) {
      k0 += trim;
      k1 -= trim;
    }
  };
  // The sample's voxels in the (trimmed) bed's slices and in `region` (null: all).
  auto sampleBedRegion = [&](const Grid<std::uint8_t>* region) {
    Grid<std::uint8_t> m(sl, 0);
    const std::size_t plane = static_cast<std::size_t>(sl.ny() * sl.nx());
    for (std::int64_t k = std::max(k0, s0); k <= std::min(k1, s1 - 1); ++k)
      for (std::size_t p = 0; p < plane; ++p) {
        const std::size_t n = static_cast<std::size_t>(k - s0) * plane + p;
        m[n] = region ? (*region)[n] : 1;
      }
    if (std::find(m.values().begin(), m.values().end(), 1) == m.values().end())
      m = region ? *region : Grid<std::uint8_t>(sl, 1);  // no bed plane in the sample
    return m;
  };
  Grid<std::uint8_t> bedRegion;
  PhaseLevels levels;
  double interiorSigma = 0, blurVox = 0, vpd = 0, surfacePrelim = 0, edgeBias = 0, otsuPhi = 0;
  double samplePhi = std::numeric_limits<double>::quiet_NaN();  // mean-intensity phi, its bed
  int ring = 0;
  bool refined = false, fromFit = false;
  ColumnFit seen;
  DeepLevel deep[2];
  {
    const std::int64_t hd = denoiseHalo(o);
    const std::int64_t ra = std::max<std::int64_t>(0, s0 - hd), rb = std::min(nz, s1 + hd);
    Grid<float> raw = readVolumeSlab(h, ra, rb);
    Grid<float> den = o.denoise == DenoiseMethod::Median ? crossMedianFilter(raw, threads)
                      : o.denoise == DenoiseMethod::MedianBox
                          ? medianFilter(raw, o.medianRadiusVoxels, threads)
                          : raw;
    if (ra != s0 || rb != s1) {
      raw = cropPlanes(raw, s0 - ra, s1 - ra);
      den = cropPlanes(den, s0 - ra, s1 - ra);
    }
    // The wall's blur: from the column's own fit when it was fitted on the whole stream (as
    // in memory), else from the wall step of the sample (on M^2 for an MRI wall).
    if (hasColumn && column->refined && column->blurMm > 0.0) {
      seen = *column;
      refined = fromFit = true;
      blurVox = seen.blurMm / voxel;
    } else if (hasColumn && o.refineColumn) {
      const bool squared = model == NoiseModel::Rician;
      const ColumnRefineOptions ro{.slabSlices = o.columnFit.slabSlices,
                                   .squared = squared,
                                   .wallThicknessMm = o.columnWallMm};
      // The sample's planes keep their heights (subLattice moves the origin), so a leaning
      // axis is read at the right place about its own zRefMm.
      seen = refineColumn(squared ? raw : den, *column, ro);
      refined = seen.refined && seen.blurMm > 0.0;
      if (refined) blurVox = seen.blurMm / voxel;
    }
    // The core: 3 blur sigma + 2 voxels in from the wall (whole voxels, as the rings).
    ring = hasColumn ? static_cast<int>(std::ceil(3.0 * std::max(blurVox, 1.0) + 2.0)) : 0;
    ring = std::min(ring, kRings);
    double coreCount = 0;
    sumRange(sums, 0, 0, ring, &coreCount);
    if (hasColumn && coreCount * static_cast<double>(nz) < 64) ring = 0;  // the whole column
    const auto region = ringRegion(sl, s0, rings, ring, hasColumn && ring > 0);
    const Grid<std::uint8_t>* reg = region ? &*region : nullptr;

    Grid<std::uint8_t> prelim = applyThreshold(den, tOtsu, voidBright);
    den = Grid<float>();
    removeSmallComponents(prelim, 0, o.maxSpeckVoxels);
    removeSmallComponents(prelim, 1, o.maxHoleVoxels);
    const PhaseReading pr =
        readPhaseLevels(raw, prelim, reg, blurVox, voidBright, model, o.phaseLevelTail, threads);
    levels = pr.levels;
    interiorSigma = pr.interiorSigma;
    deep[0] = pr.deep[0];
    deep[1] = pr.deep[1];
    trimBed(blurVox);
    bedRegion = sampleBedRegion(region ? &*region : nullptr);
    vpd = voxelsPerDiameter(prelim, &bedRegion);
    otsuPhi = regionVoidFraction(prelim, &bedRegion);
    if (levels.clear) {
      const MeanVoidFraction m = meanVoidFraction(raw, &bedRegion, levels, blurVox, prelim);
      edgeBias = m.edgeBiasVoxels;
      surfacePrelim = m.surfacePerVoxel;
      samplePhi = m.phi;
    }
  }
  // The sample's buffers are freed; their pages would sit under the slabs that follow.
  releaseFreedHeap();
  // The 7-point median closes throats on coarse images: cut the raw image there (as in
  // memory, docs/ingest.md).
  std::string medianNote;
  if (levels.clear && o.denoise == DenoiseMethod::Median && o.medianMinVoxelsPerD > 0.0 &&
      vpd > 0.0 && vpd < o.medianMinVoxelsPerD) {
    out.cut = DenoiseMethod::None;
    medianNote = "median not used for the threshold: " + std::to_string(vpd) +
                 " voxels per particle diameter < " + std::to_string(o.medianMinVoxelsPerD);
  }
  out.first = k0;
  out.last = k1;
  out.ring = ring;
  double regionCount = 0;
  double meanI = sumRange(sums, k0, k1, ring, &regionCount) / std::max(1.0, regionCount);
  double phiRaw = levels.clear
                      ? (meanI - levels.solidLevel) / (levels.voidLevel - levels.solidLevel)
                      : std::numeric_limits<double>::quiet_NaN();
  double phi = std::clamp(phiRaw - edgeBias * surfacePrelim, 0.0, 1.0);
  // The two-peak check as in memory, on one region: the sample's bed planes (the loose
  // top of a bed, where a sample next to the headspace lies, reads 0.1 more void than the
  // whole bed).
  if (levels.clear && std::abs(samplePhi - otsuPhi) > 0.1) {
    levels.clear = false;
    levels.note = "mean-intensity porosity " + std::to_string(samplePhi) +
                  " is more than 0.1 from Otsu's " + std::to_string(otsuPhi) + " (sample slab)";
  }
  const double noise = interiorSigma > 0.0 ? interiorSigma : levels.noiseSigma;
  out.qualityJson = {
      {"noise_sigma", noise},
      {"snr", noise > 0 ? std::abs(levels.voidSignal - levels.solidSignal) / noise : 0.0},
      {"blur_mm", refined ? nlohmann::json(seen.blurMm) : nlohmann::json(nullptr)},
      {"blur_from", !refined  ? "not measured (no wall seen)"
                    : fromFit ? "edge-spread fit at the column wall (whole column, streamed)"
                              : "edge-spread fit at the column wall (sample slab)"},
      {"from", "sample slab"}};
  out.sampleFirst = s0;
  out.sampleLast = s1 - 1;
  out.sampleJson = {{"first", s0},
                    {"last", s1 - 1},
                    {"planes", S},
                    {"voxels_per_diameter", finiteOrNull(vpd)},
                    {"otsu_void_fraction", finiteOrNull(otsuPhi)},
                    {"solid_level_deep", finiteOrNull(deep[0].level)},
                    {"void_level_deep", finiteOrNull(deep[1].level)}};
  out.thresholdJson = {{"levels",
                        {{"clear", levels.clear},
                         {"model", levels.model == NoiseModel::Rician ? "rician" : "gaussian"},
                         {"void_level", levels.voidLevel},
                         {"solid_level", levels.solidLevel},
                         {"noise_sigma", levels.noiseSigma},
                         {"note", levels.note}}},
                       {"bed_slices", {{"first", k0}, {"last", k1}}},
                       {"region_ring_voxels", ring},
                       {"mean_intensity", finiteOrNull(meanI)},
                       {"porosity_mean_intensity", finiteOrNull(phiRaw)}};
  if (!medianNote.empty()) out.thresholdJson["median_note"] = medianNote;
  if (!levels.clear) {
    if (o.threshold == ThresholdMethod::Volume)
      progress.message("warning: --threshold volume: " + levels.note + "; using Otsu");
    out.cut = o.denoise;
    out.threshold = tOtsu;
    return out;
  }

  // Pass: the counts of the image the threshold cuts over the bed's slices and the region.
  IngestOptions oc = o;
  oc.denoise = out.cut;
  const int P = comm ? comm->size() : 1, me = comm ? comm->rank() : 0;
  const std::int64_t T = std::clamp<std::int64_t>(slabPlanes, 1, nz);
  const std::int64_t first = k0 / T, last = k1 / T;
  const std::size_t plane = rings.plane();
  // The wall's blur divided out of the grey values next to it (as in memory, docs/
  // ingest.md "Wall-blur correction"): the porosity is then aimed over the whole column.
  if (hasColumn && refined && o.wallBlurCorrection) {
    WallFix fix;
    fix.column = *column;
    fix.correction.blurMm = seen.blurMm;
    fix.correction.rician = model == NoiseModel::Rician;
    fix.correction.noiseSigma = noise;
    fix.correction.wallLevel = seen.wallLevel;
    fix.correction.outsideLevel = seen.outsideLevel;
    fix.correction.wallThicknessMm = seen.wallThicknessMm;
    out.fix = fix;
    ring = 0;
    out.ring = 0;
    const auto whole = ringRegion(sl, s0, rings, 0, true);
    bedRegion = sampleBedRegion(&*whole);
    out.thresholdJson["region_ring_voxels"] = 0;
    out.thresholdJson["wall_blur_correction"] = {
        {"applied", true},
        {"blur_mm", seen.blurMm},
        {"reach_mm", fix.correction.reachSigmas * seen.blurMm},
        {"model", fix.correction.rician ? "rician (signal-free wall)" : "grey levels"}};
  }
  if (!out.fix)
    out.thresholdJson["wall_blur_correction"] = {
        {"applied", false},
        {"note", !hasColumn ? "no column"
                 : !refined ? "no wall step seen in the sample slab"
                            : "--no-wall-blur-correction"}};
  const WallFix* fix = out.fix ? &*out.fix : nullptr;
  RingSums corrected;  // the raw sums again, of the corrected image
  if (fix) {
    corrected.reset(lat, column);
  }
  // f(value) for the voxels of `img` (planes from global a) at wall ring `ring` or deeper.
  auto eachInRegion = [&](const Grid<float>& img, std::int64_t a, auto&& f) {
    for (std::int64_t k = 0; k < img.lattice().nz(); ++k) {
      const std::vector<std::uint8_t>& r = rings(a + k);
      const float* v = img.data() + static_cast<std::size_t>(k) * plane;
      for (std::size_t p = 0; p < plane; ++p)
        if (r[p] >= ring && r[p] <= kRings) f(v[p]);
    }
  };
  ValueCounts counts;
  {
    SlabProgress sp(progress, "volume threshold counts", (last - first + P) / P, "ingest");
    for (std::int64_t s = first; s <= last; ++s) {
      if (s % P != me) continue;
      sp.step((s - first) / P);
      const std::int64_t a = std::max(k0, s * T), b = std::min(k1 + 1, (s + 1) * T);
      {
        const Grid<float> img =
            denoisedPlanes(h, oc, a, b, threads, fix ? &corrected : nullptr, fix);
        eachInRegion(img, a, [&](float v) { counts.add(v); });
      }
      releaseFreedHeap();  // the slabs' pages (stream_ingest.cpp, the write pass)
    }
  }
  counts.reduce(comm);
  out.passes = 1;
  if (fix) {  // the mean intensity over the whole column, corrected
    corrected.reduce(comm);
    double n = 0;
    meanI = sumRange(corrected, k0, k1, 0, &n) / std::max(1.0, n);
    phiRaw = (meanI - levels.solidLevel) / (levels.voidLevel - levels.solidLevel);
    phi = std::clamp(phiRaw - edgeBias * surfacePrelim, 0.0, 1.0);
    out.thresholdJson["mean_intensity"] = meanI;
    out.thresholdJson["porosity_mean_intensity"] = phiRaw;
  }
  // Exact order statistics for integer grey values (8/16-bit files); any other value, on
  // any rank, sends all through fine bins, so that one process and any number of ranks cut
  // at the same threshold (under mpirun only the integer counts are summed).
  const bool exact = !counts.overflow && counts.other.empty();
  std::vector<std::pair<float, std::uint64_t>> sorted;
  if (exact) sorted = counts.sorted();
  std::vector<double> bins;
  if (!exact) {  // one more pass over fine bins
    ++out.passes;
    bins.assign(65536, 0.0);
    const double scale =
        static_cast<double>(bins.size()) / (static_cast<double>(counts.hi) - counts.lo);
    for (std::int64_t s = first; s <= last && counts.hi > counts.lo; ++s) {
      if (s % P != me) continue;
      const std::int64_t a = std::max(k0, s * T), b = std::min(k1 + 1, (s + 1) * T);
      {
        const Grid<float> img = denoisedPlanes(h, oc, a, b, threads, nullptr, fix);
        eachInRegion(img, a, [&](float v) {
          bins[std::min<std::size_t>(static_cast<std::size_t>((v - counts.lo) * scale),
                                     bins.size() - 1)] += 1.0;
        });
      }
      releaseFreedHeap();
    }
    if (comm && P > 1) comm->sum(bins);
  }
  auto quantile = [&](double target) {
    return !exact ? quantileThresholdFromBins(bins, counts.lo, counts.hi, target, voidBright)
                  : quantileThreshold(sorted, target, voidBright);
  };
  double t = quantile(phi);
  const double aimedFirst = phi;

  // On the sample once more: the segmentation's own interface density (MRI edge
  // correction, as in memory) and the shift the speck and hole clean-up makes.
  const double contrast = std::abs(levels.voidSignal - levels.solidSignal);
  const double jitter = noise > 0.0 && contrast > 0.0
                            ? std::sqrt(2.0 * std::numbers::pi) *
                                  std::sqrt(blurVox * blurVox + 1.0 / 12.0) * noise / contrast
                            : std::numeric_limits<double>::infinity();
  double surfaceSeg = 0, before = 0, after = 0;
  {
    Grid<float> cut = denoisedPlanes(h, oc, s0, s1, threads, nullptr, fix);
    Grid<std::uint8_t> ind = applyThreshold(cut, t, voidBright);
    cut = Grid<float>();
    before = regionVoidFraction(ind, &bedRegion);
    removeSmallComponents(ind, 0, o.maxSpeckVoxels);
    removeSmallComponents(ind, 1, o.maxHoleVoxels);
    after = regionVoidFraction(ind, &bedRegion);
    if (edgeBias != 0.0 && jitter <= o.surfaceRereadMaxJitter)
      surfaceSeg = surfaceDensityPerVoxel(ind, &bedRegion);
  }
  releaseFreedHeap();
  const double surface = std::max(surfacePrelim, surfaceSeg);
  phi = std::clamp(phiRaw - edgeBias * surface, 0.0, 1.0);
  const double shift = std::isfinite(after - before) ? after - before : 0.0;
  const double target = std::clamp(phi - shift, 0.0, 1.0);
  if (std::abs(target - aimedFirst) > 1e-6) t = quantile(target);
  out.used = true;
  out.threshold = t;
  out.aimed = phi;
  out.thresholdJson["porosity_mean_intensity_corrected"] = phi;
  out.thresholdJson["edge_bias_voxels"] = edgeBias;
  out.thresholdJson["surface_per_voxel_preliminary"] = surfacePrelim;
  out.thresholdJson["surface_per_voxel_segmentation"] = surfaceSeg;
  out.thresholdJson["edge_jitter_voxels"] = finiteOrNull(jitter);
  out.thresholdJson["cleanup_shift_sample"] = shift;
  out.thresholdJson["porosity_aimed_before_cleanup"] = target;
  out.thresholdJson["order_statistics"] =
      exact ? "exact value counts" : "65536 bins over the value range";
  return out;
}

}  // namespace voxpack::ingest::stream_detail
