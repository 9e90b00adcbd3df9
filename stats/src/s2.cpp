// Two-point probability by zero-padded FFT (docs/references.md, docs/stats.md).
#include "voxpack/stats/s2.hpp"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <type_traits>
#include <vector>

#include "voxpack/core/errors.hpp"

namespace voxpack::stats {
namespace {

// FFTW's planner is not thread-safe and its thread support must be initialised once.
std::mutex& plannerMutex() {
  static std::mutex m;
  return m;
}
void initFftwThreads() {
  static std::once_flag once;
  std::call_once(once, [] {
    fftw_init_threads();
    fftwf_init_threads();
  });
}

template <class R>
struct Fftw;
template <>
struct Fftw<double> {
  using Plan = fftw_plan;
  using Complex = fftw_complex;
  static void* alloc(std::size_t n) { return fftw_malloc(n * sizeof(double)); }
  static void release(void* p) { fftw_free(p); }
  static void threads(int n) { fftw_plan_with_nthreads(n); }
  static Plan r2c(int n0, int n1, int n2, double* in, Complex* out) {
    return fftw_plan_dft_r2c_3d(n0, n1, n2, in, out, FFTW_ESTIMATE);
  }
  static Plan c2r(int n0, int n1, int n2, Complex* in, double* out) {
    return fftw_plan_dft_c2r_3d(n0, n1, n2, in, out, FFTW_ESTIMATE);
  }
  using Dim = fftw_iodim64;
  static Plan r2cMany(const Dim& d, int hr, const Dim* h, double* in, Complex* out) {
    return fftw_plan_guru64_dft_r2c(1, &d, hr, h, in, out, FFTW_ESTIMATE);
  }
  static Plan c2rMany(const Dim& d, int hr, const Dim* h, Complex* in, double* out) {
    return fftw_plan_guru64_dft_c2r(1, &d, hr, h, in, out, FFTW_ESTIMATE);
  }
  static Plan c2cMany(const Dim& d, int hr, const Dim* h, Complex* io, int sign) {
    return fftw_plan_guru64_dft(1, &d, hr, h, io, io, sign, FFTW_ESTIMATE);
  }
  static void execute(Plan p) { fftw_execute(p); }
  static void executeR2c(Plan p, double* in, Complex* out) { fftw_execute_dft_r2c(p, in, out); }
  static void destroy(Plan p) { fftw_destroy_plan(p); }
};
template <>
struct Fftw<float> {
  using Plan = fftwf_plan;
  using Complex = fftwf_complex;
  static void* alloc(std::size_t n) { return fftwf_malloc(n * sizeof(float)); }
  static void release(void* p) { fftwf_free(p); }
  static void threads(int n) { fftwf_plan_with_nthreads(n); }
  static Plan r2c(int n0, int n1, int n2, float* in, Complex* out) {
    return fftwf_plan_dft_r2c_3d(n0, n1, n2, in, out, FFTW_ESTIMATE);
  }
  static Plan c2r(int n0, int n1, int n2, Complex* in, float* out) {
    return fftwf_plan_dft_c2r_3d(n0, n1, n2, in, out, FFTW_ESTIMATE);
  }
  using Dim = fftwf_iodim64;
  static Plan r2cMany(const Dim& d, int hr, const Dim* h, float* in, Complex* out) {
    return fftwf_plan_guru64_dft_r2c(1, &d, hr, h, in, out, FFTW_ESTIMATE);
  }
  static Plan c2rMany(const Dim& d, int hr, const Dim* h, Complex* in, float* out) {
    return fftwf_plan_guru64_dft_c2r(1, &d, hr, h, in, out, FFTW_ESTIMATE);
  }
  static Plan c2cMany(const Dim& d, int hr, const Dim* h, Complex* io, int sign) {
    return fftwf_plan_guru64_dft(1, &d, hr, h, io, io, sign, FFTW_ESTIMATE);
  }
  static void execute(Plan p) { fftwf_execute(p); }
  static void executeR2c(Plan p, float* in, Complex* out) { fftwf_execute_dft_r2c(p, in, out); }
  static void destroy(Plan p) { fftwf_destroy_plan(p); }
};

using Dims = std::array<std::int64_t, 3>;

// One in-place padded buffer and its forward/backward plans, reused for every field
// correlated on the same lattice (numerator and pair count).
template <class R>
class PaddedCorrelator {
 public:
  PaddedCorrelator(const Dims& dims, const Dims& padded, const Dims& maxLag, int threads)
      : dims_(dims), padded_(padded), maxLag_(maxLag), threads_(std::max(1, threads)) {
    rowStride_ = 2 * (padded_[2] / 2 + 1);
    count_ = static_cast<std::size_t>(padded_[0] * padded_[1] * rowStride_);
    buffer_ = static_cast<R*>(Fftw<R>::alloc(count_));
    if (!buffer_) throw InputError("S2: cannot allocate the FFT buffer");
    initFftwThreads();
    std::lock_guard<std::mutex> lock(plannerMutex());
    Fftw<R>::threads(threads_);
    try {
      makePlans();
    } catch (...) {
      for (auto p : forward_) Fftw<R>::destroy(p);
      for (auto p : backward_) Fftw<R>::destroy(p);
      Fftw<R>::release(buffer_);
      throw;
    }
  }
  ~PaddedCorrelator() {
    std::lock_guard<std::mutex> lock(plannerMutex());
    for (auto p : forward_) Fftw<R>::destroy(p);
    for (auto p : backward_) Fftw<R>::destroy(p);
    Fftw<R>::release(buffer_);
  }
  PaddedCorrelator(const PaddedCorrelator&) = delete;
  PaddedCorrelator& operator=(const PaddedCorrelator&) = delete;

