// Column (container) fit from the segmented volume; derivation in docs/ingest.md.
#include "voxpack/ingest/column.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <tuple>
#include <vector>

#include "column_detail.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::ingest {
namespace {

struct Circle {
  double cx = 0, cy = 0, r = 0;
  bool ok = false;
  std::size_t used = 0;
};

// Kasa's algebraic circle fit, then rounds of dropping points whose distance to the circle
// is beyond max(1.5, 3 x 1.4826 MAD): pellets lying against the wall pull edge points
// inward, and they are a minority.
Circle robustCircle(const std::vector<std::array<double, 2>>& pts, double minDrop) {
  std::vector<std::uint8_t> keep(pts.size(), 1);
  Circle c;
  for (int round = 0; round < 5; ++round) {
    double s[3][3] = {}, t[3] = {};
    std::size_t n = 0;
    for (std::size_t p = 0; p < pts.size(); ++p) {
      if (!keep[p]) continue;
      const double x = pts[p][0], y = pts[p][1], z = -(x * x + y * y);
      const double row[3] = {x, y, 1.0};
      for (int a = 0; a < 3; ++a) {
        t[a] += row[a] * z;
        for (int b = 0; b < 3; ++b) s[a][b] += row[a] * row[b];
      }
      ++n;
    }
    if (n < 5) return Circle{};
    const double det = s[0][0] * (s[1][1] * s[2][2] - s[1][2] * s[2][1]) -
                       s[0][1] * (s[1][0] * s[2][2] - s[1][2] * s[2][0]) +
                       s[0][2] * (s[1][0] * s[2][1] - s[1][1] * s[2][0]);
    if (!(std::abs(det) > 1e-300)) return Circle{};
    double sol[3];
    for (int col = 0; col < 3; ++col) {
      double a[3][3];
      for (int r = 0; r < 3; ++r)
        for (int q = 0; q < 3; ++q) a[r][q] = q == col ? t[r] : s[r][q];
      sol[col] = (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                  a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                  a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])) /
                 det;
    }
    c.cx = -0.5 * sol[0];
    c.cy = -0.5 * sol[1];
    const double r2 = c.cx * c.cx + c.cy * c.cy - sol[2];
    if (!(r2 > 0)) return Circle{};
    c.r = std::sqrt(r2);
    c.ok = true;
    c.used = n;
    std::vector<double> res;
    for (std::size_t p = 0; p < pts.size(); ++p)
      if (keep[p]) res.push_back(std::abs(std::hypot(pts[p][0] - c.cx, pts[p][1] - c.cy) - c.r));
    std::nth_element(res.begin(), res.begin() + static_cast<std::ptrdiff_t>(res.size() / 2),
                     res.end());
    const double cut = std::max(minDrop, 3.0 * 1.4826 * res[res.size() / 2]);
    bool changed = false;
    for (std::size_t p = 0; p < pts.size(); ++p) {
      const bool k = std::abs(std::hypot(pts[p][0] - c.cx, pts[p][1] - c.cy) - c.r) <= cut;
      changed |= k != static_cast<bool>(keep[p]);
      keep[p] = k;
    }
    if (!changed) break;
  }
  return c;
}

// 4-connected components of `in`: label per pixel (0 = none), sizes indexed by label.
std::vector<std::int32_t> components(const std::vector<std::uint8_t>& in, std::int64_t ny,
                                     std::int64_t nx, std::vector<std::size_t>& sizes) {
  std::vector<std::int32_t> label(in.size(), 0);
  sizes.assign(1, 0);
  std::vector<std::int64_t> stack;
  for (std::size_t s = 0; s < in.size(); ++s) {
    if (!in[s] || label[s]) continue;
    const auto id = static_cast<std::int32_t>(sizes.size());
    sizes.push_back(0);
    label[s] = id;
    stack.assign(1, static_cast<std::int64_t>(s));
    while (!stack.empty()) {
      const std::int64_t o = stack.back();
      stack.pop_back();
      ++sizes.back();
      const std::int64_t j = o / nx, i = o % nx;
      const std::int64_t cand[4][2] = {{j - 1, i}, {j + 1, i}, {j, i - 1}, {j, i + 1}};
      for (const auto& c : cand) {
        if (c[0] < 0 || c[1] < 0 || c[0] >= ny || c[1] >= nx) continue;
        const auto q = static_cast<std::size_t>(c[0] * nx + c[1]);
        if (in[q] && !label[q]) {
          label[q] = id;
          stack.push_back(static_cast<std::int64_t>(q));
        }
      }
    }
  }
  return label;
}

}  // namespace

