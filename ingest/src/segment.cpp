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
                                  std::size_t maxVoxels, std::int64_t countZ0,
                                  std::int64_t countZ1) {
  if (maxVoxels == 0) return 0;
  const Lattice& l = ind.lattice();
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  const auto plane = static_cast<std::size_t>(ny * nx);
  // 0 unvisited, 1 settled by an earlier search (kept, or of the other phase once
  // flipped), 2 reached by the current one.
  std::vector<std::uint8_t> seen(ind.size(), 0);
  std::vector<std::size_t> stack, members;
  std::size_t flipped = 0;
  const std::int64_t nb[6][3] = {{-1, 0, 0}, {1, 0, 0},  {0, -1, 0},
                                 {0, 1, 0},  {0, 0, -1}, {0, 0, 1}};
  for (std::size_t start = 0; start < ind.size(); ++start) {
    if (seen[start] || ind[start] != phase) continue;
    // A search gives up as soon as the component is known to be kept: more than
    // maxVoxels voxels, a border voxel, or a voxel settled by an earlier search (which
    // kept its component). So it holds at most maxVoxels + 6 voxels, whatever the
    // component's size, and each voxel is reached once.
    stack.assign(1, start);
    members.assign(1, start);
    seen[start] = 2;
    bool keep = false;
    while (!stack.empty() && !keep) {
      const std::size_t off = stack.back();
      stack.pop_back();
      const Index3 p = l.indexOf(off);
      if (p.k == 0 || p.j == 0 || p.i == 0 || p.k == nz - 1 || p.j == ny - 1 || p.i == nx - 1) {
        keep = true;
        break;
      }
      for (const auto& d : nb) {
        const std::size_t o = l.offset(p.k + d[0], p.j + d[1], p.i + d[2]);
        if (ind[o] != phase || seen[o] == 2) continue;
        if (seen[o] == 1 || members.size() == maxVoxels) {
          keep = true;
          break;
        }
        seen[o] = 2;
        stack.push_back(o);
        members.push_back(o);
      }
    }
    for (std::size_t o : members) seen[o] = 1;
    if (keep) continue;
    for (std::size_t o : members) ind[o] = static_cast<std::uint8_t>(1 - phase);
    const auto k0 = static_cast<std::int64_t>(start / plane);
    if (k0 >= countZ0 && k0 < countZ1) ++flipped;
  }
  return flipped;
}

std::size_t removeSmallComponents(Grid<std::uint8_t>& ind, std::uint8_t phase,
                                  std::size_t maxVoxels) {
  return removeSmallComponents(ind, phase, maxVoxels, 0, ind.lattice().nz());
}

}  // namespace voxpack::ingest
