// Mean empty space, isotropic path: rays against the digital solid's surface through a
// CGAL AABB tree (docs/stats.md). CGAL stays inside this file (slow headers).
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <unordered_set>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/stats/mes.hpp"

namespace voxpack::stats {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Triangle = Kernel::Triangle_3;
using Ray = Kernel::Ray_3;
using TriangleIter = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, TriangleIter>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

// Faces between void-in-mask voxels and the rest, merged into maximal rectangles per
// plane (greedy meshing) so the tree holds several times fewer triangles.
std::vector<Triangle> surfaceTriangles(const Bed& bed) {
  const Lattice& l = bed.lattice();
  const std::int64_t n[3] = {l.nz(), l.ny(), l.nx()};
  auto isVoid = [&](std::int64_t k, std::int64_t j, std::int64_t i) {
    const std::size_t o = l.offset(k, j, i);
    return bed.indicator[o] != 0 && (!bed.mask || (*bed.mask)[o] != 0);
  };
  std::vector<Triangle> tris;
  // axis a: faces between index c and c+1 along a; (u, v) the other two axes.
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3, v = (a + 2) % 3;
    const std::int64_t nu = n[u], nv = n[v];
    std::vector<std::uint8_t> face(static_cast<std::size_t>(nu * nv));
    for (std::int64_t c = 0; c + 1 < n[a]; ++c) {
      for (std::int64_t iu = 0; iu < nu; ++iu)
        for (std::int64_t iv = 0; iv < nv; ++iv) {
          std::int64_t p[3], q[3];
          p[a] = c;
          q[a] = c + 1;
          p[u] = q[u] = iu;
          p[v] = q[v] = iv;
          face[static_cast<std::size_t>(iu * nv + iv)] =
              isVoid(p[0], p[1], p[2]) != isVoid(q[0], q[1], q[2]);
        }
      // Greedy rectangles.
      for (std::int64_t iu = 0; iu < nu; ++iu)
        for (std::int64_t iv = 0; iv < nv; ++iv) {
          if (!face[static_cast<std::size_t>(iu * nv + iv)]) continue;
          std::int64_t w = 1;
          while (iv + w < nv && face[static_cast<std::size_t>(iu * nv + iv + w)]) ++w;
          std::int64_t h = 1;
          for (;; ++h) {
            if (iu + h >= nu) break;
            bool full = true;
            for (std::int64_t t = 0; t < w && full; ++t)
              full = face[static_cast<std::size_t>((iu + h) * nv + iv + t)] != 0;
            if (!full) break;
          }
          for (std::int64_t s = 0; s < h; ++s)
            for (std::int64_t t = 0; t < w; ++t)
              face[static_cast<std::size_t>((iu + s) * nv + iv + t)] = 0;
          // Corners in continuous index space (k, j, i), then to mm (x, y, z).
          auto corner = [&](double du, double dv) {
            double idx[3];
            idx[a] = static_cast<double>(c) + 0.5;
            idx[u] = static_cast<double>(iu) - 0.5 + du;
            idx[v] = static_cast<double>(iv) - 0.5 + dv;
            return Point(l.originMm[2] + idx[2] * l.spacingMm[2],
                         l.originMm[1] + idx[1] * l.spacingMm[1],
                         l.originMm[0] + idx[0] * l.spacingMm[0]);
          };
          const double hu = static_cast<double>(h), wv = static_cast<double>(w);
          const Point p00 = corner(0, 0), p10 = corner(hu, 0), p11 = corner(hu, wv),
                      p01 = corner(0, wv);
          tris.emplace_back(p00, p10, p11);
          tris.emplace_back(p00, p11, p01);
        }
    }
  }
  return tris;
}

// Uniform direction on the unit sphere.
Kernel::Vector_3 randomDirection(RandomStream& rng) {
  const double z = rng.uniform(-1.0, 1.0);
  const double phi = rng.uniform(0.0, 2 * std::numbers::pi);
  const double s = std::sqrt(std::max(0.0, 1 - z * z));
  return {s * std::cos(phi), s * std::sin(phi), z};
}

}  // namespace

