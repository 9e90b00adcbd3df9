// The digitiser: voxel-centre (or k^3 supersampled) inside tests of the exact shape,
// scanned row by row over the rotated shape's bounding box only.
#include "voxpack/packer/digitise.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "voxpack/core/errors.hpp"

namespace voxpack::packer {

Quat normalisedQuaternion(double w, double x, double y, double z) {
  const double n = std::sqrt(w * w + x * x + y * y + z * z);
  if (!std::isfinite(n) || n < 1e-12)
    throw InputError("orientation quaternion (" + std::to_string(w) + ", " + std::to_string(x) +
                     ", " + std::to_string(y) + ", " + std::to_string(z) +
                     ") has zero or non-finite norm");
  return Quat(w / n, x / n, y / n, z / n);
}

std::uint64_t digitiseMemoryEstimateBytes(const Shape& shape, double voxelMm) {
  if (!(voxelMm > 0) || !std::isfinite(voxelMm))
    throw InputError("digitise: voxel size must be a positive number of mm");
  const double across = 2 * shape.boundingRadiusMm() / voxelMm + 3;
  const double cells = across * across * across;
  const double voxels = 1.05 * shape.volumeMm3() / (voxelMm * voxelMm * voxelMm) + 64;
  const double faces = 1.5 * shape.surfaceMm2() / (voxelMm * voxelMm) + 64;
  // Bitmap 1 B per cell, Voxel 12 B, surface index 4 B + face bits 1 B.
  const double bytes = cells + 12 * voxels + 5 * faces;
  return bytes < 9.0e18 ? static_cast<std::uint64_t>(bytes) : std::uint64_t{9000000000000000000ULL};
}

namespace {

// Parameter range [t0, t1] of the line p0 + t * step inside the box b; false when the
// line misses it.
bool clipLine(const Vec3& p0, const Vec3& step, const BoundsMm& b, double& t0, double& t1) {
  for (int a = 0; a < 3; ++a) {
    if (std::abs(step[a]) < 1e-300) {
      if (p0[a] < b.min[a] || p0[a] > b.max[a]) return false;
      continue;
    }
    double u = (b.min[a] - p0[a]) / step[a], v = (b.max[a] - p0[a]) / step[a];
    if (u > v) std::swap(u, v);
    t0 = std::max(t0, u);
    t1 = std::min(t1, v);
  }
  return t0 <= t1;
}

// Per-thread scratch so repeated digitisations (MC/DEM rotate every step) do not allocate.
struct Scratch {
  std::vector<std::uint8_t> solid;   // padded bounding-box bitmap
  std::vector<std::uint8_t> row;     // inside flags of one sample row
  std::vector<std::uint16_t> count;  // supersample hits per voxel of one row
  std::vector<std::int32_t> rowLo;   // per (k, j) row: first voxel index that may be solid
  std::vector<std::int32_t> rowHi;   // per (k, j) row: last voxel index that may be solid
};
Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

}  // namespace

DigitalParticle digitise(const Shape& shape, const Vec3& centreMm, const Quat& q,
                         const Lattice& lattice, const DigitiseOptions& options) {
  const double qn = std::sqrt(q.w() * q.w() + q.x() * q.x() + q.y() * q.y() + q.z() * q.z());
  if (!std::isfinite(qn) || std::abs(qn - 1) > 1e-6)
    throw InputError("digitise: orientation quaternion is not a unit quaternion (norm " +
                     std::to_string(qn) + ")");
  if (options.supersample < 1 || options.supersample > 8)
    throw InputError("digitise: supersample must be in 1..8, got " +
                     std::to_string(options.supersample));
  if (!centreMm.allFinite()) throw InputError("digitise: particle centre is not finite");
  const int ss = options.supersample;
  const Eigen::Matrix3d R = Quat(q.coeffs() / qn).toRotationMatrix();
  const Eigen::Matrix3d Rt = R.transpose();
  const double sx = lattice.spacingMm[2], sy = lattice.spacingMm[1], sz = lattice.spacingMm[0];
  // Half-open rule (kBoundaryTieBreak): sampling p + delta of the shape at centreMm is
  // sampling p of the shape moved by -delta.
  const Vec3 centre = centreMm - kBoundaryTieBreak * Vec3(sx, sy, sz);

  // World bounding box of the rotated body box, intersected with the bounding sphere box.
  const BoundsMm body = shape.bodyBoundsMm();
  const Vec3 half = 0.5 * (body.max - body.min), mid = 0.5 * (body.max + body.min);
  const Vec3 ext = R.cwiseAbs() * half;
  const double rb = shape.boundingRadiusMm();
  const Vec3 wmin = (centre + R * mid - ext).cwiseMax(centre - Vec3::Constant(rb));
  const Vec3 wmax = (centre + R * mid + ext).cwiseMin(centre + Vec3::Constant(rb));
  const Vec3 cmin = lattice.continuousIndex(wmin), cmax = lattice.continuousIndex(wmax);
  // Samples sit within +-(1/2 - 1/2k) of a voxel centre; floor/ceil covers them all.
  const auto lo = [](double v) { return static_cast<std::int64_t>(std::floor(v)); };
  const auto hi = [](double v) { return static_cast<std::int64_t>(std::ceil(v)); };
  // Checked in floating point first: a tiny voxel size must not overflow the indices.
  const double cells = (std::ceil(cmax.x()) - std::floor(cmin.x()) + 1) *
                       (std::ceil(cmax.y()) - std::floor(cmin.y()) + 1) *
                       (std::ceil(cmax.z()) - std::floor(cmin.z()) + 1);
  if (!(cells <= static_cast<double>(std::int64_t{1} << 28)))
    throw InputError("digitise: the particle spans " + std::to_string(cells) +
                     " voxels, more than 2^28: voxel size too small for this shape");
  const std::int64_t i0 = lo(cmin.x()), i1 = hi(cmax.x());
  const std::int64_t j0 = lo(cmin.y()), j1 = hi(cmax.y());
  const std::int64_t k0 = lo(cmin.z()), k1 = hi(cmax.z());
  const std::int64_t ni = i1 - i0 + 1, nj = j1 - j0 + 1, nk = k1 - k0 + 1;
  const std::int64_t pi = ni + 2, pj = nj + 2;  // padded strides
  Scratch& sc = scratch();
  sc.solid.assign(static_cast<std::size_t>(pi * pj * (nk + 2)), 0);
  const auto pad = [&](std::int64_t k, std::int64_t j, std::int64_t i) {
    return static_cast<std::size_t>(((k + 1) * pj + (j + 1)) * pi + (i + 1));
  };

  const double sub = 1.0 / ss;
  const Vec3 stepBody = Rt.col(0) * (sx * sub);
  const int nSamples = static_cast<int>(ni) * ss;
  sc.row.resize(static_cast<std::size_t>(nSamples));
  sc.count.resize(static_cast<std::size_t>(ni));
  sc.rowLo.assign(static_cast<std::size_t>(nk * nj), static_cast<std::int32_t>(ni));
  sc.rowHi.assign(static_cast<std::size_t>(nk * nj), -1);
  const int need = (ss * ss * ss + 1) / 2;  // "at least half of k^3 inside"
  const double off0 = -0.5 + 0.5 * sub;
  for (std::int64_t k = 0; k < nk; ++k) {
    for (std::int64_t j = 0; j < nj; ++j) {
      const std::size_t r = static_cast<std::size_t>(k * nj + j);
      if (ss > 1) std::fill(sc.count.begin(), sc.count.end(), std::uint16_t{0});
      for (int b = 0; b < ss; ++b) {
        for (int a = 0; a < ss; ++a) {
          const Vec3 w0 = lattice.centerMm(k0 + k, j0 + j, i0) +
                          Vec3(off0 * sx, (off0 + a * sub) * sy, (off0 + b * sub) * sz);
          const Vec3 p0 = Rt * (w0 - centre);
          double t0 = 0, t1 = nSamples - 1;
          if (!clipLine(p0, stepBody, body, t0, t1)) continue;
          const int s0 = std::max(0, static_cast<int>(std::ceil(t0)));
          const int s1 = std::min(nSamples - 1, static_cast<int>(std::floor(t1)));
          if (s1 < s0) continue;
          shape.insideRow(p0 + static_cast<double>(s0) * stepBody, stepBody, s1 - s0 + 1,
                          sc.row.data() + s0);
          sc.rowLo[r] = std::min(sc.rowLo[r], s0 / ss);
          sc.rowHi[r] = std::max(sc.rowHi[r], s1 / ss);
          if (ss == 1) {
            std::copy(sc.row.begin() + s0, sc.row.begin() + s1 + 1,
                      sc.solid.begin() + static_cast<std::ptrdiff_t>(pad(k, j, s0)));
          } else {
            int i = s0 / ss, phase = s0 % ss;
            for (int s = s0; s <= s1; ++s) {
              sc.count[static_cast<std::size_t>(i)] += sc.row[static_cast<std::size_t>(s)];
              if (++phase == ss) {
                phase = 0;
                ++i;
              }
            }
          }
        }
      }
      if (ss > 1) {
        std::uint8_t* dst = &sc.solid[pad(k, j, 0)];
        for (std::int32_t i = sc.rowLo[r]; i <= sc.rowHi[r]; ++i)
          dst[i] = sc.count[static_cast<std::size_t>(i)] >= need ? 1 : 0;
      }
    }
  }

  DigitalParticle out;
  out.voxelVolumeMm3 = sx * sy * sz;
  {
    // Rough sizes (exact volume, 1.5x area in faces) so the vectors rarely grow.
    const double v = shape.volumeMm3() / out.voxelVolumeMm3;
    const double f = 1.5 * shape.surfaceMm2() / std::min({sx * sy, sy * sz, sx * sz});
    if (v < 1e9) out.voxels.reserve(static_cast<std::size_t>(v * 1.05) + 64);
    if (f < 1e9) {
      out.surface.reserve(static_cast<std::size_t>(f * 0.8) + 64);
      out.surfaceFaces.reserve(static_cast<std::size_t>(f * 0.8) + 64);
    }
  }
  double s1 = 0, sI = 0, sJ = 0, sK = 0;
  double sII = 0, sJJ = 0, sKK = 0, sIJ = 0, sIK = 0, sJK = 0;
  std::size_t fx = 0, fy = 0, fz = 0;
  const std::size_t dk = static_cast<std::size_t>(pi * pj), dj = static_cast<std::size_t>(pi);
  for (std::int64_t k = 0; k < nk; ++k) {
    for (std::int64_t j = 0; j < nj; ++j) {
      const std::size_t r = static_cast<std::size_t>(k * nj + j);
      const std::size_t base = pad(k, j, 0);
      // Moments per row in exact integers: n, sum i, sum i^2.
      std::int64_t rn = 0, ri = 0, rii = 0;
      for (std::int64_t i = sc.rowLo[r]; i <= sc.rowHi[r]; ++i) {
        const std::size_t o = base + static_cast<std::size_t>(i);
        if (!sc.solid[o]) continue;
        std::uint8_t f = 0;
        if (!sc.solid[o - 1]) f |= kFaceMinusX;
        if (!sc.solid[o + 1]) f |= kFacePlusX;
        if (!sc.solid[o - dj]) f |= kFaceMinusY;
        if (!sc.solid[o + dj]) f |= kFacePlusY;
        if (!sc.solid[o - dk]) f |= kFaceMinusZ;
        if (!sc.solid[o + dk]) f |= kFacePlusZ;
        if (f) {
          out.surface.push_back(static_cast<std::uint32_t>(out.voxels.size()));
          out.surfaceFaces.push_back(f);
          fx += ((f & kFaceMinusX) != 0) + ((f & kFacePlusX) != 0);
          fy += ((f & kFaceMinusY) != 0) + ((f & kFacePlusY) != 0);
          fz += ((f & kFaceMinusZ) != 0) + ((f & kFacePlusZ) != 0);
        }
        out.voxels.push_back({static_cast<std::int32_t>(k0 + k), static_cast<std::int32_t>(j0 + j),
                              static_cast<std::int32_t>(i0 + i)});
        ++rn;
        ri += i;
        rii += i * i;
      }
      if (rn == 0) continue;
      // Local index units (small numbers: no cancellation).
      const double n = static_cast<double>(rn), x = static_cast<double>(ri),
                   xx = static_cast<double>(rii);
      const double y = static_cast<double>(j), z = static_cast<double>(k);
      s1 += n;
      sI += x;
      sII += xx;
      sJ += y * n;
      sJJ += y * y * n;
      sK += z * n;
      sKK += z * z * n;
      sIJ += y * x;
      sIK += z * x;
      sJK += y * z * n;
    }
  }
  out.faceCount = fx + fy + fz;
  out.faceSurfaceMm2 = static_cast<double>(fx) * sy * sz + static_cast<double>(fy) * sx * sz +
                       static_cast<double>(fz) * sx * sy;
  if (s1 == 0) {
    out.centreOfMassMm = centreMm;
    return out;
  }
  const Vec3 mean(sI / s1, sJ / s1, sK / s1);
  const Vec3 origin = lattice.centerMm(k0, j0, i0);
  out.centreOfMassMm = origin + Vec3(mean.x() * sx, mean.y() * sy, mean.z() * sz);
  // Central second moments C = sum r r^T (mm^2) and the inertia of N voxel cubes.
  Eigen::Matrix3d C;
  C(0, 0) = (sII - s1 * mean.x() * mean.x()) * sx * sx;
  C(1, 1) = (sJJ - s1 * mean.y() * mean.y()) * sy * sy;
  C(2, 2) = (sKK - s1 * mean.z() * mean.z()) * sz * sz;
  C(0, 1) = C(1, 0) = (sIJ - s1 * mean.x() * mean.y()) * sx * sy;
  C(0, 2) = C(2, 0) = (sIK - s1 * mean.x() * mean.z()) * sx * sz;
  C(1, 2) = C(2, 1) = (sJK - s1 * mean.y() * mean.z()) * sy * sz;
  const double v = out.voxelVolumeMm3;
  Eigen::Matrix3d I = v * (C.trace() * Eigen::Matrix3d::Identity() - C);
  I(0, 0) += s1 * v * (sy * sy + sz * sz) / 12;
  I(1, 1) += s1 * v * (sx * sx + sz * sz) / 12;
  I(2, 2) += s1 * v * (sx * sx + sy * sy) / 12;
  out.inertiaPerDensity = I;
  return out;
}

}  // namespace voxpack::packer
