// voxpack_bench_ingest [--threads N] [--n 256] [--nz 512] [--keep DIR]
// Builds a sphere bed in a column (the paper's NMR geometry: 256 x 256 x 512 voxels of
// 0.18 mm, pellets 30 voxels across), images it as a 16-bit MRI phantom (SNR 10, blur
// 1 voxel, bias 20 %), writes it as NRRD, then times `ingest` with the default pipeline
// (read + 7-point median + Otsu + clean-up + column fit + bed write) and, separately,
// with N4 bias correction added.
#include <time.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/ingest/image_io.hpp"
#include "voxpack/ingest/ingest.hpp"
#include "voxpack/ingest/phantom.hpp"

using namespace voxpack;
using namespace voxpack::ingest;
namespace fs = std::filesystem;

namespace {

// CPU seconds of the whole process (all threads): on a shared machine the wall time
// includes waiting for other jobs, the CPU time does not.
double cpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

Bed sphereColumn(std::int64_t n, std::int64_t nz, double voxelMm) {
  const Lattice l = Lattice::isotropic(nz, n, n, voxelMm);
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(l, 1);
  bed.mask = Grid<std::uint8_t>(l, 0);
  const double c = 0.5 * static_cast<double>(n - 1), R = 0.5 * static_cast<double>(n) - 8.0;
  const double r = 15.0;
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < n; ++j)
      for (std::int64_t i = 0; i < n; ++i) {
        const double dx = static_cast<double>(i) - c, dy = static_cast<double>(j) - c;
        (*bed.mask)(k, j, i) = dx * dx + dy * dy < R * R;
      }
  RandomStream rng(1, 0);
  std::vector<std::array<double, 3>> centres;
  for (int a = 0; a < 60000; ++a) {
    const std::array<double, 3> p = {rng.uniform(0.0, static_cast<double>(nz - 1)),
                                     c + rng.uniform(-(R - r), R - r),
                                     c + rng.uniform(-(R - r), R - r)};
    if ((p[1] - c) * (p[1] - c) + (p[2] - c) * (p[2] - c) > (R - r) * (R - r)) continue;
    bool ok = true;
    for (const auto& q : centres)
      if ((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
              (p[2] - q[2]) * (p[2] - q[2]) <
          4 * r * r) {
        ok = false;
        break;
      }
    if (ok) centres.push_back(p);
  }
  for (const auto& p : centres)
    for (auto k = std::llround(p[0] - r); k <= std::llround(p[0] + r); ++k)
      for (auto j = std::llround(p[1] - r); j <= std::llround(p[1] + r); ++j)
        for (auto i = std::llround(p[2] - r); i <= std::llround(p[2] + r); ++i) {
          if (!l.contains(k, j, i)) continue;
          const double d2 = (static_cast<double>(k) - p[0]) * (static_cast<double>(k) - p[0]) +
                            (static_cast<double>(j) - p[1]) * (static_cast<double>(j) - p[1]) +
                            (static_cast<double>(i) - p[2]) * (static_cast<double>(i) - p[2]);
          if (d2 < r * r) bed.indicator(k, j, i) = 0;
        }
  std::cout << "bed: " << centres.size() << " spheres of 30 voxels, porosity "
            << summarize(bed).porosity << '\n';
  return bed;
}

}  // namespace

int main(int argc, char** argv) {
  int threads = 2;
  std::int64_t n = 256, nz = 512;
  std::string keep;
  for (int a = 1; a + 1 < argc; a += 2) {
    if (!std::strcmp(argv[a], "--threads")) threads = std::atoi(argv[a + 1]);
    if (!std::strcmp(argv[a], "--n")) n = std::atoll(argv[a + 1]);
    if (!std::strcmp(argv[a], "--nz")) nz = std::atoll(argv[a + 1]);
    if (!std::strcmp(argv[a], "--keep")) keep = argv[a + 1];
  }
  const fs::path dir =
      keep.empty() ? fs::temp_directory_path() / "voxpack_bench_ingest" : fs::path(keep);
  fs::create_directories(dir);
  const fs::path image = dir / "bench.nrrd";
  auto t0 = std::chrono::steady_clock::now();
  const Bed bed = sphereColumn(n, nz, 0.18);
  PhantomOptions po;
  po.snr = 10;
  po.blurMm = 0.18;
  po.biasFraction = 0.2;
  po.seed = 1;
  writeVolume(image, makePhantom(bed, po, threads), PixelType::UInt16,
              {{"voxpack_void", "bright"}});
  std::cout << "setup (bed + phantom + write " << image << "): " << since(t0) << " s\n";

  for (bool n4 : {false, true}) {
    IngestOptions o;
    o.n4 = n4;
    t0 = std::chrono::steady_clock::now();
    const double c0 = cpuSeconds();
    IngestResult r = ingestVolume(image, o, threads);
    writeBed(dir / "bench.h5", r.bed);
    const double total = since(t0), cpu = cpuSeconds() - c0;
    std::cout << (n4 ? "default + N4" : "default pipeline") << ": " << total << " s wall, " << cpu
              << " s CPU (threads " << threads << "), stages " << r.report["timing_s"].dump()
              << ", porosity " << r.report["porosity"] << " (truth " << summarize(bed).porosity
              << "), column radius " << r.column.radiusMm << " mm (truth "
              << (0.5 * static_cast<double>(n) - 8.0) * 0.18 << ")\n";
  }
  if (keep.empty()) fs::remove_all(dir);
  return 0;
}
