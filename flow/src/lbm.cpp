// D3Q19 TRT lattice Boltzmann on fluid cells only.
//
// Storage: populations as deviations from the rest equilibrium (f - w_q), cell-major
// f[cell * 19 + q] (measured 2x less CPU time than structure-of-arrays f[q * N + cell], whose
// 18 gather + 19 write + 18 index streams overwhelm the prefetchers); the deviation keeps float32
// accurate (the values are ~1e-3 of w_q, so float's 24 bits hold the flow instead of the constant
// w_q). Two lattices, pull scheme: one pass reads the post-collision populations of the neighbours
// (or, behind a wall, the cell's own opposite population: halfway bounce-back), collides in the
// populations' precision, writes the new post-collision populations. float32 collides in float
// (8 lanes per AVX2 instruction instead of 4): k moved by <= 2e-6 against 3e-8 with a double
// collision of the same float populations, 1.1-1.6x faster (docs/flow.md, "float32 against
// float64"); the force's source terms lose nothing by it (a tiny term keeps float's relative
// precision; what float cannot hold is its sum with the population, stored in float anyway). The
// step's sums (mass, velocity) accumulate in double. The pull source of every (cell, q) is a
// precomputed index into the population array (indirect addressing), so the kernel is a
// plain loop over fluid cells. Every cell's update depends on the old lattice only, and
// reductions are summed per fixed block of cells and then in block order, so the result
// is bitwise identical for any thread count.
//
// AA streaming (Bailey, Myre, Walsh, Lilja & Saar 2009), the default without interpolated
// walls: one lattice, updated in place. An even step reads a cell's own incoming populations
// f_q = A[x][q], collides, and writes f*_q to A[x][qbar] (a purely local pass, no index). An
// odd step reads f_q from L(x, q) = A[x - c_q][qbar] (or A[x][q] behind a wall) and writes
// f*_qbar back to the same L(x, q); after it A[y][q] holds f*_q(y - c_q), the incoming
// population of the next even step. Every location is read and written by one cell only in
// each step, so the pass is race-free, and a cell's collision sees exactly the values the
// pull scheme gives it: the two schemes produce the same bits. L is the pull index with the
// slot's direction reversed, so both use 18 indices per cell.
//
// Interpolated walls (LbmDomain::signedDistance): Bouzidi, Firdaouss & Lallemand (2001)
// linear interpolation. A wall link is a (fluid cell, incoming direction) whose pull source
// is a solid cell; its wall cut q along the link comes from the signed distance. After the
// pull, the incoming population is replaced by a*f[i1] + b*f[i2] of post-collision values
// (q < 1/2: 2q f_i(x) + (1-2q) f_i(x + c_q), q >= 1/2: f_i(x)/(2q) + (2q-1)/(2q) f_q(x),
// i = opposite of q). The links are sorted by cell, so the kernel walks them in step.
#include "voxpack/flow/lbm.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>

#include "d3q19.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/memory.hpp"