  // value(offset) gives the field at C-order offset of the unpadded lattice.
  template <class Value>
  LagGrid run(Value value) {
    const std::int64_t p0 = padded_[0], p1 = padded_[1], s = rowStride_;
    const std::int64_t n0 = dims_[0], n1 = dims_[1], n2 = dims_[2];
    R* buf = buffer_;
#pragma omp parallel for num_threads(threads_) schedule(static)
    for (std::int64_t k = 0; k < p0; ++k) {
      for (std::int64_t j = 0; j < p1; ++j) {
        R* row = buf + (k * p1 + j) * s;
        std::int64_t i = 0;
        if (k < n0 && j < n1) {
          const std::size_t base = static_cast<std::size_t>((k * n1 + j) * n2);
          for (; i < n2; ++i) row[i] = static_cast<R>(value(base + static_cast<std::size_t>(i)));
        }
        for (; i < s; ++i) row[i] = R(0);
      }
    }
    for (auto p : forward_) Fftw<R>::execute(p);
    // |F|² in place: the autocorrelation's spectrum (Wiener-Khinchin).
    const std::int64_t pairs = static_cast<std::int64_t>(count_ / 2);
#pragma omp parallel for num_threads(threads_) schedule(static)
    for (std::int64_t c = 0; c < pairs; ++c) {
      const R re = buf[2 * c], im = buf[2 * c + 1];
      buf[2 * c] = re * re + im * im;
      buf[2 * c + 1] = R(0);
    }
    for (auto p : backward_) Fftw<R>::execute(p);
    LagGrid out;
    out.maxLag = maxLag_;
    const std::int64_t hz = maxLag_[0], hy = maxLag_[1], hx = maxLag_[2];
    const std::int64_t ly = 2 * hy + 1, lx = 2 * hx + 1;
    out.values.assign(static_cast<std::size_t>((2 * hz + 1) * ly * lx), 0.0);
    const double norm = 1.0 / (static_cast<double>(padded_[0]) * static_cast<double>(padded_[1]) *
                               static_cast<double>(padded_[2]));
    const std::int64_t p2 = padded_[2];
#pragma omp parallel for num_threads(threads_) schedule(static)
    for (std::int64_t dz = -hz; dz <= hz; ++dz) {
      const std::int64_t kk = (dz + p0) % p0;
      for (std::int64_t dy = -hy; dy <= hy; ++dy) {
        const std::int64_t jj = (dy + p1) % p1;
        const R* row = buf + (kk * p1 + jj) * s;
        double* dst = out.values.data() + ((dz + hz) * ly + (dy + hy)) * lx;
        for (std::int64_t dx = -hx; dx <= hx; ++dx)
          dst[dx + hx] = static_cast<double>(row[(dx + p2) % p2]) * norm;
      }
    }
    return out;
  }

 private:
  Dims dims_, padded_, maxLag_;
  int threads_;
  std::int64_t rowStride_ = 0;
  std::size_t count_ = 0;
  R* buffer_ = nullptr;
  std::vector<typename Fftw<R>::Plan> forward_, backward_;

