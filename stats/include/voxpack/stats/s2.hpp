#pragma once
/// \file s2.hpp
/// Two-point probability S2(h) of the void phase by FFT, masked and non-periodic
/// (docs/references.md): S2(h) = IFFT(|FFT(I·M)|²)(h) / IFFT(|FFT(M)|²)(h), zero-padded only
/// to n + h_max per axis. Derivation and the float/double choice: docs/stats.md.

#include <array>
#include <cstdint>
#include <vector>

#include "voxpack/core/grid.hpp"
#include "voxpack/core/progress.hpp"

namespace voxpack::stats {

/// Floating-point type of the FFTs.
enum class FftPrecision { Double, Float };

/// Options of twoPointProbability.
struct S2Options {
  /// Largest lag (mm) reported, > 0; <= 0 = default: a quarter of the smallest extent,
  /// at most 64 voxels.
  double maxLagMm = 0;
  /// Width (mm) of the radial bins; <= 0 = one voxel (smallest spacing).
  double binWidthMm = 0;
  /// Lags whose pair count is below this fraction (0..1) of the zero-lag count are dropped
  /// (noise, not signal); 0 keeps every lag with at least one pair.
  double minPairFraction = 0.3;
  /// FFT precision; double keeps pair counts exact to ~1e-9 (docs/stats.md).
  FftPrecision precision = FftPrecision::Double;
  /// Worker threads (>= 1) for FFTW and the lag reduction.
  int threads = 1;
  /// When every mask slice is the same (a column), compute the pair count exactly as the
  /// 2D pair count of one slice times (n_z − |h_z|) instead of a 3D FFT pair.
  bool prismMask = true;
  /// Streamed S2 only (S2SlabAccumulator): edge (voxels, y and x) of the tiles a slab is
  /// cut into, so the FFT buffers scale with the tile, not the plane; 0 = the whole plane.
  std::int64_t tileVoxels = 0;
};

/// One S2 curve: per bin the mean lag (mm), S2, and the pair count summed over the bin.
struct S2Curve {
  std::vector<double> hMm;    ///< pair-weighted mean |h| of each bin (mm); bin 0 is h = 0
  std::vector<double> s2;     ///< Σ numerator / Σ pair count over the bin
  std::vector<double> pairs;  ///< Σ pair count over the bin
};

/// Autocorrelation values for every lag with |h_a| <= maxLag[a], dense, C order
/// [2hz+1][2hy+1][2hx+1], lag 0 in the middle.
struct LagGrid {
  std::array<std::int64_t, 3> maxLag{0, 0, 0};  ///< (hz, hy, hx) voxels
  std::vector<double> values;                   ///< (2hz+1)(2hy+1)(2hx+1) values
  /// Value at lag (dz, dy, dx), each |d| <= maxLag.
  double at(std::int64_t dz, std::int64_t dy, std::int64_t dx) const {
    const std::int64_t ny = 2 * maxLag[1] + 1, nx = 2 * maxLag[2] + 1;
    return values[static_cast<std::size_t>(((dz + maxLag[0]) * ny + (dy + maxLag[1])) * nx +
                                           (dx + maxLag[2]))];
  }
};

/// Result of twoPointProbability.
struct S2Result {
  double phi = 0;          ///< porosity inside the mask (S2 at h = 0); 0 when empty mask
  bool emptyMask = false;  ///< no voxel inside the mask: curves are empty
  std::array<std::int64_t, 3> maxLagVoxels{0, 0, 0};  ///< (hz, hy, hx) lags computed
  std::array<std::int64_t, 3> paddedDims{0, 0, 0};    ///< FFT sizes used
  S2Curve radial;      ///< averaged over all directions, binned by |h|
  S2Curve axial;       ///< h along z only (h⊥ = 0), one bin per lag
  S2Curve transverse;  ///< h in the x-y plane only (h_z = 0), binned by |h|
  /// Lag (mm) where (S2 − φ²)/(φ − φ²) of the radial curve first falls below 1/e
  /// (linear interpolation); < 0 when not reached within the lags computed.
  double correlationLengthMm = -1;
  /// Specific surface (1/mm) from the slope at 0: s = −4 S2'(0), first radial bin.
  double specificSurfacePerMm = -1;
};

/// Autocorrelation Σ_x f(x) f(x+h) for |h_a| <= maxLag[a] of a real field on `dims`
/// (C order), by zero-padded FFT (no wrap-around). Exposed for tests and benchmarks.
LagGrid autocorrelation(const std::vector<double>& field, const std::array<std::int64_t, 3>& dims,
                        const std::array<std::int64_t, 3>& maxLag, FftPrecision precision,
                        int threads);

/// S2 of the void phase of `indicator` (1 void) inside `mask` (nullptr = everywhere).
S2Result twoPointProbability(const Grid<std::uint8_t>& indicator, const Grid<std::uint8_t>* mask,
                             const S2Options& options, Progress& progress = nullProgress());

/// The same estimator by brute-force direct sums over every pair (O(N·lags)); for tests.
S2Result twoPointProbabilityDirect(const Grid<std::uint8_t>& indicator,
                                   const Grid<std::uint8_t>* mask, const S2Options& options);

/// Lags (hz, hy, hx) voxels twoPointProbability computes on `lattice` with `options`.
std::array<std::int64_t, 3> s2MaxLag(const Lattice& lattice, const S2Options& options);

/// FFT sizes of the zero-padded correlation of a field of `dims` for lags `maxLag`.
std::array<std::int64_t, 3> s2PaddedDims(const std::array<std::int64_t, 3>& dims,
                                         const std::array<std::int64_t, 3>& maxLag);

/// Voxels (planes, rows, columns) one streamed S2 tile of `edge` (0 = whole planes) owns in
/// a slab of `planes` planes of ny x nx: the edge clipped to the plane.
std::array<std::int64_t, 3> s2TileOwn(std::int64_t planes, std::int64_t ny, std::int64_t nx,
                                      std::int64_t edge);

/// FFT box of one streamed S2 tile that owns `own` (planes, rows, columns) voxels: the
/// tile plus hz planes above and hy, hx on each side, rounded up to FFT-friendly sizes.
std::array<std::int64_t, 3> s2TileBox(const std::array<std::int64_t, 3>& own,
                                      const std::array<std::int64_t, 3>& maxLag);

/// Bytes of the two FFT buffers one streamed S2 tile of `own` voxels holds.
std::uint64_t s2TileBufferBytes(const std::array<std::int64_t, 3>& own,
                                const std::array<std::int64_t, 3>& maxLag, FftPrecision precision);

/// S2 of a bed streamed in z-slabs (docs/scale.md). Each slab owns planes [z0, z1) and is
/// given with hz more planes above (clipped at the top). The slab is cut into tiles of
/// S2Options::tileVoxels in y and x; for lags with h_z >= 0 each tile adds the pairs whose
/// first point lies in it, Σ_{p in tile} f(p) f(p+h), as one FFT cross-correlation of the
/// tile with the box around it (the tile, hz planes above, hy and hx each side): every
/// p + h lies inside that box, so the cyclic correlation needs no padding and has no
/// wrap-around. The other half of the lags follows from C(−h) = C(h). In double precision
/// every lag sum is rounded to its integer (the counts are integers, the FFT error is
/// < 1e-6), so the sum over tiles and slabs equals the whole-volume count exactly, in any
/// order.
class S2SlabAccumulator {
 public:
  /// Accumulator for `lattice` (the whole region streamed); `hasMask`: a mask is given with
  /// each slab; `prismMask`: every mask slice equals `prismSlice` (then the pair count is
  /// the slice's 2D count times (n_z − |h_z|), as in the in-memory path).
  S2SlabAccumulator(const Lattice& lattice, bool hasMask, bool prismMask, const S2Options& options);
  /// Lags computed; the slab halo is maxLag()[0] planes.
  const std::array<std::int64_t, 3>& maxLag() const { return maxLag_; }
  /// Sets the mask slice of a prism mask (needed once when prismMask).
  void setPrismSlice(const Grid<std::uint8_t>& slice);
  /// Adds the slab owning planes [z0, z1): `indicator` (and `mask`) hold planes
  /// [z0, min(nz, z1 + hz)).
  void addSlab(std::int64_t z0, std::int64_t z1, const Grid<std::uint8_t>& indicator,
               const Grid<std::uint8_t>* mask);
  /// Numerator sums over the lags with h_z >= 0 ((hz+1)(2hy+1)(2hx+1), for reductions).
  std::vector<double>& numerator() { return num_; }
  /// Pair-count sums (used only for a non-prism mask).
  std::vector<double>& pairCounts() { return den_; }
  /// Largest FFT sizes used by a tile.
  const std::array<std::int64_t, 3>& fftDims() const { return padded_; }
  /// The S2 result from the accumulated sums (identical to twoPointProbability's in double
  /// precision).
  S2Result finish() const;

 private:
  Lattice lattice_;
  bool hasMask_, prism_;
  S2Options options_;
  std::array<std::int64_t, 3> maxLag_{0, 0, 0};
  std::array<std::int64_t, 3> padded_{0, 0, 0};
  std::vector<double> num_, den_, prismPlane_;
  template <class R>
  void addTiles(std::int64_t own, const Grid<std::uint8_t>& indicator,
                const Grid<std::uint8_t>* mask);
};

/// Smallest FFT-friendly size (factors 2, 3, 5, 7 only) >= n.
std::int64_t fftFriendlySize(std::int64_t n);

}  // namespace voxpack::stats