namespace voxpack::flow {
namespace {

constexpr std::size_t kBlock = 4096;  // cells per reduction block (fixed: determinism)

// Relaxation rates and force of one run.
struct Rates {
  double omegaPlus, omegaMinus;
  double force[3];
};

// One interpolated wall link: f[slot] of `cell` = a * fin[i1] + b * fin[i2].
struct WallLink {
  std::uint32_t cell, slot, i1, i2;
  double a, b;
};

// Sums over one block.
struct BlockSums {
  double axial = 0, speed = 0, mass = 0;
};

// One macroscopic evaluation of a cell's incoming populations f (deviations).
struct Moments {
  double drho, rho, u[3];
};

// The first moments written out for this velocity set (kC order): a loop over kC
// multiplies by 0 and +-1 at run time (IEEE rules forbid folding x * 0), which measured
// as most of the kernel's time.
inline Moments moments(const double* f, const double* force) {
  Moments m{};
  const double d1 = f[1] - f[10], d2 = f[2] - f[11], d3 = f[3] - f[12], d4 = f[4] - f[13],
               d5 = f[5] - f[14], d6 = f[6] - f[15], d7 = f[7] - f[16], d8 = f[8] - f[17],
               d9 = f[9] - f[18];
  const double j[3] = {d1 + d4 + d5 + d6 + d7, d2 + d4 - d5 + d8 + d9, d3 + d6 - d7 + d8 - d9};
  double s = f[0];
  for (int q = 1; q < kQ; ++q) s += f[q];
  m.drho = s;
  m.rho = 1.0 + s;
  // Guo's forcing: the velocity carries half the force of the step.
  for (int d = 0; d < 3; ++d) m.u[d] = (j[d] + 0.5 * force[d]) / m.rho;
  return m;
}

// One fused stream + TRT collision step over cells [begin, end), in batches of kLanes cells:
// the loads (indirect) and the wall links are per cell, the collision runs across the
// batch's lanes as one SIMD loop, each lane doing exactly the scalar arithmetic in the same
// order (no FMA: -ffp-contract=off), so the result is the same bits as a cell-by-cell loop,
// and the reductions are added in cell order. Kind: kPull reads `fin` through the pull index
// `src` and writes `fout`; kAaEven and kAaOdd update `fout` in place (`fin` == `fout`), the
// odd step through the AA index L in `src`.
constexpr int kLanes = 8;
constexpr int kPull = 0, kAaEven = 1, kAaOdd = 2;

template <class T, int Kind>
__attribute__((always_inline)) inline void stepRangeBody(
    const T* fin, T* fout, const std::uint32_t* src, const std::uint8_t* inSample,
    const WallLink* lk, const WallLink* lkEnd, std::size_t begin, std::size_t end, const Rates& r,
    int axis, BlockSums* sums) {
  using C = T;  // the collision's precision: that of the populations
  const C wp = static_cast<C>(r.omegaPlus), wm = static_cast<C>(r.omegaMinus);
  const C gp = C(1) - C(0.5) * wp, gm = C(1) - C(0.5) * wm;
  const C forceC[3] = {static_cast<C>(r.force[0]), static_cast<C>(r.force[1]),
                       static_cast<C>(r.force[2])};
  const C zeroC[3] = {0, 0, 0};
  for (std::size_t c0 = begin; c0 < end; c0 += kLanes) {
    const int nl = static_cast<int>(std::min<std::size_t>(kLanes, end - c0));
    alignas(64) C f[kQ][kLanes], out[kQ][kLanes], F[3][kLanes];
    alignas(64) C u[3][kLanes], uuOut[kLanes], rhoOut[kLanes];
    for (int l = 0; l < kLanes; ++l) {
      const std::size_t c = c0 + static_cast<std::size_t>(l);
      if (l >= nl) {  // a lane past the range computes on zeros and is not stored
        for (int q = 0; q < kQ; ++q) f[q][l] = C(0);
        for (int d = 0; d < 3; ++d) F[d][l] = C(0);
        continue;
      }
      const std::uint32_t* from = src + c * (kQ - 1);
      f[0][l] = fin[c * kQ];
      if constexpr (Kind == kAaEven) {
        for (int q = 1; q < kQ; ++q) f[q][l] = fin[c * kQ + static_cast<std::size_t>(q)];
      } else {
        for (int q = 1; q < kQ; ++q) f[q][l] = fin[from[q - 1]];
      }
      if constexpr (Kind == kPull) {
        for (; lk != lkEnd && lk->cell == c; ++lk)
          f[lk->slot][l] = static_cast<C>(lk->a * static_cast<double>(fin[lk->i1]) +
                                          lk->b * static_cast<double>(fin[lk->i2]));
      }
      const C* force = inSample[c] ? forceC : zeroC;
      for (int d = 0; d < 3; ++d) F[d][l] = force[d];
    }
#pragma omp simd
    for (int l = 0; l < kLanes; ++l) {
      // Moments, written out for D3Q19 (kC order): a loop over kC would multiply by 0 and
      // +-1 at run time (IEEE rules forbid folding x * 0).
      const C d1 = f[1][l] - f[10][l], d2 = f[2][l] - f[11][l], d3 = f[3][l] - f[12][l],
              d4 = f[4][l] - f[13][l], d5 = f[5][l] - f[14][l], d6 = f[6][l] - f[15][l],
              d7 = f[7][l] - f[16][l], d8 = f[8][l] - f[17][l], d9 = f[9][l] - f[18][l];
      const C j0 = d1 + d4 + d5 + d6 + d7, j1 = d2 + d4 - d5 + d8 + d9, j2 = d3 + d6 - d7 + d8 - d9;
      C sum = f[0][l];
      for (int q = 1; q < kQ; ++q) sum += f[q][l];
      const C drho = sum, rho = C(1.0) + sum;
      // Guo's forcing: the velocity carries half the force of the step.
      const C F0 = F[0][l], F1 = F[1][l], F2 = F[2][l];
      const C u0 = (j0 + C(0.5) * F0) / rho, u1 = (j1 + C(0.5) * F1) / rho,
              u2 = (j2 + C(0.5) * F2) / rho;
      const C uu = u0 * u0 + u1 * u1 + u2 * u2;
      const C uF = u0 * F0 + u1 * F1 + u2 * F2;
      u[0][l] = u0;
      u[1][l] = u1;
      u[2][l] = u2;
      uuOut[l] = uu;
      rhoOut[l] = rho;
      {  // rest population
        const C eq = C(kW[0]) * (drho - C(1.5) * rho * uu);
        const C s0 = C(kW[0]) * (-C(3.0) * uF);
        out[0][l] = f[0][l] - wp * (f[0][l] - eq) + gp * s0;
      }
      // c_q . u and c_q . F for q = 1..9; pairs (q, q + 9) with c_{q+9} = -c_q.
      const C cu[10] = {C(0), u0, u1, u2, u0 + u1, u0 - u1, u0 + u2, u0 - u2, u1 + u2, u1 - u2};
      const C cf[10] = {C(0), F0, F1, F2, F0 + F1, F0 - F1, F0 + F2, F0 - F2, F1 + F2, F1 - F2};
#pragma GCC unroll 9
      for (int q = 1; q <= 9; ++q) {
        const int qb = q + 9;
        const C w = static_cast<C>(kW[q]);
        const C eqp = w * (drho + rho * (C(4.5) * cu[q] * cu[q] - C(1.5) * uu));
        const C eqm = w * rho * C(3.0) * cu[q];
        const C sp = w * (C(9.0) * cu[q] * cf[q] - C(3.0) * uF);
        const C sm = w * C(3.0) * cf[q];
        const C fp = C(0.5) * (f[q][l] + f[qb][l]);
        const C fm = C(0.5) * (f[q][l] - f[qb][l]);
        const C relaxP = -wp * (fp - eqp) + gp * sp;
        const C relaxM = -wm * (fm - eqm) + gm * sm;
        out[q][l] = f[q][l] + relaxP + relaxM;
        out[qb][l] = f[qb][l] + relaxP - relaxM;
      }
    }
    for (int l = 0; l < nl; ++l) {
      const std::size_t c = c0 + static_cast<std::size_t>(l);
      if constexpr (Kind == kPull) {
        for (int q = 0; q < kQ; ++q) fout[c * kQ + q] = static_cast<T>(out[q][l]);
      } else if constexpr (Kind == kAaEven) {
        fout[c * kQ] = static_cast<T>(out[0][l]);
        for (int q = 1; q < kQ; ++q)
          fout[c * kQ + static_cast<std::size_t>(kOpposite[q])] = static_cast<T>(out[q][l]);
      } else {
        const std::uint32_t* to = src + c * (kQ - 1);
        fout[c * kQ] = static_cast<T>(out[0][l]);
        for (int q = 1; q < kQ; ++q) fout[to[q - 1]] = static_cast<T>(out[kOpposite[q]][l]);
      }
      if (sums && inSample[c]) {
        sums->axial += static_cast<double>(u[axis][l]);
        sums->speed += std::sqrt(static_cast<double>(uuOut[l]));
      }
      if (sums) sums->mass += static_cast<double>(rhoOut[l]);
    }
  }
}

// The body compiled twice per precision, for AVX2 and the baseline, picked at load time
// (GCC and clang take target_clones on plain functions only, not on templates); `kind`
// selects the pass inside the clone.
template <class T>
__attribute__((always_inline)) inline void stepRangeKind(
    int kind, const T* fin, T* fout, const std::uint32_t* src, const std::uint8_t* inSample,
    const WallLink* lk, const WallLink* lkEnd, std::size_t begin, std::size_t end, const Rates& r,
    int axis, BlockSums* sums) {
  if (kind == kAaEven)
    stepRangeBody<T, kAaEven>(fin, fout, src, inSample, lk, lkEnd, begin, end, r, axis, sums);
  else if (kind == kAaOdd)
    stepRangeBody<T, kAaOdd>(fin, fout, src, inSample, lk, lkEnd, begin, end, r, axis, sums);
  else
    stepRangeBody<T, kPull>(fin, fout, src, inSample, lk, lkEnd, begin, end, r, axis, sums);
}
__attribute__((target_clones("avx2", "default"))) void stepRangeFloat(
    int kind, const float* fin, float* fout, const std::uint32_t* src, const std::uint8_t* inSample,
    const WallLink* lk, const WallLink* lkEnd, std::size_t begin, std::size_t end, const Rates& r,
    int axis, BlockSums* sums) {
  stepRangeKind(kind, fin, fout, src, inSample, lk, lkEnd, begin, end, r, axis, sums);
}
__attribute__((target_clones("avx2", "default"))) void stepRangeDouble(
    int kind, const double* fin, double* fout, const std::uint32_t* src,
    const std::uint8_t* inSample, const WallLink* lk, const WallLink* lkEnd, std::size_t begin,
    std::size_t end, const Rates& r, int axis, BlockSums* sums) {
  stepRangeKind(kind, fin, fout, src, inSample, lk, lkEnd, begin, end, r, axis, sums);
}

template <class T>
class Solver {
 public:
  // `src` is the pull index for two lattices, the AA index L for AA (see the file comment).
  Solver(std::size_t n, std::vector<std::uint32_t> src, std::vector<std::uint8_t> inSample,
         std::vector<WallLink> links, const Rates& rates, int axis, int threads, bool aa)
      : n_(n),
        aa_(aa),
        src_(std::move(src)),
        inSample_(std::move(inSample)),
        links_(std::move(links)),
        a_(kQ * n, T(0)),
        b_(aa ? 0 : kQ * n, T(0)),
        rates_(rates),
        axis_(axis),
        blocks_((n + kBlock - 1) / kBlock),
        // At least 8 blocks (32768 cells) per thread, else fewer threads: a small lattice
        // runs without a parallel region. Each region ends in a barrier, and on a loaded
        // machine a barrier waits for a descheduled thread's time slice (measured 10 ms a
        // step on 4000 cells at load 6). The result does not depend on the count.
        threads_(static_cast<int>(
            std::clamp<std::size_t>(blocks_ / 8, 1, static_cast<std::size_t>(threads)))) {
    // First wall link of every block (and one past the last): links are sorted by cell.
    linkStart_.resize(blocks_ + 1);
    std::size_t l = 0;
    for (std::size_t bi = 0; bi <= blocks_; ++bi) {
      const std::size_t first = std::min(n_, bi * kBlock);
      while (l < links_.size() && links_[l].cell < first) ++l;
      linkStart_[bi] = l;
    }
  }