  // Separable 1D passes that skip what is known to be zero or not needed (docs/stats.md):
  // forward, x only on the n0·n1 rows holding data, y only on the n0 planes holding data,
  // then z everywhere; backward, z everywhere, then y only on the 2hz+1 planes of the lags
  // reported, x only on their 2hy+1 rows. Plans are made once and reused for every field.
  void makePlans() {
    using Dim = typename Fftw<R>::Dim;
    using Complex = typename Fftw<R>::Complex;
    const std::int64_t p0 = padded_[0], p1 = padded_[1], p2 = padded_[2];
    const std::int64_t h = p2 / 2 + 1, s = rowStride_;
    const std::int64_t n0 = dims_[0], n1 = dims_[1];
    auto* c = reinterpret_cast<Complex*>(buffer_);
    auto check = [](typename Fftw<R>::Plan p) {
      if (!p) throw InternalError("S2: FFTW could not plan a transform");
      return p;
    };
    {
      const Dim d{p2, 1, 1};
      const Dim many[2] = {{n0, p1 * s, p1 * h}, {n1, s, h}};
      forward_.push_back(check(Fftw<R>::r2cMany(d, 2, many, buffer_, c)));
    }
    {
      const Dim d{p1, h, h};
      const Dim many[2] = {{n0, p1 * h, p1 * h}, {h, 1, 1}};
      forward_.push_back(check(Fftw<R>::c2cMany(d, 2, many, c, FFTW_FORWARD)));
    }
    const Dim dz{p0, p1 * h, p1 * h};
    const Dim zmany[2] = {{p1, h, h}, {h, 1, 1}};
    forward_.push_back(check(Fftw<R>::c2cMany(dz, 2, zmany, c, FFTW_FORWARD)));
    backward_.push_back(check(Fftw<R>::c2cMany(dz, 2, zmany, c, FFTW_BACKWARD)));
    // Lag groups: [0, h_a] and [P_a − h_a, P_a − 1] on z and y.
    const std::int64_t hz = maxLag_[0], hy = maxLag_[1];
    const std::pair<std::int64_t, std::int64_t> planes[2] = {{0, hz + 1}, {p0 - hz, hz}};
    const std::pair<std::int64_t, std::int64_t> rows[2] = {{0, hy + 1}, {p1 - hy, hy}};
    for (const auto& [first, count] : planes) {
      if (count <= 0) continue;
      const Dim d{p1, h, h};
      const Dim many[2] = {{count, p1 * h, p1 * h}, {h, 1, 1}};
      backward_.push_back(check(Fftw<R>::c2cMany(d, 2, many, c + first * p1 * h, FFTW_BACKWARD)));
    }
    for (const auto& [first, count] : planes) {
      if (count <= 0) continue;
      for (const auto& [row, rowCount] : rows) {
        if (rowCount <= 0) continue;
        const Dim d{p2, 1, 1};
        const Dim many[2] = {{count, p1 * h, p1 * s}, {rowCount, h, s}};
        const std::int64_t offset = first * p1 + row;
        backward_.push_back(
            check(Fftw<R>::c2rMany(d, 2, many, c + offset * h, buffer_ + offset * s)));
      }
    }
  }
};

// Cross-correlation Σ_p a(p) b(p + h) on one box, for the lags 0 <= dz <= hz,
// |dy| <= hy, |dx| <= hx. The caller keeps a zero outside a sub-box (the tile) whose every
// p + h lies inside the box, so the cyclic correlation is the linear one: no padding.
// Two in-place buffers (a's spectrum, then b's), one forward and one backward plan.
template <class R>
class BoxCrossCorrelator {
 public:
  BoxCrossCorrelator(const Dims& box, const Dims& maxLag, int threads)
      : box_(box), maxLag_(maxLag), threads_(std::max(1, threads)) {
    stride_ = 2 * (box_[2] / 2 + 1);
    count_ = static_cast<std::size_t>(box_[0] * box_[1] * stride_);
    a_ = static_cast<R*>(Fftw<R>::alloc(count_));
    b_ = static_cast<R*>(Fftw<R>::alloc(count_));
    if (!a_ || !b_) {
      Fftw<R>::release(a_);
      Fftw<R>::release(b_);
      throw InputError("S2: cannot allocate the FFT buffers of a tile");
    }
    initFftwThreads();
    std::lock_guard<std::mutex> lock(plannerMutex());
    Fftw<R>::threads(threads_);
    using Complex = typename Fftw<R>::Complex;
    const int n0 = static_cast<int>(box_[0]), n1 = static_cast<int>(box_[1]),
              n2 = static_cast<int>(box_[2]);
    forward_ = Fftw<R>::r2c(n0, n1, n2, b_, reinterpret_cast<Complex*>(b_));
    backward_ = Fftw<R>::c2r(n0, n1, n2, reinterpret_cast<Complex*>(b_), b_);
    if (!forward_ || !backward_) {
      if (forward_) Fftw<R>::destroy(forward_);
      if (backward_) Fftw<R>::destroy(backward_);
      Fftw<R>::release(a_);
      Fftw<R>::release(b_);
      throw InternalError("S2: FFTW could not plan a tile transform");
    }
  }
  ~BoxCrossCorrelator() {
    std::lock_guard<std::mutex> lock(plannerMutex());
    Fftw<R>::destroy(forward_);
    Fftw<R>::destroy(backward_);
    Fftw<R>::release(a_);
    Fftw<R>::release(b_);
  }
  BoxCrossCorrelator(const BoxCrossCorrelator&) = delete;
  BoxCrossCorrelator& operator=(const BoxCrossCorrelator&) = delete;

