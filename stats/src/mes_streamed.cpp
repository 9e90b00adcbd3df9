// Mean empty space of beds bigger than memory: z-slabs read with a halo each side, every run
// through an owned voxel seen whole when it fits the halo, the exact sums reduced over the
// ranks (docs/scale.md).
#include <algorithm>
#include <chrono>

#include "mes_window.hpp"
#include "stream_plan.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/stats/streamed.hpp"

namespace voxpack::stats {
namespace {
using stream_plan::fitsWithHeadroom;
using stream_plan::Slabs;
using stream_plan::u;
}  // namespace

std::uint64_t estimateMesStreamedBytes(const BedHeader& h, const VoxelBox& region,
                                       const std::array<bool, 3>& cutAxes, std::int64_t slab,
                                       std::int64_t halo) {
  const std::int64_t nz = region.dims[0];
  const std::uint64_t plane = u(region.dims[1]) * u(region.dims[2]);
  const std::int64_t own = std::min(slab, nz);
  const std::int64_t window = std::min(nz, own + 2 * halo);
  const std::uint64_t perWindowVoxel = 1 + (h.hasMask ? 1 : 0);
  // Minus-sampling tables: 13 directions, one double per chord length.
  const std::uint64_t tables =
      13 * 8 * (u(region.dims[0]) + u(region.dims[1]) + u(region.dims[2]) + 2);
  return kProcessBaseBytes + particleTableBytes(h) + tables + 16 * plane +
         u(window) * plane * perWindowVoxel + u(own) * plane * mesScratchBytesPerVoxel(cutAxes);
}

MesStreamPlan planMesStream(const BedHeader& h, const VoxelBox& region,
                            const std::array<bool, 3>& cutAxes, const MemoryBudget& budget,
                            std::int64_t slab, std::int64_t halo, int ranks) {
  const std::int64_t nz = region.dims[0];
  auto fits = [&](std::int64_t t, std::int64_t hh) {
    return fitsWithHeadroom(budget, estimateMesStreamedBytes(h, region, cutAxes, t, hh));
  };
  // The largest v in [lo, hi] with ok(v), assuming ok is monotone and ok(lo) (or lo).
  auto largest = [](std::int64_t lo, std::int64_t hi, auto ok) {
    while (lo < hi) {
      const std::int64_t mid = lo + (hi - lo + 1) / 2;
      if (ok(mid))
        lo = mid;
      else
        hi = mid - 1;
    }
    return lo;
  };
  MesStreamPlan p;
  if (slab > 0) {
    p.slabPlanes = std::min(slab, nz);
  } else if (ranks <= 1 && fits(nz, 0)) {
    p.slabPlanes = nz;  // one window: every chord is whole
  } else {
    // The thickest slab with a halo of twice its thickness, at most a rank's share.
    const std::int64_t share = (nz + ranks - 1) / std::max(1, ranks);
    p.slabPlanes = std::max<std::int64_t>(
        1, largest(0, share, [&](std::int64_t t) { return fits(t, halo >= 0 ? halo : 2 * t); }));
  }
  if (halo >= 0)
    p.haloPlanes = std::min(halo, nz);
  else if (p.slabPlanes < nz)  // the tallest halo that fits beside the slab
    p.haloPlanes = largest(0, nz, [&](std::int64_t hh) { return fits(p.slabPlanes, hh); });
  p.bytes = estimateMesStreamedBytes(h, region, cutAxes, p.slabPlanes, p.haloPlanes);
  requireWithinBudget(p.bytes, budget,
                      "mean empty space streamed in slabs of " + std::to_string(p.slabPlanes) +
                          " planes with a halo of " + std::to_string(p.haloPlanes));
  return p;
}

MesResult meanEmptySpaceStreamed(const BedSlabReader& reader, const VoxelBox& region,
                                 const MesGeometry& g, const MesStreamPlan& plan, double binWidthMm,
                                 int threads, Progress& progress, const Communicator& comm) {
  const auto t0 = std::chrono::steady_clock::now();
  MesSums sums(g.lattice, binWidthMm);
  const std::int64_t nz = region.dims[0];
  const Slabs slabs(nz, plan.slabPlanes, comm);
  SlabProgress sp(progress, "mean empty space", slabs.last - slabs.first, "stats");
  NullProgress quiet;
  for (std::int64_t s = slabs.first; s < slabs.last; ++s) {
    sp.step(s - slabs.first);
    const std::int64_t z0 = s * slabs.planes, z1 = std::min(nz, z0 + slabs.planes);
    const std::int64_t w0 = std::max<std::int64_t>(0, z0 - plan.haloPlanes);
    const std::int64_t w1 = std::min(nz, z1 + plan.haloPlanes);
    const VoxelBox box{{region.first[0] + w0, region.first[1], region.first[2]},
                       {w1 - w0, region.dims[1], region.dims[2]}};
    const Grid<std::uint8_t> ind = reader.indicator(box);
    const auto mask = reader.mask(box);
    MesWindow w;
    w.indicator = ind.data();
    w.mask = mask ? mask->data() : nullptr;
    w.planes = w1 - w0;
    w.firstPlane = w0;
    w.ownFirst = z0 - w0;
    w.ownLast = z1 - w0;
    scanMesWindow(w, g, threads, sums, quiet);
  }
  sp.step(slabs.last - slabs.first);
  sums.reduce(comm);
  MesResult r = sums.finish(g);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace voxpack::stats
