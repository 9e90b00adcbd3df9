// The column fit of a streamed image (docs/scale.md, "The column, streamed"): fitColumn's
// per-slab circles and refineColumn's wall profiles, filled slab by slab. Each column slab
// is read by one process in planes of at most a streaming slab, in increasing z, so every
// per-slab sum is added in the in-memory order; the processes' results are summed with
// zeros elsewhere, which is exact, so any slab size and any number of ranks give the same
// column.
#include <algorithm>
#include <cmath>
#include <string>

#include "column_detail.hpp"
#include "heap.hpp"
#include "stream_detail.hpp"
#include "voxpack/ingest/segment.hpp"

namespace voxpack::ingest::stream_detail {
namespace {

constexpr std::size_t kSlabValues = 6;  // found, touches, z, x, y, radius

// Calls f(planes, firstPlane) for the column slabs this rank owns (slab c: rank c mod P),
// in chunks of at most `chunk` planes, in increasing z within each slab.
template <class Read, class F>
void forOwnColumnSlabs(const Lattice& lat, int slabSlices, std::int64_t chunk,
                       const Communicator* comm, Progress& progress, const std::string& stage,
                       Read&& read, F&& f) {
  const int P = comm ? comm->size() : 1, me = comm ? comm->rank() : 0;
  const std::int64_t nz = lat.nz(), slabs = column_detail::columnSlabs(nz, slabSlices);
  SlabProgress sp(progress, stage, (slabs - me + P - 1) / P, "ingest");
  for (std::int64_t c = 0; c < slabs; ++c) {
    if (c % P != me) continue;
    sp.step(c / P);
    const std::int64_t z0 = c * nz / slabs, z1 = (c + 1) * nz / slabs;
    f.begin(c, z0, z1);
    for (std::int64_t a = z0; a < z1; a += chunk) {
      const std::int64_t b = std::min(z1, a + chunk);
      {
        const Grid<float> img = read(a, b);
        f.planes(img, a);
      }
      releaseFreedHeap();
    }
    f.end();
  }
}

}  // namespace

ColumnFit streamedColumnFit(const VolumeHeader& h, const IngestOptions& o, double tOtsu,
                            bool voidBright, bool squared, std::int64_t slabPlanes, int threads,
                            Progress& progress, const Communicator* comm, int& passes) {
  column_detail::checkFitOptions(o.columnFit);
  const Lattice& lat = h.lattice;
  const std::int64_t nz = lat.nz(), chunk = std::clamp<std::int64_t>(slabPlanes, 1, nz);
  const auto plane = static_cast<std::size_t>(lat.ny() * lat.nx());
  const std::int64_t slabs = column_detail::columnSlabs(nz, o.columnFit.slabSlices);
  auto denoised = [&](std::int64_t a, std::int64_t b) {
    return denoisedPlanes(h, o, a, b, threads);
  };

  // The rough fit: per slab, each pixel's count of solid voxels on the preliminary (Otsu)
  // cut. The in-memory fit also clears specks and holes first; a speck or hole moves a
  // pixel's count by its height only, and the refinement below fits the grey step.
  std::vector<double> found(static_cast<std::size_t>(slabs) * kSlabValues, 0.0);
  struct Counter {
    const Lattice& lat;
    const IngestOptions& o;
    std::vector<double>& found;
    double t;
    bool voidBright;
    std::size_t plane;
    std::vector<std::int32_t> count;
    std::int64_t c = 0, z0 = 0, z1 = 0;
    void begin(std::int64_t slab, std::int64_t a, std::int64_t b) {
      c = slab;
      z0 = a;
      z1 = b;
      count.assign(plane, 0);
    }
    void planes(const Grid<float>& img, std::int64_t) {
      const Grid<std::uint8_t> ind = applyThreshold(img, t, voidBright);
      for (const std::uint8_t* k = ind.data(); k < ind.data() + ind.size(); k += plane)
        for (std::size_t p = 0; p < plane; ++p) count[p] += k[p] == 0;
    }
    void end() {
      const column_detail::SlabCircle s =
          column_detail::fitSlabCircle(count, lat, z0, z1, o.columnFit);
      double* v = found.data() + static_cast<std::size_t>(c) * kSlabValues;
      v[0] = s.found;
      v[1] = s.touches;
      v[2] = s.zMm;
      v[3] = s.xMm;
      v[4] = s.yMm;
      v[5] = s.radiusMm;
      count = {};
    }
  } counter{lat, o, found, tOtsu, voidBright, plane, {}};
  forOwnColumnSlabs(lat, o.columnFit.slabSlices, chunk, comm, progress,
                    "column fit (pass " + std::to_string(passes + 1) + ")", denoised, counter);
  ++passes;
  if (comm && comm->size() > 1) comm->sum(found);  // each slab from one rank, zeros elsewhere
  std::vector<column_detail::SlabCircle> circles(static_cast<std::size_t>(slabs));
  for (std::size_t c = 0; c < circles.size(); ++c) {
    const double* v = found.data() + c * kSlabValues;
    circles[c] = {v[0] != 0.0, v[1] != 0.0, v[2], v[3], v[4], v[5]};
  }
  const ColumnFit rough = column_detail::combineSlabCircles(circles, lat);
  if (!rough.found || !o.refineColumn) return rough;

  // The refinement: refineColumn's iterations, one pass each, on the denoised image (or on
  // the raw one, squared, for a signal-free MRI wall).
  const ColumnRefineOptions ro{
      .slabSlices = o.columnFit.slabSlices, .squared = squared, .wallThicknessMm = o.columnWallMm};
  auto source = [&](std::int64_t a, std::int64_t b) {
    return squared ? readVolumeSlab(h, a, b) : denoisedPlanes(h, o, a, b, threads);
  };
  return column_detail::refineIterations(lat, rough, ro, [&](column_detail::WallProfiles& prof) {
    struct Filler {
      column_detail::WallProfiles& prof;
      std::size_t plane;
      void begin(std::int64_t, std::int64_t, std::int64_t) {}
      void planes(const Grid<float>& img, std::int64_t a) {
        for (std::int64_t k = 0; k < img.lattice().nz(); ++k)
          prof.addPlane(img.data() + static_cast<std::size_t>(k) * plane, a + k);
      }
      void end() {}
    } filler{prof, plane};
    forOwnColumnSlabs(lat, o.columnFit.slabSlices, chunk, comm, progress,
                      "column wall step (pass " + std::to_string(passes + 1) + ")", source, filler);
    ++passes;
    if (comm && comm->size() > 1) comm->sum(prof.flat());  // each slab from one rank
  });
}

}  // namespace voxpack::ingest::stream_detail