  // a(k, j, i) and b(k, j, i) give the fields at box cell (k, j, i). Returns the lag sums
  // in the accumulator's half-grid order [hz+1][2hy+1][2hx+1].
  template <class A, class B>
  std::vector<double> run(A a, B b) {
    using Complex = typename Fftw<R>::Complex;
    fill(a_, a);
    fill(b_, b);
    Fftw<R>::executeR2c(forward_, a_, reinterpret_cast<Complex*>(a_));
    Fftw<R>::executeR2c(forward_, b_, reinterpret_cast<Complex*>(b_));
    // conj(A)·B is the spectrum of Σ_p a(p) b(p + h).
    const std::int64_t pairs = static_cast<std::int64_t>(count_ / 2);
    R* fa = a_;
    R* fb = b_;
#pragma omp parallel for num_threads(threads_) schedule(static)
    for (std::int64_t c = 0; c < pairs; ++c) {
      const R ar = fa[2 * c], ai = fa[2 * c + 1], br = fb[2 * c], bi = fb[2 * c + 1];
      fb[2 * c] = ar * br + ai * bi;
      fb[2 * c + 1] = ar * bi - ai * br;
    }
    Fftw<R>::execute(backward_);
    const std::int64_t hz = maxLag_[0], hy = maxLag_[1], hx = maxLag_[2];
    const std::int64_t ly = 2 * hy + 1, lx = 2 * hx + 1;
    const std::int64_t n1 = box_[1], n2 = box_[2];
    const double norm =
        1.0 / (static_cast<double>(box_[0]) * static_cast<double>(n1) * static_cast<double>(n2));
    std::vector<double> out(static_cast<std::size_t>((hz + 1) * ly * lx));
    for (std::int64_t dz = 0; dz <= hz; ++dz)
      for (std::int64_t dy = -hy; dy <= hy; ++dy) {
        const R* row = fb + (dz * n1 + (dy + n1) % n1) * stride_;
        double* dst = out.data() + (dz * ly + (dy + hy)) * lx;
        for (std::int64_t dx = -hx; dx <= hx; ++dx) {
          const double v = static_cast<double>(row[(dx + n2) % n2]) * norm;
          dst[dx + hx] = std::is_same_v<R, double> ? std::nearbyint(v) : v;
        }
      }
    return out;
  }

 private:
  Dims box_, maxLag_;
  int threads_;
  std::int64_t stride_ = 0;
  std::size_t count_ = 0;
  R* a_ = nullptr;
  R* b_ = nullptr;
  typename Fftw<R>::Plan forward_{}, backward_{};

