// Containers: exact inside tests, wall distances and their digitisation to a mask.
#include "voxpack/packer/container.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <numbers>

#include "mesh_internal.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/spec.hpp"
#include "voxpack/packer/digitise.hpp"

namespace voxpack::packer {

void Container::insideRow(const Vec3& p0, const Vec3& step, int n, std::uint8_t* out) const {
  for (int s = 0; s < n; ++s) out[s] = inside(p0 + static_cast<double>(s) * step) ? 1 : 0;
}

namespace {

// Inward normal from central differences of the wall distance (outside points, edges).
Vec3 numericInwardNormal(const Container& c, const Vec3& p, double scale) {
  const double h = scale * 1e-6;
  Vec3 g;
  for (int a = 0; a < 3; ++a) {
    Vec3 e = Vec3::Zero();
    e[a] = h;
    g[a] = c.wallDistanceMm(p + e) - c.wallDistanceMm(p - e);
  }
  const double n = g.norm();
  return n > 0 ? Vec3(g / n) : Vec3(Vec3::UnitZ());
}

class CylinderContainer final : public Container {
 public:
  CylinderContainer(double d, double h) : r_(d / 2), h_(h) {}
  std::string spec() const override {
    return "cylinder:d=" + formatNumber(2 * r_) + ",h=" + formatNumber(h_);
  }
  bool inside(const Vec3& p) const override {
    return p.x() * p.x() + p.y() * p.y() <= r_ * r_ && p.z() >= 0 && p.z() <= h_;
  }
  double wallDistanceMm(const Vec3& p) const override {
    const double rho = std::hypot(p.x(), p.y());
    const double dr = rho - r_, dz = std::abs(p.z() - h_ / 2) - h_ / 2;
    return -(std::min(std::max(dr, dz), 0.0) + std::hypot(std::max(dr, 0.0), std::max(dz, 0.0)));
  }
  Vec3 inwardNormal(const Vec3& p) const override {
    if (!inside(p)) return numericInwardNormal(*this, p, r_ + h_);
    const double rho = std::hypot(p.x(), p.y());
    const double toSide = r_ - rho, toBottom = p.z(), toTop = h_ - p.z();
    if (toSide <= toBottom && toSide <= toTop && rho > 0)
      return Vec3(-p.x() / rho, -p.y() / rho, 0);
    return toBottom <= toTop ? Vec3(Vec3::UnitZ()) : Vec3(-Vec3::UnitZ());
  }
  BoundsMm boundsMm() const override { return {Vec3(-r_, -r_, 0), Vec3(r_, r_, h_)}; }
  double volumeMm3() const override { return std::numbers::pi * r_ * r_ * h_; }
  bool cylinderAxis(double& cx, double& cy, double& radius) const override {
    cx = 0;
    cy = 0;
    radius = r_;
    return true;
  }

 private:
  double r_, h_;
};

class BoxContainer final : public Container {
 public:
  BoxContainer(double x, double y, double z) : h_(x / 2, y / 2, z / 2) {}
  std::string spec() const override {
    return "box:x=" + formatNumber(2 * h_.x()) + ",y=" + formatNumber(2 * h_.y()) +
           ",z=" + formatNumber(2 * h_.z());
  }
  bool inside(const Vec3& p) const override {
    return std::abs(p.x()) <= h_.x() && std::abs(p.y()) <= h_.y() && p.z() >= 0 &&
           p.z() <= 2 * h_.z();
  }
  double wallDistanceMm(const Vec3& p) const override {
    const Vec3 d = (p - Vec3(0, 0, h_.z())).cwiseAbs() - h_;
    return -(std::min(d.maxCoeff(), 0.0) + d.cwiseMax(0.0).norm());
  }
  Vec3 inwardNormal(const Vec3& p) const override {
    if (!inside(p)) return numericInwardNormal(*this, p, h_.sum());
    const Vec3 q = p - Vec3(0, 0, h_.z());
    int best = 0;
    double gap = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
      const double g = h_[a] - std::abs(q[a]);
      if (g < gap) {
        gap = g;
        best = a;
      }
    }
    Vec3 n = Vec3::Zero();
    n[best] = q[best] > 0 ? -1 : 1;
    return n;
  }
  BoundsMm boundsMm() const override {
    return {Vec3(-h_.x(), -h_.y(), 0), Vec3(h_.x(), h_.y(), 2 * h_.z())};
  }
  double volumeMm3() const override { return 8 * h_.prod(); }

