// Particle templates: the digitised surface of a shape, once, in its principal frame.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "constants.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/packer/dem.hpp"

namespace voxpack::packer::dem {
namespace {

// Principal frame of the inertia tensor. A tensor that is already diagonal keeps the shape
// frame so that its voxel faces stay along the shape's natural axes (a degenerate solver
// basis could turn a cylinder's lattice by an arbitrary angle about its axis).
Eigen::Matrix3d principalAxes(const Eigen::Matrix3d& inertia, Vec3& moments) {
  const double scale = inertia.diagonal().cwiseAbs().maxCoeff();
  const double off =
      std::max({std::abs(inertia(0, 1)), std::abs(inertia(0, 2)), std::abs(inertia(1, 2))});
  if (off <= 1e-9 * scale) {
    moments = inertia.diagonal();
    return Eigen::Matrix3d::Identity();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(inertia);
  Eigen::Matrix3d v = solver.eigenvectors();
  if (v.determinant() < 0) v.col(2) = -v.col(2);
  moments = solver.eigenvalues();
  return v;
}

}  // namespace

ParticleTemplate buildTemplate(std::shared_ptr<const DemShape> shape, double voxelMm,
                               double densityGPerCm3) {
  if (!shape) throw InputError("dem: no shape");
  if (!(voxelMm > 0) || !std::isfinite(voxelMm)) throw InputError("dem: voxel size must be > 0");
  if (!(densityGPerCm3 > 0) || !std::isfinite(densityGPerCm3))
    throw InputError("dem: --density must be > 0");
  ParticleTemplate t;
  t.shape = shape;
  const double rho = densityGPerCm3 * 1e-3;  // g/mm^3
  t.massG = rho * shape->volumeMm3();
  Vec3 moments;
  const Eigen::Matrix3d axes = principalAxes(rho * shape->inertiaPerDensity(), moments);
  t.inertiaG = moments;
  t.principalToShape = Quat(axes).normalized();
  t.radiusMm = shape->boundingRadiusMm();
  t.diameterMm = std::cbrt(6.0 * shape->volumeMm3() / kPi);
  if (!(t.massG > 0) || !(t.radiusMm > 0) || !(moments.minCoeff() > 0))
    throw InputError("dem: shape " + shape->spec() + " has no volume");

  // Digitise in the shape frame: voxel centres on multiples of h (the paper's lattice at the
  // reference pose); a solid voxel's face is out-facing when its neighbour is empty.
  const double h = voxelMm;
  const int n = static_cast<int>(std::ceil(t.radiusMm / h)) + 1;
  const int w = 2 * n + 1;
  if (static_cast<double>(w) * w * w > 4e8)
    throw InputError("dem: voxel size " + std::to_string(h) + " mm is too fine for " +
                     shape->spec());
  std::vector<std::uint8_t> solid(static_cast<std::size_t>(w) * w * w, 0);
  auto at = [&](int k, int j, int i) -> std::uint8_t& {
    return solid[(static_cast<std::size_t>(k + n) * w + static_cast<std::size_t>(j + n)) * w +
                 static_cast<std::size_t>(i + n)];
  };
  for (int k = -n + 1; k < n; ++k)
    for (int j = -n + 1; j < n; ++j)
      for (int i = -n + 1; i < n; ++i) at(k, j, i) = shape->inside(Vec3(i * h, j * h, k * h));

  const Quat toPrincipal = t.principalToShape.conjugate();
  static const int dk[6] = {0, 0, 0, 0, -1, 1}, dj[6] = {0, 0, -1, 1, 0, 0},
                   di[6] = {-1, 1, 0, 0, 0, 0};
  for (int k = -n + 1; k < n; ++k)
    for (int j = -n + 1; j < n; ++j)
      for (int i = -n + 1; i < n; ++i) {
        if (!at(k, j, i)) continue;
        for (int f = 0; f < 6; ++f) {
          if (at(k + dk[f], j + dj[f], i + di[f])) continue;
          const Vec3 face(di[f], dj[f], dk[f]);
          // Sub-voxel: the node sits on the exact surface (projection along the normal), so
          // a depth is measured from the master shape and not quantised to voxels.
          Vec3 p = Vec3(i * h, j * h, k * h) + 0.5 * h * face;
          for (int it = 0; it < 4; ++it) {
            const double s = shape->signedDistanceMm(p);
            if (std::abs(s) < 1e-9 * h) break;
            p -= s * shape->normal(p);
          }
          const Vec3 nrm = shape->normal(p);
          t.nodeP.push_back(toPrincipal * p);
          t.nodeFace.push_back(toPrincipal * face);
          t.nodeNormal.push_back(toPrincipal * nrm);
          t.nodeArea.push_back(h * h);
          t.nodeLsArea.push_back(h * h * std::max(0.0, face.dot(nrm)));
        }
      }
  if (t.nodeP.empty())
    throw InputError("dem: shape " + shape->spec() + " has no voxel at " + std::to_string(h) +
                     " mm; use a smaller --voxel-size");

  // Largest flat face: the stiffest contact, which sets the time step.
  for (int a = 0; a < 3; ++a)
    for (int sgn = -1; sgn <= 1; sgn += 2) {
      Vec3 axis = Vec3::Zero();
      axis[a] = sgn;
      double area = 0;
      for (std::size_t m = 0; m < t.nodeP.size(); ++m)
        if (t.nodeNormal[m].dot(axis) > 0.98) area += t.nodeLsArea[m];
      t.flatAreaMm2 = std::max(t.flatAreaMm2, area);
    }

  // Thinnest wall: from every node, the chord through the body along its inward normal,
  // marched in steps of h/4 to where the shape is left (then bisected to 1e-3 h).
  t.thinWallMm = 2 * t.radiusMm;
  for (std::size_t m = 0; m < t.nodeP.size(); ++m) {
    const Vec3 p = t.principalToShape * t.nodeP[m];
    const Vec3 in = -(t.principalToShape * t.nodeNormal[m]);
    double lo = 0, hi = 0;
    for (double s = 0.25 * h; s <= 2 * t.radiusMm + h; s += 0.25 * h)
      if (shape->signedDistanceMm(p + s * in) > 0) {
        lo = s - 0.25 * h;
        hi = s;
        break;
      }
    if (!(hi > 0) || lo >= t.thinWallMm) continue;
    while (hi - lo > 1e-3 * h) {
      const double mid = 0.5 * (lo + hi);
      (shape->signedDistanceMm(p + mid * in) > 0 ? hi : lo) = mid;
    }
    t.thinWallMm = std::min(t.thinWallMm, hi);
  }

  // Two-level bounding-sphere hierarchy: 3^3 coarse cells of 3^3 fine cells each, so a pair
  // visits only the nodes near its contact.
  const double r = t.radiusMm * (1 + 1e-9) + h;
  const double cc = 2 * r / 3, cf = cc / 3;
  auto cellOf = [&](const Vec3& p, double size, int cells) {
    std::array<int, 3> c{};
    for (int a = 0; a < 3; ++a)
      c[a] = std::clamp(static_cast<int>(std::floor((p[a] + r) / size)), 0, cells - 1);
    return c;
  };
  const std::size_t nn = t.nodeP.size();
  std::vector<std::uint32_t> order(nn);
  std::vector<std::uint64_t> key(nn);
  for (std::size_t m = 0; m < nn; ++m) {
    const auto c = cellOf(t.nodeP[m], cc, 3);
    const auto f = cellOf(t.nodeP[m], cf, 9);
    const std::uint64_t ck = static_cast<std::uint64_t>((c[2] * 3 + c[1]) * 3 + c[0]);
    const std::uint64_t fk = static_cast<std::uint64_t>((f[2] * 9 + f[1]) * 9 + f[0]);
    key[m] = ck * 1000 + fk;
    order[m] = static_cast<std::uint32_t>(m);
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return key[a] < key[b]; });
  auto permute = [&](auto& v) {
    auto copy = v;
    for (std::size_t m = 0; m < nn; ++m) v[m] = copy[order[m]];
  };
  permute(t.nodeP);
  permute(t.nodeFace);
  permute(t.nodeNormal);
  permute(t.nodeArea);
  permute(t.nodeLsArea);
  std::vector<std::uint64_t> sortedKey(nn);
  for (std::size_t m = 0; m < nn; ++m) sortedKey[m] = key[order[m]];

