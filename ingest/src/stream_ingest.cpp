// The streamed ingest path: plan (what streams, the halo, the slab size under the budget),
// a first pass for the threshold (exact value histogram of the denoised image), and a
// second pass that thresholds, cleans up and writes each slab. docs/scale.md.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <unordered_map>

#include "heap.hpp"
#include "phase_reading.hpp"
#include "stream_detail.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/version.hpp"
#include "voxpack/ingest/segment.hpp"
#include "voxpack/ingest/stream.hpp"

namespace voxpack::ingest {
namespace {

using namespace stream_detail;

// Distinct grey values the first pass keeps exactly (uint8/uint16 inputs stay far below;
// a float image with more falls back to a second pass over Otsu's bins).
constexpr std::size_t kMaxDistinctValues = ValueCounts::kMaxDistinct;
// Resident bytes of the process before any volume (libraries, ITK factories, HDF5).

// A component of at most m voxels spans at most m planes; one more plane keeps the cut
// planes (counted as border by the flood fill) out of its reach.
std::int64_t cleanupHalo(std::size_t m, std::int64_t nz) {
  return m == 0 ? 0 : static_cast<std::int64_t>(std::min<std::uint64_t>(m + 1, nz));
}

double seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

const char* denoiseName(DenoiseMethod d) {
  return d == DenoiseMethod::Median      ? "median"
         : d == DenoiseMethod::MedianBox ? "median-box"
         : d == DenoiseMethod::Curvature ? "curvature"
                                         : "none";
}
const char* thresholdName(ThresholdMethod t) {
  return t == ThresholdMethod::Otsu     ? "otsu"
         : t == ThresholdMethod::KMeans ? "kmeans"
         : t == ThresholdMethod::Manual ? "manual"
         : t == ThresholdMethod::Volume ? "volume"
                                        : "auto";
}

nlohmann::json latticeJson(const Lattice& l) {
  return {{"dims", {l.dims[0], l.dims[1], l.dims[2]}},
          {"spacing_mm", {l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]}},
          {"origin_mm", {l.originMm[0], l.originMm[1], l.originMm[2]}}};
}

// Otsu's bins of segment.cpp's otsuThreshold: the same index expression per value.
std::size_t otsuBin(float v, float lo, double scale, int bins) {
  return std::min<std::size_t>(static_cast<std::size_t>((v - lo) * scale),
                               static_cast<std::size_t>(bins - 1));
}

// segment.cpp's otsuThreshold from its histogram (the bin counts are integers, exact in
// double below 2^53, so the sums equal the in-memory ones).
double otsuFromBins(const std::vector<double>& h, float lo, float hi, std::uint64_t total) {
  if (!(hi > lo)) return lo;
  const int bins = static_cast<int>(h.size());
  const double scale = bins / (static_cast<double>(hi) - lo);
  double sumAll = 0.0;
  for (int b = 0; b < bins; ++b) sumAll += b * h[static_cast<std::size_t>(b)];
  double w0 = 0.0, sum0 = 0.0, best = -1.0;
  int bestBin = 0;
  for (int b = 0; b < bins - 1; ++b) {
    w0 += h[static_cast<std::size_t>(b)];
    sum0 += b * h[static_cast<std::size_t>(b)];
    const double w1 = static_cast<double>(total) - w0;
    if (w0 <= 0.0 || w1 <= 0.0) continue;
    const double d = sum0 / w0 - (sumAll - sum0) / w1;
    const double between = w0 * w1 * d * d;
    if (between > best) {
      best = between;
      bestBin = b;
    }
  }
  return lo + (bestBin + 1) / scale;
}

// segment.cpp's kmeansThreshold on exact value counts. Class sums are count x value: the
// same numbers as the in-memory running sums whenever those are exact (integer grey
// values, as from uint8/uint16 files, below 2^53); for float images they may differ in
// the last bits.
double kmeansFromCounts(const std::vector<std::pair<float, std::uint64_t>>& counts, float lo,
                        float hi) {
  double t = 0.5 * (static_cast<double>(lo) + hi);
  for (int it = 0; it < 100; ++it) {
    double s0 = 0, s1 = 0;
    std::uint64_t n0 = 0, n1 = 0;
    for (const auto& [v, c] : counts) {
      if (v <= t) {
        s0 += static_cast<double>(c) * v;
        n0 += c;
      } else {
        s1 += static_cast<double>(c) * v;
        n1 += c;
      }
    }
    if (n0 == 0 || n1 == 0) break;
    const double next = 0.5 * (s0 / static_cast<double>(n0) + s1 / static_cast<double>(n1));
    if (std::abs(next - t) <= 1e-6 * (std::abs(hi - lo) + 1e-30)) {
      t = next;
      break;
    }
    t = next;
  }
  return t;
}

void checkCancel(Progress& progress) {
  if (progress.cancelled()) throw Cancelled("ingest cancelled");
}

}  // namespace

