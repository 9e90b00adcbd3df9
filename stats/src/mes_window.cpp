// Mean empty space, lattice path, over a window of z-planes: the run-length scan along the 13
// directions for the planes a window owns, seeing runs through its halo, with sums that are
// exact integers so the whole bed, any slab split and any rank count give the same bits
// (docs/stats.md, docs/scale.md).
#include "mes_window.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "voxpack/core/errors.hpp"

namespace voxpack::stats {
namespace {

// 2^-44 of a voxel: values and weights are >= 1 in these units, so a rounded term is exact to
// 6e-14 relative, and 2^127 leaves room for 2^36 voxels of weight·length² up to 2^47.
constexpr int kFractionBits = 44;
__extension__ typedef unsigned __int128 Unsigned128;

long double toReal(__int128 v) { return std::ldexp(static_cast<long double>(v), -kFractionBits); }

}  // namespace

MesGeometry mesGeometry(const Lattice& l, const std::array<bool, 3>& cutAxes) {
  MesGeometry g;
  g.lattice = l;
  g.cutAxes = cutAxes;
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  for (const auto& dir : latticeDirections()) {
    const int dk = dir[0], dj = dir[1], di = dir[2];
    g.stepMm.push_back(std::sqrt(std::pow(dk * l.spacingMm[0], 2) +
                                 std::pow(dj * l.spacingMm[1], 2) +
                                 std::pow(di * l.spacingMm[2], 2)));
    g.lineCut.push_back((dk != 0 && cutAxes[0]) || (dj != 0 && cutAxes[1]) ||
                        (di != 0 && cutAxes[2]));
    // Minus sampling over all lines of the whole bed: a chord of ℓ voxels is seen whole at
    // T(ℓ) = Σ_lines max(0, L − ℓ − 1) positions (lines differ in length along diagonals).
    auto lineLength = [&](std::int64_t k, std::int64_t j, std::int64_t i) {
      std::int64_t len = nz + ny + nx;
      if (dk) len = std::min(len, dk > 0 ? nz - k : k + 1);
      if (dj) len = std::min(len, dj > 0 ? ny - j : j + 1);
      if (di) len = std::min(len, di > 0 ? nx - i : i + 1);
      return static_cast<std::size_t>(len);
    };
    std::vector<double> lengthCount;
    auto countLine = [&](std::int64_t k, std::int64_t j, std::int64_t i) {
      const std::size_t len = lineLength(k, j, i);
      if (len >= lengthCount.size()) lengthCount.resize(len + 1, 0.0);
      lengthCount[len] += 1;
    };
    const std::int64_t ek = dk > 0 ? 0 : nz - 1, ej = dj > 0 ? 0 : ny - 1, ei = di > 0 ? 0 : nx - 1;
    for (std::int64_t k = 0; k < nz; ++k)
      for (std::int64_t j = 0; j < ny; ++j) {
        if ((dk != 0 && k == ek) || (dj != 0 && j == ej)) {
          for (std::int64_t i = 0; i < nx; ++i) countLine(k, j, i);
        } else if (di != 0) {
          countLine(k, j, ei);
        }
      }
    std::vector<double> positions(lengthCount.size() + 1, 0.0);
    for (std::size_t ell = 0; ell < positions.size(); ++ell)
      for (std::size_t len = ell + 2; len < lengthCount.size(); ++len)
        positions[ell] += lengthCount[len] * static_cast<double>(len - ell - 1);
    g.positions.push_back(std::move(positions));
  }
  return g;
}

MesSums::MesSums(double voxelMm, double binWidthMm, std::size_t directions)
    : voxelMm_(voxelMm), binWidthMm_(binWidthMm), chords_(directions) {}

MesSums::MesSums(const Lattice& l, double binWidthMm)
    : MesSums(
          std::min({l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]}),
          binWidthMm > 0 ? binWidthMm : std::min({l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]}),
          latticeDirections().size()) {}

// Out of range marks the sums (finish throws): this runs inside parallel loops.
MesSums::Fixed MesSums::fixed(double value) {
  const double s = std::nearbyint(std::ldexp(value, kFractionBits));
  if (!(std::fabs(s) < 0x1p120)) {
    overflow_ = true;
    return 0;
  }
  return static_cast<Fixed>(s);
}

void MesSums::add(Fixed& to, Fixed value) {
  if (__builtin_add_overflow(to, value, &to)) overflow_ = true;
}