  // One step; when `sums` is given, fills the totals of this step (block order).
  void step(BlockSums* total) {
    std::vector<BlockSums> part(total ? blocks_ : 0);
    const int kind = !aa_ ? kPull : (odd_ ? kAaOdd : kAaEven);
    const T* fin = a_.data();
    T* fout = aa_ ? a_.data() : b_.data();
    const std::int64_t nb = static_cast<std::int64_t>(blocks_);
#pragma omp parallel for schedule(static) num_threads(threads_) if (threads_ > 1)
    for (std::int64_t bi = 0; bi < nb; ++bi) {
      const std::size_t begin = static_cast<std::size_t>(bi) * kBlock;
      const std::size_t end = std::min(n_, begin + kBlock);
      const WallLink* l0 = links_.data() + linkStart_[static_cast<std::size_t>(bi)];
      const WallLink* l1 = links_.data() + linkStart_[static_cast<std::size_t>(bi) + 1];
      BlockSums* s = total ? &part[static_cast<std::size_t>(bi)] : nullptr;
      if constexpr (std::is_same_v<T, float>)
        stepRangeFloat(kind, fin, fout, src_.data(), inSample_.data(), l0, l1, begin, end, rates_,
                       axis_, s);
      else
        stepRangeDouble(kind, fin, fout, src_.data(), inSample_.data(), l0, l1, begin, end, rates_,
                        axis_, s);
    }
    if (aa_)
      odd_ = !odd_;
    else
      a_.swap(b_);
    if (total) {
      *total = BlockSums{};
      for (const BlockSums& p : part) {
        total->axial += p.axial;
        total->speed += p.speed;
        total->mass += p.mass;
      }
    }
  }