  template <class F>
  void fill(R* buf, F f) const {
    const std::int64_t n0 = box_[0], n1 = box_[1], n2 = box_[2], s = stride_;
#pragma omp parallel for num_threads(threads_) schedule(static)
    for (std::int64_t k = 0; k < n0; ++k)
      for (std::int64_t j = 0; j < n1; ++j) {
        R* row = buf + (k * n1 + j) * s;
        for (std::int64_t i = 0; i < n2; ++i) row[i] = static_cast<R>(f(k, j, i));
        for (std::int64_t i = n2; i < s; ++i) row[i] = R(0);
      }
  }
};

Dims paddedDims(const Dims& dims, const Dims& maxLag) {
  Dims p{};
  for (int a = 0; a < 3; ++a) p[a] = fftFriendlySize(dims[a] + maxLag[a]);
  return p;
}

// Numerator and pair-count lag grids, FFT path.
// True when every slice of the mask equals the first (a prism along z, e.g. a column).
bool isPrism(const Grid<std::uint8_t>& mask) {
  const Lattice& l = mask.lattice();
  const std::size_t slice = static_cast<std::size_t>(l.ny() * l.nx());
  const std::uint8_t* m = mask.data();
  for (std::int64_t k = 1; k < l.nz(); ++k)
    if (!std::equal(m, m + slice, m + static_cast<std::size_t>(k) * slice)) return false;
  return true;
}

// Lag sums of 0/1 fields are integers; in double precision the FFT error is far below
// 0.5 (relative 1e-16 of sums < 2^53), so rounding makes them exact and order-free: the
// streamed and MPI paths then give bit-identical sums (docs/scale.md).
template <class R>
void roundCounts(LagGrid& g) {
  if constexpr (std::is_same_v<R, double>)
    for (double& v : g.values) v = std::nearbyint(v);
}

template <class R>
std::pair<LagGrid, LagGrid> fftLagGrids(const Grid<std::uint8_t>& indicator,
                                        const Grid<std::uint8_t>* mask, const Dims& maxLag,
                                        int threads, bool prismMask, Progress& progress) {
  const Dims dims = indicator.lattice().dims;
  PaddedCorrelator<R> corr(dims, paddedDims(dims, maxLag), maxLag, threads);
  const std::uint8_t* ind = indicator.data();
  LagGrid num;
  if (mask) {
    const std::uint8_t* m = mask->data();
    num = corr.run([&](std::size_t o) { return ind[o] & m[o]; });
  } else {
    num = corr.run([&](std::size_t o) { return ind[o]; });
  }
  roundCounts<R>(num);
  progress.report("S2", 0.5);
  LagGrid den;
  den.maxLag = maxLag;
  auto fillProduct = [&](const LagGrid& plane, auto along) {
    // Pair count of a field that is a product f(y, x)·g(z): plane autocorrelation times
    // the pair count along z.
    den.values.resize(num.values.size());
    std::size_t idx = 0;
    for (std::int64_t dz = -maxLag[0]; dz <= maxLag[0]; ++dz)
      for (std::int64_t dy = -maxLag[1]; dy <= maxLag[1]; ++dy)
        for (std::int64_t dx = -maxLag[2]; dx <= maxLag[2]; ++dx)
          den.values[idx++] = plane.at(0, dy, dx) * along(dz);
  };
  if (mask && prismMask && isPrism(*mask)) {
    // A column mask that repeats slice after slice: its 3D pair count factorises exactly
    // into the 2D pair count of one slice times (n_z − |h_z|): one FFT pair saved.
    const std::uint8_t* m = mask->data();
    PaddedCorrelator<R> plane({1, dims[1], dims[2]},
                              paddedDims({1, dims[1], dims[2]}, {0, maxLag[1], maxLag[2]}),
                              {0, maxLag[1], maxLag[2]}, threads);
    LagGrid slice = plane.run([&](std::size_t o) { return m[o]; });
    roundCounts<R>(slice);
    fillProduct(slice,
                [&](std::int64_t dz) { return static_cast<double>(dims[0] - std::abs(dz)); });
  } else if (mask) {
    const std::uint8_t* m = mask->data();
    den = corr.run([&](std::size_t o) { return m[o]; });
    roundCounts<R>(den);
  } else {
    // Without a mask the pair count is exact: Π (n_a − |h_a|).
    LagGrid plane;
    plane.maxLag = {0, maxLag[1], maxLag[2]};
    for (std::int64_t dy = -maxLag[1]; dy <= maxLag[1]; ++dy)
      for (std::int64_t dx = -maxLag[2]; dx <= maxLag[2]; ++dx)
        plane.values.push_back(static_cast<double>(dims[1] - std::abs(dy)) *
                               static_cast<double>(dims[2] - std::abs(dx)));
    fillProduct(plane,
                [&](std::int64_t dz) { return static_cast<double>(dims[0] - std::abs(dz)); });
  }
  progress.report("S2", 1.0);
  return {std::move(num), std::move(den)};
}

Dims resolveMaxLag(const Lattice& l, const S2Options& o) {
  const double minSpacing = std::min({l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]});
  double lagMm = o.maxLagMm;
  if (!(lagMm > 0)) {
    const std::int64_t minDim = std::min({l.dims[0], l.dims[1], l.dims[2]});
    lagMm = static_cast<double>(std::clamp<std::int64_t>(minDim / 4, 1, 64)) * minSpacing;
  }
  Dims h{};
  for (int a = 0; a < 3; ++a)
    h[a] = std::clamp<std::int64_t>(
        static_cast<std::int64_t>(std::floor(lagMm / l.spacingMm[a] + 1e-9)), 0, l.dims[a] - 1);
  return h;
}

void validateOptions(const Grid<std::uint8_t>& indicator, const Grid<std::uint8_t>* mask,
                     const S2Options& o) {
  indicator.lattice().validate("S2 indicator");
  if (mask && mask->lattice().dims != indicator.lattice().dims)
    throw InputError("S2: the mask and the indicator have different dimensions");
  if (!std::isfinite(o.maxLagMm)) throw InputError("S2: max lag must be finite");
  if (!std::isfinite(o.binWidthMm)) throw InputError("S2: bin width must be finite");
  if (!(o.minPairFraction >= 0 && o.minPairFraction <= 1))
    throw InputError("S2: min pair fraction must be in [0, 1]");
}

struct BinSums {
  std::vector<double> num, den, lagDen;
  void add(std::size_t b, double n, double d, double r) {
    if (b >= num.size()) {
      num.resize(b + 1, 0.0);
      den.resize(b + 1, 0.0);
      lagDen.resize(b + 1, 0.0);
    }
    num[b] += n;
    den[b] += d;
    lagDen[b] += r * d;
  }
  S2Curve curve() const {
    S2Curve c;
    for (std::size_t b = 0; b < num.size(); ++b) {
      if (!(den[b] > 0)) continue;
      c.hMm.push_back(lagDen[b] / den[b]);
      c.s2.push_back(num[b] / den[b]);
      c.pairs.push_back(den[b]);
    }
    return c;
  }
};

S2Result reduce(const LagGrid& num, const LagGrid& den, const Lattice& l, const S2Options& o,
                const Dims& maxLag) {
  S2Result r;
  r.maxLagVoxels = maxLag;
  const double zeroPairs = den.at(0, 0, 0);
  if (!(zeroPairs > 0.5)) {
    r.emptyMask = true;
    return r;
  }
  r.phi = num.at(0, 0, 0) / zeroPairs;
  const double minSpacing = std::min({l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]});
  const double width = o.binWidthMm > 0 ? o.binWidthMm : minSpacing;
  double maxLagMm = 0;
  for (int a = 0; a < 3; ++a)
    maxLagMm = std::max(maxLagMm, static_cast<double>(maxLag[a]) * l.spacingMm[a]);
  if (o.maxLagMm > 0) maxLagMm = std::min(maxLagMm, o.maxLagMm);
  const double threshold = std::max(0.5, o.minPairFraction * zeroPairs);
  const double sz = l.spacingMm[0], sy = l.spacingMm[1], sx = l.spacingMm[2];
  auto binOf = [&](double rr) -> std::size_t {
    if (rr == 0) return 0;
    return static_cast<std::size_t>(std::max(1.0, std::round(rr / width)));
  };
  BinSums radial, axial, transverse;
  for (std::int64_t dz = -maxLag[0]; dz <= maxLag[0]; ++dz)
    for (std::int64_t dy = -maxLag[1]; dy <= maxLag[1]; ++dy)
      for (std::int64_t dx = -maxLag[2]; dx <= maxLag[2]; ++dx) {
        const double d = den.at(dz, dy, dx);
        if (d < threshold) continue;
        const double n = num.at(dz, dy, dx);
        const double z = static_cast<double>(dz) * sz, y = static_cast<double>(dy) * sy,
                     x = static_cast<double>(dx) * sx;
        const double rr = std::sqrt(z * z + y * y + x * x);
        if (rr > maxLagMm * (1 + 1e-12)) continue;
        radial.add(binOf(rr), n, d, rr);
        if (dy == 0 && dx == 0) axial.add(static_cast<std::size_t>(std::abs(dz)), n, d, rr);
        if (dz == 0) transverse.add(binOf(rr), n, d, rr);
      }
  r.radial = radial.curve();
  r.axial = axial.curve();
  r.transverse = transverse.curve();
  // Correlation length: first 1/e crossing of the normalised covariance.
  const double var = r.phi - r.phi * r.phi;
  if (var > 1e-12) {
    const auto& h = r.radial.hMm;
    const auto& s = r.radial.s2;
    for (std::size_t b = 1; b < s.size(); ++b) {
      const double f1 = (s[b] - r.phi * r.phi) / var;
      if (f1 < std::exp(-1.0)) {
        const double f0 = (s[b - 1] - r.phi * r.phi) / var;
        const double t = (f0 - std::exp(-1.0)) / (f0 - f1);
        r.correlationLengthMm = h[b - 1] + t * (h[b] - h[b - 1]);
        break;
      }
    }
    if (s.size() > 1 && h[1] > 0) r.specificSurfacePerMm = -4.0 * (s[1] - s[0]) / h[1];
  }
  return r;
}

}  // namespace