MesResult meanEmptySpaceIsotropic(const Bed& bed, const MesIsotropicOptions& options,
                                  Progress& progress, std::vector<std::size_t>* sampleOffsets,
                                  std::vector<double>* sampleMeans) {
  if (options.samples < 1) throw InputError("mean empty space: samples must be >= 1");
  if (options.directions < 1) throw InputError("mean empty space: directions must be >= 1");
  if (!std::isfinite(options.binWidthMm)) throw InputError("mean empty space: bad bin width");
  const auto t0 = std::chrono::steady_clock::now();
  const Lattice& l = bed.lattice();
  auto isVoid = [&](std::size_t o) {
    return bed.indicator[o] != 0 && (!bed.mask || (*bed.mask)[o] != 0);
  };
  MesResult r;
  r.directions = options.directions;
  for (std::size_t o = 0; o < l.size(); ++o) r.voidVoxels += isVoid(o);
  const double width = options.binWidthMm > 0
                           ? options.binWidthMm
                           : std::min({l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]});
  // Sample: every void voxel when few, else distinct uniform picks (seeded stream 0).
  std::vector<std::size_t> picks;
  if (r.voidVoxels <= static_cast<std::size_t>(options.samples)) {
    for (std::size_t o = 0; o < l.size(); ++o)
      if (isVoid(o)) picks.push_back(o);
  } else {
    RandomStream rng(options.seed, 0);
    std::unordered_set<std::size_t> seen;
    while (picks.size() < static_cast<std::size_t>(options.samples)) {
      const std::size_t o = rng.below(l.size());
      if (isVoid(o) && seen.insert(o).second) picks.push_back(o);
    }
    std::sort(picks.begin(), picks.end());
  }
  progress.report("mean empty space (isotropic)", 0.0);
  const std::vector<Triangle> tris = surfaceTriangles(bed);
  std::vector<double> means(picks.size(), std::numeric_limits<double>::quiet_NaN());
  std::vector<double> weights(picks.size(), 0.0);
  const std::array<bool, 3> cutAxes = windowCutAxes(bed);
  if (!tris.empty()) {
    Tree tree(tris.begin(), tris.end());
    tree.build();
    const auto count = static_cast<std::int64_t>(picks.size());
#pragma omp parallel for num_threads(std::max(1, options.threads)) schedule(dynamic, 16)
    for (std::int64_t s = 0; s < count; ++s) {
      const std::size_t o = picks[static_cast<std::size_t>(s)];
      const Index3 idx = l.indexOf(o);
      const Vec3 c = l.centerMm(idx.k, idx.j, idx.i);
      const Point origin(c.x(), c.y(), c.z());
      RandomStream rng(options.seed, 1 + o);  // keyed by voxel, not by thread
      double sum = 0;
      bool cut = false;
      // Reach of the chord star (voxels, to the centre of the solid voxel beyond the hit
      // face) towards − and + along z, y, x: for the minus-sampling weight.
      double reach[6] = {0, 0, 0, 0, 0, 0};
      const double centre[3] = {c.z(), c.y(), c.x()};
      for (int d = 0; d < options.directions && !cut; ++d) {
        const Kernel::Vector_3 u = randomDirection(rng);
        for (double sign : {1.0, -1.0}) {
          const auto hit = tree.first_intersection(Ray(origin, sign * u));
          const Point* p = hit ? boost::get<Point>(&hit->first) : nullptr;
          if (!p) {
            cut = true;
            break;
          }
          sum += std::sqrt(CGAL::squared_distance(origin, *p));
          const double at[3] = {p->z(), p->y(), p->x()};
          for (int a = 0; a < 3; ++a) {
            const double t = (at[a] - centre[a]) / l.spacingMm[static_cast<std::size_t>(a)];
            reach[2 * a] = std::max(reach[2 * a], -t + 0.5);
            reach[2 * a + 1] = std::max(reach[2 * a + 1], t + 0.5);
          }
        }
      }
      if (cut) continue;
      double w = 1;
      for (int a = 0; a < 3; ++a) {
        if (!cutAxes[static_cast<std::size_t>(a)]) continue;
        const double n = static_cast<double>(l.dims[static_cast<std::size_t>(a)]);
        w *= n / std::max(1.0, n - std::round(reach[2 * a] + reach[2 * a + 1]));
      }
      means[static_cast<std::size_t>(s)] = sum / options.directions;
      weights[static_cast<std::size_t>(s)] = w;
    }
  }
  for (double m : means) r.undefinedVoxels += std::isnan(m);
  r.distribution = summarizeLengths(means, width, &weights);
  if (sampleOffsets) *sampleOffsets = picks;
  if (sampleMeans) *sampleMeans = means;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  progress.report("mean empty space (isotropic)", 1.0);
  return r;
}

}  // namespace voxpack::stats