  int threads() const { return threads_; }

  // Incoming populations of cell c: the values its next collision reads. Two lattices: the
  // pull of the stored post-collision state. AA: after an even number of steps the cell's
  // own slots; after an odd number the post-collision values sit swapped, reached through L.
  void incoming(std::size_t c, double* f) const {
    f[0] = a_[c * kQ];
    if (aa_ && !odd_) {
      for (int q = 1; q < kQ; ++q) f[q] = a_[c * kQ + static_cast<std::size_t>(q)];
      return;
    }
    for (int q = 1; q < kQ; ++q) f[q] = a_[src_[c * (kQ - 1) + q - 1]];
    // The cell's links by binary search in its block (links are sorted by cell): a scan of
    // the block per cell made mass() and fields() quadratic in the links per block.
    const std::size_t bi = c / kBlock;
    const auto first = links_.begin() + static_cast<std::ptrdiff_t>(linkStart_[bi]);
    const auto last = links_.begin() + static_cast<std::ptrdiff_t>(linkStart_[bi + 1]);
    auto lk = std::lower_bound(first, last, c,
                               [](const WallLink& x, std::size_t cell) { return x.cell < cell; });
    for (; lk != last && lk->cell == c; ++lk)
      f[lk->slot] =
          lk->a * static_cast<double>(a_[lk->i1]) + lk->b * static_cast<double>(a_[lk->i2]);
  }

  // Sum of rho over all cells of the incoming state: the mass the next collision sees. Read
  // through incoming() so that AA and two lattices sum the same values in the same order.
  double mass() const {
    std::vector<double> part(blocks_, 0.0);
    const std::int64_t nb = static_cast<std::int64_t>(blocks_);
#pragma omp parallel for schedule(static) num_threads(threads_) if (threads_ > 1)
    for (std::int64_t bi = 0; bi < nb; ++bi) {
      const std::size_t begin = static_cast<std::size_t>(bi) * kBlock;
      const std::size_t end = std::min(n_, begin + kBlock);
      double s = 0;
      for (std::size_t c = begin; c < end; ++c) {
        double f[kQ];
        incoming(c, f);
        s += 1.0;
        for (int q = 0; q < kQ; ++q) s += f[q];
      }
      part[static_cast<std::size_t>(bi)] = s;
    }
    double total = 0;
    for (double p : part) total += p;
    return total;
  }

