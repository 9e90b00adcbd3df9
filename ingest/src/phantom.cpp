// Synthetic MRI / XMT images of a known bed (ground truth for ingest); model in
// docs/ingest.md.
#include "voxpack/ingest/phantom.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <vector>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/ingest/resample.hpp"

namespace voxpack::ingest {
namespace {

// 1-D Gaussian blur along one axis (stride `stride`, `n` samples, `lines` lines).
void blurAxis(Grid<float>& g, int axis, double sigmaVox, int threads) {
  if (!(sigmaVox > 1e-3)) return;
  const Lattice& l = g.lattice();
  const std::int64_t n = l.dims[axis];
  if (n < 2) return;
  const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigmaVox)));
  std::vector<double> w(static_cast<std::size_t>(2 * radius + 1));
  double sum = 0;
  for (int t = -radius; t <= radius; ++t) {
    w[static_cast<std::size_t>(t + radius)] = std::exp(-0.5 * t * t / (sigmaVox * sigmaVox));
    sum += w[static_cast<std::size_t>(t + radius)];
  }
  for (double& v : w) v /= sum;
  const std::size_t stride = axis == 2   ? 1
                             : axis == 1 ? static_cast<std::size_t>(l.nx())
                                         : static_cast<std::size_t>(l.nx() * l.ny());
  const std::size_t lines = g.size() / static_cast<std::size_t>(n);
#pragma omp parallel num_threads(std::max(1, threads))
  {
    std::vector<float> line(static_cast<std::size_t>(n));
#pragma omp for schedule(static)
    for (std::int64_t li = 0; li < static_cast<std::int64_t>(lines); ++li) {
      // Line li: its start offset, enumerating the other two axes.
      std::size_t start;
      const auto u = static_cast<std::size_t>(li);
      if (axis == 2) {
        start = u * static_cast<std::size_t>(n);
      } else if (axis == 1) {
        const auto nx = static_cast<std::size_t>(l.nx());
        start = (u / nx) * nx * static_cast<std::size_t>(n) + u % nx;
      } else {
        start = u;
      }
      for (std::int64_t s = 0; s < n; ++s)
        line[static_cast<std::size_t>(s)] = g[start + static_cast<std::size_t>(s) * stride];
      for (std::int64_t s = 0; s < n; ++s) {
        double acc = 0;
        for (int t = -radius; t <= radius; ++t) {
          const std::int64_t q = std::clamp<std::int64_t>(s + t, 0, n - 1);
          acc += w[static_cast<std::size_t>(t + radius)] * line[static_cast<std::size_t>(q)];
        }
        g[start + static_cast<std::size_t>(s) * stride] = static_cast<float>(acc);
      }
    }
  }
}

}  // namespace

double maxBlurMm(const Lattice& l) {
  return kMaxBlurVoxels * std::min({l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]});
}

void requireBlurWithinLimit(double sigmaMm, const Lattice& l) {
  // The kernel spans 3 sigma each side: beyond 50 voxels the cost grows without bound
  // while the image is a flat grey long before.
  if (sigmaMm > maxBlurMm(l)) {
    std::ostringstream m;
    m << "--blur-mm " << sigmaMm << ": must be at most " << maxBlurMm(l) << " mm ("
      << kMaxBlurVoxels << " voxels of this lattice)";
    throw UsageError(m.str());
  }
}

std::uint64_t estimatePhantomPeakBytes(const Bed& bed, const PhantomOptions& o) {
  const auto n = static_cast<std::uint64_t>(bed.lattice().size());
  std::uint64_t out = n;
  if (o.voxelSizeMm > 0.0)
    out = static_cast<std::uint64_t>(resampledLattice(bed.lattice(), o.voxelSizeMm).size());
  // Image and bias field on the bed lattice, the resampled image, and the writer's
  // converted copy plus ITK's buffer (4 + 4 B per output voxel).
  return 4 * n + (o.biasFraction > 0.0 ? 4 * n : 0) + (o.voxelSizeMm > 0.0 ? 4 * out : 0) + 8 * out;
}

