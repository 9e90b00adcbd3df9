// Closed meshes of the exact shapes. Curved boundaries are polygons with a sagitta at most
// the chord tolerance; a final scale makes the enclosed volume exact (docs/export.md), so
// the polygon straddles the exact surface instead of lying inside it.
#include "voxpack/export/tessellate.hpp"

#include <cmath>
#include <numbers>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/spec.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::exporter {
namespace {

constexpr double kPi = std::numbers::pi;
using Poly = std::vector<Eigen::Vector2d>;

Poly circle(double r, int n, double phase = 0.0) {
  Poly p(static_cast<std::size_t>(n));
  for (int s = 0; s < n; ++s) {
    const double a = phase + 2 * kPi * s / n;
    p[static_cast<std::size_t>(s)] = {r * std::cos(a), r * std::sin(a)};
  }
  return p;
}

// A prism z in [-h, h] over the counter-clockwise polygon `outer`, star-shaped about the
// origin (caps are fans from the axis), with an optional hole `inner` (same count, CCW).
TriMesh prism(const Poly& outer, const Poly* inner, double h) {
  TriMesh m;
  const auto n = static_cast<std::uint32_t>(outer.size());
  for (double z : {-h, h})
    for (const auto& p : outer) m.vertices.emplace_back(p.x(), p.y(), z);
  for (std::uint32_t s = 0; s < n; ++s) {
    const std::uint32_t a = s, b = (s + 1) % n;
    m.triangles.push_back({a, b, b + n});
    m.triangles.push_back({a, b + n, a + n});
  }
  if (!inner) {
    const auto cb = static_cast<std::uint32_t>(m.vertices.size());
    m.vertices.emplace_back(0, 0, -h);
    m.vertices.emplace_back(0, 0, h);
    for (std::uint32_t s = 0; s < n; ++s) {
      const std::uint32_t a = s, b = (s + 1) % n;
      m.triangles.push_back({cb, b, a});
      m.triangles.push_back({cb + 1, a + n, b + n});
    }
    return m;
  }
  const std::uint32_t i0 = 2 * n;
  for (double z : {-h, h})
    for (const auto& p : *inner) m.vertices.emplace_back(p.x(), p.y(), z);
  for (std::uint32_t s = 0; s < n; ++s) {
    const std::uint32_t a = s, b = (s + 1) % n;
    const std::uint32_t ia = i0 + a, ib = i0 + b;
    m.triangles.push_back({ia, ia + n, ib + n});  // hole wall faces the axis
    m.triangles.push_back({ia, ib + n, ib});
    m.triangles.push_back({a + n, b + n, ib + n});  // top annulus
    m.triangles.push_back({a + n, ib + n, ia + n});
    m.triangles.push_back({a, ib, b});  // bottom annulus
    m.triangles.push_back({a, ia, ib});
  }
  return m;
}

// Latitude-longitude mesh of the ellipsoid with semi-axes (a, b, c). Callers pass the ring
// count for half the tolerance: a quad's diagonal lies deeper than its edges' sagitta.
TriMesh ellipsoid(double a, double b, double c, int nLon) {
  const int nLat = std::max(4, nLon / 2);
  TriMesh m;
  m.vertices.emplace_back(0, 0, c);
  for (int t = 1; t < nLat; ++t) {
    const double th = kPi * t / nLat;
    for (int s = 0; s < nLon; ++s) {
      const double ph = 2 * kPi * s / nLon;
      m.vertices.emplace_back(a * std::sin(th) * std::cos(ph), b * std::sin(th) * std::sin(ph),
                              c * std::cos(th));
    }
  }
  const auto south = static_cast<std::uint32_t>(m.vertices.size());
  m.vertices.emplace_back(0, 0, -c);
  const auto L = static_cast<std::uint32_t>(nLon);
  auto ring = [&](int t, int s) {
    return 1 + static_cast<std::uint32_t>(t - 1) * L + static_cast<std::uint32_t>(s % nLon);
  };
  for (int s = 0; s < nLon; ++s) m.triangles.push_back({0, ring(1, s), ring(1, s + 1)});
  for (int t = 1; t + 1 < nLat; ++t)
    for (int s = 0; s < nLon; ++s) {
      m.triangles.push_back({ring(t, s), ring(t + 1, s), ring(t + 1, s + 1)});
      m.triangles.push_back({ring(t, s), ring(t + 1, s + 1), ring(t, s + 1)});
    }
  for (int s = 0; s < nLon; ++s)
    m.triangles.push_back({south, ring(nLat - 1, s + 1), ring(nLat - 1, s)});
  return m;
}

// A convex polytope's triangle oriented away from its centre.
void addOutward(TriMesh& m, std::uint32_t a, std::uint32_t b, std::uint32_t c, const Vec3& centre) {
  const Vec3 nrm = (m.vertices[b] - m.vertices[a]).cross(m.vertices[c] - m.vertices[a]);
  if (nrm.dot(m.vertices[a] - centre) >= 0)
    m.triangles.push_back({a, b, c});
  else
    m.triangles.push_back({a, c, b});
}

TriMesh box(const Vec3& lo, const Vec3& hi) {
  TriMesh m;
  for (int v = 0; v < 8; ++v)
    m.vertices.emplace_back(v & 1 ? hi.x() : lo.x(), v & 2 ? hi.y() : lo.y(),
                            v & 4 ? hi.z() : lo.z());
  const Vec3 c = (lo + hi) / 2;
  // Faces by the bit held fixed: quad (v0, v1, v3, v2) in the other two bits.
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int u = 1 << ((axis + 1) % 3), w = 1 << ((axis + 2) % 3), f = side << axis;
      const auto q0 = static_cast<std::uint32_t>(f), q1 = static_cast<std::uint32_t>(f | u),
                 q2 = static_cast<std::uint32_t>(f | u | w), q3 = static_cast<std::uint32_t>(f | w);
      addOutward(m, q0, q1, q2, c);
      addOutward(m, q0, q2, q3, c);
    }
  return m;
}

