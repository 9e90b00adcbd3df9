#pragma once
// A branch-free float pre-test of listed surface nodes: which nodes may lie inside a
// cylinder (another particle), or outside an upright one or below its floor (the column). Its
// margins make it keep a superset of the nodes the exact double test accepts, so that test, run on
// the kept nodes in list order, gives the same bits as without the filter (docs/dem.md, "The
// listed-node filter").
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "system_impl.hpp"

namespace voxpack::packer::dem {

/// Margin of the filter as a fraction of the pose's extent S (the largest coordinate the
/// transform can produce); the float error of a transformed node stays below 2e-6 S.
inline constexpr double kFilterMargin = 3e-5;

/// One filter pass: p = m node + off in float; kept when |p_z| < z and p_x^2 + p_y^2 < r2
/// (the half length and the radius^2, margins added), or, for a column (`outside`), when
/// p_z < z or p_x^2 + p_y^2 > r2 (the floor and the radius^2, margins taken off).
struct NodeFilter {
  float m[9] = {}, off[3] = {};
  float z = 0, r2 = 0;
  bool outside = false;
};

/// The nodes' coordinates in float, one array per axis.
NodeCoords nodeCoordsOf(const std::vector<Vec3>& nodes);

/// Nodes that may lie inside a cylinder (radius r, half length hl, axis z, centred at 0)
/// after p = m node + off; extent bounds |p| (the pose's S).
NodeFilter insideCylinderFilter(const Eigen::Matrix3d& m, const Vec3& off, double extent, double r,
                                double hl);

/// Nodes that may lie outside an upright column (radius r, axis z through 0) or below its
/// floor (z = 0) after p = m node + off; extent bounds |p|.
NodeFilter outsideColumnFilter(const Eigen::Matrix3d& m, const Vec3& off, double extent, double r);

/// Writes to `kept`, in list order, the nodes of idx[0..n) the filter keeps; returns how
/// many. `kept` has room for n rounded up to a multiple of 8 (the vector path stores whole
/// batches). `avx2`: 8 nodes per instruction (the same float arithmetic, so the same nodes).
std::size_t filterNodes(const NodeFilter& f, const NodeCoords& nc, const std::uint32_t* idx,
                        std::size_t n, std::uint32_t* kept, bool avx2);

/// Calls fn(ni) for each node of `list` the filter keeps, in list order (the pair and the
/// wall loops share it; chunks of 64, a multiple of 8, as filterNodes stores whole batches).
template <class Fn>
void forEachKept(const NodeFilter& f, const NodeCoords& nc, const std::vector<std::uint32_t>& list,
                 bool avx2, Fn&& fn) {
  constexpr std::size_t kChunk = 64;
  std::uint32_t kept[kChunk];
  for (std::size_t c0 = 0; c0 < list.size(); c0 += kChunk) {
    const std::size_t n = std::min(list.size() - c0, kChunk);
    const std::size_t nk = filterNodes(f, nc, list.data() + c0, n, kept, avx2);
    for (std::size_t k = 0; k < nk; ++k) fn(kept[k]);
  }
}

}  // namespace voxpack::packer::dem