namespace column_detail {

void checkFitOptions(const ColumnFitOptions& o) {
  if (o.slabSlices < 4) throw InputError("column fit: slab must hold >= 4 slices");
  if (!(o.solidFraction > 0.5 && o.solidFraction <= 1.0))
    throw InputError("column fit: solid fraction must be in (0.5, 1]");
}

std::int64_t columnSlabs(std::int64_t nz, int slabSlices) {
  return std::max<std::int64_t>(1, nz / slabSlices);
}

SlabCircle fitSlabCircle(const std::vector<std::int32_t>& solidCount, const Lattice& l,
                         std::int64_t z0, std::int64_t z1, const ColumnFitOptions& o) {
  const std::int64_t ny = l.ny(), nx = l.nx();
  const auto plane = static_cast<std::size_t>(ny * nx);
  SlabCircle out;
  // "Always solid" pixels are the wall (and, in MRI, the signal-free outside). The
  // column is an open region they bound: enclosed, or cut by the image border when the
  // column fills the field of view.
  const double slices = static_cast<double>(z1 - z0);
  const double need = o.solidFraction * slices;
  std::vector<std::uint8_t> open(plane);
  for (std::size_t p = 0; p < plane; ++p) open[p] = solidCount[p] < need;
  std::vector<std::size_t> sizes;
  const auto label = components(open, ny, nx, sizes);
  // Score the candidates: the bed has pixels that are void in some slices and solid in
  // others; air around an XMT column (and a headspace) is void throughout. Then prefer
  // a region that does not touch the border, then the larger.
  std::vector<double> mixed(sizes.size(), 0.0);
  std::vector<std::uint8_t> border(sizes.size(), 0);
  for (std::int64_t j = 0; j < ny; ++j)
    for (std::int64_t i = 0; i < nx; ++i) {
      const auto p = static_cast<std::size_t>(j * nx + i);
      const auto id = static_cast<std::size_t>(label[p]);
      if (!id) continue;
      const double solidShare = solidCount[p] / slices;
      mixed[id] += solidShare > 0.1 && solidShare < 0.9;
      if (j == 0 || i == 0 || j == ny - 1 || i == nx - 1) border[id] = 1;
    }
  std::size_t best = 0;
  auto score = [&](std::size_t id) {
    return std::make_tuple(mixed[id] > 0.02 * static_cast<double>(sizes[id]) ? 1 : 0,
                           border[id] ? 0 : 1, sizes[id]);
  };
  for (std::size_t id = 1; id < sizes.size(); ++id) {
    if (sizes[id] < 16 || static_cast<double>(sizes[id]) < 0.05 * static_cast<double>(plane))
      continue;
    if (best == 0 || score(id) > score(best)) best = id;
  }
  if (best == 0) return out;
  // Edge points: midway between a column pixel and its always-solid 4-neighbour.
  std::vector<std::array<double, 2>> pts;
  for (std::int64_t j = 0; j < ny; ++j)
    for (std::int64_t i = 0; i < nx; ++i) {
      if (static_cast<std::size_t>(label[static_cast<std::size_t>(j * nx + i)]) != best) continue;
      const std::int64_t cand[4][2] = {{j - 1, i}, {j + 1, i}, {j, i - 1}, {j, i + 1}};
      for (const auto& c : cand) {
        if (c[0] < 0 || c[1] < 0 || c[0] >= ny || c[1] >= nx) continue;
        if (open[static_cast<std::size_t>(c[0] * nx + c[1])]) continue;
        pts.push_back({0.5 * static_cast<double>(i + c[1]), 0.5 * static_cast<double>(j + c[0])});
      }
    }
  if (pts.size() < 12) return out;
  const Circle c = robustCircle(pts, 1.5);
  if (!c.ok || c.r < 4.0) return out;
  // The fitted points must span a good part of the circle (not one straight wall).
  double sx = 0, sy = 0;
  std::size_t used = 0;
  for (const auto& p : pts) {
    if (std::abs(std::hypot(p[0] - c.cx, p[1] - c.cy) - c.r) > 2.0) continue;
    sx += (p[0] - c.cx) / c.r;
    sy += (p[1] - c.cy) / c.r;
    ++used;
  }
  if (used < 12 || std::hypot(sx, sy) / static_cast<double>(used) > 0.8) return out;
  // Most edge points must lie on the circle, and its inside must not be always solid (a
  // porous solid cut as a cube has always-solid blobs everywhere, a bed has none).
  if (static_cast<double>(used) < 0.5 * static_cast<double>(pts.size())) return out;
  double inside = 0, inSolid = 0;
  for (std::int64_t j = 0; j < ny; ++j)
    for (std::int64_t i = 0; i < nx; ++i) {
      const double rr = std::hypot(static_cast<double>(i) - c.cx, static_cast<double>(j) - c.cy);
      if (rr >= c.r - 2.0) continue;
      inside += 1;
      inSolid += !open[static_cast<std::size_t>(j * nx + i)];
    }
  if (inside <= 0 || inSolid > 0.1 * inside) return out;
  out.touches = c.cx - c.r < -0.5 || c.cy - c.r < -0.5 ||
                c.cx + c.r > static_cast<double>(nx) - 0.5 ||
                c.cy + c.r > static_cast<double>(ny) - 0.5;
  out.found = true;
  out.zMm = l.originMm[0] + 0.5 * static_cast<double>(z0 + z1 - 1) * l.spacingMm[0];
  out.xMm = l.originMm[2] + c.cx * l.spacingMm[2];
  out.yMm = l.originMm[1] + c.cy * l.spacingMm[1];
  out.radiusMm = c.r * std::sqrt(l.spacingMm[1] * l.spacingMm[2]);
  return out;
}

ColumnFit combineSlabCircles(const std::vector<SlabCircle>& slabs, const Lattice& l) {
  ColumnFit fit;
  fit.zRefMm = l.originMm[0] + 0.5 * static_cast<double>(l.nz() - 1) * l.spacingMm[0];
  std::vector<SlabCircle> fits;
  bool touches = false;
  for (const auto& s : slabs)
    if (s.found) {
      fits.push_back(s);
      touches |= s.touches;
    }
  fit.slabs = static_cast<int>(fits.size());
  if (fits.empty()) {
    fit.note = "no column seen (no always-solid wall bounding the bed)";
    return fit;
  }
  fit.found = true;
  fit.touchesBorder = touches;
  // Least-squares line through the slab centres: x = a + b (z - zRef).
  double sw = 0, sz = 0, szz = 0, sxv = 0, syv = 0, szx = 0, szy = 0;
  for (const auto& f : fits) {
    const double z = f.zMm - fit.zRefMm;
    sw += 1;
    sz += z;
    szz += z * z;
    sxv += f.xMm;
    syv += f.yMm;
    szx += z * f.xMm;
    szy += z * f.yMm;
  }
  const double det = sw * szz - sz * sz;
  if (fits.size() >= 2 && det > 1e-12) {
    fit.slopeX = (sw * szx - sz * sxv) / det;
    fit.slopeY = (sw * szy - sz * syv) / det;
  }
  fit.axisXMm = (sxv - fit.slopeX * sz) / sw;
  fit.axisYMm = (syv - fit.slopeY * sz) / sw;
  std::vector<double> radii;
  for (const auto& f : fits) radii.push_back(f.radiusMm);
  std::sort(radii.begin(), radii.end());
  const std::size_t m = radii.size();
  fit.radiusMm = m % 2 ? radii[m / 2] : 0.5 * (radii[m / 2 - 1] + radii[m / 2]);
  fit.radiusSpreadMm = radii.back() - radii.front();
  if (m >= 2) {
    double mean = 0, var = 0;
    for (double r : radii) mean += r / static_cast<double>(m);
    for (double r : radii) var += (r - mean) * (r - mean) / static_cast<double>(m - 1);
    fit.radiusStdMm = std::sqrt(var / static_cast<double>(m));
  }
  fit.note = "circle fit over " + std::to_string(m) + " slab(s)" +
             (touches ? ", column cut by the field of view" : "");
  return fit;
}

}  // namespace column_detail

