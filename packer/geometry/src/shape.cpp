// Analytic master shapes and the shape spec parser. Formulas and derivations (ellipsoid
// area, trilobe cross-section) are in docs/shapes.md.
#include "voxpack/packer/shape.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <numbers>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/spec.hpp"

namespace voxpack::packer {

std::string formatNumber(double v) {
  std::array<char, 64> buf{};
  const auto r = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return std::string(buf.data(), r.ptr);
}

double Shape::volumeEquivalentDiameterMm() const {
  return std::cbrt(6.0 * volumeMm3() / std::numbers::pi);
}

Vec3 Shape::normal(const Vec3& p) const {
  // Central differences of the signed distance; the step is small against the shape but
  // far above rounding noise.
  const double h = std::max(boundingRadiusMm(), 1e-9) * 1e-5;
  Vec3 g;
  for (int a = 0; a < 3; ++a) {
    Vec3 e = Vec3::Zero();
    e[a] = h;
    g[a] = signedDistanceMm(p + e) - signedDistanceMm(p - e);
  }
  const double n = g.norm();
  if (!(n > 0)) return Vec3::UnitZ();
  return g / n;
}

BoundsMm Shape::bodyBoundsMm() const {
  const double r = boundingRadiusMm();
  return {Vec3::Constant(-r), Vec3::Constant(r)};
}

void Shape::insideRow(const Vec3& p0, const Vec3& step, int n, std::uint8_t* out) const {
  for (int s = 0; s < n; ++s) out[s] = inside(p0 + static_cast<double>(s) * step) ? 1 : 0;
}

namespace {

constexpr double kPi = std::numbers::pi;

// Shapes whose inside test is cheap inline code: one virtual call per row.
template <class Derived>
class AnalyticShape : public Shape {
 public:
  bool inside(const Vec3& p) const final {
    return static_cast<const Derived&>(*this).insideImpl(p);
  }
  // Rows are filled from the analytic intersection of the line with the shape: no test
  // per sample. Samples within rounding of the surface may differ from inside().
  void insideRow(const Vec3& p0, const Vec3& step, int n, std::uint8_t* out) const final {
    std::fill(out, out + n, std::uint8_t{0});
    static_cast<const Derived&>(*this).fillRow(p0, step, n, out);
  }
};

// Parameter interval [t0, t1] of the line p0 + t * step (in sample units).
struct Span {
  double t0 = -std::numeric_limits<double>::infinity();
  double t1 = std::numeric_limits<double>::infinity();
  bool empty() const { return !(t0 <= t1); }
  Span operator&(const Span& o) const { return {std::max(t0, o.t0), std::min(t1, o.t1)}; }
};
constexpr Span kNone{1, 0};

// Where |a + t b| <= h (one coordinate slab).
Span slab(double a, double b, double h) {
  if (std::abs(b) < 1e-300) return std::abs(a) <= h ? Span{} : kNone;
  double u = (-h - a) / b, v = (h - a) / b;
  if (u > v) std::swap(u, v);
  return {u, v};
}

// Where A t^2 + B t + C <= 0 for A >= 0 (a quadric along the line).
Span quadric(double A, double B, double C) {
  if (A < 1e-300) {
    if (std::abs(B) < 1e-300) return C <= 0 ? Span{} : kNone;
    return B > 0 ? Span{-std::numeric_limits<double>::infinity(), -C / B}
                 : Span{-C / B, std::numeric_limits<double>::infinity()};
  }
  const double disc = B * B - 4 * A * C;
  if (disc < 0) return kNone;
  // Numerically stable roots.
  const double q = -0.5 * (B + std::copysign(std::sqrt(disc), B));
  double r0 = q / A, r1 = q != 0 ? C / q : r0;
  if (r0 > r1) std::swap(r0, r1);
  return {r0, r1};
}

// Where x^2 + y^2 <= r^2 along the line (infinite cylinder around z, centre (cx, cy)).
Span disc(const Vec3& p0, const Vec3& step, double cx, double cy, double r) {
  const double ax = p0.x() - cx, ay = p0.y() - cy;
  return quadric(step.x() * step.x() + step.y() * step.y(), 2 * (ax * step.x() + ay * step.y()),
                 ax * ax + ay * ay - r * r);
}

// Sets out[s] = v for the integer samples s in the span, clipped to [0, n).
void paint(const Span& sp, int n, std::uint8_t* out, std::uint8_t v) {
  if (sp.empty()) return;
  const double lo = std::max(sp.t0, -1.0), hi = std::min(sp.t1, static_cast<double>(n));
  const int s0 = static_cast<int>(std::ceil(lo)), s1 = static_cast<int>(std::floor(hi));
  for (int s = std::max(s0, 0); s <= std::min(s1, n - 1); ++s) out[s] = v;
}

// Signed distance of a 2D point q = (a, b) to the rectangle |a| <= ha, |b| <= hb (exact).
double boxDistance2(double a, double b, double ha, double hb) {
  const double dx = std::abs(a) - ha, dy = std::abs(b) - hb;
  const double ox = std::max(dx, 0.0), oy = std::max(dy, 0.0);
  return std::min(std::max(dx, dy), 0.0) + std::hypot(ox, oy);
}

// Extrusion of a 2D signed distance d2 along z with half length h (exact when d2 is).
double extrude(double d2, double z, double h) {
  const double dz = std::abs(z) - h;
  const double ox = std::max(d2, 0.0), oz = std::max(dz, 0.0);
  return std::min(std::max(d2, dz), 0.0) + std::hypot(ox, oz);
}

class Sphere final : public AnalyticShape<Sphere> {
 public:
  explicit Sphere(double d) : r_(d / 2) {}
  bool insideImpl(const Vec3& p) const { return p.squaredNorm() <= r_ * r_; }
  void fillRow(const Vec3& p0, const Vec3& d, int n, std::uint8_t* out) const {
    paint(quadric(d.squaredNorm(), 2 * p0.dot(d), p0.squaredNorm() - r_ * r_), n, out, 1);
  }
  std::string spec() const override { return "sphere:d=" + formatNumber(2 * r_); }
  double volumeMm3() const override { return 4.0 / 3.0 * kPi * r_ * r_ * r_; }
  double surfaceMm2() const override { return 4 * kPi * r_ * r_; }
  double boundingRadiusMm() const override { return r_; }
  double signedDistanceMm(const Vec3& p) const override { return p.norm() - r_; }
  Vec3 normal(const Vec3& p) const override {
    const double n = p.norm();
    return n > 0 ? Vec3(p / n) : Vec3(Vec3::UnitZ());
  }
  Eigen::Matrix3d inertiaPerDensity() const override {
    return Eigen::Matrix3d::Identity() * (0.4 * volumeMm3() * r_ * r_);
  }
  double characteristicDiameterMm() const override { return 2 * r_; }