  // Adds a rest density delta to every cell: w_q delta to every stored population. Every
  // incoming population, pulled or interpolated (a + b = 1 over values of its own weight,
  // D3Q19's weights being symmetric), then gains w_q delta, so the mass gains delta per cell
  // and the momentum nothing.
  void addRestDensity(double delta) {
    const std::int64_t nn = static_cast<std::int64_t>(n_);
#pragma omp parallel for schedule(static) num_threads(threads_) if (threads_ > 1)
    for (std::int64_t ci = 0; ci < nn; ++ci) {
      T* f = a_.data() + static_cast<std::size_t>(ci) * kQ;
      for (int q = 0; q < kQ; ++q) f[q] = static_cast<T>(f[q] + kW[q] * delta);
    }
  }

  void fields(LbmFields& out) const {
    out.density.assign(n_, 0.0f);
    for (auto& v : out.velocity) v.assign(n_, 0.0f);
    const std::int64_t nn = static_cast<std::int64_t>(n_);
#pragma omp parallel for schedule(static) num_threads(threads_) if (threads_ > 1)
    for (std::int64_t ci = 0; ci < nn; ++ci) {
      const std::size_t c = static_cast<std::size_t>(ci);
      double f[kQ];
      incoming(c, f);
      const Moments m = moments(f, inSample_[c] ? rates_.force : kZero3);
      out.density[c] = static_cast<float>(m.drho);
      for (int d = 0; d < 3; ++d) out.velocity[d][c] = static_cast<float>(m.u[d]);
    }
  }