void MesSums::addVoxel(float meanMm, float weight) {
  ++voidVoxels_;
  if (std::isnan(meanMm)) {
    ++undefined_;
    return;
  }
  const double v = meanMm, w = weight;
  if (!(v > 0) || !std::isfinite(v) || !(w > 0) || !std::isfinite(w)) return;
  const double u = v / voxelMm_, lu = std::log(u);
  add(w_, fixed(w));
  add(wu_, fixed(w * u));
  add(wu2_, fixed(w * u * u));
  add(wl_, fixed(w * lu));
  add(wl2_, fixed(w * lu * lu));
  if (binWidthMm_ > 0) {
    const auto bin = static_cast<std::size_t>(std::floor(v / binWidthMm_));
    if (bin >= histogram_.size()) histogram_.resize(bin + 1, 0);
    add(histogram_[bin], fixed(w));
  }
  ++samples_;
}

void MesSums::addChords(std::size_t d, std::int64_t length, std::uint64_t n) {
  auto& c = chords_[d];
  const auto ell = static_cast<std::size_t>(length);
  if (ell >= c.size()) c.resize(ell + 1, 0);
  c[ell] += n;
}

void MesSums::merge(const MesSums& o) {
  overflow_ = overflow_ || o.overflow_;
  voidVoxels_ += o.voidVoxels_;
  undefined_ += o.undefined_;
  samples_ += o.samples_;
  sliceCutVoxels += o.sliceCutVoxels;
  sliceCutChords += o.sliceCutChords;
  add(w_, o.w_);
  add(wu_, o.wu_);
  add(wu2_, o.wu2_);
  add(wl_, o.wl_);
  add(wl2_, o.wl2_);
  if (o.histogram_.size() > histogram_.size()) histogram_.resize(o.histogram_.size(), 0);
  for (std::size_t b = 0; b < o.histogram_.size(); ++b) add(histogram_[b], o.histogram_[b]);
  for (std::size_t d = 0; d < chords_.size(); ++d) {
    auto& c = chords_[d];
    const auto& oc = o.chords_[d];
    if (oc.size() > c.size()) c.resize(oc.size(), 0);
    for (std::size_t e = 0; e < oc.size(); ++e) c[e] += oc[e];
  }
}

void MesSums::reduce(const Communicator& comm) {
  if (comm.size() == 1) return;
  std::vector<std::uint64_t> counts{voidVoxels_,    undefined_,     samples_,
                                    sliceCutVoxels, sliceCutChords, overflow_ ? 1u : 0u};
  comm.sum(counts);
  voidVoxels_ = counts[0];
  undefined_ = counts[1];
  samples_ = counts[2];
  sliceCutVoxels = counts[3];
  sliceCutChords = counts[4];
  overflow_ = counts[5] != 0;
  histogram_.resize(
      static_cast<std::size_t>(comm.max(static_cast<std::int64_t>(histogram_.size()))), 0);
  for (auto& c : chords_)
    c.resize(static_cast<std::size_t>(comm.max(static_cast<std::int64_t>(c.size()))), 0);
  // Each 128-bit sum as four 32-bit limbs: their sums over any number of ranks fit 64 bits,
  // and the carries are put back afterwards, modulo 2^128 (two's complement).
  std::vector<Fixed*> fixedSums{&w_, &wu_, &wu2_, &wl_, &wl2_};
  for (auto& h : histogram_) fixedSums.push_back(&h);
  std::vector<std::uint64_t> limbs;
  for (const Fixed* f : fixedSums) {
    const auto x = static_cast<Unsigned128>(*f);
    for (int q = 0; q < 4; ++q)
      limbs.push_back(static_cast<std::uint64_t>((x >> (32 * q)) & 0xffffffffu));
  }
  comm.sum(limbs);
  for (std::size_t n = 0; n < fixedSums.size(); ++n) {
    Unsigned128 x = 0;
    for (int q = 0; q < 4; ++q)
      x += static_cast<Unsigned128>(limbs[4 * n + static_cast<std::size_t>(q)]) << (32 * q);
    *fixedSums[n] = static_cast<Fixed>(x);
  }
  for (auto& c : chords_) comm.sum(c);
}