 private:
  double r_;
};

class Cylinder final : public AnalyticShape<Cylinder> {
 public:
  Cylinder(double d, double l) : r_(d / 2), h_(l / 2) {}
  bool insideImpl(const Vec3& p) const {
    return p.x() * p.x() + p.y() * p.y() <= r_ * r_ && std::abs(p.z()) <= h_;
  }
  void fillRow(const Vec3& p0, const Vec3& d, int n, std::uint8_t* out) const {
    paint(disc(p0, d, 0, 0, r_) & slab(p0.z(), d.z(), h_), n, out, 1);
  }
  std::string spec() const override {
    return "cylinder:d=" + formatNumber(2 * r_) + ",l=" + formatNumber(2 * h_);
  }
  double volumeMm3() const override { return kPi * r_ * r_ * 2 * h_; }
  double surfaceMm2() const override { return 2 * kPi * r_ * r_ + 2 * kPi * r_ * 2 * h_; }
  double boundingRadiusMm() const override { return std::hypot(r_, h_); }
  BoundsMm bodyBoundsMm() const override { return {Vec3(-r_, -r_, -h_), Vec3(r_, r_, h_)}; }
  double signedDistanceMm(const Vec3& p) const override {
    return extrude(std::hypot(p.x(), p.y()) - r_, p.z(), h_);
  }
  Eigen::Matrix3d inertiaPerDensity() const override {
    const double m = volumeMm3(), l = 2 * h_;
    Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
    I(0, 0) = I(1, 1) = m * (3 * r_ * r_ + l * l) / 12;
    I(2, 2) = m * r_ * r_ / 2;
    return I;
  }
  double characteristicDiameterMm() const override { return 2 * r_; }