 private:
  Vec3 h_;
};

// Squared Euclidean distance transform along one line (Felzenszwalb & Huttenlocher 2012):
// f holds squared distances in (mm^2), spacing h between samples.
void edt1d(std::vector<double>& f, double h, std::vector<double>& d, std::vector<int>& v,
           std::vector<double>& z) {
  const int n = static_cast<int>(f.size());
  d.resize(f.size());
  v.resize(f.size());
  z.resize(f.size() + 1);
  const double inf = std::numeric_limits<double>::infinity();
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (f[q] == inf) continue;
    const double xq = q * h;
    while (k >= 0) {
      const double xv = v[k] * h;
      const double s = ((f[q] + xq * xq) - (f[v[k]] + xv * xv)) / (2 * (xq - xv));
      if (s <= z[k]) {
        --k;
      } else {
        break;
      }
    }
    ++k;
    v[k] = q;
    z[k] = k == 0 ? -inf
                  : ((f[q] + xq * xq) - (f[v[k - 1]] + (v[k - 1] * h) * (v[k - 1] * h))) /
                        (2 * (xq - v[k - 1] * h));
    z[k + 1] = inf;
  }
  if (k < 0) {
    std::fill(d.begin(), d.end(), inf);
  } else {
    int j = 0;
    for (int q = 0; q < n; ++q) {
      while (z[j + 1] < q * h) ++j;
      const double dx = (q - v[j]) * h;
      d[q] = dx * dx + f[v[j]];
    }
  }
  f.swap(d);
}

// Euclidean distance (mm) from each voxel centre to the nearest voxel centre where
// target(voxel) is true.
std::vector<float> distanceTo(const Grid<std::uint8_t>& g, std::uint8_t target) {
  const Lattice& l = g.lattice();
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> sq(l.size());
  for (std::size_t o = 0; o < l.size(); ++o) sq[o] = g[o] == target ? 0.0 : inf;
  std::vector<double> line, d, z;
  std::vector<int> v;
  auto pass = [&](std::int64_t n, double h, auto offsetOf, std::int64_t na, std::int64_t nb) {
    line.resize(static_cast<std::size_t>(n));
    for (std::int64_t a = 0; a < na; ++a)
      for (std::int64_t b = 0; b < nb; ++b) {
        for (std::int64_t t = 0; t < n; ++t)
          line[static_cast<std::size_t>(t)] = sq[offsetOf(a, b, t)];
        edt1d(line, h, d, v, z);
        for (std::int64_t t = 0; t < n; ++t)
          sq[offsetOf(a, b, t)] = line[static_cast<std::size_t>(t)];
      }
  };
  pass(
      nx, l.spacingMm[2], [&](auto k, auto j, auto i) { return l.offset(k, j, i); }, nz, ny);
  pass(
      ny, l.spacingMm[1], [&](auto k, auto i, auto j) { return l.offset(k, j, i); }, nz, nx);
  pass(
      nz, l.spacingMm[0], [&](auto j, auto i, auto k) { return l.offset(k, j, i); }, ny, nx);
  std::vector<float> out(l.size());
  for (std::size_t o = 0; o < l.size(); ++o)
    out[o] = static_cast<float>(std::sqrt(std::min(sq[o], 1e30)));
  return out;
}