void scaleXY(TriMesh& m, double k) {
  for (auto& v : m.vertices) {
    v.x() *= k;
    v.y() *= k;
  }
}

void matchVolumePrism(TriMesh& m, double exact) {
  const double v = enclosedVolumeMm3(m);
  if (v > 0) scaleXY(m, std::sqrt(exact / v));
}

void matchVolumeUniform(TriMesh& m, double exact) {
  const double v = enclosedVolumeMm3(m);
  if (v > 0)
    for (auto& p : m.vertices) p *= std::cbrt(exact / v);
}

TriMesh meshFile(const ParsedSpec& s) {
  const double scale = s.has("scale") ? s.positive("scale") : 1.0;
  TriMesh m = readStl(*s.positional);
  for (auto& v : m.vertices) v *= scale;
  // Centre of mass of the enclosed solid (signed tetrahedra), as packer::meshShape.
  double vol = 0;
  Vec3 c = Vec3::Zero();
  for (const auto& t : m.triangles) {
    const Vec3 &a = m.vertices[t[0]], &b = m.vertices[t[1]], &d = m.vertices[t[2]];
    const double v6 = a.dot(b.cross(d));
    vol += v6;
    c += v6 * (a + b + d) / 4.0;
  }
  if (!(std::abs(vol) > 0)) throw InputError(*s.positional + ": the mesh encloses no volume");
  c /= vol;
  for (auto& v : m.vertices) v -= c;
  return m;
}

}  // namespace

int circleSegments(double radiusMm, double toleranceMm) {
  if (!(toleranceMm > 0) || !(radiusMm > 0))
    throw InputError("tessellation tolerance and radius must be > 0");
  if (toleranceMm >= radiusMm) return 8;
  const double half = std::acos(1.0 - toleranceMm / radiusMm);
  const double n = std::ceil(kPi / half);
  if (n > 1.0e6)
    throw InputError("tessellation tolerance too small for radius " + std::to_string(radiusMm));
  return std::max(8, static_cast<int>(n));
}