 private:
  double r_, h_;
};

class Ring final : public AnalyticShape<Ring> {
 public:
  Ring(double d, double di, double l) : ro_(d / 2), ri_(di / 2), h_(l / 2) {}
  bool insideImpl(const Vec3& p) const {
    const double rr = p.x() * p.x() + p.y() * p.y();
    return rr <= ro_ * ro_ && rr >= ri_ * ri_ && std::abs(p.z()) <= h_;
  }
  void fillRow(const Vec3& p0, const Vec3& d, int n, std::uint8_t* out) const {
    const Span outer = disc(p0, d, 0, 0, ro_) & slab(p0.z(), d.z(), h_);
    if (outer.empty()) return;
    paint(outer, n, out, 1);
    // The hole is open (rr < ri^2): clear only samples strictly inside it.
    const Span hole = disc(p0, d, 0, 0, ri_);
    if (hole.empty()) return;
    const double lo = std::max(hole.t0, -1.0), hi = std::min(hole.t1, static_cast<double>(n));
    for (int s = std::max(static_cast<int>(std::floor(lo)) + 1, 0);
         s <= std::min(static_cast<int>(std::ceil(hi)) - 1, n - 1); ++s)
      out[s] = insideImpl(p0 + static_cast<double>(s) * d) ? 1 : 0;
  }
  std::string spec() const override {
    return "ring:d=" + formatNumber(2 * ro_) + ",di=" + formatNumber(2 * ri_) +
           ",l=" + formatNumber(2 * h_);
  }
  double volumeMm3() const override { return kPi * (ro_ * ro_ - ri_ * ri_) * 2 * h_; }
  double surfaceMm2() const override {
    return 2 * kPi * (ro_ * ro_ - ri_ * ri_) + 2 * kPi * (ro_ + ri_) * 2 * h_;
  }
  double boundingRadiusMm() const override { return std::hypot(ro_, h_); }
  BoundsMm bodyBoundsMm() const override { return {Vec3(-ro_, -ro_, -h_), Vec3(ro_, ro_, h_)}; }
  // The profile lies at rho > 0, so the distance in the meridian half-plane is exact.
  double signedDistanceMm(const Vec3& p) const override {
    const double rho = std::hypot(p.x(), p.y());
    return boxDistance2(rho - (ro_ + ri_) / 2, p.z(), (ro_ - ri_) / 2, h_);
  }
  Eigen::Matrix3d inertiaPerDensity() const override {
    const double m = volumeMm3(), l = 2 * h_, s = ro_ * ro_ + ri_ * ri_;
    Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
    I(0, 0) = I(1, 1) = m * (3 * s + l * l) / 12;
    I(2, 2) = m * s / 2;
    return I;
  }
  double characteristicDiameterMm() const override { return 2 * ro_; }

 private:
  double ro_, ri_, h_;
};

class Box final : public AnalyticShape<Box> {
 public:
  Box(double x, double y, double z) : h_(x / 2, y / 2, z / 2) {}
  bool insideImpl(const Vec3& p) const {
    return std::abs(p.x()) <= h_.x() && std::abs(p.y()) <= h_.y() && std::abs(p.z()) <= h_.z();
  }
  void fillRow(const Vec3& p0, const Vec3& d, int n, std::uint8_t* out) const {
    paint(slab(p0.x(), d.x(), h_.x()) & slab(p0.y(), d.y(), h_.y()) & slab(p0.z(), d.z(), h_.z()),
          n, out, 1);
  }
  std::string spec() const override {
    return "box:x=" + formatNumber(2 * h_.x()) + ",y=" + formatNumber(2 * h_.y()) +
           ",z=" + formatNumber(2 * h_.z());
  }
  double volumeMm3() const override { return 8 * h_.x() * h_.y() * h_.z(); }
  double surfaceMm2() const override {
    return 8 * (h_.x() * h_.y() + h_.y() * h_.z() + h_.x() * h_.z());
  }
  double boundingRadiusMm() const override { return h_.norm(); }
  BoundsMm bodyBoundsMm() const override { return {-h_, h_}; }
  double signedDistanceMm(const Vec3& p) const override {
    const Vec3 d = p.cwiseAbs() - h_;
    return std::min(d.maxCoeff(), 0.0) + d.cwiseMax(0.0).norm();
  }
  Eigen::Matrix3d inertiaPerDensity() const override {
    const double m = volumeMm3();
    const Vec3 e = 2 * h_;
    Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
    I(0, 0) = m * (e.y() * e.y() + e.z() * e.z()) / 12;
    I(1, 1) = m * (e.x() * e.x() + e.z() * e.z()) / 12;
    I(2, 2) = m * (e.x() * e.x() + e.y() * e.y()) / 12;
    return I;
  }
  double characteristicDiameterMm() const override { return 2 * h_.maxCoeff(); }

