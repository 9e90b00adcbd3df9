// The level of one phase read deep inside it (docs/ingest.md, "The phase levels").
//
// Why a Euclidean ball: the axis test ("the phase holds along +-x, y, z") passes voxels
// beside a diagonal gap. The gaps it misses are the ones blur closes: two pellets touching
// or nearly so read as one solid in the preliminary segmentation, and the voxels of their
// neck read low. At 10 voxels per d that pulled the XMT solid level to 970 (spheres) and 936
// (cylinders) for a true 1000; the ball keeps it within 2 (measured, docs/ingest.md).
//
// Why a one-sided fit: the gaps no segmentation sees (narrower than a voxel) only ever mix
// the other phase in, so they fatten the tail towards it. The far half of the distribution
// holds pure voxels: a normal truncated at level -+ 0.5 sigma, with the phase's own sigma,
// is fitted to it (the mean of the truncated normal, solved by fixed point).
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <vector>

#include "voxpack/core/errors.hpp"
#include "voxpack/ingest/phases.hpp"

namespace voxpack::ingest {
namespace {

struct Offset {
  std::int64_t dz, dy, dx;
  int d2;  // squared length in voxels
};

// Offsets within a ball of squared radius r2 (not the centre), nearest first so that a voxel
// near the other phase is rejected after a few tests.
std::vector<Offset> ballOffsets(int r2) {
  std::vector<Offset> out;
  const int r = static_cast<int>(std::floor(std::sqrt(static_cast<double>(r2))));
  for (int z = -r; z <= r; ++z)
    for (int y = -r; y <= r; ++y)
      for (int x = -r; x <= r; ++x) {
        const int d2 = x * x + y * y + z * z;
        if (d2 == 0 || d2 > r2) continue;
        out.push_back({z, y, x, d2});
      }
  std::stable_sort(out.begin(), out.end(),
                   [](const Offset& a, const Offset& b) { return a.d2 < b.d2; });
  return out;
}

// The deep voxels of one sampled slice, as parallel arrays (5 B each, no padding): the
// reading and the squared distance of the nearest voxel of another phase (or of the box's
// edge), capped at the largest ball tested + 1; and per disjoint x pair (i even, i + 1) of
// deep voxels the difference and the smaller of the two distances.
struct SliceSamples {
  std::vector<float> value, diff;
  std::vector<std::uint8_t> clear2, pairClear2;
  std::vector<std::uint8_t> dipped;  // clear2 of the deep voxels left out on a dip
};

// The mean of a normal N(mu, s^2) truncated to x > c is mu + s lambda((c - mu) / s) with
// lambda the inverse Mills ratio; `upper` false mirrors it. Solved for mu with c = mu -+
// cut s by fixed point, from the median.
double truncatedNormalLevel(std::vector<float> v, double sigma, double cut, bool upper) {
  if (v.empty() || !(sigma > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  double mu = *mid;
  const double sgn = upper ? 1.0 : -1.0;
  // lambda(a) = phi(a) / (1 - Phi(a)) at a = -cut: fixed, since c moves with mu.
  const double a = -cut;
  const double pdf = std::exp(-0.5 * a * a) / std::sqrt(2.0 * std::numbers::pi);
  const double sf = 0.5 * std::erfc(a / std::numbers::sqrt2);
  const double lambda = pdf / sf;
  for (int it = 0; it < 100; ++it) {
    const double c = mu - sgn * cut * sigma;
    double sum = 0.0;
    std::size_t n = 0;
    for (float x : v)
      if (sgn * (x - c) > 0.0) {
        sum += x;
        ++n;
      }
    if (n == 0) break;
    const double next = sum / static_cast<double>(n) - sgn * sigma * lambda;
    const bool done = std::abs(next - mu) <= 1e-6 * sigma;
    mu = next;
    if (done) break;
  }
  return mu;
}

}  // namespace

DeepLevel phaseDeepLevel(const Grid<float>& image, const Grid<std::uint8_t>& indicator,
                         const Grid<std::uint8_t>* region, std::uint8_t phase,
                         const DeepLevelOptions& o) {
  if (indicator.size() != image.size() || (region && region->size() != image.size()))
    throw InputError("phase level: image, indicator and region differ in size");
  if (!(o.radius > 0.0) || !(o.minRadius > 0.0) || o.minRadius > o.radius || o.radius > 15.0)
    throw InputError("phase level: need 0 < min radius <= radius <= 15 voxels");
  const Lattice& l = image.lattice();
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  const int r2max = static_cast<int>(std::floor(o.radius * o.radius));
  const std::vector<Offset> ball = ballOffsets(r2max);
  const auto cap = static_cast<std::uint8_t>(r2max + 1);  // <= 226
  const std::int64_t reach = static_cast<std::int64_t>(std::floor(o.radius));

  // Slices in a fixed stride so that at most maxExamined voxels are looked at, which bounds
  // the time on a 2000^3 scan and the samples: at the peak 5 B per deep voxel and pair
  // stored and 4 B copied for the fit, with a phase's deep voxels a third or less of those
  // examined, about the 4 B per voxel that the memory estimate holds for the histogram's
  // value copy (made after this, in fitPhaseLevels).
  std::size_t perSlice = static_cast<std::size_t>(ny * nx);
  const std::size_t want = std::max<std::size_t>(o.maxExamined, perSlice);
  const std::int64_t stride = std::max<std::int64_t>(
      1, static_cast<std::int64_t>((static_cast<std::size_t>(nz) * perSlice + want - 1) / want));
  const std::int64_t slices = (nz + stride - 1) / stride;
  std::vector<SliceSamples> perK(static_cast<std::size_t>(slices));

  // Squared distance to the nearest voxel not of the phase, capped (the ball's edge).
  auto clearance = [&](std::int64_t k, std::int64_t j, std::int64_t i) -> std::uint8_t {
    for (const Offset& d : ball) {
      const std::int64_t z = k + d.dz, y = j + d.dy, x = i + d.dx;
      if (z < 0 || y < 0 || x < 0 || z >= nz || y >= ny || x >= nx)
        return static_cast<std::uint8_t>(d.d2);
      if (indicator(z, y, x) != phase) return static_cast<std::uint8_t>(d.d2);
    }
    return cap;
  };
  const int minClear2 = static_cast<int>(std::floor(o.minRadius * o.minRadius)) + 1;

  // A deep voxel on a gap the preliminary segmentation closed lies in a thin sheet that
  // reads darker (brighter, for the dark phase) than the phase around it. Its 26 neighbours
  // show it: their mean is compared with the same mean at the 8 corners of a cube of
  // half-width ceil(radius) around it that are deep themselves (off any sheet through the
  // voxel that lies along the lattice axes, as the flat faces of pellets lying flat do; a
  // bias field is smooth over the cube). A voxel whose neighbours sit more than dipSigmas
  // noise sigmas (of a 26-voxel mean) towards the other phase from the corners' mean is
  // left out. With fewer than 2 deep corners (pellets of 10 voxels or so across: the
  // corners, ceil(radius) sqrt 3 away, fall outside them) the reference is the mean of the
  // deep voxels of the whole cube instead, when there are at least 26 of them (its noise
  // is then at most the 26-voxel mean's); a sheet through the voxel is one of its 2
  // ceil(radius) + 1 layers. Else the voxel is kept. The decision reads only other voxels,
  // so it does not bias the voxel's own value.
  const bool dip = o.dipSigmas > 0.0 && o.fallbackSigma > 0.0;
  const double dipCut = o.dipSigmas * o.fallbackSigma / std::sqrt(26.0);
  const double towards = o.upper ? 1.0 : -1.0;  // +1: the other phase is darker
  const auto corner = static_cast<std::int64_t>(std::ceil(o.radius));
  const int deepClear2 = r2max + 1;  // a corner is deep in the largest ball
  auto isDeep = [&](std::int64_t z, std::int64_t y, std::int64_t x) {
    return indicator(z, y, x) == phase && clearance(z, y, x) >= deepClear2;
  };
  auto mean26 = [&](std::int64_t k, std::int64_t j, std::int64_t i) {
    double sum = 0.0;
    for (std::int64_t dz = -1; dz <= 1; ++dz)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dx = -1; dx <= 1; ++dx)
          if (dz || dy || dx) sum += image(k + dz, j + dy, i + dx);
    return sum / 26.0;
  };
  // The corners lie in slices k - corner and k + corner, and each corner serves up to four
  // voxels of slice k: their reference values (mean26 where deep, NaN where not) are kept
  // per slice as they are first asked for (kUnknown: not yet).
  constexpr double kUnknown = -std::numeric_limits<double>::infinity();
  auto cornerValue = [&](std::vector<double>& memo, std::int64_t z, std::int64_t y,
                         std::int64_t x) {
    double& v = memo[static_cast<std::size_t>(y * nx + x)];
    if (v == kUnknown)
      v = isDeep(z, y, x) ? mean26(z, y, x) : std::numeric_limits<double>::quiet_NaN();
    return v;
  };
  // Mean of the deep voxels of the cube of half-width `corner` around (k, j, i), not the
  // voxel itself; NaN with fewer than 26. `deep` holds the cube's slices k - corner ..
  // k + corner as 0 (not yet asked), 1 (not deep), 2 (deep), filled as first asked for.
  const std::int64_t cubeSlices = 2 * corner + 1;
  auto cubeMean = [&](std::vector<std::uint8_t>& deep, std::int64_t k, std::int64_t j,
                      std::int64_t i) {
    if (deep.empty()) deep.assign(static_cast<std::size_t>(cubeSlices) * perSlice, 0);
    double sum = 0.0;
    int n = 0;
    for (std::int64_t dz = -corner; dz <= corner; ++dz) {
      const std::int64_t z = k + dz;
      if (z < 0 || z >= nz) continue;
      std::uint8_t* flags = deep.data() + static_cast<std::size_t>(dz + corner) * perSlice;
      for (std::int64_t y = std::max<std::int64_t>(0, j - corner);
           y <= std::min(ny - 1, j + corner); ++y)
        for (std::int64_t x = std::max<std::int64_t>(0, i - corner);
             x <= std::min(nx - 1, i + corner); ++x) {
          if (dz == 0 && y == j && x == i) continue;
          std::uint8_t& f = flags[static_cast<std::size_t>(y * nx + x)];
          if (f == 0) f = isDeep(z, y, x) ? 2 : 1;
          if (f != 2) continue;
          sum += image(z, y, x);
          ++n;
        }
    }
    return n >= 26 ? sum / n : std::numeric_limits<double>::quiet_NaN();
  };
  // True when the voxel's neighbours dip towards the other phase (see above); memo[0] and
  // memo[1] hold the corner values of slices k - corner and k + corner, `deep` the cube's.
  auto onDip = [&](std::vector<double>(&memo)[2], std::vector<std::uint8_t>& deep, std::int64_t k,
                   std::int64_t j, std::int64_t i) {
    double ref = 0.0;
    int n = 0;
    for (int side = 0; side < 2; ++side)
      for (std::int64_t b : {-corner, corner})
        for (std::int64_t c : {-corner, corner}) {
          const std::int64_t z = k + (side ? corner : -corner), y = j + b, x = i + c;
          if (z < 0 || y < 0 || x < 0 || z >= nz || y >= ny || x >= nx) continue;
          const double v = cornerValue(memo[side], z, y, x);
          if (std::isnan(v)) continue;
          ref += v;
          ++n;
        }
    if (n >= 2) return towards * (ref / n - mean26(k, j, i)) > dipCut;
    const double cube = cubeMean(deep, k, j, i);
    return !std::isnan(cube) && towards * (cube - mean26(k, j, i)) > dipCut;
  };

#pragma omp parallel for schedule(dynamic, 1) \
    num_threads(std::max(1, o.threads)) if (o.threads > 1 && slices > 1)
  for (std::int64_t s = 0; s < slices; ++s) {
    const std::int64_t k = s * stride;
    if (k < reach || k >= nz - reach) continue;
    SliceSamples& out = perK[static_cast<std::size_t>(s)];
    std::vector<std::uint8_t> c2s(perSlice, 0);
    for (std::int64_t j = reach; j < ny - reach; ++j) {
      std::uint8_t prev = 0;  // clear2 of (k, j, i - 1) when i is odd, else 0
      for (std::int64_t i = 0; i < nx; ++i) {
        const std::size_t off = l.offset(k, j, i);
        std::uint8_t c2 = 0;
        if ((!region || (*region)[off]) && indicator[off] == phase) c2 = clearance(k, j, i);
        c2s[static_cast<std::size_t>(j * nx + i)] = c2;
        if (i % 2 == 1 && c2 >= minClear2 && prev >= minClear2) {
          out.diff.push_back(image[off] - image[off - 1]);
          out.pairClear2.push_back(std::min(prev, c2));
        }
        prev = c2;
      }
    }
    std::vector<double> memo[2];
    std::vector<std::uint8_t> deep;  // the cube's deep flags, made on first use
    if (dip)
      for (auto& m : memo) m.assign(perSlice, kUnknown);
    for (std::int64_t j = reach; j < ny - reach; ++j)
      for (std::int64_t i = reach; i < nx - reach; ++i) {
        const auto p = static_cast<std::size_t>(j * nx + i);
        if (c2s[p] < minClear2) continue;
        if (dip && onDip(memo, deep, k, j, i)) {
          out.dipped.push_back(c2s[p]);
          continue;
        }
        out.value.push_back(image(k, j, i));
        out.clear2.push_back(c2s[p]);
      }
  }

  DeepLevel r;
  r.sliceStride = static_cast<int>(stride);
  // The largest ball (radius, radius - 0.5, ... >= minRadius) that holds minVoxels.
  for (double rad = o.radius; rad >= o.minRadius - 1e-9; rad -= 0.5) {
    const int need = static_cast<int>(std::floor(rad * rad)) + 1;
    std::size_t count = 0;
    double sum = 0.0;
    for (const auto& slice : perK)
      for (std::size_t n = 0; n < slice.value.size(); ++n)
        if (slice.clear2[n] >= need) {
          ++count;
          sum += slice.value[n];
        }
    if (count < o.minVoxels) continue;
    r.voxels = count;
    for (const auto& slice : perK)
      for (std::uint8_t c : slice.dipped) r.dipExcluded += c >= need;
    r.radius = rad;
    r.mean = sum / static_cast<double>(count);
    {  // The phase's own noise: 1.4826 MAD of the pair differences about 0, / sqrt 2.
      std::vector<float> diff;
      for (const auto& slice : perK)
        for (std::size_t n = 0; n < slice.diff.size(); ++n)
          if (slice.pairClear2[n] >= need) diff.push_back(std::abs(slice.diff[n]));
      r.pairs = diff.size();
      if (diff.size() >= 100) {
        const auto mid = diff.begin() + static_cast<std::ptrdiff_t>(diff.size() / 2);
        std::nth_element(diff.begin(), mid, diff.end());
        r.sigma = 1.4826 * static_cast<double>(*mid) / std::numbers::sqrt2;
      }
    }
    if (!o.oneSided) {
      r.level = r.mean;
      return r;
    }
    std::vector<float> v;
    v.reserve(count);
    for (const auto& slice : perK)
      for (std::size_t n = 0; n < slice.value.size(); ++n)
        if (slice.clear2[n] >= need) v.push_back(slice.value[n]);
    const double sigma = r.sigma > 0.0 ? r.sigma : o.fallbackSigma;
    r.level = sigma > 0.0 ? truncatedNormalLevel(std::move(v), sigma, o.cut, o.upper) : r.mean;
    return r;
  }
  return r;
}

}  // namespace voxpack::ingest