PhantomLevels phantomLevels(Modality m) {
  // Arbitrary units chosen to fit uint16 output. MRI: only water gives signal. XMT: air
  // (pores and outside) attenuates least, the glass wall a little less than the pellets.
  if (m == Modality::Mri) return {1000.0f, 0.0f, 0.0f, 0.0f};
  return {200.0f, 1000.0f, 900.0f, 200.0f};
}

void gaussianBlur(Grid<float>& image, double sigmaMm, int threads) {
  if (!(sigmaMm >= 0.0) || !std::isfinite(sigmaMm)) throw UsageError("--blur-mm must be >= 0");
  if (sigmaMm == 0.0) return;
  requireBlurWithinLimit(sigmaMm, image.lattice());
  for (int a = 0; a < 3; ++a) blurAxis(image, a, sigmaMm / image.lattice().spacingMm[a], threads);
}

Grid<float> makePhantom(const Bed& bed, const PhantomOptions& o, int threads, Progress& progress) {
  if (!(o.snr > 0.0) || std::isnan(o.snr)) throw UsageError("--snr must be > 0");
  if (!(o.biasFraction >= 0.0 && o.biasFraction < 1.0))
    throw UsageError("--bias must be in [0, 1) (0.2 = gain varies by +-20 %)");
  if (!(o.voxelSizeMm >= 0.0) || !std::isfinite(o.voxelSizeMm))
    throw UsageError("--voxel-size must be > 0");
  if (!(o.wallThicknessMm >= 0.0) || !std::isfinite(o.wallThicknessMm))
    throw UsageError("--wall-mm must be >= 0");
  {
    // A wall wider than the box adds nothing, and its stamp grows with its square.
    const Lattice& bl = bed.lattice();
    const double widthMm = std::max(static_cast<double>(bl.nx()) * bl.spacingMm[2],
                                    static_cast<double>(bl.ny()) * bl.spacingMm[1]);
    if (o.wallThicknessMm > widthMm) {
      std::ostringstream m;
      m << "--wall-mm " << o.wallThicknessMm << ": must be at most the box width, " << widthMm
        << " mm";
      throw UsageError(m.str());
    }
    if (o.blurMm > 0.0) requireBlurWithinLimit(o.blurMm, bl);
  }
  const Lattice& l = bed.lattice();
  const PhantomLevels lv = phantomLevels(o.modality);
  Grid<float> img(l, lv.outsideLevel);
  progress.report("phantom", 0.0);

  // Phases, and a wall ring of the given thickness just outside the mask in each slice.
  const int wallVox =
      o.wallThicknessMm > 0.0
          ? std::max(1, static_cast<int>(std::lround(o.wallThicknessMm / l.spacingMm[2])))
          : 4;
  // Per slice, the wall is stamped as a disc around every mask pixel on the mask's rim:
  // cheap, as the rim is a curve.
  std::vector<std::pair<int, int>> disc;
  for (int b = -wallVox; b <= wallVox; ++b)
    for (int a = -wallVox; a <= wallVox; ++a)
      if (a * a + b * b <= wallVox * wallVox) disc.emplace_back(b, a);
  const std::int64_t ny = l.ny(), nx = l.nx();
#pragma omp parallel num_threads(std::max(1, threads))
  {
    std::vector<std::uint8_t> wall(static_cast<std::size_t>(ny * nx));
#pragma omp for schedule(dynamic, 4)
    for (std::int64_t k = 0; k < l.nz(); ++k) {
      const std::uint8_t* ind = bed.indicator.data() + l.offset(k, 0, 0);
      float* out = img.data() + l.offset(k, 0, 0);
      if (!bed.mask) {
        for (std::int64_t p = 0; p < ny * nx; ++p) out[p] = ind[p] ? lv.voidLevel : lv.solidLevel;
        continue;
      }
      const std::uint8_t* m = bed.mask->data() + l.offset(k, 0, 0);
      std::fill(wall.begin(), wall.end(), 0);
      for (std::int64_t j = 0; j < ny; ++j)
        for (std::int64_t i = 0; i < nx; ++i) {
          if (!m[j * nx + i]) continue;
          const bool rim = (j == 0 || !m[(j - 1) * nx + i]) ||
                           (j == ny - 1 || !m[(j + 1) * nx + i]) ||
                           (i == 0 || !m[j * nx + i - 1]) || (i == nx - 1 || !m[j * nx + i + 1]);
          if (!rim) continue;
          for (const auto& [b, a] : disc) {
            const std::int64_t jj = j + b, ii = i + a;
            if (jj >= 0 && ii >= 0 && jj < ny && ii < nx)
              wall[static_cast<std::size_t>(jj * nx + ii)] = 1;
          }
        }
      for (std::int64_t p = 0; p < ny * nx; ++p)
        out[p] = m[p] ? (ind[p] ? lv.voidLevel : lv.solidLevel)
                      : (wall[static_cast<std::size_t>(p)] ? lv.wallLevel : lv.outsideLevel);
    }
  }
  progress.report("phantom", 0.2);

  gaussianBlur(img, o.blurMm, threads);
  progress.report("phantom", 0.5);

  // Smooth multiplicative bias: three random plane waves of at most one period across
  // the box, scaled so the gain spans exactly [1 - F, 1 + F].
  if (o.biasFraction > 0.0) {
    RandomStream rng(o.seed, 0);
    double kv[3][3], phase[3], amp[3];
    for (int m = 0; m < 3; ++m) {
      for (double& c : kv[m]) c = rng.uniform(-1.0, 1.0);
      phase[m] = rng.uniform(0.0, 2.0 * std::numbers::pi);
      amp[m] = rng.uniform(0.5, 1.0);
    }
    std::vector<float> field(img.size());
    double lo = 1e300, hi = -1e300;
    for (std::int64_t k = 0; k < l.nz(); ++k)
      for (std::int64_t j = 0; j < l.ny(); ++j)
        for (std::int64_t i = 0; i < l.nx(); ++i) {
          const double u[3] = {(static_cast<double>(i) + 0.5) / static_cast<double>(l.nx()),
                               (static_cast<double>(j) + 0.5) / static_cast<double>(l.ny()),
                               (static_cast<double>(k) + 0.5) / static_cast<double>(l.nz())};
          double s = 0;
          for (int m = 0; m < 3; ++m)
            s += amp[m] * std::cos(2.0 * std::numbers::pi *
                                       (kv[m][0] * u[0] + kv[m][1] * u[1] + kv[m][2] * u[2]) +
                                   phase[m]);
          field[l.offset(k, j, i)] = static_cast<float>(s);
          lo = std::min(lo, s);
          hi = std::max(hi, s);
        }
    const double mid = 0.5 * (lo + hi), half = std::max(1e-12, 0.5 * (hi - lo));
    for (std::size_t n = 0; n < img.size(); ++n)
      img[n] = static_cast<float>(img[n] * (1.0 + o.biasFraction * (field[n] - mid) / half));
  }
  progress.report("phantom", 0.6);

  if (o.voxelSizeMm > 0.0) img = resampleLinear(img, resampledLattice(l, o.voxelSizeMm), threads);
  progress.report("phantom", 0.8);

  // Noise keyed by slice, so the image does not depend on the thread count.
  const double sigma = std::abs(static_cast<double>(lv.voidLevel) - lv.solidLevel) / o.snr;
  const Lattice& ol = img.lattice();
  const bool rician = o.modality == Modality::Mri;
#pragma omp parallel for num_threads(std::max(1, threads)) schedule(static)
  for (std::int64_t k = 0; k < ol.nz(); ++k) {
    RandomStream rng(o.seed, 1 + static_cast<std::uint64_t>(k));
    float* p = img.data() + ol.offset(k, 0, 0);
    const auto count = static_cast<std::size_t>(ol.nx() * ol.ny());
    for (std::size_t n = 0; n < count; ++n) {
      const double re = p[n] + sigma * rng.normal();
      if (rician) {
        const double im = sigma * rng.normal();
        p[n] = static_cast<float>(std::sqrt(re * re + im * im));
      } else {
        p[n] = static_cast<float>(re);
      }
    }
  }
  progress.report("phantom", 1.0);
  return img;
}

}  // namespace voxpack::ingest