std::int64_t stream_detail::denoiseHalo(const IngestOptions& o) {
  if (o.denoise == DenoiseMethod::Median) return 1;
  if (o.denoise == DenoiseMethod::MedianBox) return o.medianRadiusVoxels;
  return 0;
}

// Planes within the halo of a cut are wrong and dropped; at the volume's own faces the
// filter clamps exactly as on the whole volume.
Grid<float> stream_detail::denoisedPlanes(const VolumeHeader& h, const IngestOptions& o,
                                          std::int64_t a, std::int64_t b, int threads,
                                          RingSums* raw, const WallFix* fix) {
  const std::int64_t hd = denoiseHalo(o), nz = h.lattice.nz();
  const std::int64_t ra = std::max<std::int64_t>(0, a - hd), rb = std::min(nz, b + hd);
  Grid<float> img = readVolumeSlab(h, ra, rb);
  // A voxel's correction depends on its distance from the axis only: slab by slab it is
  // the whole image's, and the median of the corrected slab is the in-memory refilter.
  if (fix) correctWallBlur(img, fix->column, fix->correction, threads);
  if (raw) raw->add(img, a - ra, b - ra, a);
  if (o.denoise == DenoiseMethod::Median) img = crossMedianFilter(img, threads);
  if (o.denoise == DenoiseMethod::MedianBox) img = medianFilter(img, o.medianRadiusVoxels, threads);
  if (ra == a && rb == b) return img;
  return cropPlanes(img, a - ra, b - ra);
}

std::string streamedIngestUnsupported(const IngestOptions& o, const VolumeHeader& h) {
  std::vector<std::string> why;
  if (h.source.kind == StreamSource::Kind::None)
    why.push_back("the input (" + h.source.whyNot + ")");
  if (o.labels) why.push_back("watershed labels (--labels)");
  if (o.n4) why.push_back("N4 bias correction (--bias-correction n4)");
  if (o.denoise == DenoiseMethod::Curvature)
    why.push_back(
        "curvature diffusion (ITK scales its conductance by the whole image's "
        "gradient; use --denoise median or median-box)");
  if (o.resampleMm > 0.0) why.push_back("--resample");
  if (o.deconvolveIterations > 0) why.push_back("--deconvolve (an FFT of the whole image)");
  if (o.calibrationRuns > 0 && o.threshold != ThresholdMethod::Auto &&
      o.threshold != ThresholdMethod::Volume)
    why.push_back(
        "--calibrate with --threshold otsu, kmeans or a value (streamed, the image quality is "
        "read by the volume threshold)");
  std::string s;
  for (const auto& w : why) s += (s.empty() ? "" : "; ") + w;
  return s;
}

std::int64_t streamedHaloPlanes(const IngestOptions& o, std::int64_t nz) {
  return denoiseHalo(o) + cleanupHalo(o.maxSpeckVoxels, nz) + cleanupHalo(o.maxHoleVoxels, nz);
}