std::int64_t fftFriendlySize(std::int64_t n) {
  if (n <= 1) return 1;
  for (std::int64_t m = n;; ++m) {
    std::int64_t r = m;
    for (std::int64_t f : {2, 3, 5, 7})
      while (r % f == 0) r /= f;
    if (r == 1) return m;
  }
}

LagGrid autocorrelation(const std::vector<double>& field, const Dims& dims, const Dims& maxLag,
                        FftPrecision precision, int threads) {
  if (field.size() != static_cast<std::size_t>(dims[0] * dims[1] * dims[2]))
    throw InputError("autocorrelation: field size does not match dims");
  Dims h{};
  for (int a = 0; a < 3; ++a) h[a] = std::clamp<std::int64_t>(maxLag[a], 0, dims[a] - 1);
  auto value = [&](std::size_t o) { return field[o]; };
  if (precision == FftPrecision::Float) {
    PaddedCorrelator<float> c(dims, paddedDims(dims, h), h, threads);
    return c.run(value);
  }
  PaddedCorrelator<double> c(dims, paddedDims(dims, h), h, threads);
  return c.run(value);
}

S2Result twoPointProbability(const Grid<std::uint8_t>& indicator, const Grid<std::uint8_t>* mask,
                             const S2Options& options, Progress& progress) {
  validateOptions(indicator, mask, options);
  const Lattice& l = indicator.lattice();
  const Dims h = resolveMaxLag(l, options);
  const int threads = std::max(1, options.threads);
  auto grids = options.precision == FftPrecision::Float
                   ? fftLagGrids<float>(indicator, mask, h, threads, options.prismMask, progress)
                   : fftLagGrids<double>(indicator, mask, h, threads, options.prismMask, progress);
  S2Result r = reduce(grids.first, grids.second, l, options, h);
  r.paddedDims = paddedDims(l.dims, h);
  return r;
}