  std::size_t m = 0;
  while (m < nn) {
    const std::uint64_t ck = sortedKey[m] / 1000;
    ParticleTemplate::Cluster coarse;
    coarse.begin = static_cast<std::uint32_t>(t.fine.size());
    Vec3 coarseSum = Vec3::Zero();
    std::size_t coarseCount = 0;
    const std::size_t coarseFirstNode = m;
    while (m < nn && sortedKey[m] / 1000 == ck) {
      const std::uint64_t fk = sortedKey[m];
      ParticleTemplate::Cluster fine;
      fine.begin = static_cast<std::uint32_t>(m);
      Vec3 sum = Vec3::Zero();
      while (m < nn && sortedKey[m] == fk) sum += t.nodeP[m++];
      fine.end = static_cast<std::uint32_t>(m);
      fine.centre = sum / static_cast<double>(fine.end - fine.begin);
      for (std::uint32_t q = fine.begin; q < fine.end; ++q)
        fine.radius = std::max(fine.radius, (t.nodeP[q] - fine.centre).norm());
      coarseSum += sum;
      coarseCount += fine.end - fine.begin;
      t.fine.push_back(fine);
    }
    coarse.end = static_cast<std::uint32_t>(t.fine.size());
    coarse.centre = coarseSum / static_cast<double>(coarseCount);
    for (std::size_t q = coarseFirstNode; q < m; ++q)
      coarse.radius = std::max(coarse.radius, (t.nodeP[q] - coarse.centre).norm());
    t.coarse.push_back(coarse);
  }
  return t;
}

ParticleTemplate scaledTemplate(const ParticleTemplate& base, std::shared_ptr<const DemShape> shape,
                                double s, bool nodes) {
  if (!(s > 0) || !std::isfinite(s)) throw InputError("dem: template scale must be > 0");
  ParticleTemplate t;
  t.shape = std::move(shape);
  t.principalToShape = base.principalToShape;
  t.massG = base.massG * s * s * s;
  t.inertiaG = base.inertiaG * (s * s * s * s * s);
  t.radiusMm = base.radiusMm * s;
  t.diameterMm = base.diameterMm * s;
  t.flatAreaMm2 = base.flatAreaMm2 * s * s;
  t.thinWallMm = base.thinWallMm * s;
  if (!nodes) return t;
  t.nodeP = base.nodeP;
  for (auto& p : t.nodeP) p *= s;
  t.nodeFace = base.nodeFace;
  t.nodeNormal = base.nodeNormal;
  t.nodeArea = base.nodeArea;
  for (auto& a : t.nodeArea) a *= s * s;
  t.nodeLsArea = base.nodeLsArea;
  for (auto& a : t.nodeLsArea) a *= s * s;
  t.coarse = base.coarse;
  t.fine = base.fine;
  for (auto* cs : {&t.coarse, &t.fine})
    for (auto& c : *cs) {
      c.centre *= s;
      c.radius *= s;
    }
  return t;
}

}  // namespace voxpack::packer::dem
