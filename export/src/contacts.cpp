// Contacts from the exact signed distances of the posed shapes. The tessellated surfaces
// only seed the search; every gap reported is a signed distance of an exact shape.
#include "voxpack/export/contacts.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace voxpack::exporter {
namespace {

Vec3 toBody(const PosedParticle& p, const Vec3& x) {
  return p.orientation.conjugate() * (x - p.centreMm);
}

// Outward unit normal (world) of the exact surface nearest to x.
Vec3 normalAt(const PosedParticle& p, const Vec3& x) {
  return p.orientation * p.shape->normal(toBody(p, x));
}

// Nearest point of p's exact surface to x (one Newton step along the distance gradient;
// exact for spheres and planes, and repeated by the callers' alternation otherwise).
Vec3 project(const PosedParticle& p, const Vec3& x) {
  Vec3 y = x;
  for (int it = 0; it < 2; ++it) y = y - signedDistanceMm(p, y) * normalAt(p, y);
  return y;
}

struct Seed {
  double value = std::numeric_limits<double>::infinity();
  Vec3 point = Vec3::Zero();
};

// The vertex of `from`'s mesh deepest in `to`'s signed distance.
Seed deepestVertex(const PosedParticle& from, const PosedParticle& to) {
  Seed s;
  for (const Vec3& v : from.surface.vertices) {
    const double d = signedDistanceMm(to, v);
    if (d < s.value) {
      s.value = d;
      s.point = v;
    }
  }
  return s;
}

// Minimises f over the exact surface of A from p (on it): projected gradient descent with
// the tangential part of grad f and an adaptive step (accepted steps grow, rejected ones
// halve). Alternating projections alone stall for tangent surfaces (sublinear convergence
// at a single touching point); this converges at the rate of the curvature.
template <class F, class G>
Vec3 minimiseOnSurface(const PosedParticle& A, Vec3 p, F f, G grad, double step) {
  double fp = f(p);
  for (int it = 0; it < 200 && step > 1e-12; ++it) {
    const Vec3 nA = normalAt(A, p);
    Vec3 g = grad(p);
    g -= g.dot(nA) * nA;
    if (!(g.norm() > 1e-14)) break;
    const Vec3 trial = project(A, p - step * g);
    const double ft = f(trial);
    if (ft < fp) {
      p = trial;
      fp = ft;
      step *= 1.5;
    } else {
      step *= 0.5;
    }
  }
  return p;
}

bool pairContact(const PosedParticle& A, const PosedParticle& B, double tol, double margin,
                 Contact& c) {
  const Seed sa = deepestVertex(A, B), sb = deepestVertex(B, A);
  if (std::min(sa.value, sb.value) > tol + margin) return false;
  // p on A's surface where B's exact signed distance is least (the gap, or minus the
  // deepest penetration), seeded by the better of the two vertex seeds.
  const Vec3 start = sa.value <= sb.value ? project(A, sa.point) : project(A, project(B, sb.point));
  const double step = 0.5 * std::min(A.shape->boundingRadiusMm(), B.shape->boundingRadiusMm());
  const Vec3 p = minimiseOnSurface(
      A, start, [&](const Vec3& x) { return signedDistanceMm(B, x); },
      [&](const Vec3& x) { return normalAt(B, x); }, step);
  const double gap = signedDistanceMm(B, p);
  if (gap > tol) return false;
  const Vec3 q = project(B, p);
  c.gapMm = gap;
  c.pointMm = 0.5 * (p + q);
  Vec3 n = -normalAt(B, p);
  if (!(n.norm() > 0.5)) n = (B.centreMm - A.centreMm).normalized();
  c.normal = n.normalized();
  return true;
}

bool wallContact(const PosedParticle& A, const packer::Container& wall, double tol, Contact& c) {
  double best = std::numeric_limits<double>::infinity();
  Vec3 bestPoint = Vec3::Zero();
  for (const Vec3& v : A.surface.vertices) {
    const double d = wall.wallDistanceMm(v);
    if (d < best) {
      best = d;
      bestPoint = v;
    }
  }
  if (best > tol + 0.1 * A.shape->boundingRadiusMm()) return false;
  // The mesh vertex only seeds: the gap is the wall distance of the exact surface point
  // nearest the wall.
  const Vec3 p = minimiseOnSurface(
      A, project(A, bestPoint), [&](const Vec3& x) { return wall.wallDistanceMm(x); },
      [&](const Vec3& x) { return wall.inwardNormal(x); }, 0.5 * A.shape->boundingRadiusMm());
  const double gap = wall.wallDistanceMm(p);
  if (gap > tol) return false;
  const Vec3 out = -wall.inwardNormal(p).normalized();
  c.gapMm = gap;
  c.normal = out;
  c.pointMm = p + 0.5 * gap * out;
  return true;
}

}  // namespace

double signedDistanceMm(const PosedParticle& p, const Vec3& xMm) {
  return p.shape->signedDistanceMm(toBody(p, xMm));
}

std::vector<Contact> findContacts(const std::vector<PosedParticle>& particles,
                                  const packer::Container* wall, const ContactOptions& options) {
  const auto n = static_cast<std::int64_t>(particles.size());
  std::vector<double> radius(particles.size());
  double rmin = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < particles.size(); ++i) {
    radius[i] = particles[i].shape->boundingRadiusMm();
    rmin = std::min(rmin, radius[i]);
  }
  const double tol = std::max(0.0, options.toleranceMm);
  const double margin = 0.1 * rmin;
  std::vector<std::vector<Contact>> per(particles.size());
#pragma omp parallel for schedule(dynamic, 8) num_threads(std::max(1, options.threads))
  for (std::int64_t a = 0; a < n; ++a) {
    const auto& A = particles[static_cast<std::size_t>(a)];
    auto& out = per[static_cast<std::size_t>(a)];
    for (std::int64_t b = a + 1; b < n; ++b) {
      const auto& B = particles[static_cast<std::size_t>(b)];
      const double reach =
          radius[static_cast<std::size_t>(a)] + radius[static_cast<std::size_t>(b)] + tol;
      if ((A.centreMm - B.centreMm).squaredNorm() > reach * reach) continue;
      Contact c;
      c.a = a;
      c.b = b;
      if (pairContact(A, B, tol, margin, c)) out.push_back(c);
    }
    if (wall) {
      Contact c;
      c.a = a;
      c.b = -1;
      if (wallContact(A, *wall, tol, c)) out.push_back(c);
    }
  }
  std::vector<Contact> all;
  for (auto& v : per) all.insert(all.end(), v.begin(), v.end());
  return all;
}

}  // namespace voxpack::exporter