S2Result twoPointProbabilityDirect(const Grid<std::uint8_t>& indicator,
                                   const Grid<std::uint8_t>* mask, const S2Options& options) {
  validateOptions(indicator, mask, options);
  const Lattice& l = indicator.lattice();
  const Dims h = resolveMaxLag(l, options);
  const Dims n = l.dims;
  LagGrid num, den;
  num.maxLag = den.maxLag = h;
  const std::size_t lagCount =
      static_cast<std::size_t>((2 * h[0] + 1) * (2 * h[1] + 1) * (2 * h[2] + 1));
  num.values.assign(lagCount, 0.0);
  den.values.assign(lagCount, 0.0);
  auto m = [&](std::int64_t k, std::int64_t j, std::int64_t i) -> double {
    return mask ? (*mask)(k, j, i) : 1.0;
  };
  std::size_t idx = 0;
  for (std::int64_t dz = -h[0]; dz <= h[0]; ++dz)
    for (std::int64_t dy = -h[1]; dy <= h[1]; ++dy)
      for (std::int64_t dx = -h[2]; dx <= h[2]; ++dx, ++idx) {
        double sn = 0, sd = 0;
        for (std::int64_t k = std::max<std::int64_t>(0, -dz); k < std::min(n[0], n[0] - dz); ++k)
          for (std::int64_t j = std::max<std::int64_t>(0, -dy); j < std::min(n[1], n[1] - dy); ++j)
            for (std::int64_t i = std::max<std::int64_t>(0, -dx); i < std::min(n[2], n[2] - dx);
                 ++i) {
              const double a = m(k, j, i), b = m(k + dz, j + dy, i + dx);
              sd += a * b;
              sn += a * b * indicator(k, j, i) * indicator(k + dz, j + dy, i + dx);
            }
        num.values[idx] = sn;
        den.values[idx] = sd;
      }
  S2Result r = reduce(num, den, l, options, h);
  r.paddedDims = n;
  return r;
}

Dims s2MaxLag(const Lattice& lattice, const S2Options& options) {
  return resolveMaxLag(lattice, options);
}

Dims s2PaddedDims(const Dims& dims, const Dims& maxLag) { return paddedDims(dims, maxLag); }

Dims s2TileOwn(std::int64_t planes, std::int64_t ny, std::int64_t nx, std::int64_t edge) {
  return {planes, edge > 0 ? std::min(edge, ny) : ny, edge > 0 ? std::min(edge, nx) : nx};
}

Dims s2TileBox(const Dims& own, const Dims& maxLag) {
  return {fftFriendlySize(own[0] + maxLag[0]), fftFriendlySize(own[1] + 2 * maxLag[1]),
          fftFriendlySize(own[2] + 2 * maxLag[2])};
}

std::uint64_t s2TileBufferBytes(const Dims& own, const Dims& maxLag, FftPrecision precision) {
  const Dims b = s2TileBox(own, maxLag);
  const std::uint64_t cells = static_cast<std::uint64_t>(b[0]) * static_cast<std::uint64_t>(b[1]) *
                              2 * (static_cast<std::uint64_t>(b[2]) / 2 + 1);
  return 2 * cells * (precision == FftPrecision::Float ? 4 : 8);
}

S2SlabAccumulator::S2SlabAccumulator(const Lattice& lattice, bool hasMask, bool prismMask,
                                     const S2Options& options)
    : lattice_(lattice),
      hasMask_(hasMask),
      prism_(hasMask && prismMask && options.prismMask),
      options_(options) {
  lattice.validate("S2 lattice");
  if (!std::isfinite(options.maxLagMm)) throw InputError("S2: max lag must be finite");
  if (!std::isfinite(options.binWidthMm)) throw InputError("S2: bin width must be finite");
  if (!(options.minPairFraction >= 0 && options.minPairFraction <= 1))
    throw InputError("S2: min pair fraction must be in [0, 1]");
  maxLag_ = resolveMaxLag(lattice, options);
  const std::size_t half =
      static_cast<std::size_t>((maxLag_[0] + 1) * (2 * maxLag_[1] + 1) * (2 * maxLag_[2] + 1));
  num_.assign(half, 0.0);
  if (hasMask_ && !prism_) den_.assign(half, 0.0);
}

void S2SlabAccumulator::setPrismSlice(const Grid<std::uint8_t>& slice) {
  if (!prism_) return;
  const Dims d{1, lattice_.dims[1], lattice_.dims[2]};
  const Dims h{0, maxLag_[1], maxLag_[2]};
  const std::uint8_t* m = slice.data();
  if (options_.precision == FftPrecision::Float) {
    PaddedCorrelator<float> plane(d, paddedDims(d, h), h, options_.threads);
    prismPlane_ = plane.run([&](std::size_t o) { return m[o]; }).values;
  } else {
    PaddedCorrelator<double> plane(d, paddedDims(d, h), h, options_.threads);
    LagGrid g = plane.run([&](std::size_t o) { return m[o]; });
    roundCounts<double>(g);
    prismPlane_ = std::move(g.values);
  }
}

void S2SlabAccumulator::addSlab(std::int64_t z0, std::int64_t z1,
                                const Grid<std::uint8_t>& indicator,
                                const Grid<std::uint8_t>* mask) {
  const Lattice& l = indicator.lattice();
  const std::int64_t nz = lattice_.dims[0];
  const std::int64_t expected = std::min(nz, z1 + maxLag_[0]) - z0;
  if (l.dims[0] != expected || l.dims[1] != lattice_.dims[1] || l.dims[2] != lattice_.dims[2] ||
      z0 < 0 || z1 <= z0 || z1 > nz)
    throw InternalError("S2 slab: planes do not match the slab and its halo");
  if (hasMask_ != (mask != nullptr)) throw InternalError("S2 slab: mask presence differs");
  if (options_.precision == FftPrecision::Float)
    addTiles<float>(z1 - z0, indicator, mask);
  else
    addTiles<double>(z1 - z0, indicator, mask);
}