 private:
  std::size_t n_;
  bool aa_;
  bool odd_ = false;  // AA: the next step is an odd one (the state is swapped in place)
  std::vector<std::uint32_t> src_;
  std::vector<std::uint8_t> inSample_;
  std::vector<WallLink> links_;
  std::vector<std::size_t> linkStart_;
  std::vector<T> a_, b_;
  Rates rates_;
  int axis_;
  std::size_t blocks_;
  int threads_;
};

// Neighbour of (k, j, i) along direction c, or false when it leaves a wall-bounded axis.
inline bool neighbour(const std::array<std::int64_t, 3>& dims, const std::array<bool, 3>& per,
                      std::int64_t p[3], const int* c) {
  for (int d = 0; d < 3; ++d) {
    p[d] += c[d];
    if (p[d] < 0 || p[d] >= dims[d]) {
      if (!per[d]) return false;
      p[d] = (p[d] + dims[d]) % dims[d];
    }
  }
  return true;
}

template <class T>
LbmResult runTyped(const LbmDomain& dom, const LbmOptions& o, Progress& progress) {
  const auto& dims = dom.dims;
  const std::size_t box = static_cast<std::size_t>(dims[0] * dims[1] * dims[2]);
  LbmResult res;
  // Number the fluid cells in C order; id map for the neighbour table (freed after).
  std::vector<std::int32_t> id(box, -1);
  for (std::size_t off = 0; off < box; ++off)
    if (dom.fluid[off]) {
      id[off] = static_cast<std::int32_t>(res.cellOffset.size());
      res.cellOffset.push_back(off);
    }
  const std::size_t n = res.cellOffset.size();
  std::vector<std::uint8_t> inSample(n, 1);
  if (!dom.sample.empty())
    for (std::size_t c = 0; c < n; ++c) inSample[c] = dom.sample[res.cellOffset[c]];
  std::vector<std::uint32_t> src(static_cast<std::size_t>(kQ - 1) * n);
  const std::int64_t nn = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static) num_threads(o.threads)
  for (std::int64_t ci = 0; ci < nn; ++ci) {
    const std::size_t c = static_cast<std::size_t>(ci);
    const std::uint64_t off = res.cellOffset[c];
    const std::int64_t k = static_cast<std::int64_t>(off) / (dims[1] * dims[2]);
    const std::int64_t j = (static_cast<std::int64_t>(off) / dims[2]) % dims[1];
    const std::int64_t i = static_cast<std::int64_t>(off) % dims[2];
    for (int q = 1; q < kQ; ++q) {
      // Pull: the population moving along c_q comes from x - c_q.
      const int back[3] = {-kC[q][0], -kC[q][1], -kC[q][2]};
      std::int64_t p[3] = {k, j, i};
      std::int64_t from = -1;
      if (neighbour(dims, dom.periodic, p, back))
        from = id[static_cast<std::size_t>((p[0] * dims[1] + p[1]) * dims[2] + p[2])];
      const std::size_t slot = c * (kQ - 1) + static_cast<std::size_t>(q - 1);
      if (from >= 0)
        src[slot] = static_cast<std::uint32_t>(static_cast<std::size_t>(from) * kQ +
                                               static_cast<std::size_t>(q));
      else  // halfway bounce-back: the population that left towards the wall returns
        src[slot] = static_cast<std::uint32_t>(c * kQ + static_cast<std::size_t>(kOpposite[q]));
    }
  }
  // Interpolated wall links from the signed distance (serial: few cells, sorted by cell).
  std::vector<WallLink> links;
  if (!dom.signedDistance.empty()) {
    for (std::size_t c = 0; c < n; ++c) {
      const std::uint64_t off = res.cellOffset[c];
      const double phiF = dom.signedDistance[off];
      if (!(phiF > 0)) continue;  // the geometry disagrees with the flags: keep halfway
      const std::int64_t k = static_cast<std::int64_t>(off) / (dims[1] * dims[2]);
      const std::int64_t j = (static_cast<std::int64_t>(off) / dims[2]) % dims[1];
      const std::int64_t i = static_cast<std::int64_t>(off) % dims[2];
      for (int q = 1; q < kQ; ++q) {
        const int back[3] = {-kC[q][0], -kC[q][1], -kC[q][2]};
        std::int64_t p[3] = {k, j, i};
        if (!neighbour(dims, dom.periodic, p, back)) continue;  // box face: halfway
        const std::size_t so = static_cast<std::size_t>((p[0] * dims[1] + p[1]) * dims[2] + p[2]);
        if (id[so] >= 0) continue;  // fluid neighbour: plain streaming
        const double phiS = dom.signedDistance[so];
        if (!(phiS <= 0)) continue;  // a solid the distance does not describe: halfway
        const std::uint32_t opp = static_cast<std::uint32_t>(kOpposite[q]);
        double qw = phiF / (phiF - phiS);
        if (!dom.wallCuts.empty()) {  // the exact cut of this link (towards the wall: opp)
          const WallCut key{off, opp, 0.0f};
          const auto it = std::lower_bound(dom.wallCuts.begin(), dom.wallCuts.end(), key);
          if (it != dom.wallCuts.end() && it->cell == off && it->direction == opp) qw = it->q;
        }
        qw = std::clamp(qw, 1e-3, 1.0);
        WallLink lk{static_cast<std::uint32_t>(c),
                    static_cast<std::uint32_t>(q),
                    static_cast<std::uint32_t>(c * kQ + opp),
                    0,
                    1.0,
                    0.0};
        if (qw >= 0.5) {
          lk.i2 = static_cast<std::uint32_t>(c * kQ + static_cast<std::size_t>(q));
          lk.a = 1.0 / (2.0 * qw);
          lk.b = (2.0 * qw - 1.0) / (2.0 * qw);
        } else {
          std::int64_t p2[3] = {k, j, i};
          std::int32_t behind = -1;
          if (neighbour(dims, dom.periodic, p2, kC[q]))
            behind = id[static_cast<std::size_t>((p2[0] * dims[1] + p2[1]) * dims[2] + p2[2])];
          if (behind < 0) {
            lk.i2 = lk.i1;  // no second fluid node: halfway
          } else {
            lk.i2 = static_cast<std::uint32_t>(static_cast<std::size_t>(behind) * kQ + opp);
            lk.a = 2.0 * qw;
            lk.b = 1.0 - 2.0 * qw;
          }
        }
        links.push_back(lk);
      }
    }
  }
  res.interpolatedLinks = links.size();
  std::vector<std::int32_t>().swap(id);
  res.streaming = resolveStreaming(o.streaming, links.size());
  const bool aa = res.streaming == Streaming::AA;
  if (aa)  // L(x, q): the pull source with its direction reversed (file comment)
    for (std::uint32_t& v : src) v = v - v % kQ + static_cast<std::uint32_t>(kOpposite[v % kQ]);

  Rates rates{};
  rates.omegaPlus = 1.0 / o.tauPlus;
  const double tauMinus = 0.5 + o.magic / (o.tauPlus - 0.5);
  rates.omegaMinus = 1.0 / tauMinus;
  rates.force[o.axis] = o.force;
  res.fluidCells = n;
  for (std::uint8_t s : inSample) res.sampleFluidCells += s;