TriMesh tessellateShape(const std::string& spec, double tol, bool matchVolume) {
  const ParsedSpec s = parseSpec(spec, "shape");
  if (s.name == "mesh") {
    if (!s.positional) throw InputError("shape '" + spec + "': missing STL file");
    return meshFile(s);
  }
  const double exact = packer::parseShape(spec)->volumeMm3();  // validates the spec too
  if (s.name == "sphere") {
    const double r = s.positive("d") / 2;
    TriMesh m = ellipsoid(r, r, r, circleSegments(r, tol / 2));
    if (matchVolume) matchVolumeUniform(m, exact);
    return m;
  }
  if (s.name == "ellipsoid") {
    const double a = s.positive("a"), b = s.positive("b"), c = s.positive("c");
    TriMesh m = ellipsoid(a, b, c, circleSegments(std::max({a, b, c}), tol / 2));
    if (matchVolume) matchVolumeUniform(m, exact);
    return m;
  }
  if (s.name == "cylinder") {
    const double r = s.positive("d") / 2;
    TriMesh m = prism(circle(r, circleSegments(r, tol)), nullptr, s.positive("l") / 2);
    if (matchVolume) matchVolumePrism(m, exact);
    return m;
  }
  if (s.name == "ring") {
    const double r = s.positive("d") / 2, ri = s.positive("di") / 2;
    const int n = circleSegments(r, tol);
    const Poly outer = circle(r, n), inner = circle(ri, n);
    TriMesh m = prism(outer, &inner, s.positive("l") / 2);
    if (matchVolume) matchVolumePrism(m, exact);
    return m;
  }
  if (s.name == "box") {
    const Vec3 h(s.positive("x") / 2, s.positive("y") / 2, s.positive("z") / 2);
    return box(-h, h);
  }
  if (s.name == "trilobe") {
    const double d = s.positive("d");
    const double dl = s.has("dl") ? s.positive("dl") : d * 3 / 5;
    const double r = dl / 2, c = d / 2 - dl / 2;
    // The lobe arcs meet on the 60-degree bisectors (as packer's Trilobe).
    const double t = c / 2 + std::sqrt(r * r - 0.75 * c * c);
    const double halfArc = std::atan2(t * std::sqrt(3.0) / 2, t * 0.5 - c);
    const int m = std::max(2, static_cast<int>(std::ceil(circleSegments(r, tol) * halfArc / kPi)));
    Poly poly;
    for (int i = 0; i < 3; ++i) {
      const double a = 2 * kPi * i / 3;
      const Eigen::Vector2d centre(c * std::cos(a), c * std::sin(a));
      for (int k = 0; k < m; ++k) {
        const double th = a - halfArc + 2 * halfArc * k / m;
        poly.push_back(centre + r * Eigen::Vector2d(std::cos(th), std::sin(th)));
      }
    }
    TriMesh mesh = prism(poly, nullptr, s.positive("l") / 2);
    if (matchVolume) matchVolumePrism(mesh, exact);
    return mesh;
  }
  throw InputError("shape '" + spec + "': no tessellation for '" + s.name + "'");
}

TriMesh tessellateContainer(const std::string& spec, double tol) {
  const ParsedSpec s = parseSpec(spec, "container");
  if (s.name == "cylinder") {
    const double r = s.positive("d") / 2, h = s.positive("h");
    const int n = circleSegments(r, tol);
    // Circumscribed: the polygon's edges touch the exact wall from outside.
    TriMesh m = prism(circle(r / std::cos(kPi / n), n), nullptr, h / 2);
    for (auto& v : m.vertices) v.z() += h / 2;
    return m;
  }
  if (s.name == "box") {
    const double x = s.positive("x") / 2, y = s.positive("y") / 2, z = s.positive("z");
    return box(Vec3(-x, -y, 0), Vec3(x, y, z));
  }
  if (s.name == "mesh") {
    if (!s.positional) throw InputError("container '" + spec + "': missing STL file");
    const double scale = s.has("scale") ? s.positive("scale") : 1.0;
    TriMesh m = readStl(*s.positional);
    for (auto& v : m.vertices) v *= scale;
    return m;
  }
  return {};
}

TriMesh posed(const TriMesh& body, const Vec3& centreMm, const Quat& q, double scale) {
  TriMesh m;
  m.triangles = body.triangles;
  m.vertices.reserve(body.vertices.size());
  const Eigen::Matrix3d R = q.normalized().toRotationMatrix() * scale;
  for (const auto& v : body.vertices) m.vertices.push_back(R * v + centreMm);
  return m;
}

}  // namespace voxpack::exporter
