// Contacts from the exact signed distances of the posed shapes. The tessellated surfaces
// only seed the search; every gap reported is a signed distance of an exact shape.
#include "voxpack/export/contacts.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "voxpack/core/errors.hpp"

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

// One part of a container wall: its distance (> 0 inside) and inward normal.
struct WallSurface {
  WallPart part = WallPart::Whole;
  std::function<double(const Vec3&)> distance;
  std::function<Vec3(const Vec3&)> inward;
};

// Cylinders and boxes split into side(s), floor and lid, so a particle gets one contact
// per part it touches (the container's own wall distance is the minimum over the parts
// and would give only the nearest one); other containers stay whole.
std::vector<WallSurface> wallSurfaces(const packer::Container& wall, WallContacts which) {
  std::vector<WallSurface> out;
  if (which == WallContacts::None) return out;
  const packer::BoundsMm b = wall.boundsMm();
  const bool isBox = wall.spec().rfind("box:", 0) == 0;
  double cx = 0, cy = 0, r = 0;
  const bool isCylinder = wall.cylinderAxis(cx, cy, r);
  if (!isBox && !isCylinder) {
    out.push_back({WallPart::Whole, [&wall](const Vec3& x) { return wall.wallDistanceMm(x); },
                   [&wall](const Vec3& x) { return wall.inwardNormal(x); }});
    return out;
  }
  if (isCylinder) {
    out.push_back({WallPart::Side,
                   [cx, cy, r](const Vec3& x) { return r - std::hypot(x.x() - cx, x.y() - cy); },
                   [cx, cy](const Vec3& x) {
                     const Vec3 radial(x.x() - cx, x.y() - cy, 0);
                     const double rho = radial.norm();
                     return rho > 0 ? Vec3(-radial / rho) : Vec3(Vec3::UnitX());
                   }});
  } else {
    for (int axis = 0; axis < 2; ++axis) {
      const double lo = b.min[axis], hi = b.max[axis];
      out.push_back({WallPart::Side, [axis, lo](const Vec3& x) { return x[axis] - lo; },
                     [axis](const Vec3&) { return Vec3(Vec3::Unit(axis)); }});
      out.push_back({WallPart::Side, [axis, hi](const Vec3& x) { return hi - x[axis]; },
                     [axis](const Vec3&) { return Vec3(-Vec3::Unit(axis)); }});
    }
  }
  if (which == WallContacts::All) {
    const double lo = b.min.z(), hi = b.max.z();
    out.push_back({WallPart::Floor, [lo](const Vec3& x) { return x.z() - lo; },
                   [](const Vec3&) { return Vec3(Vec3::UnitZ()); }});
    out.push_back({WallPart::Lid, [hi](const Vec3& x) { return hi - x.z(); },
                   [](const Vec3&) { return Vec3(-Vec3::UnitZ()); }});
  }
  return out;
}

bool wallContact(const PosedParticle& A, const WallSurface& wall, double tol, Contact& c) {
  double best = std::numeric_limits<double>::infinity();
  Vec3 bestPoint = Vec3::Zero();
  for (const Vec3& v : A.surface.vertices) {
    const double d = wall.distance(v);
    if (d < best) {
      best = d;
      bestPoint = v;
    }
  }
  if (best > tol + 0.1 * A.shape->boundingRadiusMm()) return false;
  // The mesh vertex only seeds: the gap is the wall distance of the exact surface point
  // nearest the wall.
  const Vec3 p = minimiseOnSurface(A, project(A, bestPoint), wall.distance, wall.inward,
                                   0.5 * A.shape->boundingRadiusMm());
  const double gap = wall.distance(p);
  if (gap > tol) return false;
  const Vec3 out = -wall.inward(p).normalized();
  c.gapMm = gap;
  c.normal = out;
  c.pointMm = p + 0.5 * gap * out;
  c.wall = wall.part;
  return true;
}

}  // namespace

WallContacts parseWallContacts(const std::string& name) {
  if (name == "all") return WallContacts::All;
  if (name == "side") return WallContacts::Side;
  if (name == "none") return WallContacts::None;
  throw UsageError("--wall-contacts: unknown value '" + name + "' (expected all, side, none)");
}

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
  const std::vector<WallSurface> walls =
      wall ? wallSurfaces(*wall, options.wallContacts) : std::vector<WallSurface>{};
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
    for (const WallSurface& w : walls) {
      Contact c;
      c.a = a;
      c.b = -1;
      if (wallContact(A, w, tol, c)) out.push_back(c);
    }
  }
  std::vector<Contact> all;
  for (auto& v : per) all.insert(all.end(), v.begin(), v.end());
  return all;
}

}  // namespace voxpack::exporter