  Solver<T> solver(n, std::move(src), std::move(inSample), std::move(links), rates, o.axis,
                   o.threads, aa);
  res.threads = solver.threads();
  res.massInitial = solver.mass();
  const auto t0 = std::chrono::steady_clock::now();
  double previous = std::numeric_limits<double>::quiet_NaN();
  res.residual = std::numeric_limits<double>::infinity();
  const std::int64_t interval = std::max<std::int64_t>(1, o.checkInterval);
  res.massCorrected = o.massCorrection && res.interpolatedLinks > 0;  // halfway conserves mass
  while (res.steps < o.maxSteps) {
    const bool check = (res.steps + 1) % interval == 0 || res.steps + 1 == o.maxSteps;
    BlockSums sums;
    solver.step(check ? &sums : nullptr);
    ++res.steps;
    if (!check) continue;
    res.sumAxialVelocity = sums.axial;
    res.sumSpeed = sums.speed;
    if (res.massCorrected) {
      // Bouzidi's interpolation gains or loses a little mass at every step, and uncorrected
      // the loss accumulates (-1.5 % in 1e5 steps on a DEM bed, and k +1.5 %: docs/flow.md).
      // A uniform rest density puts it back without touching the momentum.
      const double delta = (res.massInitial - solver.mass()) / static_cast<double>(n);
      solver.addRestDensity(delta);
      res.massAdded += delta * static_cast<double>(n);
    }
    const double mean =
        sums.axial / static_cast<double>(std::max<std::size_t>(1, res.sampleFluidCells));
    res.history.emplace_back(res.steps, mean);
    if (std::isfinite(previous))
      res.residual = std::abs(mean) > 0 ? std::abs(mean - previous) / std::abs(mean)
                                        : (mean == previous ? 0.0 : 1.0);
    previous = mean;
    if (!std::isfinite(mean))
      throw InputError(
          "flow: the lattice Boltzmann run diverged (non-finite velocity); "
          "lower the force or raise tau");
    progress.report("flow", static_cast<double>(res.steps) / static_cast<double>(o.maxSteps));
    if (progress.cancelled()) throw Cancelled("flow: cancelled");
    if (res.residual < o.tolerance && res.steps >= o.minSteps) {
      res.status = FlowStatus::Converged;
      break;
    }
  }
  res.wallS = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  res.mlups = res.wallS > 0
                  ? static_cast<double>(n) * static_cast<double>(res.steps) / res.wallS / 1e6
                  : 0.0;
  res.massFinal = solver.mass();
  solver.fields(res.fields);
  // Averages from the final fields (the state the permeability is reported for).
  double axial = 0, speed = 0;
  for (std::size_t c = 0; c < n; ++c) {
    if (!dom.sample.empty() && !dom.sample[res.cellOffset[c]]) continue;
    const double u0 = res.fields.velocity[0][c], u1 = res.fields.velocity[1][c],
                 u2 = res.fields.velocity[2][c];
    axial += res.fields.velocity[o.axis][c];
    speed += std::sqrt(u0 * u0 + u1 * u1 + u2 * u2);
  }
  res.sumAxialVelocity = axial;
  res.sumSpeed = speed;
  res.meanAxialVelocity =
      res.sampleFluidCells ? axial / static_cast<double>(res.sampleFluidCells) : 0.0;
  return res;
}

}  // namespace

const char* streamingName(Streaming s) {
  switch (s) {
    case Streaming::Auto:
      return "auto";
    case Streaming::AA:
      return "aa";
    case Streaming::TwoLattice:
      return "two_lattice";
  }
  return "unknown";
}

Streaming resolveStreaming(Streaming requested, std::uint64_t wallLinks) {
  if (requested == Streaming::AA && wallLinks > 0)
    throw InputError("flow: AA streaming does not carry interpolated wall links; use two lattices");
  if (requested == Streaming::Auto) return wallLinks > 0 ? Streaming::TwoLattice : Streaming::AA;
  return requested;
}

const char* statusName(FlowStatus s) {
  switch (s) {
    case FlowStatus::Converged:
      return "converged";
    case FlowStatus::NotConverged:
      return "not_converged";
    case FlowStatus::Blocked:
      return "blocked";
  }
  return "unknown";
}

std::uint64_t estimateLbmBytes(std::uint64_t boxCells, std::uint64_t fluidCells,
                               Precision precision, std::uint64_t wallLinks, Streaming streaming) {
  const std::uint64_t pop = precision == Precision::Float ? 4 : 8;
  // AA unless two lattices are asked for or interpolated links need them (runLbm refuses AA
  // with links before it estimates).
  const std::uint64_t lattices = streaming != Streaming::TwoLattice && wallLinks == 0 ? 1 : 2;
  // One (AA) or two lattices of 19 populations, 18 indices, sample flag, cell offset, final
  // fields (4 floats); the id map (4 bytes per box cell) lives during setup only, but the
  // fields are made after it is freed, so the peak is the larger of the two phases.
  const std::uint64_t perCell = lattices * kQ * pop + (kQ - 1) * 4 + 1 + 8;
  const std::uint64_t setup = checkedProduct({boxCells, 4}, "flow lattice");
  const std::uint64_t fields = checkedProduct({fluidCells, 16}, "flow fields");
  return checkedProduct({fluidCells, perCell}, "flow lattice") + std::max(setup, fields) +
         checkedProduct({wallLinks, sizeof(WallLink)}, "flow wall links");
}