std::uint64_t estimateStreamedIngestBytes(const VolumeHeader& h, const IngestOptions& o,
                                          std::int64_t slabPlanes, int threads) {
  const Lattice& l = h.lattice;
  const auto plane = static_cast<std::uint64_t>(l.ny()) * static_cast<std::uint64_t>(l.nx());
  const auto nz = l.nz();
  const std::int64_t t = std::clamp<std::int64_t>(slabPlanes, 1, nz);
  const auto read = static_cast<std::uint64_t>(std::min(nz, t + 2 * streamedHaloPlanes(o, nz)));
  // Per read plane: the float slab read and the filter's output (4 + 4 B), or later the
  // indicator with the clean-up's marks and the cropped copy (1 + 1 + 1 B; the clean-up's
  // search holds at most maxVoxels + 6 offsets). Per own plane: indicator, mask, core mask
  // (3 B). Per plane: the z-chord state (9 B x 2 regions) and one raw plane buffer (8 B).
  const std::uint64_t perRead = std::max<std::uint64_t>(8, 3);
  const std::uint64_t search =
      cleanupSearchBytes(std::max(o.maxSpeckVoxels, o.maxHoleVoxels), read * plane);
  const std::uint64_t slabs =
      perRead * read * plane + 3 * static_cast<std::uint64_t>(t) * plane + 26 * plane + search;
  std::uint64_t bytes = slabs;
  // The first pass's exact value histogram (hash map node + bucket) and Otsu's bins.
  // A median or none selects input values, so an 8/16-bit file has at most 2^8/2^16.
  const bool volume =
      o.threshold == ThresholdMethod::Auto || o.threshold == ThresholdMethod::Volume;
  // Pass 1's counts (the column fit cuts at Otsu's threshold too).
  if (o.threshold == ThresholdMethod::Otsu || o.threshold == ThresholdMethod::KMeans || volume ||
      o.column == ColumnMode::Auto) {
    const std::string& c = h.info.componentType;  // ITK's name of the stored type
    const std::size_t distinct = c == "unsigned_char" || c == "char"     ? 256
                                 : c == "unsigned_short" || c == "short" ? 65536
                                                                         : kMaxDistinctValues;
    bytes += distinct * 48 + 65536 * 8 + 1024 * 8;
    // Volume: pass 1's sorted counts stay while its own counts (as many again) fill, its
    // fine bins, the raw sums per plane and wall ring (twice: raw and corrected), the ring
    // maps.
    if (volume)
      bytes += distinct * (8 + 48) + 65536 * 8 +
               2 * static_cast<std::uint64_t>(nz) * (kOutside + 1) * 8 + 2 * plane;
  }
  bytes += kIngestProcessBaseBytes;
  std::uint64_t columnFit = 0;
  if (o.column == ColumnMode::Auto) {
    // The column fit, beside a slab (not the sample, which comes after it): a solid count
    // per pixel (4 B), and the wall profiles (per slab and sector 2 x 140 bins of 8 B),
    // held three times while fitted.
    const std::int64_t cs = std::max<std::int64_t>(1, nz / std::max(4, o.columnFit.slabSlices));
    columnFit = 4 * plane + 3 * static_cast<std::uint64_t>(cs) * 16 * 282 * 8;
    bytes += columnFit;
  }
  if (volume) {
    // The sample slab is analysed as the in-memory pipeline would a volume of its planes,
    // beside pass 1's sums and counts (counted above, outside the slabs' share).
    const std::int64_t sp = volumeSamplePlanes(l);
    const Lattice sample = subLattice(l, {{0, 0, 0}, {sp, l.ny(), l.nx()}});
    const std::uint64_t samplePhase = bytes - slabs - kIngestProcessBaseBytes - columnFit +
                                      estimateIngestPeakBytes(sample, o, std::nullopt, threads);
    // After it, its per-thread slice buffers (the dip test's memos, 47 B per plane voxel,
    // deep_level.cpp, and others) stay resident in the OpenMP workers' heaps, which
    // malloc_trim does not hand back: measured 68-100 B per plane voxel in the slab passes
    // at 384^2 planes on 2 threads against 1 (docs/scale.md); counted at 128.
    bytes += static_cast<std::uint64_t>(std::max(0, threads - 1)) * 128 * plane;
    // --calibrate: the output bed's sample planes (indicator and mask) kept through the
    // write pass; the calibration itself runs after it, within the sample phase's figure.
    if (o.calibrationRuns > 0) bytes += 2 * sample.size();
    bytes = std::max(bytes, samplePhase);
  }
  return bytes;
}

std::int64_t streamedSlabPlanes(const VolumeHeader& h, const IngestOptions& o,
                                const MemoryBudget& budget, std::int64_t slabPlanes, int threads) {
  const Lattice& l = h.lattice;
  if (slabPlanes > 0) return std::min(slabPlanes, l.nz());
  if (budget.limitBytes == 0) return l.nz();
  std::int64_t lo = 0, hi = l.nz();  // largest t with estimate(t) <= limit
  while (lo < hi) {
    const std::int64_t mid = (lo + hi + 1) / 2;
    if (estimateStreamedIngestBytes(h, o, mid, threads) <= budget.limitBytes)
      lo = mid;
    else
      hi = mid - 1;
  }
  return lo;
}