 private:
  Vec3 h_;
};

// Distance from (y0, y1), y >= 0, to the ellipse with semi-axes e0 >= e1 (Eberly,
// "Distance from a point to an ellipse, an ellipsoid, or a hyperellipsoid", bisection on
// the root of F(s) = sum (r_i z_i / (s + r_i))^2 - 1).
double bisectRoot(int n, const double* r, const double* z, double g) {
  double num[3];
  for (int i = 0; i < n; ++i) num[i] = r[i] * z[i];
  double s0 = z[n - 1] - 1;
  double s1 = 0;
  if (g >= 0) {
    double len = 0;
    for (int i = 0; i < n; ++i) len += num[i] * num[i];
    s1 = std::sqrt(len) - 1;
  }
  double s = 0;
  for (int it = 0; it < 200; ++it) {
    s = 0.5 * (s0 + s1);
    if (s == s0 || s == s1) break;
    double f = -1;
    for (int i = 0; i < n; ++i) {
      const double t = num[i] / (s + r[i]);
      f += t * t;
    }
    if (f > 0)
      s0 = s;
    else if (f < 0)
      s1 = s;
    else
      break;
  }
  return s;
}

double ellipseDistance(double e0, double e1, double y0, double y1) {
  if (y1 > 0) {
    if (y0 > 0) {
      const double z[2] = {y0 / e0, y1 / e1};
      const double g = z[0] * z[0] + z[1] * z[1] - 1;
      if (g == 0) return 0;
      const double r[2] = {(e0 / e1) * (e0 / e1), 1};
      const double s = bisectRoot(2, r, z, g);
      const double x0 = r[0] * y0 / (s + r[0]), x1 = y1 / (s + 1);
      return std::hypot(x0 - y0, x1 - y1);
    }
    return std::abs(y1 - e1);
  }
  const double numer = e0 * y0, denom = e0 * e0 - e1 * e1;
  if (numer < denom) {
    const double xd = numer / denom;
    const double x0 = e0 * xd, x1 = e1 * std::sqrt(std::max(0.0, 1 - xd * xd));
    return std::hypot(x0 - y0, x1);
  }
  return std::abs(y0 - e0);
}

// Same for an ellipsoid with e0 >= e1 >= e2 and y >= 0.
double ellipsoidDistance(const double e[3], const double y[3]) {
  if (y[2] > 0) {
    if (y[1] > 0) {
      if (y[0] > 0) {
        const double z[3] = {y[0] / e[0], y[1] / e[1], y[2] / e[2]};
        const double g = z[0] * z[0] + z[1] * z[1] + z[2] * z[2] - 1;
        if (g == 0) return 0;
        const double r[3] = {(e[0] / e[2]) * (e[0] / e[2]), (e[1] / e[2]) * (e[1] / e[2]), 1};
        const double s = bisectRoot(3, r, z, g);
        double d2 = 0;
        for (int i = 0; i < 3; ++i) {
          const double x = r[i] * y[i] / (s + r[i]);
          d2 += (x - y[i]) * (x - y[i]);
        }
        return std::sqrt(d2);
      }
      return ellipseDistance(e[1], e[2], y[1], y[2]);
    }
    if (y[0] > 0) return ellipseDistance(e[0], e[2], y[0], y[2]);
    return std::abs(y[2] - e[2]);
  }
  const double d0 = e[0] * e[0] - e[2] * e[2], d1 = e[1] * e[1] - e[2] * e[2];
  const double n0 = e[0] * y[0], n1 = e[1] * y[1];
  if (n0 < d0 && n1 < d1) {
    const double q0 = n0 / d0, q1 = n1 / d1, disc = 1 - q0 * q0 - q1 * q1;
    if (disc > 0) {
      const double x0 = e[0] * q0, x1 = e[1] * q1, x2 = e[2] * std::sqrt(disc);
      return std::sqrt((x0 - y[0]) * (x0 - y[0]) + (x1 - y[1]) * (x1 - y[1]) + x2 * x2);
    }
  }
  return ellipseDistance(e[0], e[1], y[0], y[1]);
}

class Ellipsoid final : public AnalyticShape<Ellipsoid> {
 public:
  Ellipsoid(double a, double b, double c)
      : ax_(a, b, c), inv2_(1 / (a * a), 1 / (b * b), 1 / (c * c)) {
    order_ = {0, 1, 2};
    std::sort(order_.begin(), order_.end(), [&](int u, int v) { return ax_[u] > ax_[v]; });
  }
  bool insideImpl(const Vec3& p) const {
    return p.x() * p.x() * inv2_.x() + p.y() * p.y() * inv2_.y() + p.z() * p.z() * inv2_.z() <= 1;
  }
  void fillRow(const Vec3& p0, const Vec3& d, int n, std::uint8_t* out) const {
    const Vec3 a = p0.cwiseProduct(inv2_), b = d.cwiseProduct(inv2_);
    paint(quadric(d.dot(b), 2 * p0.dot(b), p0.dot(a) - 1), n, out, 1);
  }
  std::string spec() const override {
    return "ellipsoid:a=" + formatNumber(ax_.x()) + ",b=" + formatNumber(ax_.y()) +
           ",c=" + formatNumber(ax_.z());
  }
  double volumeMm3() const override { return 4.0 / 3.0 * kPi * ax_.prod(); }
  // Legendre's form with incomplete elliptic integrals (docs/shapes.md).
  double surfaceMm2() const override {
    const double a = ax_[order_[0]], b = ax_[order_[1]], c = ax_[order_[2]];
    if (a - c <= 1e-12 * a) return 4 * kPi * a * a;
    const double phi = std::acos(c / a);
    const double k =
        std::sqrt(std::clamp(a * a * (b * b - c * c) / (b * b * (a * a - c * c)), 0.0, 1.0));
    const double sp = std::sin(phi), cp = std::cos(phi);
    return 2 * kPi * c * c +
           2 * kPi * a * b / sp *
               (std::ellint_2(k, phi) * sp * sp + std::ellint_1(k, phi) * cp * cp);
  }
  double boundingRadiusMm() const override { return ax_.maxCoeff(); }
  BoundsMm bodyBoundsMm() const override { return {-ax_, ax_}; }
  double signedDistanceMm(const Vec3& p) const override {
    const double e[3] = {ax_[order_[0]], ax_[order_[1]], ax_[order_[2]]};
    const double y[3] = {std::abs(p[order_[0]]), std::abs(p[order_[1]]), std::abs(p[order_[2]])};
    const double d = ellipsoidDistance(e, y);
    return insideImpl(p) ? -d : d;
  }
  Eigen::Matrix3d inertiaPerDensity() const override {
    const double m = volumeMm3();
    const Vec3 s = ax_.cwiseProduct(ax_);
    Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
    I(0, 0) = m * (s.y() + s.z()) / 5;
    I(1, 1) = m * (s.x() + s.z()) / 5;
    I(2, 2) = m * (s.x() + s.y()) / 5;
    return I;
  }
  double characteristicDiameterMm() const override { return 2 * ax_.maxCoeff(); }

