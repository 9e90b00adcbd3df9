// Sub-voxel column refinement from the grey-level step at the wall (edge-spread fit);
// derivation in docs/ingest.md ("Column fit").
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include "column_detail.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/ingest/column.hpp"

namespace voxpack::ingest {
namespace {

constexpr double kBin = 0.1;  // radial bin, voxels
// Thinnest wall the fit may use, voxels: a thinner "wall" term would fit the void-rich
// ring just inside the wall instead of the wall.
constexpr double kMinWall = 2.5;

double cdf(double x) { return 0.5 * std::erfc(-x / std::numbers::sqrt2); }
double pdf(double x) { return std::exp(-0.5 * x * x) / std::sqrt(2.0 * std::numbers::pi); }

// Radial profile: per bin of u = r - R0 (voxels), the sum of values and the count.
struct Profile {
  double u0 = 0;
  std::vector<double> sum, count;
  double sc = 0, ss = 0;  // sum of cos / sin of the sample angles (sector direction)
  void init(double from, double to) {
    u0 = from;
    const auto n = static_cast<std::size_t>(std::ceil((to - from) / kBin));
    sum.assign(n, 0.0);
    count.assign(n, 0.0);
  }
  void add(const Profile& o) {
    for (std::size_t b = 0; b < sum.size(); ++b) {
      sum[b] += o.sum[b];
      count[b] += o.count[b];
    }
  }
  double samples() const {
    double c = 0;
    for (double x : count) c += x;
    return c;
  }
};

struct Edge {
  double r = 0, sigma = 1, wall = 4;  // step position (voxels from R0), blur, wall thickness
  double coef[4] = {0, 0, 0, 0};      // inside level, inside slope, wall level, outside level
  double sse = 1e300, weight = 0;
};

// The profile of a blurred cylinder wall: bed (level + slope towards the axis) up to r,
// wall from r to r + T, outside beyond, all convolved with a Gaussian of sigma (the
// slope term integrates in closed form). Linear in the four levels: solved exactly for
// each (r, sigma, T).
//
// Squared mode (MRI magnitude, `squared`): the profile holds M^2, whose mean is A^2 + 2
// sigma^2 for Rician noise on a signal A, so no convex noise floor bends the step. With a
// signal-free wall and outside, A = A_bed(u) w(u), w the blurred inside indicator, and the
// bin mean is A_bed^2 w^2 + const: basis w^2, (u - r) w^2 (the bed's slope), a constant
// and an outside term.
void basis(double u, double r, double s, double t, double b[4], bool squared) {
  const double in = cdf((r - u) / s);
  if (squared) {
    b[0] = in * in;
    b[1] = (u - r) * in * in;
    b[2] = 1.0;
    b[3] = cdf((u - r - t) / s);
    return;
  }
  b[0] = in;
  b[1] = (u - r) * in - s * pdf((u - r) / s);
  b[2] = cdf((u - r) / s) - cdf((u - r - t) / s);
  b[3] = cdf((u - r - t) / s);
}

double solveLevels(const Profile& p, double r, double s, double t, double coef[4], bool sq) {
  double m[4][5] = {};
  for (std::size_t k = 0; k < p.sum.size(); ++k) {
    const double w = p.count[k];
    if (w <= 0) continue;
    const double y = p.sum[k] / w, u = p.u0 + (static_cast<double>(k) + 0.5) * kBin;
    double b[4];
    basis(u, r, s, t, b, sq);
    for (int a = 0; a < 4; ++a) {
      m[a][4] += w * b[a] * y;
      for (int c = 0; c < 4; ++c) m[a][c] += w * b[a] * b[c];
    }
  }
  // A light ridge: the wall and outside levels are one and the same in MRI.
  const double ridge = 1e-9 * (m[0][0] + m[1][1] + m[2][2] + m[3][3]) + 1e-300;
  for (int a = 0; a < 4; ++a) m[a][a] += ridge;
  for (int c = 0; c < 4; ++c) {
    int piv = c;
    for (int a = c + 1; a < 4; ++a)
      if (std::abs(m[a][c]) > std::abs(m[piv][c])) piv = a;
    for (int q = 0; q < 5; ++q) std::swap(m[c][q], m[piv][q]);
    if (!(std::abs(m[c][c]) > 0)) return 1e300;
    for (int a = 0; a < 4; ++a) {
      if (a == c) continue;
      const double f = m[a][c] / m[c][c];
      for (int q = c; q < 5; ++q) m[a][q] -= f * m[c][q];
    }
  }
  for (int a = 0; a < 4; ++a) coef[a] = m[a][4] / m[a][a];
  double sse = 0;
  for (std::size_t k = 0; k < p.sum.size(); ++k) {
    const double w = p.count[k];
    if (w <= 0) continue;
    const double y = p.sum[k] / w, u = p.u0 + (static_cast<double>(k) + 0.5) * kBin;
    double b[4];
    basis(u, r, s, t, b, sq);
    double f = 0;
    for (int a = 0; a < 4; ++a) f += coef[a] * b[a];
    sse += w * (y - f) * (y - f);
  }
  return sse;
}

// Grid search, then a finer grid around the best point. sigma / T held when fixed;
// knownWall > 0 holds T alone (a wall thickness the user knows, in voxels).
Edge fitEdge(const Profile& p, double rLo, double rHi, const Edge* fixedShape, bool sq,
             double knownWall = 0) {
  Edge best;
  auto tryPoint = [&](double r, double s, double t) {
    double coef[4];
    const double sse = solveLevels(p, r, s, t, coef, sq);
    if (sse < best.sse) {
      best.sse = sse;
      best.r = r;
      best.sigma = s;
      best.wall = t;
      std::copy(coef, coef + 4, best.coef);
    }
  };
  std::vector<double> sg, tg;
  if (fixedShape) {
    sg = {fixedShape->sigma};
    tg = {fixedShape->wall};
  } else {
    for (double s = 0.05; s <= 3.0001; s += 0.1) sg.push_back(s);
    if (knownWall > 0)
      tg = {knownWall};
    else
      for (double t = kMinWall; t <= 10.0001; t += 0.75) tg.push_back(t);
  }
  const bool holdWall = fixedShape || knownWall > 0;
  for (double r = rLo; r <= rHi + 1e-9; r += 0.1)
    for (double s : sg)
      for (double t : tg) tryPoint(r, s, t);
  for (int pass = 0; pass < 2; ++pass) {
    const double dr = pass == 0 ? 0.02 : 0.004, ds = pass == 0 ? 0.025 : 0.005,
                 dt = pass == 0 ? 0.15 : 0.03;
    const Edge c = best;
    for (int a = -5; a <= 5; ++a)
      for (int b = fixedShape ? 0 : -4; b <= (fixedShape ? 0 : 4); ++b)
        for (int q = holdWall ? 0 : -5; q <= (holdWall ? 0 : 5); ++q) {
          const double s = c.sigma + b * ds, t = c.wall + q * dt;
          if (s < 0.02 || (!holdWall && t < kMinWall)) continue;
          tryPoint(c.r + a * dr, s, t);
        }
  }
  best.weight = p.samples();
  return best;
}

struct Circle {
  double cx = 0, cy = 0, r = 0;
  bool ok = false;
};

// Least-squares circle (Kasa) through sector edge points, dropping points beyond
// 3 x 1.4826 MAD (at least 0.3 voxel) in up to four rounds.
Circle fitCircle(const std::vector<std::array<double, 2>>& pts) {
  std::vector<std::uint8_t> keep(pts.size(), 1);
  Circle c;
  for (int round = 0; round < 4; ++round) {
    double s[3][4] = {};
    int n = 0;
    for (std::size_t k = 0; k < pts.size(); ++k) {
      if (!keep[k]) continue;
      const double x = pts[k][0], y = pts[k][1], row[3] = {x, y, 1.0}, z = -(x * x + y * y);
      for (int a = 0; a < 3; ++a) {
        s[a][3] += row[a] * z;
        for (int b = 0; b < 3; ++b) s[a][b] += row[a] * row[b];
      }
      ++n;
    }
    if (n < 5) return Circle{};
    for (int col = 0; col < 3; ++col) {
      int piv = col;
      for (int a = col + 1; a < 3; ++a)
        if (std::abs(s[a][col]) > std::abs(s[piv][col])) piv = a;
      for (int q = 0; q < 4; ++q) std::swap(s[col][q], s[piv][q]);
      if (!(std::abs(s[col][col]) > 1e-300)) return Circle{};
      for (int a = 0; a < 3; ++a) {
        if (a == col) continue;
        const double f = s[a][col] / s[col][col];
        for (int q = col; q < 4; ++q) s[a][q] -= f * s[col][q];
      }
    }
    const double d = s[0][3] / s[0][0], e = s[1][3] / s[1][1], f = s[2][3] / s[2][2];
    c.cx = -0.5 * d;
    c.cy = -0.5 * e;
    const double r2 = c.cx * c.cx + c.cy * c.cy - f;
    if (!(r2 > 0)) return Circle{};
    c.r = std::sqrt(r2);
    c.ok = true;
    std::vector<double> res;
    for (std::size_t k = 0; k < pts.size(); ++k)
      if (keep[k]) res.push_back(std::abs(std::hypot(pts[k][0] - c.cx, pts[k][1] - c.cy) - c.r));
    std::nth_element(res.begin(), res.begin() + static_cast<std::ptrdiff_t>(res.size() / 2),
                     res.end());
    const double cut = std::max(0.3, 3.0 * 1.4826 * res[res.size() / 2]);
    bool changed = false;
    for (std::size_t k = 0; k < pts.size(); ++k) {
      const bool kp = std::abs(std::hypot(pts[k][0] - c.cx, pts[k][1] - c.cy) - c.r) <= cut;
      changed |= kp != static_cast<bool>(keep[k]);
      keep[k] = kp;
    }
    if (!changed) break;
  }
  return c;
}

}  // namespace

namespace column_detail {

constexpr double kOuterW = 8.0;  // the profile reaches this far beyond the wall, voxels

WallProfiles::WallProfiles(const Lattice& l, const ColumnFit& fit, double innerW,
                           const ColumnRefineOptions& o)
    : l_(l), fit_(fit), o_(o), innerW_(innerW) {
  r0_ = fit.radiusMm / l.spacingMm[2];
  slabs_ = columnSlabs(l.nz(), o.slabSlices);
  bins_ = static_cast<std::size_t>(std::ceil((kOuterW + innerW) / kBin));
  stride_ = 2 * bins_ + 2;
  data_.assign(static_cast<std::size_t>(slabs_ * o.sectors) * stride_, 0.0);
}

bool WallProfiles::usable(const Lattice& l, const ColumnFit& fit, double innerW) {
  return fit.radiusMm / l.spacingMm[2] >= innerW + 2;
}

void WallProfiles::addPlane(const float* row0, std::int64_t k) {
  const std::int64_t nz = l_.nz(), ny = l_.ny(), nx = l_.nx();
  const double sx = l_.spacingMm[2], sy = l_.spacingMm[1];
  // Slab of plane k: the s with s nz / slabs <= k < (s + 1) nz / slabs.
  std::int64_t s = std::min(slabs_ - 1, (k * slabs_) / nz);
  while (s > 0 && k < s * nz / slabs_) --s;
  while (s + 1 < slabs_ && k >= (s + 1) * nz / slabs_) ++s;
  const double z = l_.originMm[0] + static_cast<double>(k) * l_.spacingMm[0];
  const double ax = (fit_.axisXMm + fit_.slopeX * (z - fit_.zRefMm) - l_.originMm[2]) / sx;
  const double ay = (fit_.axisYMm + fit_.slopeY * (z - fit_.zRefMm) - l_.originMm[1]) / sy;
  const double rOut = r0_ + kOuterW, rIn = r0_ - innerW_;
  const auto j0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor(ay - rOut)));
  const auto j1 = std::min(ny - 1, static_cast<std::int64_t>(std::ceil(ay + rOut)));
  for (std::int64_t j = j0; j <= j1; ++j) {
    const double dy = static_cast<double>(j) - ay;
    const float* row = row0 + j * nx;
    for (std::int64_t i = 0; i < nx; ++i) {
      const double dx = static_cast<double>(i) - ax;
      const double r2 = dx * dx + dy * dy;
      if (r2 < rIn * rIn || r2 >= rOut * rOut) continue;
      const double r = std::sqrt(r2), u = r - r0_;
      const auto b = static_cast<std::size_t>((u + innerW_) / kBin);
      double th = std::atan2(dy, dx) / (2.0 * std::numbers::pi);
      if (th < 0) th += 1.0;
      const auto q =
          std::min<std::int64_t>(o_.sectors - 1, static_cast<std::int64_t>(th * o_.sectors));
      if (b >= bins_) continue;
      double* p = data_.data() + static_cast<std::size_t>(s * o_.sectors + q) * stride_;
      p[b] += o_.squared ? static_cast<double>(row[i]) * row[i] : row[i];
      p[bins_ + b] += 1;
      p[2 * bins_] += dx / r;
      p[2 * bins_ + 1] += dy / r;
    }
  }
}