MesResult MesSums::finish(const MesGeometry& g) const {
  if (overflow_)
    throw ResourceError("mean empty space: a weighted length beyond the range of the exact sums");
  MesResult r;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  r.directions = static_cast<int>(chords_.size());
  r.voidVoxels = voidVoxels_;
  r.undefinedVoxels = undefined_;
  r.sliceCutVoxels = sliceCutVoxels;
  r.sliceCutChords = sliceCutChords;
  LengthDistribution& d = r.distribution;
  d.binWidthMm = binWidthMm_;
  if (samples_ == 0 || !(binWidthMm_ > 0)) {
    d.meanMm = d.stdMm = d.lognormalMu = d.lognormalSigma = nan;
  } else {
    d.samples = samples_;
    const long double w = toReal(w_), mean = toReal(wu_) / w, mu = toReal(wl_) / w;
    d.meanMm = static_cast<double>(mean * voxelMm_);
    d.stdMm =
        static_cast<double>(std::sqrt(std::max(0.0L, toReal(wu2_) / w - mean * mean)) * voxelMm_);
    d.lognormalMu = static_cast<double>(mu + std::log(static_cast<long double>(voxelMm_)));
    d.lognormalSigma = static_cast<double>(std::sqrt(std::max(0.0L, toReal(wl2_) / w - mu * mu)));
    d.binsMm.resize(histogram_.size());
    d.pdf.resize(histogram_.size());
    for (std::size_t b = 0; b < histogram_.size(); ++b) {
      d.binsMm[b] = (static_cast<double>(b) + 0.5) * binWidthMm_;
      d.pdf[b] = static_cast<double>(toReal(histogram_[b]) / (w * binWidthMm_));
    }
  }
  // Per-direction point-weighted mean chord Σ w ℓ² / Σ w ℓ from the chord counts, in
  // length order: the same bits for any split.
  double directional = 0;
  for (std::size_t k = 0; k < chords_.size(); ++k) {
    double sumL2 = 0, sumL = 0;
    const auto& pos = g.positions[k];
    for (std::size_t ell = 1; ell < chords_[k].size(); ++ell) {
      if (chords_[k][ell] == 0) continue;
      const double chord = static_cast<float>(static_cast<double>(ell) * g.stepMm[k]);
      const double w = g.lineCut[k] ? 1.0 / std::max(1.0, ell < pos.size() ? pos[ell] : 1.0) : 1.0;
      const double n = static_cast<double>(chords_[k][ell]);
      sumL2 += n * w * chord * chord;
      sumL += n * w * chord;
    }
    directional += sumL > 0 ? sumL2 / sumL : nan;
  }
  r.directionalMeanMm = directional / static_cast<double>(chords_.size());
  return r;
}

std::uint64_t mesScratchBytesPerVoxel(const std::array<bool, 3>& cutAxes) {
  std::uint64_t reach = 0;
  for (bool c : cutAxes) reach += c ? 4 : 0;
  return 4 + 1 + 1 + reach;  // float sum, count, cut flags, two uint16 reach per cut axis
}

void markFaceVoid(const std::uint8_t* ind, const std::uint8_t* msk, std::int64_t n, std::int64_t ny,
                  std::int64_t nx, std::int64_t z0, std::vector<std::uint64_t>& cutY,
                  std::vector<std::uint64_t>& cutX) {
  auto isVoid = [&](std::size_t o) { return ind[o] != 0 && (!msk || msk[o] != 0); };
  for (std::int64_t k = 0; k < n; ++k) {
    const auto z = static_cast<std::size_t>(z0 + k);
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        const bool faceY = j == 0 || j == ny - 1, faceX = i == 0 || i == nx - 1;
        if (!faceY && !faceX) {
          i = nx - 2;  // jump to the far x face
          continue;
        }
        const auto o = static_cast<std::size_t>((k * ny + j) * nx + i);
        if (!isVoid(o)) continue;
        if (faceY) cutY[z] = 1;
        if (faceX) cutX[z] = 1;
      }
  }
}