 private:
  Vec3 ax_, inv2_;
  std::array<int, 3> order_{};
};

// Trilobe extrudate: the union of three overlapping discs of radius r whose centres lie
// at distance c from the axis at angles 0, 120, 240 degrees from +x, extruded along z.
// The outer diameter is d = 2 (c + r).
class Trilobe final : public AnalyticShape<Trilobe> {
 public:
  Trilobe(double d, double dl, double l)
      : d_(d), dl_(dl), r_(dl / 2), c_(d / 2 - dl / 2), h_(l / 2) {
    for (int i = 0; i < 3; ++i) {
      const double a = 2 * kPi * i / 3;
      centre_[i] = {c_ * std::cos(a), c_ * std::sin(a)};
      dir_[i] = {std::cos(a), std::sin(a)};
    }
    // Outer vertex of lobes 0 and 1 lies on the 60-degree bisector at distance t.
    const double t = c_ / 2 + std::sqrt(r_ * r_ - 0.75 * c_ * c_);
    const Eigen::Vector2d v(t * 0.5, t * std::sqrt(3.0) / 2);
    const Eigen::Vector2d w = v - centre_[0];
    halfArc_ = std::atan2(w.y(), w.x());
    computeSection();
  }
  bool inside2(double x, double y) const {
    for (int i = 0; i < 3; ++i) {
      const double dx = x - centre_[i].x(), dy = y - centre_[i].y();
      if (dx * dx + dy * dy <= r_ * r_) return true;
    }
    return false;
  }
  bool insideImpl(const Vec3& p) const { return std::abs(p.z()) <= h_ && inside2(p.x(), p.y()); }
  void fillRow(const Vec3& p0, const Vec3& d, int n, std::uint8_t* out) const {
    const Span z = slab(p0.z(), d.z(), h_);
    if (z.empty()) return;
    for (int i = 0; i < 3; ++i)
      paint(disc(p0, d, centre_[i].x(), centre_[i].y(), r_) & z, n, out, 1);
  }
  std::string spec() const override {
    return "trilobe:d=" + formatNumber(d_) + ",dl=" + formatNumber(dl_) +
           ",l=" + formatNumber(2 * h_);
  }
  double volumeMm3() const override { return area_ * 2 * h_; }
  double surfaceMm2() const override { return 2 * area_ + perimeter_ * 2 * h_; }
  double boundingRadiusMm() const override { return std::hypot(c_ + r_, h_); }
  BoundsMm bodyBoundsMm() const override {
    // Lobe 0 reaches x = c + r; lobes 1, 2 reach x = -c/2 - r and |y| <= c sin60 + r.
    const double ymax = c_ * std::sqrt(3.0) / 2 + r_;
    return {Vec3(-c_ / 2 - r_, -ymax, -h_), Vec3(c_ + r_, ymax, h_)};
  }
  // Exact: distance to the three outer arcs (or their end vertices), extruded.
  double signedDistanceMm(const Vec3& p) const override {
    const Eigen::Vector2d q(p.x(), p.y());
    double dist = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector2d v = q - centre_[i];
      const double along = v.dot(dir_[i]);
      const double across = dir_[i].x() * v.y() - dir_[i].y() * v.x();
      const double ang = std::atan2(across, along);
      if (std::abs(ang) <= halfArc_) {
        dist = std::min(dist, std::abs(v.norm() - r_));
      } else {
        const double a = std::atan2(dir_[i].y(), dir_[i].x()) + (ang > 0 ? halfArc_ : -halfArc_);
        const Eigen::Vector2d vert = centre_[i] + r_ * Eigen::Vector2d(std::cos(a), std::sin(a));
        dist = std::min(dist, (q - vert).norm());
      }
    }
    return extrude(inside2(p.x(), p.y()) ? -dist : dist, p.z(), h_);
  }
  Eigen::Matrix3d inertiaPerDensity() const override {
    // Three-fold symmetry makes the in-plane second moment isotropic: J/2 per axis.
    const double l = 2 * h_;
    Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
    I(0, 0) = I(1, 1) = l * polar_ / 2 + area_ * l * l * l / 12;
    I(2, 2) = l * polar_;
    return I;
  }
  double characteristicDiameterMm() const override { return 2 * (c_ + r_); }