// A container given as the mask of a bed file (absent mask: the whole lattice).
class MaskContainer final : public Container {
 public:
  MaskContainer(std::string path, Bed bed) : path_(std::move(path)) {
    if (bed.mask) {
      mask_ = std::move(*bed.mask);
    } else {
      mask_ = Grid<std::uint8_t>(bed.lattice(), 1);
    }
    const Lattice& l = mask_.lattice();
    std::size_t n = 0;
    for (std::size_t o = 0; o < mask_.size(); ++o) n += mask_[o];
    if (n == 0) throw InputError("container mask:" + path_ + ": the mask selects no voxel");
    volume_ = static_cast<double>(n) * l.voxelVolumeMm3();
    bool first = true;
    for (std::int64_t k = 0; k < l.nz(); ++k)
      for (std::int64_t j = 0; j < l.ny(); ++j)
        for (std::int64_t i = 0; i < l.nx(); ++i) {
          if (!mask_(k, j, i)) continue;
          const Vec3 c = l.centerMm(k, j, i);
          const Vec3 h(l.spacingMm[2] / 2, l.spacingMm[1] / 2, l.spacingMm[0] / 2);
          if (first) {
            bounds_ = {c - h, c + h};
            first = false;
          }
          bounds_.min = bounds_.min.cwiseMin(c - h);
          bounds_.max = bounds_.max.cwiseMax(c + h);
        }
  }
  std::string spec() const override { return "mask:" + path_; }
  const Lattice& lattice() const { return mask_.lattice(); }
  bool inside(const Vec3& p) const override {
    const Index3 x = mask_.lattice().nearestIndex(p);
    return mask_.lattice().contains(x.k, x.j, x.i) && mask_(x.k, x.j, x.i) != 0;
  }
  // Voxelised: distance between voxel centres minus half a voxel puts the wall on the
  // voxel faces; the lattice border counts as wall.
  double wallDistanceMm(const Vec3& p) const override {
    std::call_once(once_, [this] { buildField(); });
    const Lattice& l = mask_.lattice();
    const Index3 x = l.nearestIndex(p);
    if (!l.contains(x.k, x.j, x.i)) {
      const Vec3 lo = l.centerMm(0, 0, 0), hi = l.centerMm(l.nz() - 1, l.ny() - 1, l.nx() - 1);
      return -(p - p.cwiseMax(lo).cwiseMin(hi)).norm() - 0.5 * l.spacingMm[2];
    }
    return field_[l.offset(x.k, x.j, x.i)];
  }
  Vec3 inwardNormal(const Vec3& p) const override {
    const Lattice& l = mask_.lattice();
    Vec3 g;
    for (int a = 0; a < 3; ++a) {
      Vec3 e = Vec3::Zero();
      e[a] = l.spacingMm[2 - a];
      g[a] = wallDistanceMm(p + e) - wallDistanceMm(p - e);
    }
    const double n = g.norm();
    return n > 0 ? Vec3(g / n) : Vec3(Vec3::UnitZ());
  }
  BoundsMm boundsMm() const override { return bounds_; }
  double volumeMm3() const override { return volume_; }

 private:
  void buildField() const {
    const Lattice& l = mask_.lattice();
    const std::vector<float> toOut = distanceTo(mask_, 0), toIn = distanceTo(mask_, 1);
    field_.resize(l.size());
    const double hmin = std::min({l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]});
    for (std::int64_t k = 0; k < l.nz(); ++k)
      for (std::int64_t j = 0; j < l.ny(); ++j)
        for (std::int64_t i = 0; i < l.nx(); ++i) {
          const std::size_t o = l.offset(k, j, i);
          if (mask_[o]) {
            // Beyond the lattice is outside: the nearest outside centre is one step past
            // the border.
            const double border = std::min({(static_cast<double>(i) + 1) * l.spacingMm[2],
                                            (static_cast<double>(l.nx() - i)) * l.spacingMm[2],
                                            (static_cast<double>(j) + 1) * l.spacingMm[1],
                                            (static_cast<double>(l.ny() - j)) * l.spacingMm[1],
                                            (static_cast<double>(k) + 1) * l.spacingMm[0],
                                            (static_cast<double>(l.nz() - k)) * l.spacingMm[0]});
            field_[o] = static_cast<float>(std::min<double>(toOut[o], border) - 0.5 * hmin);
          } else {
            field_[o] = static_cast<float>(-(toIn[o] - 0.5 * hmin));
          }
        }
  }

  std::string path_;
  Grid<std::uint8_t> mask_;
  BoundsMm bounds_;
  double volume_ = 0;
  mutable std::once_flag once_;
  mutable std::vector<float> field_;
};

}  // namespace

std::shared_ptr<const Container> parseContainer(const std::string& text) {
  const ParsedSpec s = parseSpec(text, "container");
  if (s.name != "mesh" && s.name != "mask" && s.positional)
    throw InputError("container '" + text + "': unexpected item '" + *s.positional + "'");
  if (s.name == "cylinder") {
    s.allowOnly({"d", "h"});
    return std::make_shared<CylinderContainer>(s.positive("d"), s.positive("h"));
  }
  if (s.name == "box") {
    s.allowOnly({"x", "y", "z"});
    return std::make_shared<BoxContainer>(s.positive("x"), s.positive("y"), s.positive("z"));
  }
  if (s.name == "mesh") {
    s.allowOnly({"scale"});
    if (!s.positional)
      throw InputError("container '" + text + "': missing STL file (mesh:FILE.stl)");
    const double scale = s.has("scale") ? s.positive("scale") : 1.0;
    return makeMeshContainer(*s.positional, scale);
  }
  if (s.name == "mask") {
    s.allowOnly({});
    if (!s.positional)
      throw InputError("container '" + text + "': missing bed file (mask:FILE.h5)");
    return std::make_shared<MaskContainer>(*s.positional, readBed(*s.positional));
  }
  throw InputError("unknown container '" + s.name + "' in '" + text +
                   "' (expected cylinder, box, mesh, mask)");
}

