// Chord-length distributions from exact run-length counts (docs/stats.md, docs/scale.md).
// Counting runs rather than listing chords keeps the memory at a few words per column, so
// the same code serves the whole bed, a z-slab stream and MPI ranks, with identical counts.
#include <algorithm>
#include <cmath>

#include "voxpack/stats/structure.hpp"

namespace voxpack::stats {
namespace {

constexpr std::uint64_t kAtWindow = std::uint64_t{1} << 63;  // carry: the run starts at z = 0

bool isVoid(const std::uint8_t* ind, const std::uint8_t* mask, std::size_t o) {
  return ind[o] != 0 && (!mask || mask[o] != 0);
}

}  // namespace

ChordRuns::ChordRuns(std::int64_t nz, std::int64_t ny, std::int64_t nx)
    : n_{nz, ny, nx},
      head_(static_cast<std::size_t>(ny * nx), 0),
      run_(head_.size(), 0),
      sawSolid_(head_.size(), 0),
      windowCut_(3, 0) {
  for (int a = 0; a < 3; ++a)
    counts_[static_cast<std::size_t>(a)].assign(static_cast<std::size_t>(n_[a] + 1), 0);
}

void ChordRuns::addPlanes(std::int64_t z0, const Grid<std::uint8_t>& indicator,
                          const Grid<std::uint8_t>* mask, std::int64_t planes) {
  const std::int64_t ny = n_[1], nx = n_[2];
  const std::size_t plane = static_cast<std::size_t>(ny * nx);
  const std::uint8_t* ind = indicator.data();
  const std::uint8_t* msk = mask ? mask->data() : nullptr;
  auto& cz = counts_[0];
  auto& cy = counts_[1];
  auto& cx = counts_[2];
  for (std::int64_t k = 0; k < planes; ++k) {
    const std::size_t base = static_cast<std::size_t>(k) * plane;
    const std::int64_t z = z0 + k;
    // Along z: the run from the first plane (head) waits for the carry of the planes
    // before; a run that starts after a non-void voxel here is whole when it ends here.
    for (std::size_t c = 0; c < plane; ++c) {
      if (isVoid(ind, msk, base + c)) {
        (sawSolid_[c] ? run_[c] : head_[c]) += 1;
      } else {
        if (sawSolid_[c] && run_[c] > 0) ++cz[run_[c]];
        sawSolid_[c] = 1;
        run_[c] = 0;
      }
    }
    // Along y and x: whole lines inside the plane, cut where they touch its edges.
    auto line = [&](std::size_t first, std::int64_t len, std::size_t step,
                    std::vector<std::uint64_t>& counts) {
      std::int64_t run = 0;
      bool cut = true;
      for (std::int64_t t = 0; t < len; ++t) {
        if (isVoid(ind, msk, first + static_cast<std::size_t>(t) * step)) {
          if (run == 0) cut = (t == 0);
          ++run;
        } else {
          if (run > 0 && !cut) ++counts[static_cast<std::size_t>(run)];
          run = 0;
        }
      }
    };
    for (std::int64_t i = 0; i < nx; ++i)
      line(base + static_cast<std::size_t>(i), ny, static_cast<std::size_t>(nx), cy);
    for (std::int64_t j = 0; j < ny; ++j) line(base + static_cast<std::size_t>(j * nx), nx, 1, cx);
    // The window cuts an axis when void touches the region's faces normal to it.
    const bool zFace = z == 0 || z == n_[0] - 1;
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        const bool yFace = j == 0 || j == ny - 1, xFace = i == 0 || i == nx - 1;
        if (!zFace && !yFace && !xFace) {
          i = nx - 2;  // jump to the far x face
          continue;
        }
        if (!isVoid(ind, msk, base + static_cast<std::size_t>(j * nx + i))) continue;
        windowCut_[0] |= zFace ? 1 : 0;
        windowCut_[1] |= yFace ? 1 : 0;
        windowCut_[2] |= xFace ? 1 : 0;
      }
  }
  planesAdded_ += planes;
}

std::vector<std::uint64_t> ChordRuns::joinCarry(const std::vector<std::uint64_t>& carry) {
  std::vector<std::uint64_t> out(head_.size());
  for (std::size_t c = 0; c < head_.size(); ++c) {
    const std::uint64_t in = carry.empty() ? kAtWindow : carry[c];
    const std::uint64_t len = in & ~kAtWindow;
    if (!sawSolid_[c]) {
      // All void here (or no planes): the run goes on into the next planes.
      out[c] = (len + static_cast<std::uint64_t>(planesAdded_)) | (in & kAtWindow);
      continue;
    }
    const std::uint64_t whole = len + head_[c];
    if (whole > 0 && !(in & kAtWindow)) ++counts_[0][static_cast<std::size_t>(whole)];
    out[c] = run_[c];
  }
  return out;
}

ChordLengths chordLengths(ChordRuns& runs, const Lattice& l, double binWidthMm) {
  const std::int64_t n[3] = {l.nz(), l.ny(), l.nx()};
  const double width =
      binWidthMm > 0 ? binWidthMm : std::min({l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]});
  ChordLengths c;
  std::vector<double> all, allWeights;
  std::vector<std::uint64_t> allCounts;
  for (int a = 0; a < 3; ++a) {
    // Along an axis the window cuts, a chord of l voxels is seen whole in n - l - 1 of the
    // line's positions: weight 1/(n - l - 1) (minus sampling), normalised to 1 at l = 0.
    const bool weighted = runs.windowCut()[static_cast<std::size_t>(a)] != 0;
    std::vector<double> values, weights;
    std::vector<std::uint64_t> counts;
    const auto& h = runs.counts()[static_cast<std::size_t>(a)];
    for (std::size_t len = 1; len < h.size(); ++len) {
      if (h[len] == 0) continue;
      values.push_back(static_cast<double>(len) * l.spacingMm[static_cast<std::size_t>(a)]);
      weights.push_back(
          weighted ? static_cast<double>(n[a] - 1) /
                         std::max(1.0, static_cast<double>(n[a]) - static_cast<double>(len) - 1)
                   : 1.0);
      counts.push_back(h[len]);
    }
    c.perAxis[static_cast<std::size_t>(a)] =
        summarizeCountedLengths(values, weights, counts, width);
    all.insert(all.end(), values.begin(), values.end());
    allWeights.insert(allWeights.end(), weights.begin(), weights.end());
    allCounts.insert(allCounts.end(), counts.begin(), counts.end());
  }
  c.all = summarizeCountedLengths(all, allWeights, allCounts, width);
  return c;
}

ChordLengths chordLengths(const Bed& bed, double binWidthMm) {
  const Lattice& l = bed.lattice();
  ChordRuns runs(l.nz(), l.ny(), l.nx());
  runs.addPlanes(0, bed.indicator, bed.mask ? &*bed.mask : nullptr, l.nz());
  runs.joinCarry({});
  return chordLengths(runs, l, binWidthMm);
}

}  // namespace voxpack::stats