 private:
  // Area, perimeter and polar moment of the cross-section by Green's theorem along the
  // three outer arcs (Simpson's rule; the integrands are low-order trigonometric
  // polynomials, so 2048 intervals are exact to rounding).
  void computeSection() {
    const int n = 2048;
    double area = 0, polar = 0;
    for (int i = 0; i < 3; ++i) {
      const double a0 = std::atan2(dir_[i].y(), dir_[i].x());
      const double cx = centre_[i].x(), cy = centre_[i].y();
      for (int s = 0; s <= n; ++s) {
        const double th = a0 - halfArc_ + 2 * halfArc_ * s / n;
        const double w = (s == 0 || s == n) ? 1 : (s % 2 ? 4 : 2);
        const double x = cx + r_ * std::cos(th), y = cy + r_ * std::sin(th);
        const double dx = -r_ * std::sin(th), dy = r_ * std::cos(th);
        area += w * 0.5 * (x * dy - y * dx);
        polar += w * (x * x * x * dy - y * y * y * dx) / 3;
      }
    }
    const double hstep = 2 * halfArc_ / n / 3;
    area_ = area * hstep;
    polar_ = polar * hstep;
    perimeter_ = 3 * r_ * 2 * halfArc_;
  }

  double d_, dl_;  // as given, for the canonical spec
  double r_, c_, h_;
  std::array<Eigen::Vector2d, 3> centre_, dir_;
  double halfArc_ = 0, area_ = 0, polar_ = 0, perimeter_ = 0;
};

const char* kShapeNames = "sphere, cylinder, ring, box, ellipsoid, trilobe, mesh";

}  // namespace