StreamedIngestResult ingestVolumeStreamed(const VolumeHeader& h, const IngestOptions& o,
                                          const std::filesystem::path& output,
                                          std::int64_t slabPlanes, int threads, Progress& progress,
                                          const nlohmann::json& extraProvenance,
                                          const Communicator* comm) {
  const std::string why = streamedIngestUnsupported(o, h);
  if (!why.empty()) throw UsageError("no streamed ingest for " + why);
  if (o.maxSpeckVoxels > (std::size_t{1} << 40) || o.maxHoleVoxels > (std::size_t{1} << 40))
    throw UsageError("speck/hole sizes are out of range");
  const auto tStart = std::chrono::steady_clock::now();
  const Lattice& lat = h.lattice;
  const std::int64_t nz = lat.nz();
  const std::int64_t T = std::clamp<std::int64_t>(slabPlanes, 1, nz);
  const std::int64_t slabs = (nz + T - 1) / T;
  nlohmann::json timing = nlohmann::json::object();
  // Slab s belongs to rank s mod P: round robin keeps every rank busy while rank 0 takes
  // the slabs in order (a contiguous block per rank would make rank r wait for 0..r-1).
  const int P = comm ? comm->size() : 1, me = comm ? comm->rank() : 0;
  auto mine = [&](std::int64_t s) { return s % P == me; };

  // Polarity: as segmentVolume.
  bool voidBright = false;
  std::string polaritySource = "option";
  if (o.voidPolarity == VoidPolarity::Auto) {
    const auto it = h.info.metadata.find("voxpack_void");
    if (it != h.info.metadata.end() && (it->second == "bright" || it->second == "dark")) {
      voidBright = it->second == "bright";
      polaritySource = "file header voxpack_void";
    } else {
      polaritySource = "default (dark, as in XMT)";
      progress.message("void phase assumed dark (XMT); pass --void bright for MRI water");
    }
  } else {
    voidBright = o.voidPolarity == VoidPolarity::Bright;
  }

  ColumnFit column;
  if (o.column == ColumnMode::Explicit) {
    if (!(o.columnRadiusMm > 0.0) || !std::isfinite(o.columnXMm) || !std::isfinite(o.columnYMm))
      throw UsageError("--column CX,CY,R needs finite CX, CY (mm) and R > 0 (mm)");
    column.found = true;
    column.axisXMm = o.columnXMm;
    column.axisYMm = o.columnYMm;
    column.radiusMm = o.columnRadiusMm;
    column.zRefMm = lat.originMm[0];
    column.note = "given on the command line";
  }

  // Pass 1: exact counts of the denoised grey values (the threshold's only input; for the
  // volume threshold Otsu's, beside the raw sums per plane and wall ring).
  auto t0 = std::chrono::steady_clock::now();
  double t = o.thresholdValue;
  double tOtsu = std::numeric_limits<double>::quiet_NaN();
  int passes = 1;
  const bool volume =
      o.threshold == ThresholdMethod::Auto || o.threshold == ThresholdMethod::Volume;
  IngestOptions oc = o;  // the options of the image the threshold cuts (the volume's may differ)
  StreamedVolume vol;
  // The column fit cuts at Otsu's threshold, as in memory. Its ring sums wait for the fit.
  const bool autoColumn = o.column == ColumnMode::Auto;
  if (o.threshold == ThresholdMethod::Otsu || o.threshold == ThresholdMethod::KMeans || volume ||
      autoColumn) {
    ++passes;
    ValueCounts vc;
    RingSums rs;
    const bool ringsNow = volume && !autoColumn;
    if (ringsNow) rs.reset(lat, column.found ? &column : nullptr);
    const std::int64_t own = (slabs - me + P - 1) / P;  // slabs me, me + P, ...
    SlabProgress sp(progress, "threshold histogram (pass 1)", own, "ingest");
    for (std::int64_t s = 0; s < slabs; ++s) {
      if (!mine(s)) continue;
      sp.step(s / P);
      const std::int64_t z0 = s * T, z1 = std::min(nz, z0 + T);
      {
        const Grid<float> img = denoisedPlanes(h, o, z0, z1, threads, ringsNow ? &rs : nullptr);
        for (float v : img.values()) vc.add(v);
      }
      releaseFreedHeap();
    }
    vc.reduce(comm);
    if (ringsNow) rs.reduce(comm);
    const float lo = vc.lo, hi = vc.hi;
    bool overflow = vc.overflow;
    sp.step(own);
    const std::vector<std::pair<float, std::uint64_t>> sorted = vc.sorted();
    vc = ValueCounts();
    constexpr int kBins = 1024;  // otsuThreshold's default
    std::vector<double> bins(kBins, 0.0);
    const double scale = kBins / (static_cast<double>(hi) - lo);
    if (!overflow) {
      if (hi > lo)
        for (const auto& [v, c] : sorted)
          bins[otsuBin(v, lo, scale, kBins)] += static_cast<double>(c);
    } else {
      if (o.threshold == ThresholdMethod::KMeans)
        throw ResourceError("--threshold kmeans on a streamed image with more than " +
                            std::to_string(kMaxDistinctValues) +
                            (P > 1 ? " distinct grey values, or under mpirun any non-integer one,"
                                   : " distinct grey values") +
                            " is not supported; use --threshold otsu");
      // Otsu needs only its bins over [lo, hi]: one more pass fills them.
      ++passes;
      SlabProgress bp(progress, "Otsu bins (pass 2)", (slabs - me + P - 1) / P, "ingest");
      for (std::int64_t s = 0; s < slabs && hi > lo; ++s) {
        if (!mine(s)) continue;
        bp.step(s / P);
        const std::int64_t z0 = s * T, z1 = std::min(nz, z0 + T);
        {
          const Grid<float> img = denoisedPlanes(h, o, z0, z1, threads);
          for (float v : img.values()) bins[otsuBin(v, lo, scale, kBins)] += 1.0;
        }
        releaseFreedHeap();
      }
      if (P > 1) comm->sum(bins);  // integer-valued counts: exact in any order
    }
    tOtsu = otsuFromBins(bins, lo, hi, lat.size());
    if (o.threshold == ThresholdMethod::KMeans) t = kmeansFromCounts(sorted, lo, hi);
    if (o.threshold == ThresholdMethod::Otsu || volume) t = tOtsu;
    if (autoColumn) {
      const auto tc = std::chrono::steady_clock::now();
      // The wall step on M^2 of the raw image for a signal-free (MRI) wall, as in memory.
      const bool rician =
          o.noise == NoiseChoice::Rician || (o.noise == NoiseChoice::Auto && voidBright);
      column = streamedColumnFit(h, o, tOtsu, voidBright, rician && o.refineColumn, T, threads,
                                 progress, comm, passes);
      if (!column.found) progress.message(noColumnWarning(column));
      timing["column_s"] = seconds(tc);
      if (volume) {  // the raw sums per plane and wall ring, about the fitted column
        ++passes;
        rs.reset(lat, column.found ? &column : nullptr);
        SlabProgress rp(progress, "wall-ring sums (pass " + std::to_string(passes) + ")", own,
                        "ingest");
        for (std::int64_t s = 0; s < slabs; ++s) {
          if (!mine(s)) continue;
          rp.step(s / P);
          const std::int64_t z0 = s * T, z1 = std::min(nz, z0 + T);
          rs.add(readVolumeSlab(h, z0, z1), 0, z1 - z0, z0);
          releaseFreedHeap();
        }
        rs.reduce(comm);
      }
    }
    if (volume) {
      // Otsu's class means (bin centres): the per-plane unmixing that finds the bed's slices.
      double n0 = 0, s0 = 0, n1 = 0, s1 = 0;
      for (int b = 0; b < kBins; ++b) {
        const double v = lo + (b + 0.5) / scale, c = bins[static_cast<std::size_t>(b)];
        (v <= tOtsu ? n0 : n1) += c;
        (v <= tOtsu ? s0 : s1) += c * v;
      }
      const double lowMean = n0 > 0 ? s0 / n0 : tOtsu, highMean = n1 > 0 ? s1 / n1 : tOtsu;
      vol =
          streamedVolumeThreshold(h, o, column.found ? &column : nullptr, voidBright, tOtsu,
                                  voidBright ? highMean : lowMean, voidBright ? lowMean : highMean,
                                  rs, T, threads, progress, comm);
      passes += vol.passes;
      t = vol.threshold;
      oc.denoise = vol.cut;
    }
  }
  if (!std::isfinite(t)) throw UsageError("--threshold must be a finite number");
  timing["threshold_s"] = seconds(t0);

  // Pass 2: threshold, clean-up with the halo, mask, write.
  t0 = std::chrono::steady_clock::now();
  const std::int64_t hs = cleanupHalo(o.maxSpeckVoxels, nz), hh = cleanupHalo(o.maxHoleVoxels, nz);
  const double voxel = lat.spacingMm[2];
  const double margin = (3.0 * 1.0 + 2.0) * voxel;  // segmentVolume's core margin, no blur fit
  std::optional<BedSlabWriter> writer;
  if (me == 0) writer.emplace(output, lat, column.found, false);
  BedSummary summary;
  std::uint64_t coreIn = 0, coreVoid = 0, allVoid = 0, volIn = 0, volVoid = 0;
  ChordSums chordsCore, chordsAll;
  // The volume threshold's region: the bed's slices at its wall ring and deeper.
  PlaneRings rings(lat, vol.used && column.found ? &column : nullptr);
  std::size_t specks = 0, holes = 0;
  // --calibrate images the output bed over the volume threshold's sample slab (its planes
  // are kept as they are written): the in-memory calibration on a bed of the sample's size.
  const bool calibrate = o.calibrationRuns > 0 && volume && me == 0;
  const std::int64_t c0 = vol.sampleFirst, c1 = vol.sampleLast + 1;
  Bed crop;
  if (calibrate) {
    const Lattice cl = subLattice(lat, {{c0, 0, 0}, {c1 - c0, lat.ny(), lat.nx()}});
    crop.indicator = Grid<std::uint8_t>(cl, 0);
    if (column.found) crop.mask = Grid<std::uint8_t>(cl, 0);
  }
  // Rank 0 takes every slab in order (its own or received), the others their own.
  SlabProgress wp(progress, "segment and write (pass " + std::to_string(passes) + ")",
                  me == 0 ? slabs : (slabs - me + P - 1) / P, "ingest");
  for (std::int64_t s = 0; s < slabs; ++s) {
    wp.step(me == 0 ? s : s / P);
    const std::int64_t z0 = s * T, z1 = std::min(nz, z0 + T);
    const Lattice sub = subLattice(lat, {{z0, 0, 0}, {z1 - z0, lat.ny(), lat.nx()}});
    Grid<std::uint8_t> ind;
    std::uint64_t cleaned[2] = {0, 0};  // specks removed, holes filled in this slab
    if (mine(s)) {
      const std::int64_t a = std::max<std::int64_t>(0, z0 - hs - hh),
                         b = std::min(nz, z1 + hs + hh);
      {
        const Grid<float> img =
            denoisedPlanes(h, oc, a, b, threads, nullptr, vol.fix ? &*vol.fix : nullptr);
        ind = applyThreshold(img, t, voidBright);
      }
      cleaned[0] = removeSmallComponents(ind, 0, o.maxSpeckVoxels, z0 - a, z1 - a);
      const std::int64_t a2 = std::max<std::int64_t>(0, z0 - hh), b2 = std::min(nz, z1 + hh);
      ind = cropPlanes(ind, a2 - a, b2 - a);
      cleaned[1] = removeSmallComponents(ind, 1, o.maxHoleVoxels, z0 - a2, z1 - a2);
      ind = cropPlanes(ind, z0 - a2, z1 - a2);
      if (me != 0) {  // to rank 0, which writes every slab in order
        comm->sendBytes(0, cleaned, sizeof cleaned);
        comm->sendBytes(0, ind.data(), ind.size());
        continue;
      }
    } else if (me == 0) {
      ind = Grid<std::uint8_t>(sub, 0);
      comm->receiveBytes(static_cast<int>(s % P), cleaned, sizeof cleaned);
      comm->receiveBytes(static_cast<int>(s % P), ind.data(), ind.size());
    } else {
      continue;
    }
    specks += cleaned[0];
    holes += cleaned[1];
    std::optional<Grid<std::uint8_t>> mask, core;
    if (column.found) {
      mask = columnMask(sub, column);
      core = columnCoreMask(sub, column, margin);
    }
    accumulateSummary(summary, ind, mask ? &*mask : nullptr);
    if (vol.used)
      for (std::int64_t k = std::max(z0, vol.first); k < std::min(z1, vol.last + 1); ++k) {
        const std::vector<std::uint8_t>& r = rings(k);
        for (std::size_t p = 0; p < r.size(); ++p)
          if (r[p] >= vol.ring && r[p] <= kRings) {
            ++volIn;
            volVoid += ind[static_cast<std::size_t>(k - z0) * r.size() + p];
          }
      }
    for (std::size_t n = 0; n < ind.size(); ++n) {
      allVoid += ind[n];
      if (core) {
        coreIn += (*core)[n];
        coreVoid += (*core)[n] & ind[n];
      }
    }
    chordsAll.addInPlane(ind, nullptr);
    chordsAll.addAlongZ(ind, nullptr);
    if (core) {
      chordsCore.addInPlane(ind, &*core);
      chordsCore.addAlongZ(ind, &*core);
    }
    writer->writeIndicator(z0, ind);
    if (mask) writer->writeMask(z0, *mask);
    if (calibrate) {
      const std::size_t plane = static_cast<std::size_t>(lat.ny() * lat.nx());
      for (std::int64_t k = std::max(z0, c0); k < std::min(z1, c1); ++k) {
        const std::size_t from = static_cast<std::size_t>(k - z0) * plane,
                          to = static_cast<std::size_t>(k - c0) * plane;
        std::copy_n(ind.data() + from, plane, crop.indicator.data() + to);
        if (mask) std::copy_n(mask->data() + from, plane, crop.mask->data() + to);
      }
    }
    // Each slab's buffers are freed; without handing their pages back, glibc's heap grows
    // by about a slab per few slabs (384^3 in slabs of 18 planes: 159 MB against 126 MB).
    releaseFreedHeap();
  }
  if (me != 0) {  // the other ranks are done: rank 0 reports and writes
    StreamedIngestResult r;
    r.lattice = lat;
    r.thresholdUsed = t;
    r.voidBright = voidBright;
    r.column = column;
    return r;
  }
  wp.step(slabs);
  finishSummary(summary);
  timing["segment_s"] = seconds(t0);

  // segmentVolume uses the column core as the region when it holds >= 64 voxels.
  const bool coreUsed = column.found && coreIn >= 64;
  const double achieved =
      vol.used
          ? static_cast<double>(volVoid) / static_cast<double>(std::max<std::uint64_t>(1, volIn))
      : coreUsed ? static_cast<double>(coreVoid) / static_cast<double>(coreIn)
                 : static_cast<double>(allVoid) / static_cast<double>(lat.size());
  const double vpd = coreUsed ? chordsCore.diameter() : chordsAll.diameter();
  const std::string method = vol.used ? "volume" : volume ? "otsu" : thresholdName(o.threshold);

  nlohmann::json rep;
  rep["input"] = h.info.files.empty() ? std::string() : h.info.files.front();
  rep["reader"] = {{"source", h.info.source},
                   {"image_io", h.info.imageIO},
                   {"component_type", h.info.componentType},
                   {"files", h.info.files.size()},
                   {"spacing_from_file", h.info.spacingFromFile},
                   {"lattice", latticeJson(lat)}};
  rep["options"] = {{"voxel_size_mm", o.read.voxelSizeMm},
                    {"denoise", denoiseName(o.denoise)},
                    {"median_radius_voxels", o.medianRadiusVoxels},
                    {"curvature_iterations", o.curvature.iterations},
                    {"curvature_conductance", o.curvature.conductance},
                    {"n4", o.n4},
                    {"n4_shrink_factor", o.n4Options.shrinkFactor},
                    {"n4_fitting_levels", o.n4Options.fittingLevels},
                    {"resample_mm", o.resampleMm},
                    {"threshold", method},
                    {"noise", o.noise == NoiseChoice::Auto     ? "auto"
                              : o.noise == NoiseChoice::Rician ? "rician"
                                                               : "gaussian"},
                    {"refine_column", o.refineColumn},
                    {"max_speck_voxels", o.maxSpeckVoxels},
                    {"max_hole_voxels", o.maxHoleVoxels},
                    {"column", o.column == ColumnMode::None   ? "none"
                               : o.column == ColumnMode::Auto ? "auto"
                                                              : "explicit"},
                    {"labels", o.labels}};
  rep["threshold"] = {{"method", method},
                      {"requested", thresholdName(o.threshold)},
                      {"value", finiteOrNull(t)},
                      {"otsu_value", finiteOrNull(tOtsu)},
                      {"void", voidBright ? "bright" : "dark"},
                      {"void_from", polaritySource},
                      {"region", vol.used   ? (vol.ring > 0   ? "column core, bed slices"
                                               : column.found ? "column, bed slices"
                                                              : "whole image, bed slices")
                                 : coreUsed ? "column core"
                                            : "whole image"},
                      {"porosity_segmented_region", finiteOrNull(achieved)}};
  rep["quality"] = {{"noise_sigma", 0.0},
                    {"snr", 0.0},
                    {"blur_mm", nullptr},
                    {"blur_from", "not measured (no wall seen)"},
                    {"voxel_mm", finiteOrNull(voxel)},
                    {"voxels_per_diameter", finiteOrNull(vpd)},
                    {"diameter_from", "sphere-equivalent 6V/S = 1.5 x mean solid chord"}};
  if (volume) {  // the volume threshold read the image quality on its sample slab
    for (const auto& [k, v] : vol.qualityJson.items()) rep["quality"][k] = v;
    for (const auto& [k, v] : vol.thresholdJson.items()) rep["threshold"][k] = v;
    if (vol.used) rep["threshold"]["porosity_aimed"] = vol.aimed;
  }
  rep["cleanup"] = {{"specks_removed", specks}, {"holes_filled", holes}};
  rep["column"] = columnJson(column, o.column);
  rep["output_lattice"] = latticeJson(lat);
  rep["porosity"] = summary.emptyMask ? nlohmann::json(nullptr) : finiteOrNull(summary.porosity);
  timing["total_s"] = seconds(tStart);
  rep["timing_s"] = timing;
  rep["streamed"] = {
      {"slab_planes", T},
      {"slabs", slabs},
      {"halo_planes", streamedHaloPlanes(o, nz)},
      {"passes", passes},
      {"ranks", P},
      {"memory_estimate_bytes", estimateStreamedIngestBytes(h, o, T, threads)},
      {"volume_sample", volume ? vol.sampleJson : nlohmann::json(nullptr)},
      {"note",
       "read by z-slab; the denoise and speck/hole clean-up use a halo that makes every "
       "slab exact; the threshold comes from the exact value histogram of pass 1, or (volume) "
       "from the levels of a sample slab, the mean intensity of the whole bed and the exact "
       "counts of its slices"}};
  nlohmann::json calibration;
  if (calibrate) {
    const auto tc = std::chrono::steady_clock::now();
    IngestResult sample;
    sample.bed = std::move(crop);
    sample.voidBright = voidBright;
    sample.column = column;
    const auto& q = rep["quality"];
    auto number = [](const nlohmann::json& v) { return v.is_number() ? v.get<double>() : 0.0; };
    sample.quality.noiseSigma = number(q["noise_sigma"]);
    sample.quality.snr = number(q["snr"]);
    sample.quality.blurMeasured = q["blur_mm"].is_number();
    sample.quality.blurMm = number(q["blur_mm"]);
    sample.quality.voxelMm = voxel;
    sample.quality.voxelsPerDiameter = vpd;
    // The sample's cut end inside the bed: the phantom's blur reads past it as if the bed
    // stopped there, so 3 blur sigma (at least 2 planes) are left out at each end.
    const auto trim = std::max<std::int64_t>(
        2, static_cast<std::int64_t>(std::ceil(3.0 * sample.quality.blurMm / voxel)));
    calibration = calibrateDensityBias(sample, o, threads, progress, trim);
    calibration["region"] = {
        {"first", c0},
        {"last", c1 - 1},
        {"trim_planes", trim},
        {"note",
         "streamed: the output bed over the volume threshold's sample slab, imaged and "
         "segmented in memory"}};
    rep["calibration"] = calibration;
    timing["calibration_s"] = seconds(tc);
    rep["timing_s"] = timing;
  }
  sanitizeNonFinite(rep);
  nlohmann::json prov = {
      {"voxpack_version", versionString()}, {"command", "ingest"}, {"ingest", rep}};
  if (calibrate) prov["calibration"] = rep["calibration"];
  if (extraProvenance.is_object())
    for (const auto& [k, v] : extraProvenance.items()) prov[k] = v;
  checkCancel(progress);
  writer->finish(ParticleTable{}, prov);

  StreamedIngestResult r;
  r.lattice = lat;
  r.thresholdUsed = t;
  r.voidBright = voidBright;
  r.column = column;
  r.report = rep;
  return r;
}

}  // namespace voxpack::ingest