template <class R>
void S2SlabAccumulator::addTiles(std::int64_t own, const Grid<std::uint8_t>& indicator,
                                 const Grid<std::uint8_t>* mask) {
  const Dims d = indicator.lattice().dims;  // own planes + halo (clipped at the top)
  const std::int64_t ny = d[1], nx = d[2], hy = maxLag_[1], hx = maxLag_[2];
  const Dims tile = s2TileOwn(own, ny, nx, options_.tileVoxels);
  const std::int64_t ty = tile[1], tx = tile[2];
  const Dims box = s2TileBox(tile, maxLag_);
  for (int a = 0; a < 3; ++a) padded_[a] = std::max(padded_[a], box[a]);
  BoxCrossCorrelator<R> corr(box, maxLag_, options_.threads);
  const std::uint8_t* ind = indicator.data();
  const std::uint8_t* m = mask ? mask->data() : nullptr;
  const std::int64_t planes = d[0], halfZ = maxLag_[0];
  for (std::int64_t y0 = 0; y0 < ny; y0 += ty)
    for (std::int64_t x0 = 0; x0 < nx; x0 += tx) {
      // Box cell (k, j, i) is slab voxel (k, y0 − hy + j, x0 − hx + i). `b` is the field on
      // the tile and its halo (zero outside the volume), `a` the field on the tile alone.
      const std::int64_t y1 = std::min(ny, y0 + ty), x1 = std::min(nx, x0 + tx);
      auto offset = [&](std::int64_t k, std::int64_t j, std::int64_t i, bool tileOnly) {
        const std::int64_t y = y0 - hy + j, x = x0 - hx + i;
        const bool in = tileOnly
                            ? (k < own && y >= y0 && y < y1 && x >= x0 && x < x1)
                            : (k < planes && k < own + halfZ && y >= y0 - hy && y < y1 + hy &&
                               y >= 0 && y < ny && x >= x0 - hx && x < x1 + hx && x >= 0 && x < nx);
        return in ? static_cast<std::ptrdiff_t>((k * ny + y) * nx + x) : std::ptrdiff_t{-1};
      };
      auto field = [&](bool tileOnly, bool maskOnly) {
        return [&, tileOnly, maskOnly](std::int64_t k, std::int64_t j, std::int64_t i) -> int {
          const std::ptrdiff_t o = offset(k, j, i, tileOnly);
          if (o < 0) return 0;
          if (maskOnly) return m[o];
          return m ? (ind[o] & m[o]) : ind[o];
        };
      };
      const std::vector<double> num = corr.run(field(true, false), field(false, false));
      for (std::size_t n = 0; n < num_.size(); ++n) num_[n] += num[n];
      if (!den_.empty()) {
        const std::vector<double> den = corr.run(field(true, true), field(false, true));
        for (std::size_t n = 0; n < den_.size(); ++n) den_[n] += den[n];
      }
    }
}

S2Result S2SlabAccumulator::finish() const {
  const Dims h = maxLag_;
  const std::int64_t ly = 2 * h[1] + 1, lx = 2 * h[2] + 1;
  const std::size_t plane = static_cast<std::size_t>(ly * lx);
  LagGrid num, den;
  num.maxLag = den.maxLag = h;
  num.values.assign(static_cast<std::size_t>(2 * h[0] + 1) * plane, 0.0);
  den.values.assign(num.values.size(), 0.0);
  const Dims n = lattice_.dims;
  std::size_t idx = 0;
  for (std::int64_t dz = -h[0]; dz <= h[0]; ++dz)
    for (std::int64_t dy = -h[1]; dy <= h[1]; ++dy)
      for (std::int64_t dx = -h[2]; dx <= h[2]; ++dx, ++idx) {
        // C(−h) = C(h): the h_z < 0 half mirrors the half accumulated.
        const bool up = dz > 0 || (dz == 0 && (dy > 0 || (dy == 0 && dx >= 0)));
        const std::int64_t sz = up ? dz : -dz, sy = up ? dy : -dy, sx = up ? dx : -dx;
        const std::size_t half =
            static_cast<std::size_t>((sz * ly + (sy + h[1])) * lx + (sx + h[2]));
        num.values[idx] = num_[half];
        if (!den_.empty()) {
          den.values[idx] = den_[half];
        } else if (prism_) {
          const std::size_t p = static_cast<std::size_t>((dy + h[1]) * lx + (dx + h[2]));
          den.values[idx] = (prismPlane_.empty() ? 0.0 : prismPlane_[p]) *
                            static_cast<double>(n[0] - std::abs(dz));
        } else {
          den.values[idx] = static_cast<double>(n[1] - std::abs(dy)) *
                            static_cast<double>(n[2] - std::abs(dx)) *
                            static_cast<double>(n[0] - std::abs(dz));
        }
      }
  S2Result r = reduce(num, den, lattice_, options_, h);
  r.paddedDims = padded_;
  return r;
}

}  // namespace voxpack::stats
