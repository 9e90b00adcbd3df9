// Particle-wall contacts: one contact per wall region (floor, round side, box face), from
// the surface nodes near the wall or, for spheres, in closed form.
#include <algorithm>
#include <cmath>

#include "node_filter.hpp"
#include "system_impl.hpp"

namespace voxpack::packer::dem {

// Wall force and torque on particle i (container lifted by zw, moving at vw) into wallF[i]...
void DemSystem::Impl::wallForces(std::size_t i, double zw, double vw,
                                 std::vector<Hit> (&hits)[kWallRegions], std::uint64_t& evals,
                                 std::uint64_t& searches) {
  wallF[i].setZero();
  wallT[i].setZero();
  wallElastic[i] = 0;
  wallDepth[i] = 0;
  wallTouching[i] = 0;
  if (!awake[i]) return;
  const Vec3 wallShift(0, 0, zw);
  const ParticleTemplate& tp = tmpl[tid[i]];
  ++evals;
  if (container->wallDistanceMm(x[i] - wallShift) > tp.radiusMm) {
    for (auto& xi : wallXi[i]) xi.setZero();
    return;
  }
  const Body a = body(i);
  Body w;
  w.x = x[i];
  w.v = Vec3(0, 0, vw);
  std::array<bool, kWallRegions> touched{};
  auto add = [&](int region, const ContactOut& c) {
    const auto r = static_cast<std::size_t>(region);
    wallXi[i][r] = c.touching ? c.xi : Vec3::Zero();
    touched[r] = c.touching;
    if (!c.touching) return;
    wallF[i] += c.force;
    wallT[i] += c.torqueA;
    wallElastic[i] += c.elastic;
    wallDepth[i] = std::max(wallDepth[i], c.maxDepth);
    ++wallTouching[i];
  };
  if (closedForm[tid[i]]) {
    // Sphere against each wall in reach: the cap of a plane cut (a round wall of radius
    // D/2 >> r is taken as its tangent plane): V = pi delta^2 (3r - delta) / 3,
    // A = pi delta (2r - delta).
    const double r = analytic[tid[i]].r;
    WallPatch patch[kWallRegions];
    const int np = container->nearWalls(x[i] - wallShift, r, patch);
    for (int m = 0; m < np; ++m) {
      // Deeper than the whole sphere (a blow-up) still counts as the whole sphere.
      const double delta = std::min(r - patch[m].distanceMm, 2 * r);
      if (!(delta > 0)) continue;
      const double volume = kPi * delta * delta * (3 * r - delta) / 3;
      const double area = kPi * delta * (2 * r - delta);
      const Vec3 cp = x[i] - patch[m].distanceMm * patch[m].normal;
      add(patch[m].region, closedContact(volume, area, delta, patch[m].normal, cp, a, w, wallLaw,
                                         wallXi[i][static_cast<std::size_t>(patch[m].region)]));
    }
    evals += static_cast<std::uint64_t>(np);
  } else {
    for (auto& h : hits) h.clear();
    const Eigen::Matrix3d& r = rot[i];
    const bool voxel = opt.contact == ContactModel::kVoxel;
    WallList& wl = wallLists[i];
    bool fresh = wl.valid;
    if (fresh) {
      const double move =
          (r - wl.r).norm() * tp.radiusMm + (x[i] - wl.x).norm() + std::abs(zw - wl.lift);
      fresh = move < nodeSkin;
    }
    auto probe = [&](std::uint32_t ni, const Vec3& p, double s) {
      const Vec3 pw = p - wallShift;
      const int region = std::clamp(container->wallRegion(pw), 0, kWallRegions - 1);
      Hit h;
      h.p = p;
      h.depth = -s;
      if (voxel) {
        h.dir = -(r * tp.nodeFace[ni]);
        h.kw = k * tp.nodeArea[ni];
      } else {
        h.dir = container->inwardNormal(pw);
        h.kw = k * tp.nodeLsArea[ni];
      }
      if (h.kw > 0) hits[region].push_back(h);
    };
    if (fresh && column.on) {
      // Most listed nodes are inside the column, within the skin: the float filter
      // (node_filter.hpp) keeps a superset of those outside it or below the floor, and the
      // exact test runs on those alone, in list order, so the hits are the same bits.
      evals += wl.nodes.size();
      const Vec3 off = x[i] - Vec3(column.cx, column.cy, column.floorZ + zw);
      const NodeFilter nf = outsideColumnFilter(r, off, tp.radiusMm + off.norm(), column.r);
      forEachKept(nf, nodeCoords[tid[i]], wl.nodes, avx2, [&](std::uint32_t ni) {
        const Vec3 p = x[i] + r * tp.nodeP[ni];
        const double s = container->wallDistanceMm(p - wallShift);
        if (s < 0) probe(ni, p, s);
      });
    } else if (fresh) {
      evals += wl.nodes.size();
      for (const std::uint32_t ni : wl.nodes) {
        const Vec3 p = x[i] + r * tp.nodeP[ni];
        const double s = container->wallDistanceMm(p - wallShift);
        if (s < 0) probe(ni, p, s);
      }
    } else {
      ++searches;
      wl.nodes.clear();
      for (const auto& c : tp.coarse) {
        ++evals;
        if (container->wallDistanceMm(x[i] + r * c.centre - wallShift) > c.radius + nodeSkin)
          continue;
        for (std::uint32_t fi = c.begin; fi < c.end; ++fi) {
          const auto& f = tp.fine[fi];
          ++evals;
          if (container->wallDistanceMm(x[i] + r * f.centre - wallShift) > f.radius + nodeSkin)
            continue;
          for (std::uint32_t ni = f.begin; ni < f.end; ++ni) {
            const Vec3 p = x[i] + r * tp.nodeP[ni];
            ++evals;
            const double s = container->wallDistanceMm(p - wallShift);
            if (s >= nodeSkin) continue;
            wl.nodes.push_back(ni);
            if (s < 0) probe(ni, p, s);
          }
        }
      }
      wl.r = r;
      wl.x = x[i];
      wl.lift = zw;
      wl.valid = true;
    }
    for (int region = 0; region < kWallRegions; ++region)
      if (!hits[region].empty())
        add(region,
            nodeContact(hits[region], a, w, wallLaw, wallXi[i][static_cast<std::size_t>(region)]));
  }
  for (int region = 0; region < kWallRegions; ++region)
    if (!touched[static_cast<std::size_t>(region)])
      wallXi[i][static_cast<std::size_t>(region)].setZero();
}

}  // namespace voxpack::packer::dem