ColumnFit WallProfiles::fit(const ColumnFit& rough, double& innerW, bool& done) const {
  done = true;
  const std::int64_t nz = l_.nz(), ny = l_.ny(), nx = l_.nx();
  const double sx = l_.spacingMm[2], sy = l_.spacingMm[1];
  const double r0 = r0_;
  const std::int64_t slabs = slabs_;
  ColumnFit fit = fit_;
  std::vector<Profile> prof(static_cast<std::size_t>(slabs * o_.sectors));
  for (std::size_t n = 0; n < prof.size(); ++n) {
    Profile& p = prof[n];
    p.init(-innerW_, kOuterW);
    const double* d = data_.data() + n * stride_;
    std::copy(d, d + bins_, p.sum.begin());
    std::copy(d + bins_, d + 2 * bins_, p.count.begin());
    p.sc = d[2 * bins_];
    p.ss = d[2 * bins_ + 1];
  }
  Profile all;
  all.init(-innerW_, kOuterW);
  for (const auto& p : prof) all.add(p);
  // A signal-free (squared, MRI) wall reads as the outside: its thickness is not in the
  // profile, and holding it there only lends the outside term to the step (measured:
  // +0.065 density at 10 voxels per d), so a known thickness serves the grey fit alone.
  Edge global =
      fitEdge(all, -2.0, 2.0, nullptr, o_.squared, o_.squared ? 0.0 : o_.wallThicknessMm / sx);
  // A grey wall fitted at the floor may be thinner than the fit resolves: its blurred
  // bump fixes r + T/2, and the floor then puts the step up to kMinWall / 2 voxels too far
  // in (-0.66 voxel at 10 voxels per d on a 1.33-voxel wall). The wall held at half the
  // floor is taken instead when it fits the profile better; held there the radius is off
  // by at most kMinWall / 4 = 0.625 voxel (docs/ingest.md, "An unresolved wall"). A known
  // thickness (--column-wall-mm) removes the question.
  bool unresolved = false;
  if (!o_.squared && !(o_.wallThicknessMm > 0.0) && global.wall <= kMinWall + 1e-6) {
    const Edge thin = fitEdge(all, -2.0, 2.0, nullptr, false, 0.5 * kMinWall);
    if (thin.sse < global.sse) {
      global = thin;
      unresolved = true;
    }
  }
  // The step must stand out of the noise: bed-side level against the wall level.
  const double resid = std::sqrt(global.sse / std::max(1.0, global.weight));
  const double amplitude =
      o_.squared ? std::abs(global.coef[0]) : std::abs(global.coef[0] - global.coef[2]);
  if (!(global.weight > 0) || !(amplitude > 0.5 * resid) || global.sigma > 2.95) {
    ColumnFit r = rough;
    r.note += "; no clear grey step at the wall, circle fit kept";
    return r;
  }
  // Per slab: an edge per sector (R alone, shape held), a circle through them.
  std::vector<double> zs, xs, ys, rs;
  int sectorsUsed = 0;
  for (std::int64_t s = 0; s < slabs; ++s) {
    double maxCount = 0;
    for (int q = 0; q < o_.sectors; ++q)
      maxCount = std::max(maxCount, prof[static_cast<std::size_t>(s * o_.sectors + q)].samples());
    const std::int64_t z0 = s * nz / slabs, z1 = (s + 1) * nz / slabs;
    const double zMid = l_.originMm[0] + 0.5 * static_cast<double>(z0 + z1 - 1) * l_.spacingMm[0];
    const double ax = (fit.axisXMm + fit.slopeX * (zMid - fit.zRefMm) - l_.originMm[2]) / sx;
    const double ay = (fit.axisYMm + fit.slopeY * (zMid - fit.zRefMm) - l_.originMm[1]) / sy;
    std::vector<std::array<double, 2>> pts;
    std::vector<double> edgeR;
    for (int q = 0; q < o_.sectors; ++q) {
      const Profile& p = prof[static_cast<std::size_t>(s * o_.sectors + q)];
      // Sectors cut by the field of view hold fewer samples: skip them.
      if (!(p.samples() >= 0.7 * maxCount) || maxCount <= 0) continue;
      const Edge e = fitEdge(p, -2.0, 2.0, &global, o_.squared);
      if (e.r <= -1.99 || e.r >= 1.99) continue;
      const double norm = std::hypot(p.sc, p.ss);
      if (!(norm > 0)) continue;
      pts.push_back({ax + (r0 + e.r) * p.sc / norm, ay + (r0 + e.r) * p.ss / norm});
      edgeR.push_back(r0 + e.r);
      ++sectorsUsed;
    }
    if (pts.size() < 3) continue;
    const Circle c = pts.size() >= 6 ? fitCircle(pts) : Circle{};
    zs.push_back(zMid);
    if (c.ok && std::abs(c.r - r0) < 2.5) {
      xs.push_back(l_.originMm[2] + c.cx * sx);
      ys.push_back(l_.originMm[1] + c.cy * sy);
      rs.push_back(c.r * sx);
    } else {
      double m = 0;
      for (double r : edgeR) m += r / static_cast<double>(edgeR.size());
      xs.push_back(l_.originMm[2] + ax * sx);
      ys.push_back(l_.originMm[1] + ay * sy);
      rs.push_back(m * sx);
    }
  }
  if (rs.empty()) return rough;
  {
    double mean = 0;
    for (double r : rs) mean += r / static_cast<double>(rs.size());
    if (std::abs(mean - rough.radiusMm) > 1.5 * sx) {
      ColumnFit r = rough;
      r.note += "; grey-step fit disagreed with the circle fit by > 1.5 voxels, circle kept";
      return r;
    }
  }
  const std::size_t m = rs.size();
  double sw = 0, sz = 0, szz = 0, sxv = 0, syv = 0, szx = 0, szy = 0;
  for (std::size_t k = 0; k < m; ++k) {
    const double z = zs[k] - fit.zRefMm;
    sw += 1;
    sz += z;
    szz += z * z;
    sxv += xs[k];
    syv += ys[k];
    szx += z * xs[k];
    szy += z * ys[k];
  }
  const double det = sw * szz - sz * sz;
  fit.slopeX = fit.slopeY = 0;
  if (m >= 2 && det > 1e-12) {
    fit.slopeX = (sw * szx - sz * sxv) / det;
    fit.slopeY = (sw * szy - sz * syv) / det;
  }
  fit.axisXMm = (sxv - fit.slopeX * sz) / sw;
  fit.axisYMm = (syv - fit.slopeY * sz) / sw;
  std::vector<double> sorted = rs;
  std::sort(sorted.begin(), sorted.end());
  double mean = 0;
  for (double r : rs) mean += r / static_cast<double>(m);
  fit.radiusMm = mean;
  fit.radiusSpreadMm = sorted.back() - sorted.front();
  double var = 0;
  for (double r : rs) var += (r - mean) * (r - mean);
  fit.radiusStdMm = m >= 2 ? std::sqrt(var / static_cast<double>(m - 1) / static_cast<double>(m))
                           : 0.05 * sx;  // one slab: no scatter to read; a twentieth of a voxel
  fit.slabs = static_cast<int>(m);
  fit.sectors = sectorsUsed;
  fit.blurMm = global.sigma * sx;
  fit.wallThicknessMm = global.wall * sx;
  fit.wallResolved = !unresolved;
  // The squared fit's levels are in M^2 (the MRI wall carries no signal): not kept.
  fit.wallLevel = o_.squared ? 0.0 : global.coef[2];
  fit.outsideLevel = o_.squared ? 0.0 : global.coef[3];
  fit.refined = true;
  innerW = std::clamp(2.5 * global.sigma + 2.0, 3.0, 6.0);
  const double rv = fit.radiusMm / sx;
  const double cx = (fit.axisXMm - l_.originMm[2]) / sx, cy = (fit.axisYMm - l_.originMm[1]) / sy;
  fit.touchesBorder = cx - rv < -0.5 || cy - rv < -0.5 || cx + rv > static_cast<double>(nx) - 0.5 ||
                      cy + rv > static_cast<double>(ny) - 0.5;
  fit.note = "wall step fitted over " + std::to_string(fit.slabs) + " slab(s), " +
             std::to_string(fit.sectors) + " sector edges" +
             (fit.refined && !fit.wallResolved
                  ? ", wall thinner than 2.5 voxels (not resolved): held at 1.25, radius +-0.6 "
                    "voxel; pass --column-wall-mm"
                  : "") +
             (fit.touchesBorder ? ", column cut by the field of view" : "");
  done = false;
  return fit;
}

void checkRefineOptions(const ColumnRefineOptions& o) {
  if (o.slabSlices < 4 || o.sectors < 6 || o.iterations < 1)
    throw InputError("column refinement: slab >= 4 slices, >= 6 sectors, >= 1 iteration");
}

}  // namespace column_detail

ColumnFit refineColumn(const Grid<float>& image, const ColumnFit& rough,
                       const ColumnRefineOptions& o) {
  const Lattice& l = image.lattice();
  return column_detail::refineIterations(l, rough, o, [&](column_detail::WallProfiles& prof) {
    for (std::int64_t k = 0; k < l.nz(); ++k) prof.addPlane(image.data() + l.offset(k, 0, 0), k);
  });
}

}  // namespace voxpack::ingest