ColumnFit fitColumn(const Grid<std::uint8_t>& ind, const ColumnFitOptions& o) {
  column_detail::checkFitOptions(o);
  const Lattice& l = ind.lattice();
  const std::int64_t nz = l.nz();
  const std::int64_t slabs = column_detail::columnSlabs(nz, o.slabSlices);
  const auto plane = static_cast<std::size_t>(l.ny() * l.nx());
  std::vector<column_detail::SlabCircle> fits;
  for (std::int64_t s = 0; s < slabs; ++s) {
    const std::int64_t z0 = s * nz / slabs, z1 = (s + 1) * nz / slabs;
    std::vector<std::int32_t> solidCount(plane, 0);
    for (std::int64_t k = z0; k < z1; ++k) {
      const std::uint8_t* sl = ind.data() + l.offset(k, 0, 0);
      for (std::size_t p = 0; p < plane; ++p) solidCount[p] += sl[p] == 0;
    }
    fits.push_back(column_detail::fitSlabCircle(solidCount, l, z0, z1, o));
  }
  return column_detail::combineSlabCircles(fits, l);
}

Grid<std::uint8_t> columnMask(const Lattice& l, const ColumnFit& c) {
  Grid<std::uint8_t> mask(l, 0);
  const double r2 = c.radiusMm * c.radiusMm;
  for (std::int64_t k = 0; k < l.nz(); ++k)
    column_detail::forEachInPlane(
        l, c, k, [&](std::int64_t j, std::int64_t i, double d2) { mask(k, j, i) = d2 < r2; });
  return mask;
}

Grid<std::uint8_t> columnCoreMask(const Lattice& l, const ColumnFit& c, double marginMm) {
  ColumnFit inner = c;
  inner.radiusMm = std::max(0.0, c.radiusMm - marginMm);
  return columnMask(l, inner);
}

}  // namespace voxpack::ingest
