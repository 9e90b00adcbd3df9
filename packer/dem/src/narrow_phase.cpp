// The narrow phase: which surface nodes of one body lie inside the other (cluster walk and
// node lists), and the closed-form overlap of two spheres.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "node_filter.hpp"
#include "system_impl.hpp"

namespace voxpack::packer::dem {

// A penetrating node ni of a (b's outward normal nShape there, in b's shape frame) as a hit
// on a; rbS maps b's shape frame to the world.
Hit DemSystem::Impl::nodeHit(const ParticleTemplate& ta, const ParticleTemplate& tb,
                             std::uint32_t ni, const Vec3& nShape, double s, const Vec3& xa,
                             const Eigen::Matrix3d& ra, const Eigen::Matrix3d& rbS, double factor,
                             double sign) const {
  Hit h;
  h.p = xa + ra * ta.nodeP[ni];
  h.depth = -s;
  const Vec3 nb = rbS * nShape;  // b's outward normal at the node
  if (opt.contact == ContactModel::kVoxel) {
    h.dir = -(ra * ta.nodeFace[ni]);
    h.kw = k * ta.nodeArea[ni] * factor;
  } else {
    h.dir = nb;
    h.kw = k * ta.nodeLsArea[ni] * factor;
  }
  h.dir *= sign;
  // Interpenetration is judged by depth alone: a surface that has crossed the medial surface
  // of b's wall has nodes near that surface, about half the wall deep. A turned normal is
  // no sign of it: at every edge of b the medial surface meets the surface, so a node a
  // hundredth of the wall under a rim meets the neighbouring face's normal (settled beds of
  // cylinders, rings and trilobes showed such "flips" at 0.02-0.28 of the wall, all at edges).
  h.wallFraction = h.depth / tb.thinWallMm;
  return h;
}

// Nodes of a inside b, searched through a's cluster hierarchy; nodes within the node skin
// of b go to `list`. m, off map a's body frame into b's shape frame, rbS b's shape frame
// to the world. Force direction on a times sign.
void DemSystem::Impl::searchNodes(std::size_t a, std::size_t b, const Eigen::Matrix3d& ra,
                                  const Eigen::Matrix3d& rbS, const Eigen::Matrix3d& m,
                                  const Vec3& off, double factor, double sign,
                                  std::vector<Hit>& hits, std::vector<std::uint32_t>& list,
                                  std::uint64_t& evals) const {
  const ParticleTemplate& ta = tmpl[tid[a]];
  const ParticleTemplate& tb = tmpl[tid[b]];
  const double rb0 = tb.radiusMm + nodeSkin;
  // b's bounding sphere in a's frame: the cheap first test, no rotation per cluster.
  const Vec3 cba = ra.transpose() * (x[b] - x[a]);
  list.clear();
  for (const auto& c : ta.coarse) {
    const double reachC = rb0 + c.radius;
    if ((c.centre - cba).squaredNorm() > reachC * reachC) continue;
    ++evals;
    if (sdfShape(tid[b], m * c.centre + off) > c.radius + nodeSkin) continue;
    for (std::uint32_t fi = c.begin; fi < c.end; ++fi) {
      const auto& f = ta.fine[fi];
      const double reachF = rb0 + f.radius;
      if ((f.centre - cba).squaredNorm() > reachF * reachF) continue;
      ++evals;
      if (sdfShape(tid[b], m * f.centre + off) > f.radius + nodeSkin) continue;
      for (std::uint32_t ni = f.begin; ni < f.end; ++ni) {
        if ((ta.nodeP[ni] - cba).squaredNorm() > rb0 * rb0) continue;
        const Vec3 pb = m * ta.nodeP[ni] + off;
        ++evals;
        const double s = sdfShape(tid[b], pb);
        if (s >= nodeSkin) continue;
        list.push_back(ni);
        if (s >= 0) continue;
        const Hit h = nodeHit(ta, tb, ni, tb.shape->normal(pb), s, x[a], ra, rbS, factor, sign);
        if (h.kw > 0) hits.push_back(h);
      }
    }
  }
}

// Nodes of a inside b among the listed ones (same order as the search found them).
void DemSystem::Impl::listedNodes(std::size_t a, std::size_t b, const Eigen::Matrix3d& ra,
                                  const Eigen::Matrix3d& rbS, const Eigen::Matrix3d& m,
                                  const Vec3& off, double factor, double sign,
                                  std::vector<Hit>& hits, const std::vector<std::uint32_t>& list,
                                  std::uint64_t& evals) const {
  const ParticleTemplate& ta = tmpl[tid[a]];
  const ParticleTemplate& tb = tmpl[tid[b]];
  evals += list.size();
  const Analytic& form = analytic[tid[b]];
  if (form.form == 2) {
    // A cylinder (most listed nodes lie outside it): a node is inside only when both its
    // axial and its radial distance are negative, and there the signed distance is the
    // larger of the two, the bits of analyticSignedDistanceMm (sqrt(0) + max(dr, dz)).
    // Two passes over chunks of the list: the float filter (node_filter.hpp) keeps a
    // superset of the nodes that may be inside, then the exact test, in double, runs on
    // those alone. Two thirds of the listed nodes fail the filter, and as a branch its
    // outcome mispredicted. The same nodes pass the exact test in the same order as
    // without the filter: the same bits.
    const double extent = ta.radiusMm + off.norm();
    const NodeFilter nf = insideCylinderFilter(m, off, extent, form.r, form.hl);
    forEachKept(nf, nodeCoords[tid[a]], list, avx2, [&](std::uint32_t ni) {
      const Vec3 pb = m * ta.nodeP[ni] + off;
      const double dz = std::abs(pb.z()) - form.hl;
      if (dz >= 0) return;
      const double rho = std::sqrt(pb.x() * pb.x() + pb.y() * pb.y());
      const double dr = rho - form.r;
      if (dr >= 0) return;
      // The shape's normal inside (FastSdfShape::normal, its bits): the nearer face.
      const Vec3 nShape = dr > dz ? (rho > 0 ? Vec3(pb.x() / rho, pb.y() / rho, 0) : Vec3(1, 0, 0))
                                  : Vec3(0, 0, pb.z() >= 0 ? 1 : -1);
      const Hit h = nodeHit(ta, tb, ni, nShape, std::max(dr, dz), x[a], ra, rbS, factor, sign);
      if (h.kw > 0) hits.push_back(h);
    });
    return;
  }
  for (const std::uint32_t ni : list) {
    const Vec3 pb = m * ta.nodeP[ni] + off;
    const double s = sdfShape(tid[b], pb);
    if (s >= 0) continue;
    const Hit h = nodeHit(ta, tb, ni, tb.shape->normal(pb), s, x[a], ra, rbS, factor, sign);
    if (h.kw > 0) hits.push_back(h);
  }
}

// Hits of pair p (nodes of i in j, then nodes of j in i), from its node lists when the
// relative pose has not moved more than the skin since they were searched.
void DemSystem::Impl::pairHits(Pair& p, std::vector<Hit>& hits, std::uint64_t& evals,
                               std::uint64_t& searches) const {
  const Eigen::Matrix3d& ri = rot[p.i];
  const Eigen::Matrix3d& rj = rot[p.j];
  const Eigen::Matrix3d m = rj.transpose() * ri;  // i's frame -> j's frame
  const Vec3 off = rj.transpose() * (x[p.i] - x[p.j]);
  const Vec3 offT = ri.transpose() * (x[p.j] - x[p.i]);  // i's frame: j's centre
  NodeList& nl = p.nodes;
  bool fresh = nl.valid;
  if (fresh) {
    // A node at radius r moves by at most |dm|_F r + |d off| (Frobenius bounds the 2-norm);
    // the inverse transform has the same |dm|_F.
    const double dm = (m - nl.m).norm();
    const double moveI = dm * tmpl[tid[p.i]].radiusMm + (off - nl.off).norm();
    const double moveJ = dm * tmpl[tid[p.j]].radiusMm + (offT - nl.offT).norm();
    fresh = std::max(moveI, moveJ) < nodeSkin;
  }
  // Into the other body's shape frame, where its distance function is defined.
  const Eigen::Matrix3d& si = toShape[tid[p.i]];
  const Eigen::Matrix3d& sj = toShape[tid[p.j]];
  const Eigen::Matrix3d mIJ = sj * m, mJI = si * m.transpose();
  const Vec3 offIJ = sj * off, offJI = si * offT;
  const Eigen::Matrix3d rjS = rj * sj.transpose(), riS = ri * si.transpose();
  if (fresh) {
    listedNodes(p.i, p.j, ri, rjS, mIJ, offIJ, 0.5, 1.0, hits, nl.a, evals);
    listedNodes(p.j, p.i, rj, riS, mJI, offJI, 0.5, -1.0, hits, nl.b, evals);
    return;
  }
  ++searches;
  searchNodes(p.i, p.j, ri, rjS, mIJ, offIJ, 0.5, 1.0, hits, nl.a, evals);
  searchNodes(p.j, p.i, rj, riS, mJI, offJI, 0.5, -1.0, hits, nl.b, evals);
  nl.m = m;
  nl.off = off;
  nl.offT = offT;
  nl.valid = true;
}

// Two spheres in closed form: overlap delta = ri + rj - c along the centre line, lens volume
// V and its cross-section A = -dV/dc (the continuum limit of the node sum, so a sphere bed
// sees the same contact law as a node-resolved one).
ContactOut DemSystem::Impl::spherePair(const Pair& p) const {
  const double ri = analytic[tid[p.i]].r, rj = analytic[tid[p.j]].r;
  const Vec3 d = x[p.i] - x[p.j];
  const double c2 = d.squaredNorm(), reach = ri + rj;
  if (c2 >= reach * reach || !(c2 > 0)) return ContactOut{};
  const double c = std::sqrt(c2);
  const double delta = reach - c;
  const Vec3 n = d / c;                                  // pushes i away from j
  const double ai = (c2 - rj * rj + ri * ri) / (2 * c);  // i's centre to the lens plane
  const Vec3 cp = x[p.i] - ai * n;
  const double area = kPi * std::max(0.0, ri * ri - ai * ai);
  const double volume = kPi * delta * delta *
                        (c2 + 2 * c * (ri + rj) - 3 * (ri * ri + rj * rj) + 6 * ri * rj) / (12 * c);
  ContactOut out = closedContact(volume, area, delta, n, cp, body(p.i), body(p.j), pairLaw, p.xi);
  out.wallFraction = delta / (2 * std::min(ri, rj));  // a sphere's thinnest wall is its d
  return out;
}

}  // namespace voxpack::packer::dem