LbmResult runLbm(const LbmDomain& domain, const LbmOptions& o, const MemoryBudget& budget,
                 Progress& progress) {
  const std::uint64_t box =
      checkedProduct({static_cast<std::uint64_t>(std::max<std::int64_t>(0, domain.dims[0])),
                      static_cast<std::uint64_t>(std::max<std::int64_t>(0, domain.dims[1])),
                      static_cast<std::uint64_t>(std::max<std::int64_t>(0, domain.dims[2]))},
                     "flow lattice");
  if (box == 0 || domain.fluid.size() != box)
    throw InputError("flow: the lattice is empty or its fluid flags do not match its size");
  if (!domain.sample.empty() && domain.sample.size() != box)
    throw InputError("flow: the sample flags do not match the lattice size");
  if (!domain.signedDistance.empty() && domain.signedDistance.size() != box)
    throw InputError("flow: the signed distance does not match the lattice size");
  if (!std::is_sorted(domain.wallCuts.begin(), domain.wallCuts.end()))
    throw InputError("flow: the wall cuts are not sorted by (cell, direction)");
  if (o.axis < 0 || o.axis > 2) throw InputError("flow: axis must be 0 (z), 1 (y) or 2 (x)");
  if (!(o.tauPlus > 0.5) || !std::isfinite(o.tauPlus))
    throw InputError("flow: tau must be greater than 0.5");
  if (!(o.magic > 0)) throw InputError("flow: the TRT magic parameter must be positive");
  if (!(o.tolerance > 0)) throw InputError("flow: --tolerance must be positive");
  if (o.maxSteps < 1) throw InputError("flow: --max-steps must be at least 1");
  std::uint64_t fluid = 0;
  for (std::uint8_t f : domain.fluid) fluid += f != 0;
  if (fluid == 0) throw InputError("flow: no fluid cell (the sample is all solid)");
  if (fluid * kQ >= std::numeric_limits<std::uint32_t>::max())
    throw ResourceError("flow: " + std::to_string(fluid) +
                        " fluid cells exceed the 32-bit pull index (at most 2.2e8 cells)");
  // Interpolated links: at most one per (fluid cell, direction) with a solid neighbour.
  std::uint64_t wallLinks = 0;
  if (!domain.signedDistance.empty()) {
    const auto& d = domain.dims;
    for (std::size_t off = 0; off < box; ++off) {
      if (!domain.fluid[off]) continue;
      for (int q = 1; q < kQ; ++q) {
        std::int64_t p[3] = {static_cast<std::int64_t>(off) / (d[1] * d[2]),
                             (static_cast<std::int64_t>(off) / d[2]) % d[1],
                             static_cast<std::int64_t>(off) % d[2]};
        if (neighbour(d, domain.periodic, p, kC[q]) &&
            !domain.fluid[static_cast<std::size_t>((p[0] * d[1] + p[1]) * d[2] + p[2])])
          ++wallLinks;
      }
    }
  }
  resolveStreaming(o.streaming, wallLinks);  // refuse AA with interpolated links up front
  requireWithinBudget(estimateLbmBytes(box, fluid, o.precision, wallLinks, o.streaming), budget,
                      "flow");
  LbmOptions opt = o;
  opt.threads = std::max(1, o.threads);
  if (o.precision == Precision::Double) return runTyped<double>(domain, opt, progress);
  return runTyped<float>(domain, opt, progress);
}

bool percolates(const LbmDomain& dom, int axis) {
  const auto& dims = dom.dims;
  const std::size_t box = static_cast<std::size_t>(dims[0] * dims[1] * dims[2]);
  if (dom.fluid.size() != box || box == 0) return false;
  std::array<bool, 3> per = dom.periodic;
  per[static_cast<std::size_t>(axis)] = false;  // a path must cross the sample, not wrap
  std::vector<std::uint8_t> seen(box, 0);
  std::vector<std::size_t> stack;
  // Seeds: fluid cells of the first layer along the axis.
  for (std::size_t off = 0; off < box; ++off) {
    std::int64_t p[3] = {static_cast<std::int64_t>(off) / (dims[1] * dims[2]),
                         (static_cast<std::int64_t>(off) / dims[2]) % dims[1],
                         static_cast<std::int64_t>(off) % dims[2]};
    if (p[axis] == 0 && dom.fluid[off]) {
      seen[off] = 1;
      stack.push_back(off);
    }
  }
  while (!stack.empty()) {
    const std::size_t off = stack.back();
    stack.pop_back();
    const std::int64_t k = static_cast<std::int64_t>(off) / (dims[1] * dims[2]);
    const std::int64_t j = (static_cast<std::int64_t>(off) / dims[2]) % dims[1];
    const std::int64_t i = static_cast<std::int64_t>(off) % dims[2];
    const std::int64_t here[3] = {k, j, i};
    if (here[axis] == dims[axis] - 1) return true;
    for (int q = 1; q < kQ; ++q) {
      std::int64_t p[3] = {k, j, i};
      if (!neighbour(dims, per, p, kC[q])) continue;
      const std::size_t o2 = static_cast<std::size_t>((p[0] * dims[1] + p[1]) * dims[2] + p[2]);
      if (dom.fluid[o2] && !seen[o2]) {
        seen[o2] = 1;
        stack.push_back(o2);
      }
    }
  }
  return false;
}

}  // namespace voxpack::flow
