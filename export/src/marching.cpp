// Iso-surface of an imaged bed: Gaussian-smoothed solid fraction, marching tetrahedra on
// the voxel centres (Kuhn's six tetrahedra per cube share the cube diagonal, so neighbour
// cubes agree on every face and the surface is closed and manifold), then Taubin smoothing
// (alternating lambda / mu steps, which smooths without the shrinkage of plain Laplacian).
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "voxpack/core/errors.hpp"
#include "voxpack/export/surfaces.hpp"

namespace voxpack::exporter {
namespace {

// Separable Gaussian along one axis of a padded float grid (dims n0 n1 n2, C order).
void blurAxis(std::vector<float>& f, const std::array<std::int64_t, 3>& n, int axis,
              const std::vector<float>& w, int threads) {
  const int r = static_cast<int>(w.size()) - 1;
  const std::int64_t stride = axis == 2 ? 1 : (axis == 1 ? n[2] : n[1] * n[2]);
  const std::int64_t len = n[static_cast<std::size_t>(axis)];
  const std::int64_t lines = n[0] * n[1] * n[2] / len;
#pragma omp parallel num_threads(std::max(1, threads))
  {
    std::vector<float> line(static_cast<std::size_t>(len)), out(static_cast<std::size_t>(len));
#pragma omp for schedule(static)
    for (std::int64_t L = 0; L < lines; ++L) {
      // Start of line L: all indices with the axis coordinate 0.
      std::int64_t start;
      if (axis == 2)
        start = L * n[2];
      else if (axis == 1)
        start = (L / n[2]) * n[1] * n[2] + (L % n[2]);
      else
        start = L;
      for (std::int64_t s = 0; s < len; ++s)
        line[static_cast<std::size_t>(s)] = f[static_cast<std::size_t>(start + s * stride)];
      for (std::int64_t s = 0; s < len; ++s) {
        double acc = w[0] * line[static_cast<std::size_t>(s)];
        for (int t = 1; t <= r; ++t) {
          const std::int64_t a = s - t, b = s + t;
          if (a >= 0) acc += w[static_cast<std::size_t>(t)] * line[static_cast<std::size_t>(a)];
          if (b < len) acc += w[static_cast<std::size_t>(t)] * line[static_cast<std::size_t>(b)];
        }
        out[static_cast<std::size_t>(s)] = static_cast<float>(acc);
      }
      for (std::int64_t s = 0; s < len; ++s)
        f[static_cast<std::size_t>(start + s * stride)] = out[static_cast<std::size_t>(s)];
    }
  }
}

void taubin(TriMesh& m, int iterations) {
  if (iterations <= 0) return;
  std::vector<std::vector<std::uint32_t>> nb(m.vertices.size());
  for (const auto& t : m.triangles)
    for (int e = 0; e < 3; ++e) {
      nb[t[e]].push_back(t[(e + 1) % 3]);
      nb[t[(e + 1) % 3]].push_back(t[e]);
    }
  for (auto& v : nb) {
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  }
  std::vector<Vec3> next(m.vertices.size());
  const double steps[2] = {0.5, -0.53};
  for (int it = 0; it < iterations; ++it)
    for (double f : steps) {
      for (std::size_t v = 0; v < m.vertices.size(); ++v) {
        if (nb[v].empty()) {
          next[v] = m.vertices[v];
          continue;
        }
        Vec3 c = Vec3::Zero();
        for (auto u : nb[v]) c += m.vertices[u];
        c /= static_cast<double>(nb[v].size());
        next[v] = m.vertices[v] + f * (c - m.vertices[v]);
      }
      m.vertices.swap(next);
    }
}

}  // namespace

SurfaceResult indicatorSurface(const Bed& bed, const IsoSurfaceOptions& o, Progress& progress) {
  const Lattice& l = bed.lattice();
  const int sigmaR = o.smoothingVoxels > 0 ? static_cast<int>(std::ceil(3 * o.smoothingVoxels)) : 0;
  const std::int64_t pad = sigmaR + 1;
  const std::array<std::int64_t, 3> n{l.nz() + 2 * pad, l.ny() + 2 * pad, l.nx() + 2 * pad};
  std::vector<float> f(static_cast<std::size_t>(n[0] * n[1] * n[2]), 0.0f);
  auto at = [&](std::int64_t k, std::int64_t j, std::int64_t i) {
    return static_cast<std::size_t>((k * n[1] + j) * n[2] + i);
  };
  for (std::int64_t k = 0; k < l.nz(); ++k)
    for (std::int64_t j = 0; j < l.ny(); ++j)
      for (std::int64_t i = 0; i < l.nx(); ++i) {
        const std::size_t off = l.offset(k, j, i);
        const bool solid = bed.indicator[off] == 0 && (!bed.mask || (*bed.mask)[off]);
        f[at(k + pad, j + pad, i + pad)] = solid ? 1.0f : 0.0f;
      }
  if (sigmaR > 0) {
    std::vector<float> w(static_cast<std::size_t>(sigmaR) + 1);
    double sum = 0;
    for (int t = 0; t <= sigmaR; ++t) {
      w[static_cast<std::size_t>(t)] =
          static_cast<float>(std::exp(-0.5 * t * t / (o.smoothingVoxels * o.smoothingVoxels)));
      sum += (t ? 2 : 1) * w[static_cast<std::size_t>(t)];
    }
    for (auto& x : w) x = static_cast<float>(x / sum);
    for (int axis = 0; axis < 3; ++axis) blurAxis(f, n, axis, w, o.threads);
  }
  progress.report("export: iso-surface", 0.3);

  // Kuhn tetrahedra: corner bits c = i | j << 1 | k << 2; each path 0 -> 7 adds one bit.
  static const int kTets[6][4] = {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7},
                                  {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}};
  TriMesh m;
  std::unordered_map<std::uint64_t, std::uint32_t> edgeVertex;
  const float level = 0.5f;
  auto pointOf = [&](std::int64_t k, std::int64_t j, std::int64_t i) {
    return l.centerMm(k - pad, j - pad, i - pad);
  };
  auto vertexOn = [&](std::int64_t k, std::int64_t j, std::int64_t i, int ca, int cb) {
    if (ca > cb) std::swap(ca, cb);  // ca is a bit subset of cb (Kuhn edges)
    const std::int64_t ka = k + (ca >> 2 & 1), ja = j + (ca >> 1 & 1), ia = i + (ca & 1);
    const std::int64_t kb = k + (cb >> 2 & 1), jb = j + (cb >> 1 & 1), ib = i + (cb & 1);
    const std::uint64_t key =
        static_cast<std::uint64_t>(at(ka, ja, ia)) * 8 + static_cast<std::uint64_t>(ca ^ cb);
    auto it = edgeVertex.find(key);
    if (it != edgeVertex.end()) return it->second;
    const float fa = f[at(ka, ja, ia)], fb = f[at(kb, jb, ib)];
    const double t = std::clamp((level - fa) / static_cast<double>(fb - fa), 0.0, 1.0);
    const Vec3 p = (1 - t) * pointOf(ka, ja, ia) + t * pointOf(kb, jb, ib);
    const auto id = static_cast<std::uint32_t>(m.vertices.size());
    m.vertices.push_back(p);
    edgeVertex.emplace(key, id);
    return id;
  };
  for (std::int64_t k = 0; k + 1 < n[0]; ++k) {
    if (progress.cancelled()) throw Cancelled("export cancelled");
    for (std::int64_t j = 0; j + 1 < n[1]; ++j)
      for (std::int64_t i = 0; i + 1 < n[2]; ++i) {
        float v[8];
        int inside = 0;
        for (int c = 0; c < 8; ++c) {
          v[c] = f[at(k + (c >> 2 & 1), j + (c >> 1 & 1), i + (c & 1))];
          inside += v[c] > level;
        }
        if (inside == 0 || inside == 8) continue;
        for (const auto& tet : kTets) {
          int in[4], out[4], ni = 0, no = 0;
          for (int c : tet) (v[c] > level ? in[ni++] : out[no++]) = c;
          if (ni == 0 || no == 0) continue;
          auto corner = [&](int c) {
            return pointOf(k + (c >> 2 & 1), j + (c >> 1 & 1), i + (c & 1));
          };
          Vec3 cin = Vec3::Zero(), cout = Vec3::Zero();
          for (int s = 0; s < ni; ++s) cin += corner(in[s]);
          for (int s = 0; s < no; ++s) cout += corner(out[s]);
          const Vec3 outward = cout / no - cin / ni;
          auto emit = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
            const Vec3 nrm = (m.vertices[b] - m.vertices[a]).cross(m.vertices[c] - m.vertices[a]);
            if (nrm.dot(outward) >= 0)
              m.triangles.push_back({a, b, c});
            else
              m.triangles.push_back({a, c, b});
          };
          if (ni == 1 || no == 1) {
            const int apex = ni == 1 ? in[0] : out[0];
            const int* others = ni == 1 ? out : in;
            emit(vertexOn(k, j, i, apex, others[0]), vertexOn(k, j, i, apex, others[1]),
                 vertexOn(k, j, i, apex, others[2]));
          } else {
            const std::uint32_t a = vertexOn(k, j, i, in[0], out[0]),
                                b = vertexOn(k, j, i, in[0], out[1]);
            const std::uint32_t c = vertexOn(k, j, i, in[1], out[1]),
                                d = vertexOn(k, j, i, in[1], out[0]);
            emit(a, b, c);
            emit(a, c, d);
          }
        }
      }
  }
  progress.report("export: iso-surface", 0.8);
  taubin(m, o.taubinIterations);
  SurfaceResult r;
  r.report = {{"surface", "iso"},
              {"smoothing_voxels", o.smoothingVoxels},
              {"taubin_iterations", o.taubinIterations},
              {"triangles", m.triangles.size()},
              {"vertices", m.vertices.size()},
              {"solids", 1}};
  r.solids.push_back({"bed", std::move(m)});
  progress.report("export: iso-surface", 1.0);
  return r;
}

}  // namespace voxpack::exporter
