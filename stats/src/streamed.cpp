// Statistics of beds bigger than memory: estimates, packed region, and the z-slab stream
// (docs/scale.md). Every partial result is an integer count (or an integer-valued double),
// so sums over slabs and ranks are exact and the result does not depend on the order.
#include "voxpack/stats/streamed.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "mes_window.hpp"
#include "stream_plan.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/stats/s2.hpp"
#include "voxpack_stats_extra.hpp"

namespace voxpack::stats {
namespace {

using nlohmann::json;
using Dims = std::array<std::int64_t, 3>;

using stream_plan::fitsWithHeadroom;
using stream_plan::Slabs;
using stream_plan::u;

std::set<std::string> requested(const StatsOptions& o) {
  return o.only.empty() ? statisticNames() : o.only;
}

// Bytes of one zero-padded in-place FFT buffer.
std::uint64_t fftBufferBytes(const Dims& padded, bool single) {
  return u(padded[0]) * u(padded[1]) * 2 * (u(padded[2]) / 2 + 1) * (single ? 4 : 8);
}

std::uint64_t lagGridBytes(const Dims& h) {
  return u(2 * h[0] + 1) * u(2 * h[1] + 1) * u(2 * h[2] + 1) * 8;
}

VoxelBox planes(const VoxelBox& region, std::int64_t z0, std::int64_t z1) {
  return VoxelBox{{region.first[0] + z0, region.first[1], region.first[2]},
                  {z1 - z0, region.dims[1], region.dims[2]}};
}

// ChordRuns: head and open run (2 x uint32) and a flag per column, the carry (uint64) per
// column when the runs are joined, and the run-length counts along each axis.
std::uint64_t chordStateBytes(const Dims& d) {
  return 17 * u(d[1]) * u(d[2]) + 8 * (u(d[0]) + u(d[1]) + u(d[2]) + 3);
}

}  // namespace

const std::set<std::string>& streamableStatistics() {
  static const std::set<std::string> names{"axial", "radial", "s2", "chords", "mes", "orientation"};
  return names;
}

std::uint64_t estimateInMemoryBytes(const BedHeader& h, const StatsOptions& options,
                                    const std::optional<VoxelBox>& roi) {
  const Dims d = roi ? roi->dims : h.lattice.dims;
  const std::uint64_t n = u(d[0]) * u(d[1]) * u(d[2]);
  const std::uint64_t perVoxel = 1 + (h.hasMask ? 1 : 0) + (h.hasLabels ? 4 : 0);
  const std::uint64_t bed = bedMemoryBytes(h);
  const std::uint64_t region = roi ? n * perVoxel + particleTableBytes(h) : bed;
  const Lattice l = roi ? subLattice(h.lattice, *roi) : h.lattice;
  std::uint64_t work = 64 * u(d[0]) + 16 * u(d[1]) * u(d[2]);
  const auto which = requested(options);
  auto want = [&](const char* s) { return which.count(s) != 0; };
  if (want("s2")) {
    const S2Options so = s2Options(options);
    const Dims lag = s2MaxLag(l, so);
    std::uint64_t s2 =
        fftBufferBytes(s2PaddedDims(d, lag), options.s2Float) + 4 * lagGridBytes(lag);
    if (h.hasMask)
      s2 += fftBufferBytes(s2PaddedDims({1, d[1], d[2]}, {0, lag[1], lag[2]}), options.s2Float);
    work = std::max(work, s2);
  }
  // Scratch per voxel of the other statistics, read off their code (docs/scale.md):
  // lattice mean empty space: float sums, counts, cut flags and up to six uint16 reach
  // fields (mesScratchBytesPerVoxel) for one chunk of planes; pore sizes: the source, two double
  // distance fields and the void distances; chords: the run state per column (chordStateBytes).
  if (want("mes")) {
    // Lattice: one chunk of planes at the worst case of three cut axes (18 B).
    const std::uint64_t chunk = u(mesInMemoryChunkPlanes(d[0], d[1], d[2])) * u(d[1]) * u(d[2]);
    if (options.mesMethod != "isotropic")
      work = std::max(work, chunk * mesScratchBytesPerVoxel({true, true, true}));
    if (options.mesMethod != "lattice") work = std::max(work, 12 * n);  // CGAL's tree
  }
  if (want("psd")) work = std::max(work, 21 * n);
  if (want("chords")) work = std::max(work, chordStateBytes(d));
  if (want("coordination") && h.hasLabels) work = std::max(work, 2 * n + 64 * h.particles);
  const std::uint64_t peak = roi ? std::max(bed + region, region + work) : bed + work;
  return kProcessBaseBytes + peak;
}

std::uint64_t estimateStreamedBytes(const BedHeader& h, const VoxelBox& region,
                                    const StatsOptions& options, std::int64_t planes) {
  const Dims d = region.dims;
  const Lattice l = subLattice(h.lattice, region);
  const auto which = requested(options);
  const bool s2 = which.count("s2") != 0;
  const Dims lag = s2 ? s2MaxLag(l, s2Options(options)) : Dims{0, 0, 0};
  const std::int64_t t = std::min(planes, d[0]);
  const std::int64_t read = std::min(d[0], t + lag[0]);
  const std::uint64_t plane = u(d[1]) * u(d[2]);
  std::uint64_t bytes = kProcessBaseBytes + particleTableBytes(h) + 16 * plane + 64 * u(d[0]);
  bytes += u(read) * plane * (1 + (h.hasMask ? 1 : 0)) + (h.hasMask ? plane : 0);
  if (which.count("chords")) bytes += chordStateBytes(d);
  if (s2) {
    const Dims own = s2TileOwn(t, d[1], d[2], options.s2TileVoxels);
    bytes +=
        s2TileBufferBytes(own, lag, options.s2Float ? FftPrecision::Float : FftPrecision::Double);
    bytes += 4 * lagGridBytes(lag);
  }
  return bytes;
}

std::int64_t chooseS2TileVoxels(const BedHeader& h, const VoxelBox& region,
                                const StatsOptions& options, const MemoryBudget& budget,
                                std::int64_t slabPlanes) {
  const Dims d = region.dims;
  const Dims lag = s2MaxLag(subLattice(h.lattice, region), s2Options(options));
  auto split = [](std::int64_t n, std::int64_t e) { return (n + e - 1) / e; };
  // The plane cut into k x k equal tiles, k = 1 (whole planes) up to tiles a few lags
  // across; the cut that fits with the least FFT work over the volume wins: slabs x tiles
  // per slab x box cells x log2(box cells).
  std::int64_t best = 0;
  double bestCost = std::numeric_limits<double>::infinity();
  const std::int64_t wide = std::max(d[1], d[2]);
  const std::int64_t smallest = std::max<std::int64_t>(8, std::max(lag[1], lag[2]) / 2);
  for (std::int64_t k = 1; k <= 64; ++k) {
    const std::int64_t edge = k == 1 ? 0 : split(wide, k);
    if (k > 1 && edge < smallest) break;
    StatsOptions o = options;
    o.s2TileVoxels = edge;
    const std::int64_t t =
        slabPlanes > 0 ? std::min(slabPlanes, d[0]) : slabPlanesWithin(h, region, o, budget);
    if (t <= 0 || !fitsWithHeadroom(budget, estimateStreamedBytes(h, region, o, t))) continue;
    const Dims own = s2TileOwn(t, d[1], d[2], edge);
    const std::int64_t ty = own[1], tx = own[2];
    const Dims box = s2TileBox(own, lag);
    const double cells =
        static_cast<double>(box[0]) * static_cast<double>(box[1]) * static_cast<double>(box[2]);
    const double cost = static_cast<double>(split(d[0], t) * split(d[1], ty) * split(d[2], tx)) *
                        cells * std::log2(cells);
    if (cost < bestCost * 0.999) {
      bestCost = cost;
      best = edge;
    }
  }
  return best;
}

std::int64_t slabPlanesWithin(const BedHeader& h, const VoxelBox& region,
                              const StatsOptions& options, const MemoryBudget& budget) {
  const std::int64_t nz = region.dims[0];
  if (fitsWithHeadroom(budget, estimateStreamedBytes(h, region, options, nz))) return nz;
  if (!fitsWithHeadroom(budget, estimateStreamedBytes(h, region, options, 1))) return 0;
  std::int64_t lo = 1, hi = nz;  // fits(lo), !fits(hi)
  while (hi - lo > 1) {
    const std::int64_t mid = lo + (hi - lo) / 2;
    (fitsWithHeadroom(budget, estimateStreamedBytes(h, region, options, mid)) ? lo : hi) = mid;
  }
  return lo;
}

PackedSlices packedSlices(const SliceCounts& c, double fraction) {
  // The rule of compare's packedRegion (compare/src/compare.cpp), on counts: a slice is
  // "packing" when partly solid; a fully solid slice is an end wall or lid.
  const std::size_t nz = c.mask.size();
  std::vector<double> d(nz, -1.0);
  std::uint64_t total = 0;
  for (std::size_t k = 0; k < nz; ++k) {
    total += c.mask[k];
    if (c.mask[k] > 0) d[k] = static_cast<double>(c.solid[k]) / static_cast<double>(c.mask[k]);
  }
  auto packing = [](double v) { return v > 0.0 && v < 0.999; };
  PackedSlices r;
  r.lastSlice = static_cast<std::int64_t>(nz) - 1;
  for (double v : d)
    if (packing(v)) r.peakDensity = std::max(r.peakDensity, v);
  if (fraction > 0 && r.peakDensity > 0) {
    const double cut = fraction * r.peakDensity;
    std::int64_t lo = -1, hi = -1;
    for (std::size_t k = 0; k < nz; ++k)
      if (packing(d[k]) && d[k] >= cut) {
        if (lo < 0) lo = static_cast<std::int64_t>(k);
        hi = static_cast<std::int64_t>(k);
      }
    if (lo >= 0) {
      r.firstSlice = lo;
      r.lastSlice = hi;
    }
  }
  std::uint64_t outside = 0;
  for (std::size_t k = 0; k < nz; ++k) {
    const auto kk = static_cast<std::int64_t>(k);
    if (kk < r.firstSlice || kk > r.lastSlice) outside += c.mask[k];
  }
  r.headspaceFraction = total ? static_cast<double>(outside) / static_cast<double>(total) : 0.0;
  r.found = r.firstSlice > 0 || r.lastSlice < static_cast<std::int64_t>(nz) - 1;
  return r;
}

json packedRegionJson(const PackedSlices& r, const Lattice& l, const std::string& mode,
                      bool applied) {
  auto z = [&](std::int64_t k) { return l.originMm[0] + static_cast<double>(k) * l.spacingMm[0]; };
  return {{"mode", mode},
          {"applied", applied},
          {"first_slice", r.firstSlice},
          {"last_slice", r.lastSlice},
          {"z_mm", {z(r.firstSlice), z(r.lastSlice)}},
          {"peak_density", r.peakDensity},
          {"headspace_fraction", r.headspaceFraction},
          {"rule", "slices partly solid and >= 0.5 x the densest slice (as compare)"}};
}

json computeStatsStreamed(const std::filesystem::path& path, const StatsOptions& given,
                          const StreamOptions& stream, Progress& progress,
                          const Communicator& comm) {
  validateStatsOptions(given);
  StatsOptions options = given;  // the S2 tile edge may be chosen below
  const auto which = requested(options);
  std::string cannot;
  for (const auto& s : which)
    if (!streamableStatistics().count(s)) cannot += (cannot.empty() ? "" : ", ") + s;
  if (!cannot.empty())
    throw InputError("stats: " + cannot +
                     " cannot be streamed in slabs (streamed: axial, radial, s2, chords, mes, "
                     "orientation; "
                     "pass --only with those, or raise --memory-limit)");
  if (which.count("mes") && options.mesMethod != "lattice")
    throw InputError("stats: mes --mes-method " + options.mesMethod +
                     " cannot be streamed in slabs (the lattice method can; or raise "
                     "--memory-limit)");
  auto want = [&](const char* s) { return which.count(s) != 0; };
  NullProgress quiet;
  Progress& prog = comm.rank() == 0 ? progress : quiet;

  BedSlabReader reader(path, comm.parallel());
  const BedHeader& h = reader.header();
  VoxelBox region{{0, 0, 0}, h.lattice.dims};
  json roiRecord = nullptr;
  ParticleTable particles = readBedParticles(path, stream.budget);
  if (stream.roi) {
    const CropBox cb = cropBox(h.lattice, *stream.roi);
    region = VoxelBox{cb.first, cb.dims};
    roiRecord = roiJson(*stream.roi, cb);
    // Particles whose centre lies in the ROI box (cropBed's rule for beds without labels).
    const Lattice rl = subLattice(h.lattice, region);
    ParticleTable kept;
    for (std::size_t p = 0; p < particles.size(); ++p) {
      const Vec3 ci = rl.continuousIndex(particles.positionMm[p]);
      bool in = true;
      for (int a = 0; a < 3; ++a) {
        const double c = ci[2 - a];
        in = in && c > -0.5 && c < static_cast<double>(region.dims[a]) - 0.5;
      }
      if (!in) continue;
      kept.positionMm.push_back(particles.positionMm[p]);
      if (!particles.orientation.empty()) kept.orientation.push_back(particles.orientation[p]);
      if (!particles.shape.empty()) kept.shape.push_back(particles.shape[p]);
    }
    particles = std::move(kept);
  }

  if (want("s2") && options.s2TileVoxels <= 0)
    options.s2TileVoxels = chooseS2TileVoxels(h, region, options, stream.budget, stream.slabPlanes);
  std::int64_t t = stream.slabPlanes > 0 ? stream.slabPlanes
                                         : slabPlanesWithin(h, region, options, stream.budget);
  if (t <= 0) {
    requireWithinBudget(estimateStreamedBytes(h, region, options, 1), stream.budget,
                        path.string() + ": stats streamed in slabs of one plane");
    t = 1;  // fits the limit, only not its planning headroom
  }
  requireWithinBudget(
      estimateStreamedBytes(h, region, options, t), stream.budget,
      path.string() + ": stats streamed in slabs of " + std::to_string(t) + " planes");
  if (want("mes"))  // its least need (no cut axis, one plane, no halo), before any pass
    requireWithinBudget(estimateMesStreamedBytes(h, region, {false, false, false}, 1, 0),
                        stream.budget, path.string() + ": mean empty space in slabs of one plane");

  // Pass 1: slice counts (porosity, axial profile, packed region) and the prism test.
  std::optional<Grid<std::uint8_t>> refSlice = reader.mask(planes(region, 0, 1));
  SliceCounts counts;
  counts.mask.assign(u(region.dims[0]), 0);
  counts.solid.assign(counts.mask.size(), 0);
  bool prism = h.hasMask;
  // Void on the y and x faces, per plane: the axes the window cuts, for mean empty space.
  std::vector<std::uint64_t> faceY(want("mes") ? u(region.dims[0]) : 0), faceX(faceY.size());
  {
    const Slabs slabs(region.dims[0], t, comm);
    SlabProgress sp(prog, "slice counts", slabs.last - slabs.first, "stats");
    for (std::int64_t s = slabs.first; s < slabs.last; ++s) {
      sp.step(s - slabs.first);
      const std::int64_t z0 = s * slabs.planes, z1 = std::min(region.dims[0], z0 + slabs.planes);
      const Grid<std::uint8_t> ind = reader.indicator(planes(region, z0, z1));
      const auto mask = reader.mask(planes(region, z0, z1));
      accumulateSliceCounts(counts, z0, ind, mask ? &*mask : nullptr);
      if (want("mes"))
        markFaceVoid(ind.data(), mask ? mask->data() : nullptr, z1 - z0, region.dims[1],
                     region.dims[2], z0, faceY, faceX);
      if (mask && prism) {
        const std::size_t slice = refSlice->size();
        for (std::int64_t k = 0; k < z1 - z0 && prism; ++k)
          prism = std::equal(refSlice->data(), refSlice->data() + slice,
                             mask->data() + static_cast<std::size_t>(k) * slice);
      }
    }
    sp.step(slabs.last - slabs.first);
  }
  comm.sum(counts.mask);
  comm.sum(counts.solid);
  comm.sum(faceY);
  comm.sum(faceX);
  prism = comm.allTrue(prism);

  const PackedSlices packed = packedSlices(counts, stream.packedRegionFraction);
  const Lattice whole = subLattice(h.lattice, region);
  const bool applyPacked = stream.packedRegion && packed.found;
  const json packedRecord =
      packedRegionJson(packed, whole, stream.packedRegion ? "auto" : "off", applyPacked);
  if (!stream.packedRegion && packed.headspaceFraction > 0.10)
    prog.message("warning: " + path.string() + ": " +
                 std::to_string(static_cast<int>(std::lround(100 * packed.headspaceFraction))) +
                 " % of the mask lies outside the packed region (headspace or end walls) and "
                 "is included; pass --packed-region auto to exclude it");
  if (applyPacked) {
    region.first[0] += packed.firstSlice;
    region.dims[0] = packed.lastSlice - packed.firstSlice + 1;
    const auto b = static_cast<std::ptrdiff_t>(packed.firstSlice);
    const auto e = static_cast<std::ptrdiff_t>(packed.lastSlice + 1);
    counts.mask = std::vector<std::uint64_t>(counts.mask.begin() + b, counts.mask.begin() + e);
    counts.solid = std::vector<std::uint64_t>(counts.solid.begin() + b, counts.solid.begin() + e);
    if (!faceY.empty()) {
      faceY = std::vector<std::uint64_t>(faceY.begin() + b, faceY.begin() + e);
      faceX = std::vector<std::uint64_t>(faceX.begin() + b, faceX.begin() + e);
    }
  }
  const Lattice l = subLattice(h.lattice, region);

  BedSummary sum;
  for (std::size_t k = 0; k < counts.mask.size(); ++k) {
    sum.voxelsInMask += counts.mask[k];
    sum.voidVoxels += counts.mask[k] - counts.solid[k];
  }
  finishSummary(sum);
  const double diameter =
      options.particleDiameterMm > 0 ? options.particleDiameterMm : inferDiameterMm(particles);
  json out = statsHeaderJson(l, options, which, sum, diameter);
  const double trim = options.trimMm >= 0 ? options.trimMm : (diameter > 0 ? 2 * diameter : 0);
  AxialOptions ao;
  ao.trimMm = trim;
  const AxialProfile axial = axialProfile(l, counts, ao);
  if (want("axial")) out["axial"] = axialJson(axial, trim);

  // Pass 2: radial column counts and chord runs over the own planes, S2 over the own planes
  // plus the halo.
  std::int64_t halo = 0;
  if (want("radial") || want("s2") || want("chords")) {
    const RadialOptions ro = radialOptions(options, axial, diameter);
    const std::int64_t nz = region.dims[0];
    const std::int64_t k0 = std::max<std::int64_t>(0, ro.firstSlice);
    const std::int64_t k1 = ro.lastSlice < 0 ? nz - 1 : std::min(nz - 1, ro.lastSlice);
    ColumnCounts cc(region.dims[1], region.dims[2]);
    std::optional<S2SlabAccumulator> acc;
    std::optional<ChordRuns> chords;
    if (want("chords")) chords.emplace(region.dims[0], region.dims[1], region.dims[2]);
    if (want("s2")) {
      acc.emplace(l, h.hasMask, prism, s2Options(options));
      if (prism) acc->setPrismSlice(*reader.mask(planes(region, 0, 1)));
      halo = acc->maxLag()[0];
    }
    const Slabs slabs(nz, t, comm);
    SlabProgress sp(prog, want("s2") ? "S2 and radial profile" : "radial profile",
                    slabs.last - slabs.first, "stats");
    for (std::int64_t s = slabs.first; s < slabs.last; ++s) {
      sp.step(s - slabs.first);
      const std::int64_t z0 = s * slabs.planes, z1 = std::min(nz, z0 + slabs.planes);
      const std::int64_t ze = std::min(nz, z1 + halo);
      const Grid<std::uint8_t> ind = reader.indicator(planes(region, z0, ze));
      const auto mask = reader.mask(planes(region, z0, ze));
      const Grid<std::uint8_t>* m = mask ? &*mask : nullptr;
      accumulateColumnCounts(cc, z0, ind, m, std::max(k0, z0), std::min(k1, z1 - 1));
      if (acc) acc->addSlab(z0, z1, ind, m);
      if (chords) chords->addPlanes(z0, ind, m, z1 - z0);
    }
    sp.step(slabs.last - slabs.first);
    comm.sum(cc.mask);
    comm.sum(cc.solid);
    std::vector<std::uint64_t> withMask{cc.slicesWithMask};
    comm.sum(withMask);
    cc.slicesWithMask = withMask[0];
    if (want("radial")) out["radial"] = radialJson(radialProfile(l, h.hasMask, cc, ro), diameter);
    if (chords) {
      // The z runs that cross rank boundaries are joined in rank order (the carry of rank
      // r - 1 meets rank r's first planes); all other counts are sums.
      std::vector<std::uint64_t> carry(comm.rank() > 0 ? cc.mask.size() : 0);
      comm.receiveFromPrevious(carry);
      comm.sendToNext(chords->joinCarry(carry));
      for (auto& c : chords->counts()) comm.sum(c);
      comm.sum(chords->windowCut());
      out["chords"] = chordsJson(chordLengths(*chords, l, 0));
    }
    if (acc) {
      comm.sum(acc->numerator());
      comm.sum(acc->pairCounts());
      S2Result r = acc->finish();
      for (int a = 0; a < 3; ++a) r.paddedDims[a] = comm.max(r.paddedDims[a]);
      out["s2"] = s2Json(r, options);
    }
  }
  json mesRecord = nullptr;
  if (want("mes")) {
    // Pass 3: mean empty space over slabs with a halo (docs/scale.md).
    const std::size_t nz = counts.mask.size();
    const std::array<bool, 3> cutAxes{
        nz > 0 && (counts.mask[0] > counts.solid[0] || counts.mask[nz - 1] > counts.solid[nz - 1]),
        std::any_of(faceY.begin(), faceY.end(), [](std::uint64_t v) { return v != 0; }),
        std::any_of(faceX.begin(), faceX.end(), [](std::uint64_t v) { return v != 0; })};
    const MesStreamPlan plan = planMesStream(h, region, cutAxes, stream.budget, stream.slabPlanes,
                                             stream.mesHaloPlanes, comm.size());
    const MesResult r = meanEmptySpaceStreamed(reader, region, mesGeometry(l, cutAxes), plan, 0,
                                               options.threads, prog, comm);
    json m = mesJson(r, "lattice-13");
    if (diameter > 0 && m["mean_mm"].is_number())
      m["mean_d"] = m["mean_mm"].get<double>() / diameter;
    out["mes"] = m;
    const bool exact = r.sliceCutVoxels == 0 && r.sliceCutChords == 0;
    mesRecord = {{"slab_planes", plan.slabPlanes},       {"halo_planes", plan.haloPlanes},
                 {"estimate_bytes", plan.bytes},         {"exact", exact},
                 {"slice_cut_voxels", r.sliceCutVoxels}, {"slice_cut_chords", r.sliceCutChords}};
    if (!exact)
      prog.message("warning: mean empty space: " + std::to_string(r.sliceCutVoxels) +
                   " void voxels and " + std::to_string(r.sliceCutChords) +
                   " chords ran past the slab windows (halo " + std::to_string(plan.haloPlanes) +
                   " planes) and are left out as cut; raise --memory-limit for the exact result");
  }
  if (want("orientation")) {
    Bed tableOnly;
    tableOnly.particles = particles;
    addExtraStatistics(out, tableOnly, options, {"orientation"}, diameter, prog);
  }
  out["roi_mm"] = roiRecord;
  out["packed_region"] = packedRecord;
  out["streamed"] = {
      {"slab_planes", t},
      {"slabs", Slabs(region.dims[0], t, comm).count},
      {"halo_planes", halo},
      {"s2_tile_voxels", want("s2") ? json(options.s2TileVoxels) : json(nullptr)},
      {"ranks", comm.size()},
      {"estimate_bytes",
       std::max(estimateStreamedBytes(h, region, options, t),
                mesRecord.is_null() ? 0 : mesRecord["estimate_bytes"].get<std::uint64_t>())},
      {"mes", mesRecord}};
  sanitizeNonFinite(out);
  return out;
}

BedSummary summarizeStreamed(const std::filesystem::path& path, const MemoryBudget& budget,
                             std::int64_t slabPlanes, const Communicator& comm) {
  BedSlabReader reader(path, comm.parallel());
  const BedHeader& h = reader.header();
  const VoxelBox region{{0, 0, 0}, h.lattice.dims};
  StatsOptions o;
  o.only = {"axial"};
  std::int64_t t = slabPlanes > 0 ? slabPlanes : slabPlanesWithin(h, region, o, budget);
  if (t <= 0) {
    requireWithinBudget(estimateStreamedBytes(h, region, o, 1), budget,
                        path.string() + ": porosity in slabs of one plane");
    t = 1;  // fits the limit, only not its planning headroom
  }
  BedSummary sum;
  const Slabs slabs(region.dims[0], t, comm);
  for (std::int64_t s = slabs.first; s < slabs.last; ++s) {
    const std::int64_t z0 = s * slabs.planes, z1 = std::min(region.dims[0], z0 + slabs.planes);
    const auto ind = reader.indicator(planes(region, z0, z1));
    const auto mask = reader.mask(planes(region, z0, z1));
    accumulateSummary(sum, ind, mask ? &*mask : nullptr);
  }
  std::vector<std::uint64_t> c{sum.voxelsInMask, sum.voidVoxels};
  comm.sum(c);
  sum.voxelsInMask = c[0];
  sum.voidVoxels = c[1];
  finishSummary(sum);
  return sum;
}

}  // namespace voxpack::stats