void scanMesWindow(const MesWindow& w, const MesGeometry& g, int threads, MesSums& sums,
                   Progress& progress, MesField* field) {
  const Lattice& l = g.lattice;
  const std::int64_t ny = l.ny(), nx = l.nx();
  const std::int64_t bedN[3] = {l.nz(), ny, nx};
  const std::int64_t wz = w.planes, own0 = w.ownFirst, own1 = w.ownLast;
  const std::int64_t plane = ny * nx;
  const auto ownN = static_cast<std::size_t>((own1 - own0) * plane);
  const std::int64_t ownBase = own0 * plane;
  const std::uint8_t* ind = w.indicator;
  const std::uint8_t* msk = w.mask;
  // A run cut at the bed's boundary (bit 1) has no whole chord in the bed either; a run cut
  // at a window edge inside the bed (bit 2) might, had the window been taller.
  constexpr std::uint8_t kBedCut = 1, kSliceCut = 2;
  const std::uint8_t bottomCut = w.firstPlane == 0 ? kBedCut : kSliceCut;
  const std::uint8_t topCut = w.firstPlane + wz == bedN[0] ? kBedCut : kSliceCut;
  std::vector<float> sum(ownN, 0.0f);
  std::vector<std::uint8_t> count(ownN, 0), cut(ownN, 0);
  std::array<std::vector<std::uint16_t>, 6> reach;
  for (std::size_t a = 0; a < 3; ++a)
    if (g.cutAxes[a]) {
      reach[2 * a].assign(ownN, 0);
      reach[2 * a + 1].assign(ownN, 0);
    }
  auto isVoid = [&](std::int64_t o) {
    const auto p = static_cast<std::size_t>(o);
    return ind[p] != 0 && (!msk || msk[p] != 0);
  };
  const int nt = std::max(1, threads);
  const auto& dirs = latticeDirections();
  for (std::size_t d = 0; d < dirs.size(); ++d) {
    if (progress.cancelled()) throw Cancelled("mean empty space");
    progress.report("mean empty space", static_cast<double>(d) / static_cast<double>(dirs.size()));
    const int u[3] = {dirs[d][0], dirs[d][1], dirs[d][2]};
    const int dk = u[0], dj = u[1], di = u[2];
    const std::int64_t stride = (dk * ny + dj) * nx + di;
    const std::int64_t ej = dj > 0 ? 0 : ny - 1, ei = di > 0 ? 0 : nx - 1;
    // The lines through the owned planes: for dk = 1, every point of the first owned plane
    // (walked back to where its run starts) and the y/x entry faces of the later owned
    // planes; for dk = 0, the entry faces of every owned plane. Start s is decoded from its
    // number, so no list of starts is held.
    const std::int64_t rowStarts = dj != 0 ? nx : 0;
    const std::int64_t faceStarts = rowStarts + (di != 0 ? (dj != 0 ? ny - 1 : ny) : 0);
    const std::int64_t firstPlaneStarts = dk != 0 ? plane : 0;
    const std::int64_t faceK0 = dk != 0 ? own0 + 1 : own0;
    const std::int64_t nStarts =
        firstPlaneStarts + std::max<std::int64_t>(0, own1 - faceK0) * faceStarts;
    std::vector<std::vector<std::uint64_t>> chordCount(static_cast<std::size_t>(nt));
    std::uint64_t sliceChords = 0;
#pragma omp parallel num_threads(nt) reduction(+ : sliceChords)
    {
      auto& myChords = chordCount[static_cast<std::size_t>(omp_get_thread_num())];
#pragma omp for schedule(dynamic, 256)
      for (std::int64_t s = 0; s < nStarts; ++s) {
        std::int64_t k, j, i;
        const bool walkBack = s < firstPlaneStarts;
        if (walkBack) {
          k = own0;
          j = s / nx;
          i = s % nx;
        } else {
          const std::int64_t f = s - firstPlaneStarts;
          k = faceK0 + f / faceStarts;
          const std::int64_t r = f % faceStarts;
          if (r < rowStarts) {
            j = ej;
            i = r;
          } else {
            const std::int64_t row = r - rowStarts;
            j = dj != 0 && ej == 0 ? row + 1 : row;
            i = ei;
          }
        }
        auto inside = [&](std::int64_t kk, std::int64_t jj, std::int64_t ii) {
          return kk >= 0 && jj >= 0 && ii >= 0 && kk < wz && jj < ny && ii < nx;
        };
        std::int64_t o = (k * ny + j) * nx + i;
        // Why the run at the start of the scan is cut, if it is: the predecessor lies
        // outside the window, through the bottom (bed or slab edge) or a y/x face (bed).
        std::uint8_t startCut = 0;
        if (walkBack && isVoid(o)) {
          while (inside(k - dk, j - dj, i - di) && isVoid(o - stride)) {
            k -= dk;
            j -= dj;
            i -= di;
            o -= stride;
          }
        }
        if (!inside(k - dk, j - dj, i - di))
          startCut = (dk != 0 && k - dk < 0 && inside(k, j - dj, i - di)) ? bottomCut : kBedCut;
        std::int64_t runStart = 0, runLen = 0, runK = 0;
        std::uint8_t runCut = 0;
        auto flush = [&](std::uint8_t why) {
          const auto chord = static_cast<float>(static_cast<double>(runLen) * g.stepMm[d]);
          const bool ownStart = runK >= own0 && runK < own1;
          if (ownStart && why == 0) {
            const auto ell = static_cast<std::size_t>(runLen);
            if (ell >= myChords.size()) myChords.resize(ell + 1, 0);
            ++myChords[ell];
          } else if (ownStart && why == kSliceCut) {
            ++sliceChords;
          }
          const std::int64_t t0 = dk ? std::max<std::int64_t>(0, own0 - runK) : 0;
          const std::int64_t t1 = dk ? std::min(runLen, own1 - runK) : runLen;
          for (std::int64_t t = t0; t < t1; ++t) {
            const auto p = static_cast<std::size_t>(runStart + t * stride - ownBase);
            if (why != 0) {
              cut[p] |= why;
              continue;
            }
            sum[p] += chord;
            ++count[p];
            // Chord ends (the bounding solid voxels) sit t + 1 steps back, runLen − t ahead.
            for (std::size_t a = 0; a < 3; ++a) {
              if (u[a] == 0 || !g.cutAxes[a]) continue;
              const auto back = static_cast<std::uint16_t>(std::min<std::int64_t>(t + 1, 65535));
              const auto ahead =
                  static_cast<std::uint16_t>(std::min<std::int64_t>(runLen - t, 65535));
              auto& lo = reach[2 * a][p];
              auto& hi = reach[2 * a + 1][p];
              lo = std::max(lo, u[a] > 0 ? back : ahead);
              hi = std::max(hi, u[a] > 0 ? ahead : back);
            }
          }
          runLen = 0;
        };
        bool first = true;
        while (inside(k, j, i)) {
          if (isVoid(o)) {
            if (runLen == 0) {
              runStart = o;
              runK = k;
              runCut = first ? startCut : 0;
            }
            ++runLen;
          } else {
            if (runLen > 0) flush(runCut);
            if (k >= own1) break;  // what follows lies beyond the owned planes
          }
          first = false;
          k += dk;
          j += dj;
          i += di;
          o += stride;
        }
        // The run ends at the window boundary: the top (bed or slab edge) or a y/x face.
        if (runLen > 0)
          flush(runCut | ((dk != 0 && k >= wz && inside(k - dk, j, i)) ? topCut : kBedCut));
      }
    }
    sums.sliceCutChords += sliceChords;
    for (const auto& c : chordCount)
      for (std::size_t ell = 0; ell < c.size(); ++ell)
        if (c[ell]) sums.addChords(d, static_cast<std::int64_t>(ell), c[ell]);
  }
  if (field) {
    field->meanMm.assign(ownN, std::numeric_limits<float>::quiet_NaN());
    field->weight.assign(ownN, 0.0f);
  }
  // m(x) and its minus-sampling weight per owned void voxel; the per-thread sums are
  // integers, so their merge order does not matter.
  std::vector<MesSums> partial(static_cast<std::size_t>(nt), sums.emptyLike());
  std::vector<std::uint64_t> sliceVoxels(static_cast<std::size_t>(nt), 0);
  const auto nOwn = static_cast<std::int64_t>(ownN);
#pragma omp parallel for num_threads(nt) schedule(static)
  for (std::int64_t q = 0; q < nOwn; ++q) {
    const auto p = static_cast<std::size_t>(q);
    if (!isVoid(q + ownBase)) continue;
    const auto tid = static_cast<std::size_t>(omp_get_thread_num());
    float mean = std::numeric_limits<float>::quiet_NaN(), weight = 0.0f;
    if (cut[p] == kSliceCut) ++sliceVoxels[tid];
    if (count[p] != 0 && cut[p] == 0) {
      double wgt = 1;
      for (std::size_t a = 0; a < 3; ++a) {
        if (!g.cutAxes[a]) continue;
        const double span =
            static_cast<double>(reach[2 * a][p]) + static_cast<double>(reach[2 * a + 1][p]);
        // Translations of the star (span + 1 voxels) that stay in the bed: n − span.
        const auto n = static_cast<double>(bedN[a]);
        wgt *= n / std::max(1.0, n - span);
      }
      mean = sum[p] / static_cast<float>(count[p]);
      weight = static_cast<float>(wgt);
    }
    if (field) {
      field->meanMm[p] = mean;
      field->weight[p] = weight;
    }
    partial[tid].addVoxel(mean, weight);
  }
  for (std::size_t t = 0; t < partial.size(); ++t) {
    sums.merge(partial[t]);
    sums.sliceCutVoxels += sliceVoxels[t];
  }
  progress.report("mean empty space", 1.0);
}

}  // namespace voxpack::stats
