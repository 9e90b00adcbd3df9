// Benchmarks of the statistics on a 256×256×512 masked column (docs/stats.md):
//   voxpack_bench_stats s2 [--float] [--threads N] [--hmax 64]   time one S2
//   voxpack_bench_stats precision                                float vs double errors
//   voxpack_bench_stats mes [--threads N]                         lattice mean empty space
//   voxpack_bench_stats mes-accuracy [--samples N] [--directions K]  lattice vs isotropic
//   voxpack_bench_stats write-bed FILE.h5                         the volume, for s2_numpy.py
// The column: Boolean spheres (radius 14 voxels, η = 0.9) inside a cylinder mask of radius
// 127 voxels, seed 1 — a stand-in for a packed bed at the paper's NMR size.
#include <time.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <iostream>
#include <string>

#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/stats/mes.hpp"
#include "voxpack/stats/s2.hpp"

using namespace voxpack;
using namespace voxpack::stats;

namespace {

Bed makeColumn(std::int64_t nz, std::int64_t nxy, double radius, double eta) {
  Lattice l = Lattice::isotropic(nz, nxy, nxy, 0.18);
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(l, 1);
  bed.mask = Grid<std::uint8_t>(l, 0);
  const double c = 0.5 * static_cast<double>(nxy - 1), rc = 0.5 * static_cast<double>(nxy) - 1;
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < nxy; ++j)
      for (std::int64_t i = 0; i < nxy; ++i)
        (*bed.mask)(k, j, i) = std::hypot(i - c, j - c) <= rc ? 1 : 0;
  const double vol = static_cast<double>(nz + 2 * radius) * std::pow(nxy + 2 * radius, 2);
  const auto count = static_cast<std::int64_t>(
      std::llround(eta / (4.0 / 3.0 * M_PI * radius * radius * radius) * vol));
  RandomStream rng(1, 0);
  for (std::int64_t s = 0; s < count; ++s) {
    const double x = rng.uniform(-radius, nxy - 1 + radius),
                 y = rng.uniform(-radius, nxy - 1 + radius),
                 z = rng.uniform(-radius, nz - 1 + radius);
    for (auto k = std::max<std::int64_t>(0, std::ceil(z - radius));
         k <= std::min<std::int64_t>(nz - 1, std::floor(z + radius)); ++k)
      for (auto j = std::max<std::int64_t>(0, std::ceil(y - radius));
           j <= std::min<std::int64_t>(nxy - 1, std::floor(y + radius)); ++j)
        for (auto i = std::max<std::int64_t>(0, std::ceil(x - radius));
             i <= std::min<std::int64_t>(nxy - 1, std::floor(x + radius)); ++i)
          if ((i - x) * (i - x) + (j - y) * (j - y) + (k - z) * (k - z) <= radius * radius)
            bed.indicator(k, j, i) = 0;
  }
  return bed;
}

double seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// CPU seconds of the whole process (all threads): on a shared machine wall time mostly
// measures the other users; CPU time measures our work.
double cpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: voxpack_bench_stats s2|precision|mes|mes-accuracy|write-bed [...]\n";
    return 2;
  }
  const std::string mode = argv[1];
  int threads = 2, directions = 64;
  std::int64_t hmax = 64, samples = 5000, nz = 512, nxy = 256;
  bool useFloat = false, generic = false;
  for (int a = 2; a < argc; ++a) {
    const std::string s = argv[a];
    if (s == "--float") useFloat = true;
    if (s == "--generic") generic = true;  // no prism-mask shortcut: two 3D FFT pairs
    if (s == "--threads" && a + 1 < argc) threads = std::stoi(argv[++a]);
    if (s == "--hmax" && a + 1 < argc) hmax = std::stoll(argv[++a]);
    if (s == "--samples" && a + 1 < argc) samples = std::stoll(argv[++a]);
    if (s == "--directions" && a + 1 < argc) directions = std::stoi(argv[++a]);
    if (s == "--nz" && a + 1 < argc) nz = std::stoll(argv[++a]);
    if (s == "--nxy" && a + 1 < argc) nxy = std::stoll(argv[++a]);
  }
  auto t0 = std::chrono::steady_clock::now();
  const Bed bed = makeColumn(nz, nxy, 14, 0.9);
  std::cerr << "volume " << nz << "x" << nxy << "x" << nxy << " built in " << seconds(t0) << " s\n";
  if (mode == "write-bed") {
    writeBed(argv[2], bed);
    return 0;
  }
  if (mode == "s2") {
    S2Options o;
    o.maxLagMm = static_cast<double>(hmax) * 0.18;
    o.threads = threads;
    o.precision = useFloat ? FftPrecision::Float : FftPrecision::Double;
    o.prismMask = !generic;
    t0 = std::chrono::steady_clock::now();
    const double c0 = cpuSeconds();
    const S2Result r = twoPointProbability(bed.indicator, &*bed.mask, o);
    const double t = seconds(t0), cpu = cpuSeconds() - c0;
    std::cout << "s2 " << (useFloat ? "float" : "double") << (generic ? " generic" : " prism")
              << " threads " << threads << " hmax " << hmax << " fft " << r.paddedDims[0] << "x"
              << r.paddedDims[1] << "x" << r.paddedDims[2] << " seconds " << t << " cpu_seconds "
              << cpu << " phi " << r.phi << " bins " << r.radial.s2.size() << " s2[10] "
              << r.radial.s2[10] << "\n";
    return 0;
  }
  if (mode == "precision") {
    S2Options o;
    o.maxLagMm = static_cast<double>(hmax) * 0.18;
    o.threads = threads;
    o.minPairFraction = 0;
    std::vector<double> field(bed.mask->values().begin(), bed.mask->values().end());
    const auto dims = bed.lattice().dims;
    const std::array<std::int64_t, 3> h{hmax, hmax, hmax};
    const LagGrid dd = autocorrelation(field, dims, h, FftPrecision::Double, threads);
    const LagGrid df = autocorrelation(field, dims, h, FftPrecision::Float, threads);
    double worstD = 0, worstF = 0;
    for (std::size_t n = 0; n < dd.values.size(); ++n) {
      worstD = std::max(worstD, std::abs(dd.values[n] - std::round(dd.values[n])));
      worstF = std::max(worstF, std::abs(df.values[n] - std::round(dd.values[n])));
    }
    std::cout << "mask pair counts: max |double - integer| " << worstD << ", max |float - integer| "
              << worstF << "\n";
    const S2Result a = twoPointProbability(bed.indicator, &*bed.mask, o);
    o.precision = FftPrecision::Float;
    const S2Result b = twoPointProbability(bed.indicator, &*bed.mask, o);
    double worstS2 = 0, minS2 = 1;
    for (std::size_t n = 0; n < a.radial.s2.size(); ++n) {
      worstS2 = std::max(worstS2, std::abs(a.radial.s2[n] - b.radial.s2[n]));
      minS2 = std::min(minS2, b.radial.s2[n]);
    }
    double worstAxial = 0;
    for (std::size_t n = 0; n < a.axial.s2.size(); ++n)
      worstAxial = std::max(worstAxial, std::abs(a.axial.s2[n] - b.axial.s2[n]));
    std::cout << "S2 radial: max |float - double| " << worstS2 << ", axial curve " << worstAxial
              << ", min float S2 " << minS2 << "\n";
    return 0;
  }
  if (mode == "mes") {
    MesLatticeOptions o;
    o.threads = threads;
    const double c0 = cpuSeconds();
    const MesResult r = meanEmptySpaceLattice(bed, o);
    const double cpu = cpuSeconds() - c0;
    std::cout << "mes lattice threads " << threads << " seconds " << r.seconds << " cpu_seconds "
              << cpu << " mean_mm " << r.distribution.meanMm << " std_mm " << r.distribution.stdMm
              << " undefined " << r.undefinedVoxels << "/" << r.voidVoxels << "\n";
    return 0;
  }
  if (mode == "mes-accuracy") {
    MesIsotropicOptions io;
    io.samples = samples;
    io.directions = directions;
    io.threads = threads;
    std::vector<std::size_t> offsets;
    std::vector<double> iso;
    const MesResult ri = meanEmptySpaceIsotropic(bed, io, nullProgress(), &offsets, &iso);
    t0 = std::chrono::steady_clock::now();
    const MesField field = meanEmptySpaceField(bed, threads);
    const double tl = seconds(t0);
    double sumL = 0, sumI = 0, sumAbs = 0;
    std::size_t n = 0;
    for (std::size_t s = 0; s < offsets.size(); ++s) {
      const double l = field.meanMm[offsets[s]];
      if (!std::isfinite(l) || !std::isfinite(iso[s])) continue;
      sumL += l;
      sumI += iso[s];
      sumAbs += std::abs(l - iso[s]) / iso[s];
      ++n;
    }
    std::cout << "isotropic: " << samples << " samples x " << directions << " directions, "
              << ri.seconds << " s, mean " << ri.distribution.meanMm << " mm\n"
              << "lattice (whole volume): " << tl << " s\n"
              << "same voxels (" << n << "): lattice mean " << sumL / n << " mm, isotropic "
              << sumI / n << " mm, rel diff " << sumL / sumI - 1 << ", mean per-voxel |rel diff| "
              << sumAbs / n << "\n";
    return 0;
  }
  std::cerr << "unknown mode " << mode << "\n";
  return 2;
}
