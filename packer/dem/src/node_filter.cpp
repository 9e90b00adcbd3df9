// The listed-node filter (node_filter.hpp): scalar, and AVX2 with gathers. The outcome is
// close to random per node, so it is computed as a mask and the kept indices written
// unconditionally (a branch mispredicted), in float (half the bytes and twice the lanes of
// double; the margins cover its error).
#include "node_filter.hpp"

#include <immintrin.h>

#include <algorithm>
#include <cmath>

namespace voxpack::packer::dem {
namespace {

// The filter's test on one node or batch: inside a particle, or outside the column.
template <bool Outside>
std::size_t filterScalar(const NodeFilter& f, const NodeCoords& nc, const std::uint32_t* idx,
                         std::size_t n, std::uint32_t* kept) {
  std::size_t nk = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t ni = idx[i];
    const float x = nc.x[ni], y = nc.y[ni], z = nc.z[ni];
    const float px = f.m[0] * x + f.m[1] * y + f.m[2] * z + f.off[0];
    const float py = f.m[3] * x + f.m[4] * y + f.m[5] * z + f.off[1];
    const float pz = f.m[6] * x + f.m[7] * y + f.m[8] * z + f.off[2];
    const float rr = px * px + py * py;
    kept[nk] = ni;
    if constexpr (Outside)
      nk += (pz < f.z) | (rr > f.r2);
    else
      nk += (std::abs(pz) < f.z) & (rr < f.r2);
  }
  return nk;
}

// For each 8-bit keep mask, the kept lanes in order, one byte each: a batch's kept indices
// are one permute and one store (AVX2 has no compress instruction).
struct CompressTable {
  std::uint64_t lanes[256];
  constexpr CompressTable() : lanes() {
    for (unsigned bits = 0; bits < 256; ++bits) {
      std::uint64_t packed = 0;
      unsigned at = 0;
      for (unsigned b = 0; b < 8; ++b)
        if (bits >> b & 1u) packed |= std::uint64_t{b} << (8 * at++);
      lanes[bits] = packed;
    }
  }
};
constexpr CompressTable kCompress;

template <bool Outside>
__attribute__((target("avx2,popcnt"))) std::size_t filterAvx2(const NodeFilter& f,
                                                              const NodeCoords& nc,
                                                              const std::uint32_t* idx,
                                                              std::size_t n, std::uint32_t* kept) {
  __m256 m[9];
  for (int k = 0; k < 9; ++k) m[k] = _mm256_set1_ps(f.m[k]);
  const __m256 o[3] = {_mm256_set1_ps(f.off[0]), _mm256_set1_ps(f.off[1]),
                       _mm256_set1_ps(f.off[2])};
  const __m256 zb = _mm256_set1_ps(f.z), r2 = _mm256_set1_ps(f.r2), sign = _mm256_set1_ps(-0.0f);
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  std::size_t nk = 0;
  // The last batch runs with its lanes past n masked off (no index read or gathered there),
  // so no node goes through the scalar twin.
  for (std::size_t i = 0; i < n; i += 8) {
    const int rem = static_cast<int>(std::min<std::size_t>(8, n - i));
    const __m256i on = _mm256_cmpgt_epi32(_mm256_set1_epi32(rem), lane);
    const __m256i vi = _mm256_maskload_epi32(reinterpret_cast<const int*>(idx + i), on);
    const __m256 onPs = _mm256_castsi256_ps(on), zero = _mm256_setzero_ps();
    const __m256 x = _mm256_mask_i32gather_ps(zero, nc.x.data(), vi, onPs, 4);
    const __m256 y = _mm256_mask_i32gather_ps(zero, nc.y.data(), vi, onPs, 4);
    const __m256 z = _mm256_mask_i32gather_ps(zero, nc.z.data(), vi, onPs, 4);
    // Each row in the scalar filter's order: ((m0 x + m1 y) + m2 z) + o.
    __m256 p[3];
    for (int r = 0; r < 3; ++r)
      p[r] = _mm256_add_ps(
          _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(m[3 * r], x), _mm256_mul_ps(m[3 * r + 1], y)),
                        _mm256_mul_ps(m[3 * r + 2], z)),
          o[r]);
    const __m256 rr = _mm256_add_ps(_mm256_mul_ps(p[0], p[0]), _mm256_mul_ps(p[1], p[1]));
    __m256 keep;
    if constexpr (Outside)
      keep = _mm256_or_ps(_mm256_cmp_ps(p[2], zb, _CMP_LT_OQ), _mm256_cmp_ps(rr, r2, _CMP_GT_OQ));
    else
      keep = _mm256_and_ps(_mm256_cmp_ps(_mm256_andnot_ps(sign, p[2]), zb, _CMP_LT_OQ),
                           _mm256_cmp_ps(rr, r2, _CMP_LT_OQ));
    const unsigned bits = static_cast<unsigned>(_mm256_movemask_ps(_mm256_and_ps(keep, onPs)));
    const __m256i perm =
        _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(static_cast<long long>(kCompress.lanes[bits])));
    // Writes 8 lanes at kept + nk (nk <= i): within n rounded up to a multiple of 8.
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(kept + nk),
                        _mm256_permutevar8x32_epi32(vi, perm));
    nk += static_cast<std::size_t>(__builtin_popcount(bits));
  }
  return nk;
}

}  // namespace

NodeCoords nodeCoordsOf(const std::vector<Vec3>& nodes) {
  NodeCoords nc;
  for (const Vec3& p : nodes) {
    nc.x.push_back(static_cast<float>(p.x()));
    nc.y.push_back(static_cast<float>(p.y()));
    nc.z.push_back(static_cast<float>(p.z()));
  }
  return nc;
}

namespace {

// A filter with the pose p = m node + off in float and no bounds yet.
NodeFilter withPose(const Eigen::Matrix3d& m, const Vec3& off) {
  NodeFilter f;
  for (int i = 0; i < 3; ++i) {
    for (int c = 0; c < 3; ++c) f.m[3 * i + c] = static_cast<float>(m(i, c));
    f.off[i] = static_cast<float>(off[i]);
  }
  return f;
}

}  // namespace

NodeFilter insideCylinderFilter(const Eigen::Matrix3d& m, const Vec3& off, double extent, double r,
                                double hl) {
  NodeFilter f = withPose(m, off);
  f.z = static_cast<float>(hl + kFilterMargin * extent);
  f.r2 = static_cast<float>(r * r + kFilterMargin * extent * extent);
  return f;
}

NodeFilter outsideColumnFilter(const Eigen::Matrix3d& m, const Vec3& off, double extent, double r) {
  NodeFilter f = withPose(m, off);
  f.z = static_cast<float>(kFilterMargin * extent);
  f.r2 = static_cast<float>(r * r - kFilterMargin * extent * extent);
  f.outside = true;
  return f;
}

std::size_t filterNodes(const NodeFilter& f, const NodeCoords& nc, const std::uint32_t* idx,
                        std::size_t n, std::uint32_t* kept, bool avx2) {
  if (f.outside)
    return avx2 ? filterAvx2<true>(f, nc, idx, n, kept) : filterScalar<true>(f, nc, idx, n, kept);
  return avx2 ? filterAvx2<false>(f, nc, idx, n, kept) : filterScalar<false>(f, nc, idx, n, kept);
}

}  // namespace voxpack::packer::dem
