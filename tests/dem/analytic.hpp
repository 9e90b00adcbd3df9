#pragma once
// Exact test shapes and containers for the DEM tests (no dependency on the geometry module).
#include <algorithm>
#include <cmath>

#include "voxpack/packer/dem.hpp"

namespace voxpack::test {

using packer::dem::DemContainer;
using packer::dem::DemShape;

inline constexpr double kPi = 3.14159265358979323846;

/// Sphere of diameter d.
class TestSphere final : public DemShape {
 public:
  explicit TestSphere(double d) : r_(0.5 * d) {}
  std::string spec() const override { return "sphere:d=" + std::to_string(2 * r_); }
  double volumeMm3() const override { return 4.0 / 3.0 * kPi * r_ * r_ * r_; }
  Eigen::Matrix3d inertiaPerDensity() const override {
    return Eigen::Matrix3d::Identity() * (0.4 * volumeMm3() * r_ * r_);
  }
  double boundingRadiusMm() const override { return r_; }
  bool inside(const Vec3& p) const override { return p.norm() <= r_; }
  double signedDistanceMm(const Vec3& p) const override { return p.norm() - r_; }
  Vec3 normal(const Vec3& p) const override {
    const double n = p.norm();
    return n > 0 ? Vec3(p / n) : Vec3(0, 0, 1);
  }

 private:
  double r_;
};

/// Sphere of diameter d that declares its closed form (the DEM's fast sphere path).
class TestFastSphere final : public DemShape {
 public:
  explicit TestFastSphere(double d) : s_(d), r_(0.5 * d) {}
  std::string spec() const override { return s_.spec(); }
  double volumeMm3() const override { return s_.volumeMm3(); }
  Eigen::Matrix3d inertiaPerDensity() const override { return s_.inertiaPerDensity(); }
  double boundingRadiusMm() const override { return r_; }
  bool inside(const Vec3& p) const override { return s_.inside(p); }
  double signedDistanceMm(const Vec3& p) const override { return s_.signedDistanceMm(p); }
  Vec3 normal(const Vec3& p) const override { return s_.normal(p); }
  int analyticForm(double& r, double& hl) const override {
    r = r_;
    hl = 0;
    return 1;
  }

 private:
  TestSphere s_;
  double r_;
};

/// Solid cylinder of diameter d and length l, axis z.
class TestCylinder final : public DemShape {
 public:
  TestCylinder(double d, double l) : r_(0.5 * d), hl_(0.5 * l) {}
  std::string spec() const override {
    return "cylinder:d=" + std::to_string(2 * r_) + ",l=" + std::to_string(2 * hl_);
  }
  double volumeMm3() const override { return kPi * r_ * r_ * 2 * hl_; }
  Eigen::Matrix3d inertiaPerDensity() const override {
    const double v = volumeMm3(), l = 2 * hl_;
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    m(0, 0) = m(1, 1) = v * (3 * r_ * r_ + l * l) / 12;
    m(2, 2) = v * r_ * r_ / 2;
    return m;
  }
  double boundingRadiusMm() const override { return std::hypot(r_, hl_); }
  bool inside(const Vec3& p) const override {
    return std::hypot(p.x(), p.y()) <= r_ && std::abs(p.z()) <= hl_;
  }
  double signedDistanceMm(const Vec3& p) const override {
    const double dr = std::hypot(p.x(), p.y()) - r_, dz = std::abs(p.z()) - hl_;
    return std::hypot(std::max(dr, 0.0), std::max(dz, 0.0)) + std::min(std::max(dr, dz), 0.0);
  }
  Vec3 normal(const Vec3& p) const override {
    const double rho = std::hypot(p.x(), p.y());
    const Vec3 radial = rho > 0 ? Vec3(p.x() / rho, p.y() / rho, 0) : Vec3(1, 0, 0);
    const Vec3 axial(0, 0, p.z() >= 0 ? 1 : -1);
    const double dr = rho - r_, dz = std::abs(p.z()) - hl_;
    if (dr > 0 && dz > 0) return (dr * radial + dz * axial).normalized();
    return dr > dz ? radial : axial;
  }

 private:
  double r_, hl_;
};

/// Open-top vertical cylinder of diameter d, floor at z = 0.
class TestColumn final : public DemContainer {
 public:
  explicit TestColumn(double d, double h = 100) : r_(0.5 * d), h_(h) {}
  double wallDistanceMm(const Vec3& p) const override {
    return std::min(r_ - std::hypot(p.x(), p.y()), p.z());
  }
  Vec3 inwardNormal(const Vec3& p) const override {
    const double rho = std::hypot(p.x(), p.y());
    if (p.z() < r_ - rho) return Vec3(0, 0, 1);
    return rho > 0 ? Vec3(-p.x() / rho, -p.y() / rho, 0) : Vec3(0, 0, 1);
  }
  // Two contact regions: the floor (5) and the round side (0).
  int wallRegion(const Vec3& p) const override {
    return p.z() < r_ - std::hypot(p.x(), p.y()) ? 5 : 0;
  }
  int nearWalls(const Vec3& p, double reach, packer::dem::WallPatch* out) const override {
    int n = 0;
    if (p.z() < reach) out[n++] = {p.z(), Vec3(0, 0, 1), 5};
    const double rho = std::hypot(p.x(), p.y());
    if (rho > 0 && r_ - rho < reach) out[n++] = {r_ - rho, Vec3(-p.x() / rho, -p.y() / rho, 0), 0};
    return n;
  }
  Vec3 minMm() const override { return Vec3(-r_, -r_, 0); }
  Vec3 maxMm() const override { return Vec3(r_, r_, h_); }

 private:
  double r_, h_;
};

/// A floor tilted by `angle` (rad) about the x axis: the half-space above the plane through
/// the origin with normal (0, -sin a, cos a).
class TestIncline final : public DemContainer {
 public:
  explicit TestIncline(double angle) : n_(0, -std::sin(angle), std::cos(angle)) {}
  double wallDistanceMm(const Vec3& p) const override { return p.dot(n_); }
  Vec3 inwardNormal(const Vec3&) const override { return n_; }
  int wallRegion(const Vec3&) const override { return 5; }
  Vec3 minMm() const override { return Vec3(-500, -500, -500); }
  Vec3 maxMm() const override { return Vec3(500, 500, 500); }

 private:
  Vec3 n_;
};

/// Open-top box [-a/2, a/2]^2 x [0, h].
class TestBox final : public DemContainer {
 public:
  explicit TestBox(double a, double h = 100) : a_(0.5 * a), h_(h) {}
  double wallDistanceMm(const Vec3& p) const override {
    return std::min({a_ - std::abs(p.x()), a_ - std::abs(p.y()), p.z()});
  }
  Vec3 inwardNormal(const Vec3& p) const override {
    const double dx = a_ - std::abs(p.x()), dy = a_ - std::abs(p.y()), dz = p.z();
    if (dz <= dx && dz <= dy) return Vec3(0, 0, 1);
    if (dx <= dy) return Vec3(p.x() > 0 ? -1 : 1, 0, 0);
    return Vec3(0, p.y() > 0 ? -1 : 1, 0);
  }
  Vec3 minMm() const override { return Vec3(-a_, -a_, 0); }
  Vec3 maxMm() const override { return Vec3(a_, a_, h_); }

 private:
  double a_, h_;
};

}  // namespace voxpack::test