Lattice latticeForContainer(const Container& c, double voxelMm, int marginVoxels) {
  if (!(voxelMm > 0) || !std::isfinite(voxelMm))
    throw InputError("voxel size must be a positive number of mm");
  if (marginVoxels < 0) throw InputError("lattice margin must be >= 0 voxels");
  // A mask container already lives on a lattice: keep it when the voxel size agrees, so
  // its mask is reproduced voxel for voxel.
  if (const auto* m = dynamic_cast<const MaskContainer*>(&c)) {
    const Lattice& l = m->lattice();
    if (l.isIsotropic() && std::abs(l.spacingMm[0] - voxelMm) <= 1e-9 * voxelMm) return l;
  }
  const BoundsMm b = c.boundsMm();
  const Vec3 ext = b.max - b.min;
  Lattice l;
  for (int a = 0; a < 3; ++a) {
    const double cells = std::ceil(ext[a] / voxelMm - 1e-9);
    const double n = std::max(1.0, cells) + 2.0 * marginVoxels;
    if (n > 1e6)
      throw InputError("container is " + std::to_string(n) +
                       " voxels across: voxel size too small");
    l.dims[2 - a] = static_cast<std::int64_t>(n);
    l.spacingMm[2 - a] = voxelMm;
    l.originMm[2 - a] = b.min[a] + (0.5 - marginVoxels) * voxelMm;
  }
  return l;
}

Grid<std::uint8_t> containerMask(const Container& c, const Lattice& lattice, int supersample) {
  if (supersample < 1 || supersample > 8)
    throw InputError("container mask: supersample must be in 1..8, got " +
                     std::to_string(supersample));
  Grid<std::uint8_t> mask(lattice, 0);
  const int ss = supersample;
  const std::int64_t nx = lattice.nx();
  const int nSamples = static_cast<int>(nx) * ss;
  std::vector<std::uint8_t> row(static_cast<std::size_t>(nSamples));
  std::vector<int> count(static_cast<std::size_t>(nx));
  const double sub = 1.0 / ss, off0 = -0.5 + 0.5 * sub;
  const double sx = lattice.spacingMm[2], sy = lattice.spacingMm[1], sz = lattice.spacingMm[0];
  const int need = (ss * ss * ss + 1) / 2;
  const Vec3 tie = kBoundaryTieBreak * Vec3(sx, sy, sz);
  for (std::int64_t k = 0; k < lattice.nz(); ++k)
    for (std::int64_t j = 0; j < lattice.ny(); ++j) {
      std::fill(count.begin(), count.end(), 0);
      for (int b = 0; b < ss; ++b)
        for (int a = 0; a < ss; ++a) {
          // Half-open rule of digitise.hpp: the sample p is judged at p + delta.
          const Vec3 p0 = lattice.centerMm(k, j, 0) +
                          Vec3(off0 * sx, (off0 + a * sub) * sy, (off0 + b * sub) * sz) + tie;
          c.insideRow(p0, Vec3(sx * sub, 0, 0), nSamples, row.data());
          for (int s = 0; s < nSamples; ++s)
            count[static_cast<std::size_t>(s / ss)] += row[static_cast<std::size_t>(s)];
        }
      std::uint8_t* dst = &mask(k, j, 0);
      for (std::int64_t i = 0; i < nx; ++i)
        dst[i] = count[static_cast<std::size_t>(i)] >= need ? 1 : 0;
    }
  return mask;
}

Grid<float> wallDistanceField(const Container& c, const Lattice& lattice) {
  Grid<float> f(lattice, 0.0f);
  for (std::int64_t k = 0; k < lattice.nz(); ++k)
    for (std::int64_t j = 0; j < lattice.ny(); ++j)
      for (std::int64_t i = 0; i < lattice.nx(); ++i)
        f(k, j, i) = static_cast<float>(c.wallDistanceMm(lattice.centerMm(k, j, i)));
  return f;
}

}  // namespace voxpack::packer
