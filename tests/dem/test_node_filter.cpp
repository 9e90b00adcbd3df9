// The listed-node filter (packer/dem/src/node_filter.hpp) must keep every node the exact
// double test accepts, in list order, and its AVX2 and scalar paths must keep the same
// nodes: otherwise the filtered narrow phase would lose hits and change the bed.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "node_filter.hpp"

namespace voxpack::packer::dem {
namespace {

struct Case {
  Eigen::Matrix3d m;
  Vec3 off;
  std::vector<Vec3> nodes;  // principal frame
  NodeCoords nc;
};

// Nodes in a ball of radius `ball`, half of them placed within 1e-9..1e-3 mm of `surface`
// (given the transformed point, returns a nearby point on the boundary).
// `offset` draws the translation.
template <class Offset, class Surface>
Case makeCaseAt(std::mt19937_64& rng, double ball, Offset offset, Surface surface) {
  std::uniform_real_distribution<double> u(-1, 1);
  Case c;
  c.m = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized().toRotationMatrix();
  c.off = offset(rng);
  for (int i = 0; i < 600; ++i) {
    Vec3 p(u(rng), u(rng), u(rng));
    p *= ball;
    if (i % 2) {  // onto the boundary, then off it by a tiny signed step
      const Vec3 pb = surface(c.m * p + c.off);
      const double step = std::pow(10.0, -9 + 6 * (u(rng) + 1) / 2) * (u(rng) > 0 ? 1 : -1);
      p = c.m.transpose() * (pb - c.off) + Vec3(step, -step, step);
    }
    c.nodes.push_back(p);
  }
  c.nc = nodeCoordsOf(c.nodes);
  return c;
}

template <class Surface>
Case makeCase(std::mt19937_64& rng, double ball, double offMax, Surface surface) {
  return makeCaseAt(
      rng, ball,
      [&](std::mt19937_64& g) -> Vec3 {
        std::uniform_real_distribution<double> u(-1, 1);
        const double a = u(g), b = u(g), z = u(g);
        return Vec3(a, b, z) * offMax;
      },
      surface);
}

// Checks the filter against the exact test on lists of every length 0..40 (tails of the
// 8-lane batches) and on the whole node set.
template <class Exact>
void checkSuperset(const Case& c, const NodeFilter& f, Exact exact, int& exactHits) {
  std::vector<std::uint32_t> all(c.nodes.size());
  for (std::uint32_t i = 0; i < all.size(); ++i) all[i] = i;
  std::vector<std::size_t> lengths;
  for (std::size_t n = 0; n <= 40; ++n) lengths.push_back(n);
  lengths.push_back(all.size());
  for (std::size_t start : {std::size_t{0}, std::size_t{5}})
    for (std::size_t n : lengths) {
      if (start + n > all.size()) continue;
      const std::uint32_t* idx = all.data() + start;
      // Room for whole batches (n rounded up to 8), and a guard word after it.
      const std::size_t room = (n + 7) / 8 * 8;
      std::vector<std::uint32_t> scalar(room + 1, 0xdeadbeef), vector(room + 1, 0xdeadbeef);
      const std::size_t ns = filterNodes(f, c.nc, idx, n, scalar.data(), false);
      ASSERT_EQ(scalar[room], 0xdeadbeefu);
      scalar.resize(ns);
      if (__builtin_cpu_supports("avx2")) {
        const std::size_t nv = filterNodes(f, c.nc, idx, n, vector.data(), true);
        ASSERT_EQ(vector[room], 0xdeadbeefu) << "the vector path wrote past its room";
        vector.resize(nv);
        ASSERT_EQ(scalar, vector) << "AVX2 and scalar paths kept different nodes";
      }
      ASSERT_TRUE(std::is_sorted(scalar.begin(), scalar.end())) << "list order lost";
      for (std::size_t k = 0; k < n; ++k) {
        const std::uint32_t ni = idx[k];
        if (!exact(c.m * c.nodes[ni] + c.off)) continue;
        if (n == all.size()) ++exactHits;
        ASSERT_TRUE(std::binary_search(scalar.begin(), scalar.end(), ni))
            << "node " << ni << " passes the exact test but was filtered out: p "
            << (c.m * c.nodes[ni] + c.off).transpose() << " f.z " << f.z << " f.r2 " << f.r2
            << " off " << c.off.transpose();
      }
    }
}

// How many of the case's nodes the filter keeps (a filter that kept everything would pass
// the superset test too: it must also reject).
int keptOfAll(const Case& c, const NodeFilter& f) {
  std::vector<std::uint32_t> all(c.nodes.size()), out(c.nodes.size() + 8);
  for (std::uint32_t i = 0; i < all.size(); ++i) all[i] = i;
  return static_cast<int>(filterNodes(f, c.nc, all.data(), all.size(), out.data(), false));
}

TEST(NodeFilter, KeepsEveryNodeInsideACylinderInListOrder) {
  std::mt19937_64 rng(7);
  const double r = 2.7, hl = 1.9;
  int exactHits = 0, kept = 0;
  for (int t = 0; t < 20; ++t) {
    const Case c = makeCase(rng, 3.3, 6.0, [&](const Vec3& p) -> Vec3 {
      const double rho = std::hypot(p.x(), p.y());
      // The nearer of the round side and the flat ends.
      if (std::abs(std::abs(p.z()) - hl) < std::abs(rho - r) || rho == 0)
        return Vec3(p.x(), p.y(), std::copysign(hl, p.z()));
      return Vec3(p.x() * r / rho, p.y() * r / rho, p.z());
    });
    const double extent = 3.3 * std::sqrt(3.0) + c.off.norm();
    const NodeFilter f = insideCylinderFilter(c.m, c.off, extent, r, hl);
    checkSuperset(
        c, f,
        [&](const Vec3& p) {  // narrow_phase.cpp's exact test
          return std::abs(p.z()) - hl < 0 && std::sqrt(p.x() * p.x() + p.y() * p.y()) - r < 0;
        },
        exactHits);
    kept += keptOfAll(c, f);
  }
  EXPECT_GT(exactHits, 300);  // the cases do reach inside
  EXPECT_LT(kept, 20 * 600 * 9 / 10);
}

// The column's filter (walls.cpp): a particle near the round wall or the floor of a column of
// radius 24 mm, low in the bed or far up it (a large extent, so larger float errors).
TEST(NodeFilter, KeepsEveryNodeOutsideAColumnInListOrder) {
  std::mt19937_64 rng(11);
  const double radius = 24.0;
  int exactHits = 0, kept = 0;
  for (int t = 0; t < 20; ++t) {
    const double height = t % 4 == 3 ? 240.0 : 0.0;  // far up: the floor is out of reach
    const Case c = makeCaseAt(
        rng, 3.3,
        [&](std::mt19937_64& g) -> Vec3 {
          std::uniform_real_distribution<double> u(0, 1);
          const double rho = radius - 4.0 * u(g), angle = 6.283185307179586 * u(g);
          return Vec3(rho * std::cos(angle), rho * std::sin(angle), height + 4.0 * u(g));
        },
        [&](const Vec3& p) -> Vec3 {
          const double rho = std::hypot(p.x(), p.y());
          if (std::abs(p.z()) < std::abs(radius - rho)) return Vec3(p.x(), p.y(), 0.0);
          return Vec3(p.x() * radius / rho, p.y() * radius / rho, p.z());
        });
    const double extent = 3.3 * std::sqrt(3.0) + c.off.norm();
    const NodeFilter f = outsideColumnFilter(c.m, c.off, extent, radius);
    checkSuperset(
        c, f,
        [&](const Vec3& p) {  // the column's wallDistanceMm < 0
          return std::min(radius - std::sqrt(p.x() * p.x() + p.y() * p.y()), p.z()) < 0;
        },
        exactHits);
    kept += keptOfAll(c, f);
  }
  EXPECT_GT(exactHits, 300);  // the cases do reach outside
  EXPECT_LT(kept, 20 * 600 * 9 / 10);
}

}  // namespace
}  // namespace voxpack::packer::dem
