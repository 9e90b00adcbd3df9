// Global thresholds and clean-up of the two-phase segmentation.
#include "voxpack/ingest/segment.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "voxpack/core/errors.hpp"

namespace voxpack::ingest {
namespace {

std::pair<float, float> valueRange(const Grid<float>& image) {
  if (image.empty()) throw InputError("empty image");
  const auto [lo, hi] = std::minmax_element(image.values().begin(), image.values().end());
  return {*lo, *hi};
}

}  // namespace

double otsuThreshold(const Grid<float>& image, int bins) {
  const auto [lo, hi] = valueRange(image);
  if (!(hi > lo)) return lo;
  std::vector<double> h(static_cast<std::size_t>(bins), 0.0);
  const double scale = bins / (static_cast<double>(hi) - lo);
  for (float v : image.values()) {
    const auto b = std::min<std::size_t>(static_cast<std::size_t>((v - lo) * scale),
                                         static_cast<std::size_t>(bins - 1));
    h[b] += 1.0;
  }
  const double total = static_cast<double>(image.size());
  double sumAll = 0.0;
  for (int b = 0; b < bins; ++b) sumAll += b * h[static_cast<std::size_t>(b)];
  // Maximise the between-class variance w0 w1 (mu0 - mu1)^2 over the cut after bin b.
  double w0 = 0.0, sum0 = 0.0, best = -1.0;
  int bestBin = 0;
  for (int b = 0; b < bins - 1; ++b) {
    w0 += h[static_cast<std::size_t>(b)];
    sum0 += b * h[static_cast<std::size_t>(b)];
    const double w1 = total - w0;
    if (w0 <= 0.0 || w1 <= 0.0) continue;
    const double d = sum0 / w0 - (sumAll - sum0) / w1;
    const double between = w0 * w1 * d * d;
    if (between > best) {
      best = between;
      bestBin = b;
    }
  }
  // The cut lies at the upper edge of the last bin of the dark class.
  return lo + (bestBin + 1) / scale;
}

double kmeansThreshold(const Grid<float>& image) {
  const auto [lo, hi] = valueRange(image);
  double t = 0.5 * (static_cast<double>(lo) + hi);
  for (int it = 0; it < 100; ++it) {
    double s0 = 0, s1 = 0;
    std::size_t n0 = 0, n1 = 0;
    for (float v : image.values()) {
      if (v <= t) {
        s0 += v;
        ++n0;
      } else {
        s1 += v;
        ++n1;
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

Grid<std::uint8_t> applyThreshold(const Grid<float>& image, double threshold, bool voidBright) {
  Grid<std::uint8_t> ind(image.lattice(), 0);
  for (std::size_t n = 0; n < image.size(); ++n) {
    const bool above = image[n] > threshold;
    ind[n] = static_cast<std::uint8_t>(above == voidBright ? 1 : 0);
  }
  return ind;
}

std::size_t removeSmallComponents(Grid<std::uint8_t>& ind, std::uint8_t phase,
                                  std::size_t maxVoxels) {
  if (maxVoxels == 0) return 0;
  const Lattice& l = ind.lattice();
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  std::vector<std::uint8_t> seen(ind.size(), 0);
  std::vector<std::size_t> stack, members;
  std::size_t flipped = 0;
  for (std::size_t start = 0; start < ind.size(); ++start) {
    if (seen[start] || ind[start] != phase) continue;
    // Flood fill (face neighbours); members are kept only while the component is small.
    stack.assign(1, start);
    seen[start] = 1;
    members.clear();
    std::size_t size = 0;
    bool border = false;
    while (!stack.empty()) {
      const std::size_t off = stack.back();
      stack.pop_back();
      ++size;
      if (size <= maxVoxels) members.push_back(off);
      const Index3 p = l.indexOf(off);
      if (p.k == 0 || p.j == 0 || p.i == 0 || p.k == nz - 1 || p.j == ny - 1 || p.i == nx - 1)
        border = true;
      const std::int64_t nb[6][3] = {{-1, 0, 0}, {1, 0, 0},  {0, -1, 0},
                                     {0, 1, 0},  {0, 0, -1}, {0, 0, 1}};
      for (const auto& d : nb) {
        const std::int64_t k = p.k + d[0], j = p.j + d[1], i = p.i + d[2];
        if (!l.contains(k, j, i)) continue;
        const std::size_t o = l.offset(k, j, i);
        if (!seen[o] && ind[o] == phase) {
          seen[o] = 1;
          stack.push_back(o);
        }
      }
    }
    if (size <= maxVoxels && !border) {
      for (std::size_t o : members) ind[o] = static_cast<std::uint8_t>(1 - phase);
      ++flipped;
    }
  }
  return flipped;
}

}  // namespace voxpack::ingest
