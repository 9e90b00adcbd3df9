// Column (container) fit from the segmented volume; derivation in docs/ingest.md.
#include "voxpack/ingest/column.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "voxpack/core/errors.hpp"

namespace voxpack::ingest {
namespace {

// 4-connected flood fill over pixels where allowed != 0, seeded from every border pixel.
std::vector<std::uint8_t> reachFromBorder(const std::vector<std::uint8_t>& allowed, std::int64_t ny,
                                          std::int64_t nx) {
  std::vector<std::uint8_t> reached(allowed.size(), 0);
  std::vector<std::int64_t> stack;
  auto push = [&](std::int64_t j, std::int64_t i) {
    const auto o = static_cast<std::size_t>(j * nx + i);
    if (allowed[o] && !reached[o]) {
      reached[o] = 1;
      stack.push_back(static_cast<std::int64_t>(o));
    }
  };
  for (std::int64_t i = 0; i < nx; ++i) {
    push(0, i);
    push(ny - 1, i);
  }
  for (std::int64_t j = 0; j < ny; ++j) {
    push(j, 0);
    push(j, nx - 1);
  }
  while (!stack.empty()) {
    const std::int64_t o = stack.back();
    stack.pop_back();
    const std::int64_t j = o / nx, i = o % nx;
    if (j > 0) push(j - 1, i);
    if (j < ny - 1) push(j + 1, i);
    if (i > 0) push(j, i - 1);
    if (i < nx - 1) push(j, i + 1);
  }
  return reached;
}

// Largest 4-connected component of `in` (1 = member), as a mask.
std::vector<std::uint8_t> largestComponent(const std::vector<std::uint8_t>& in, std::int64_t ny,
                                           std::int64_t nx) {
  std::vector<std::int32_t> label(in.size(), 0);
  std::vector<std::size_t> sizes{0};
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
  std::vector<std::uint8_t> out(in.size(), 0);
  if (sizes.size() == 1) return out;
  const auto best =
      static_cast<std::int32_t>(std::max_element(sizes.begin() + 1, sizes.end()) - sizes.begin());
  for (std::size_t s = 0; s < in.size(); ++s) out[s] = label[s] == best;
  return out;
}

struct SlabFit {
  double zMm, xMm, yMm, radiusMm;
};

}  // namespace

ColumnFit fitColumn(const Grid<std::uint8_t>& ind, const ColumnFitOptions& o) {
  if (o.slabSlices < 4) throw InputError("column fit: slab must hold >= 4 slices");
  if (!(o.solidFraction > 0.5 && o.solidFraction <= 1.0))
    throw InputError("column fit: solid fraction must be in (0.5, 1]");
  const Lattice& l = ind.lattice();
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  ColumnFit fit;
  fit.zRefMm = l.originMm[0] + 0.5 * static_cast<double>(nz - 1) * l.spacingMm[0];
  const std::int64_t slabs = std::max<std::int64_t>(1, nz / o.slabSlices);
  const auto plane = static_cast<std::size_t>(ny * nx);
  std::vector<SlabFit> fits;
  for (std::int64_t s = 0; s < slabs; ++s) {
    const std::int64_t z0 = s * nz / slabs, z1 = (s + 1) * nz / slabs;
    std::vector<std::int32_t> solidCount(plane, 0);
    for (std::int64_t k = z0; k < z1; ++k) {
      const std::uint8_t* sl = ind.data() + l.offset(k, 0, 0);
      for (std::size_t p = 0; p < plane; ++p) solidCount[p] += sl[p] == 0;
    }
    // "Always solid" pixels are the wall (and, in MRI, the signal-free outside); the
    // column is what they enclose: pixels not reachable from the border without crossing
    // them, holes (pellets solid through the whole slab) filled afterwards.
    const double need = o.solidFraction * static_cast<double>(z1 - z0);
    std::vector<std::uint8_t> open(plane);
    for (std::size_t p = 0; p < plane; ++p) open[p] = solidCount[p] < need;
    const auto outside = reachFromBorder(open, ny, nx);
    std::vector<std::uint8_t> inside(plane);
    for (std::size_t p = 0; p < plane; ++p) inside[p] = open[p] && !outside[p];
    inside = largestComponent(inside, ny, nx);
    std::vector<std::uint8_t> notInside(plane);
    for (std::size_t p = 0; p < plane; ++p) notInside[p] = !inside[p];
    const auto beyond = reachFromBorder(notInside, ny, nx);
    double area = 0, sx = 0, sy = 0;
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        const auto p = static_cast<std::size_t>(j * nx + i);
        if (beyond[p]) continue;
        area += 1;
        sx += static_cast<double>(i);
        sy += static_cast<double>(j);
      }
    // A column must be a sizeable part of the slice; small enclosed pockets are pores.
    if (area < 0.05 * static_cast<double>(plane) || area < 16) continue;
    SlabFit f;
    f.zMm = l.originMm[0] + 0.5 * static_cast<double>(z0 + z1 - 1) * l.spacingMm[0];
    f.xMm = l.originMm[2] + sx / area * l.spacingMm[2];
    f.yMm = l.originMm[1] + sy / area * l.spacingMm[1];
    f.radiusMm = std::sqrt(area * l.spacingMm[1] * l.spacingMm[2] / std::numbers::pi);
    fits.push_back(f);
  }
  fit.slabs = static_cast<int>(fits.size());
  if (fits.empty()) {
    fit.note = "no enclosed column seen (no always-solid wall around the bed)";
    return fit;
  }
  fit.found = true;
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
  fit.note = "fitted over " + std::to_string(m) + " slab(s)";
  return fit;
}

Grid<std::uint8_t> columnMask(const Lattice& l, const ColumnFit& c) {
  Grid<std::uint8_t> mask(l, 0);
  const double r2 = c.radiusMm * c.radiusMm;
  for (std::int64_t k = 0; k < l.nz(); ++k) {
    const double z = l.originMm[0] + static_cast<double>(k) * l.spacingMm[0];
    const double ax = c.axisXMm + c.slopeX * (z - c.zRefMm);
    const double ay = c.axisYMm + c.slopeY * (z - c.zRefMm);
    for (std::int64_t j = 0; j < l.ny(); ++j) {
      const double dy = l.originMm[1] + static_cast<double>(j) * l.spacingMm[1] - ay;
      for (std::int64_t i = 0; i < l.nx(); ++i) {
        const double dx = l.originMm[2] + static_cast<double>(i) * l.spacingMm[2] - ax;
        mask(k, j, i) = dx * dx + dy * dy < r2;
      }
    }
  }
  return mask;
}

}  // namespace voxpack::ingest