std::shared_ptr<const Shape> parseShape(const std::string& text) {
  const ParsedSpec s = parseSpec(text, "shape");
  if (s.name != "mesh" && s.positional)
    throw InputError("shape '" + text + "': unexpected item '" + *s.positional + "'");
  if (s.name == "sphere") {
    s.allowOnly({"d"});
    return std::make_shared<Sphere>(s.positive("d"));
  }
  if (s.name == "cylinder") {
    s.allowOnly({"d", "l"});
    return std::make_shared<Cylinder>(s.positive("d"), s.positive("l"));
  }
  if (s.name == "ring") {
    s.allowOnly({"d", "di", "l"});
    const double d = s.positive("d"), di = s.positive("di"), l = s.positive("l");
    if (!(di < d))
      throw InputError("shape '" + text + "': inner diameter di must be < d (got di=" +
                       formatNumber(di) + ", d=" + formatNumber(d) + ")");
    return std::make_shared<Ring>(d, di, l);
  }
  if (s.name == "box") {
    s.allowOnly({"x", "y", "z"});
    return std::make_shared<Box>(s.positive("x"), s.positive("y"), s.positive("z"));
  }
  if (s.name == "ellipsoid") {
    s.allowOnly({"a", "b", "c"});
    return std::make_shared<Ellipsoid>(s.positive("a"), s.positive("b"), s.positive("c"));
  }
  if (s.name == "trilobe") {
    s.allowOnly({"d", "dl", "l"});
    const double d = s.positive("d"), l = s.positive("l");
    const double dl = s.has("dl") ? s.positive("dl") : d * 3 / 5;  // 0.6 d
    // Lobes must overlap past the axis (c < r) so the section is one simply connected
    // region; dl = d would be a plain cylinder.
    if (!(dl > d / 2 && dl < d))
      throw InputError("shape '" + text + "': lobe diameter dl must lie in (d/2, d) (got dl=" +
                       formatNumber(dl) + ", d=" + formatNumber(d) + ")");
    return std::make_shared<Trilobe>(d, dl, l);
  }
  if (s.name == "mesh") {
    s.allowOnly({"scale"});
    if (!s.positional) throw InputError("shape '" + text + "': missing STL file (mesh:FILE.stl)");
    const double scale = s.has("scale") ? s.positive("scale") : 1.0;
    return meshShape(*s.positional, scale);
  }
  throw InputError("unknown shape '" + s.name + "' in '" + text + "' (expected " +
                   std::string(kShapeNames) + ")");
}

}  // namespace voxpack::packer
