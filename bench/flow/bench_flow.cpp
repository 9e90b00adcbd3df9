// voxpack_bench_flow MODE [OUT.json]: MODE = sc | scb | speed | tau | precision | big | bedres.
//   sc:        simple-cubic arrays over Zick & Homsy's range at 16/24/32/48 voxels per d
//              (args: OUT RES_LIST CELL_CAP PHI_MIN PHI_MAX TAU)
//   scb:       the same with interpolated (Bouzidi) walls on the exact sphere
//   big:       random overlapping spheres at porosity 0.4 in n^3 (size, steps to converge)
//   speed:     MLUPS on 1 and 2 threads against a copy kernel measured in the same run
//   tau:       steps to convergence against the relaxation time (k unchanged)
//   precision: float32 against float64 populations on the same cells
//   bedres:    one packing re-digitised at several voxel sizes, then computeFlow on each
//              (args: OUT BED.h5 VOXEL_MM_LIST Z0:Z1 WALLS_LIST [THREADS] [LAYERS: 0 = 0.6 d])
//   cellres:   one tilted particle in a periodic cubic cell at several voxels per d, halfway
//              and interpolated walls through computeFlow (args: OUT SHAPE SOLID_FRACTION
//              PER_D_LIST [THREADS]): which wall treatment converges, on one shape alone
// Wall and CPU seconds are both written (the machine is shared: see "load").
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "flow_fixtures.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/memory.hpp"
#include "voxpack/flow/flow.hpp"
#include "voxpack/flow/lbm.hpp"
#include "voxpack/packer/container.hpp"
#include "voxpack/packer/digitise.hpp"
#include "voxpack/packer/shape.hpp"

using namespace voxpack;
using nlohmann::json;

namespace {

double cpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

json load() {
  double l[3] = {0, 0, 0};
  if (FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (std::fscanf(f, "%lf %lf %lf", &l[0], &l[1], &l[2]) != 3) l[0] = -1;
    std::fclose(f);
  }
  return {l[0], l[1], l[2]};
}

struct ZH {
  double phi, k;
};
const ZH kZickHomsy[] = {{0.027, 2.008}, {0.064, 2.810}, {0.125, 4.292}, {0.216, 7.442},
                         {0.343, 15.4},  {0.45, 28.1},   {0.5236, 42.1}};

json runCell(double phi, double perD, double tau, flow::Precision prec, int threads, double tol,
             bool interpolated = false) {
  flow::LbmDomain d;
  double dia = 0;
  double phiD = phi;
  if (interpolated)
    dia = test::scUnitCellExact(phi, perD, d);
  else
    phiD = test::scUnitCell(phi, perD, d, &dia);
  flow::LbmOptions o;
  o.tauPlus = tau;
  o.force = 1e-6;
  o.tolerance = tol;
  o.checkInterval = 100;
  o.maxSteps = 200000;
  o.precision = prec;
  o.threads = threads;
  const double c0 = cpuSeconds();
  const flow::LbmResult r = flow::runLbm(d, o);
  const double cpu = cpuSeconds() - c0;
  const double us = r.sumAxialVelocity / static_cast<double>(d.fluid.size());
  const double k = flow::latticeViscosity(tau) * us / o.force / (dia * dia);
  json j = {{"phi_target", phi},
            {"phi_digital", phiD},
            {"voxels_per_d", dia},
            {"box", d.dims[0]},
            {"k_over_d2", k},
            {"steps", r.steps},
            {"status", flow::statusName(r.status)},
            {"wall_s", r.wallS},
            {"cpu_s", cpu},
            {"mlups", r.mlups},
            {"tau", tau},
            {"cells", r.fluidCells},
            {"threads_used", r.threads},
            {"streaming", flow::streamingName(r.streaming)},
            {"wall", interpolated ? "interpolated (Bouzidi, exact sphere)" : "halfway (digitised)"},
            {"residual", r.residual}};
  for (const ZH& z : kZickHomsy)
    if (std::abs(z.phi - phi) < 1e-9) {
      const double ref = 1.0 / (18.0 * phi * z.k);
      j["k_over_d2_zick_homsy"] = ref;
      j["rel_error"] = k / ref - 1.0;
    }
  return j;
}

// Copy kernel b = a (float), bytes moved per second counting read + write.
double copyBandwidth(std::size_t n, int threads) {
  std::vector<float> a(n, 1.0f), b(n, 0.0f);
  const std::int64_t nn = static_cast<std::int64_t>(n);
  double best = 0;
  for (int rep = 0; rep < 5; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
#pragma omp parallel for schedule(static) num_threads(threads)
    for (std::int64_t i = 0; i < nn; ++i)
      b[static_cast<std::size_t>(i)] = a[static_cast<std::size_t>(i)];
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // Read a, read b for ownership (write-allocate), write b: 3 x 4 bytes per element, the
    // convention of the LBM's byte count below.
    best = std::max(best, 3.0 * static_cast<double>(n) * sizeof(float) / s);
    std::swap(a, b);
  }
  return best;
}

// Overlapping random spheres (d = 16 voxels, periodic, fixed seed) at porosity ~0.4 in an
// n^3 box.
flow::LbmDomain randomSpheres(std::int64_t n) {
  flow::LbmDomain d;
  d.dims = {n, n, n};
  d.fluid.assign(static_cast<std::size_t>(n * n * n), 1);
  d.periodic = {true, true, true};
  const double rad = 8.0, vol = 4.0 / 3.0 * 3.14159265358979 * rad * rad * rad;
  const std::int64_t count = std::llround(-std::log(0.4) * static_cast<double>(n * n * n) / vol);
  std::uint64_t st = 2463534242ull;  // xorshift, fixed seed
  auto next = [&]() {
    st ^= st << 13, st ^= st >> 7, st ^= st << 17;
    return static_cast<double>(st >> 11) / 9007199254740992.0 * static_cast<double>(n);
  };
  for (std::int64_t s2 = 0; s2 < count; ++s2) {
    const double cz = next(), cy = next(), cx = next();
    for (std::int64_t k = std::int64_t(cz - rad) - 1; k <= std::int64_t(cz + rad) + 1; ++k)
      for (std::int64_t j = std::int64_t(cy - rad) - 1; j <= std::int64_t(cy + rad) + 1; ++j)
        for (std::int64_t i = std::int64_t(cx - rad) - 1; i <= std::int64_t(cx + rad) + 1; ++i) {
          const double dz = k - cz, dy = j - cy, dx = i - cx;
          if (dz * dz + dy * dy + dx * dx >= rad * rad) continue;
          const std::int64_t kk = (k % n + n) % n, jj = (j % n + n) % n, ii = (i % n + n) % n;
          d.fluid[static_cast<std::size_t>((kk * n + jj) * n + ii)] = 0;
        }
  }
  return d;
}

// The particle table of `src` digitised on its container's lattice at `voxelMm` (the voxel
// centre test of `voxpack pack`), keeping only the layers within `margin` of [z0, z1]:
// one packing at any resolution, so a resolution series does not mix packings.
Bed redigitise(const Bed& src, double voxelMm, double z0, double z1) {
  const auto& prov = src.provenance;
  if (!prov.contains("scene") || !prov["scene"].contains("container"))
    throw std::runtime_error("bedres: the bed's provenance has no scene.container");
  const auto container = packer::parseContainer(prov["scene"]["container"].get<std::string>());
  Lattice full = packer::latticeForContainer(*container, voxelMm);
  // Crop the lattice to the layers around the ROI before allocating (a tall column at fine
  // voxels would not fit otherwise); 2 layers of margin, cropped again by computeFlow's ROI.
  const double oz = full.originMm[0], hz = full.spacingMm[0];
  const std::int64_t k0 = std::max<std::int64_t>(0, std::int64_t(std::floor((z0 - oz) / hz)) - 2);
  const std::int64_t k1 =
      std::min<std::int64_t>(full.nz() - 1, std::int64_t(std::ceil((z1 - oz) / hz)) + 2);
  Lattice lat = full;
  lat.dims[0] = k1 - k0 + 1;
  lat.originMm[0] = oz + static_cast<double>(k0) * hz;
  Bed b;
  b.mask = packer::containerMask(*container, lat);
  b.indicator = Grid<std::uint8_t>(lat, 1);
  for (std::size_t n = 0; n < src.particles.size(); ++n) {
    const auto shape = packer::parseShape(src.particles.shape[n]);
    const auto dp =
        packer::digitise(*shape, src.particles.positionMm[n], src.particles.orientation[n], lat);
    for (const auto& v : dp.voxels)
      if (v.k >= 0 && v.k < lat.nz() && v.j >= 0 && v.j < lat.ny() && v.i >= 0 && v.i < lat.nx())
        b.indicator(v.k, v.j, v.i) = 0;
  }
  for (std::size_t n = 0; n < b.indicator.size(); ++n)
    if (!(*b.mask)[n]) b.indicator[n] = 0;
  b.particles = src.particles;
  b.provenance = src.provenance;
  return b;
}

// One particle of `spec` (tilted, so no face is aligned with the lattice) at the centre of a
// periodic cube of side `sideMm` on n^3 voxels: the voxels it covers wrap around the faces.
Bed periodicCell(const std::string& spec, double sideMm, std::int64_t n) {
  const double h = sideMm / static_cast<double>(n);
  Bed b;
  b.indicator = Grid<std::uint8_t>(Lattice::isotropic(n, n, n, h), 1);
  const auto shape = packer::parseShape(spec);
  const Vec3 centre = Vec3::Constant(0.5 * (sideMm - h));  // the cube spans [-h/2, side-h/2)
  const Quat q(Eigen::AngleAxisd(0.7, Vec3(1, 2, 0.5).normalized()));
  const auto dp = packer::digitise(*shape, centre, q, b.indicator.lattice());
  const auto wrap = [n](std::int64_t v) { return (v % n + n) % n; };
  for (const auto& v : dp.voxels) b.indicator(wrap(v.k), wrap(v.j), wrap(v.i)) = 0;
  b.particles.positionMm = {centre};
  b.particles.orientation = {q};
  b.particles.shape = {spec};
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: voxpack_bench_flow sc|speed|tau|precision [OUT.json] [opts]\n");
    return 2;
  }
  const std::string mode = argv[1];
  json out = {{"mode", mode}, {"load_start", load()}};
  const auto t0 = std::chrono::steady_clock::now();
  if (mode == "sc" || mode == "scb") {
    const bool interp = mode == "scb";
    // Resolutions from argv[3] (comma list), default 16,24,32; cells capped by argv[4].
    std::vector<double> res = {16, 24, 32};
    if (argc > 3) {
      res.clear();
      for (char* t = std::strtok(argv[3], ","); t; t = std::strtok(nullptr, ","))
        res.push_back(std::atof(t));
    }
    const double cap = argc > 4 ? std::atof(argv[4]) : 3e5;
    const double phiMin = argc > 5 ? std::atof(argv[5]) : 0.0;  // skip sparser arrays
    const double phiMax = argc > 6 ? std::atof(argv[6]) : 1.0;  // skip denser arrays
    // Interpolated walls are not exactly tau-independent under TRT (docs/flow.md): tau 1 by
    // default; halfway bounce-back with Lambda 3/16 is, so a larger tau only saves steps.
    const double tau = argc > 7 ? std::atof(argv[7]) : (interp ? 1.0 : 2.0);
    json rows = json::array();
    for (const ZH& z : kZickHomsy)
      for (double r : res) {
        if (z.phi < phiMin || z.phi > phiMax) {
          rows.push_back(
              {{"phi_target", z.phi}, {"voxels_per_d", r}, {"skipped", "phi outside [min, max]"}});
          continue;
        }
        const double n = r * std::cbrt(3.14159265 / (6 * z.phi));
        if (n * n * n > cap) {
          rows.push_back({{"phi_target", z.phi}, {"voxels_per_d", r}, {"skipped", "cells > cap"}});
          continue;
        }
        json row = runCell(z.phi, r, tau, flow::Precision::Float, 2, 1e-6, interp);
        if (argc > 2) std::ofstream(argv[2]) << json({{"partial_rows", rows}}).dump(1) << '\n';
        std::fprintf(stderr, "phi %.4f d %.0f: k/d2 %.5f err %+.4f steps %lld wall %.1f\n", z.phi,
                     r, row["k_over_d2"].get<double>(), row.value("rel_error", 0.0),
                     static_cast<long long>(row["steps"].get<std::int64_t>()),
                     row["wall_s"].get<double>());
        rows.push_back(row);
      }
    out["rows"] = rows;
    out["settings"] = "tau+ " + std::to_string(tau) +
                      ", Lambda 3/16, float32, tolerance 1e-6 per 100 steps, "
                      "2 threads; walls: " +
                      (interp ? "Bouzidi linear with the exact sphere distance, d = exact"
                              : "halfway bounce-back, d = digitised-volume diameter");
  } else if (mode == "speed") {
    // Three lattices: a simple-cubic unit cell (~60^3 box, 140 k cells, 21 MB of populations:
    // inside this machine's L3), 256^3 random spheres at porosity 0.4 (6.7 M cells, 1.5 GB:
    // far beyond any cache), against a copy of 2 x 1 GiB; and, on one thread, the unit cell at
    // 14 voxels per d (5.5 k cells: 0.82 MB with AA and its index, inside one core's 1 MiB L2;
    // 1.24 MB with two lattices), the kernel's own ceiling when memory costs almost nothing.
    flow::LbmDomain cell, cellL2;
    double dia = 0, diaL2 = 0;
    test::scUnitCell(0.2, 40.0, cell, &dia);
    test::scUnitCell(0.2, 14.0, cellL2, &diaL2);
    const std::int64_t bigN = argc > 3 ? std::atoll(argv[3]) : 256;
    const flow::LbmDomain spheres = randomSpheres(bigN);
    json rows = json::array();
    for (int th : {1, 2}) {
      const double bw = copyBandwidth(std::size_t(1) << 28, th);
      for (const auto& [name, dom, steps] :
           {std::tuple<const char*, const flow::LbmDomain*, int>{"sc_unit_cell_l2", &cellL2, 2000},
            {"sc_unit_cell", &cell, 100},
            {"random_spheres", &spheres, 20}}) {
        if (dom == &cellL2 && th != 1) continue;  // one block of cells: the solver runs 1 thread
        for (flow::Precision p : {flow::Precision::Float, flow::Precision::Double})
          for (flow::Streaming st : {flow::Streaming::TwoLattice, flow::Streaming::AA}) {
            flow::LbmOptions o;
            o.streaming = st;
            o.force = 1e-6;
            o.tolerance = 1e-30;
            o.maxSteps = steps;
            o.checkInterval = steps;
            o.precision = p;
            o.threads = th;
            const double c0 = cpuSeconds();
            const flow::LbmResult r = flow::runLbm(*dom, o);
            const double cpu = cpuSeconds() - c0;
            const double pop = p == flow::Precision::Float ? 4 : 8;
            // Per update, two lattices: 19 populations read + 19 written (+19 write-allocate
            // reads of the other lattice), 18 4-byte pull indices, 1 flag byte. AA: 19 read and
            // 19 written back to the lines just read (no write-allocate), the 18 indices on
            // odd steps only (even steps are local), 1 flag byte.
            const bool aa = st == flow::Streaming::AA;
            const double bytes = aa ? 19 * pop * 2 + 18 * 4 / 2.0 + 1 : 19 * pop * 3 + 18 * 4 + 1;
            const double bound = bw / bytes / 1e6;
            rows.push_back({{"lattice", name},
                            {"threads", th},
                            {"precision", p == flow::Precision::Float ? "float32" : "float64"},
                            {"streaming", flow::streamingName(r.streaming)},
                            {"cells", r.fluidCells},
                            {"steps", r.steps},
                            {"mlups", r.mlups},
                            {"cpu_s", cpu},
                            {"wall_s", r.wallS},
                            {"copy_gb_s", bw / 1e9},
                            {"bytes_per_update", bytes},
                            {"bound_mlups", bound},
                            {"fraction_of_bound", r.mlups / bound},
                            {"load", load()}});
            std::fprintf(
                stderr, "%s threads %d %s %s: %.1f MLUPS, copy %.2f GB/s, bound %.1f (%.0f %%)\n",
                name, th, p == flow::Precision::Float ? "float" : "double",
                flow::streamingName(r.streaming), r.mlups, bw / 1e9, bound, 100 * r.mlups / bound);
          }
      }
    }
    out["rows"] = rows;
    out["settings"] =
        "copy of 2^28 floats, best of 5, 12 B per element; sc_unit_cell_l2 2000 steps (1 "
        "thread only), sc_unit_cell 100 steps, "
        "random_spheres 20 steps (even counts: AA's two passes alternate); one run each; "
        "bytes per update: two lattices 19*3 populations + 72 B index + 1, AA 19*2 populations "
        "+ 36 B index (odd steps only) + 1";
  } else if (mode == "tau") {
    json rows = json::array();
    for (double tau : {0.6, 0.8, 1.0, 1.5, 2.0, 3.0, 5.0}) {
      json row = runCell(0.216, 24.0, tau, flow::Precision::Float, 2, 1e-6);
      std::fprintf(stderr, "tau %.2f: k/d2 %.5f steps %lld\n", tau, row["k_over_d2"].get<double>(),
                   static_cast<long long>(row["steps"].get<std::int64_t>()));
      rows.push_back(row);
    }
    out["rows"] = rows;
  } else if (mode == "precision") {
    json rows = json::array();
    for (const auto& [phi, tol] :
         {std::pair<double, double>{0.216, 1e-6}, {0.343, 1e-6}, {0.343, 1e-8}}) {
      {
        json f = runCell(phi, 24.0, 2.0, flow::Precision::Float, 2, tol);
        json d = runCell(phi, 24.0, 2.0, flow::Precision::Double, 2, tol);
        rows.push_back(
            {{"phi", phi},
             {"tolerance", tol},
             {"float", f},
             {"double", d},
             {"k_float_over_double", f["k_over_d2"].get<double>() / d["k_over_d2"].get<double>()}});
        std::fprintf(stderr, "phi %.3f tol %g: float/double %.8f\n", phi, tol,
                     rows.back()["k_float_over_double"].get<double>());
      }
    }
    out["rows"] = rows;
  } else if (mode == "big") {
    // Overlapping random spheres (d = 16 voxels, periodic) at porosity ~0.4 in n^3 boxes:
    // argv[3] = comma list of n, argv[4] = step cap per size (a capped run gives MLUPS and
    // memory; an uncapped one the steps to convergence at tolerance 1e-5).
    std::vector<std::int64_t> sizes = {64};
    if (argc > 3) {
      sizes.clear();
      for (char* t = std::strtok(argv[3], ","); t; t = std::strtok(nullptr, ","))
        sizes.push_back(std::atoll(t));
    }
    const std::int64_t cap = argc > 4 ? std::atoll(argv[4]) : 200000;
    const double tau = argc > 5 ? std::atof(argv[5]) : 1.0;  // TRT: k does not depend on it
    json rows = json::array();
    for (std::int64_t n : sizes) {
      flow::LbmDomain d = randomSpheres(n);
      flow::LbmOptions o;
      o.tauPlus = tau;
      o.force = 1e-6;
      o.tolerance = 1e-5;
      o.checkInterval = 100;
      o.maxSteps = cap;
      o.threads = 2;
      const double c0 = cpuSeconds();
      const flow::LbmResult r = flow::runLbm(d, o);
      const double cpu = cpuSeconds() - c0;
      std::uint64_t fluid = 0;
      for (auto f : d.fluid) fluid += f;
      json row = {{"n", n},
                  {"porosity", static_cast<double>(fluid) / static_cast<double>(n * n * n)},
                  {"cells", r.fluidCells},
                  {"steps", r.steps},
                  {"status", flow::statusName(r.status)},
                  {"residual", r.residual},
                  {"wall_s", r.wallS},
                  {"cpu_s", cpu},
                  {"mlups", r.mlups},
                  {"threads_used", r.threads},
                  {"streaming", flow::streamingName(r.streaming)},
                  {"estimated_bytes", flow::estimateLbmBytes(static_cast<std::uint64_t>(n * n * n),
                                                             fluid, flow::Precision::Float)},
                  {"tau", tau},
                  {"k_voxels2", flow::latticeViscosity(tau) * r.sumAxialVelocity /
                                    static_cast<double>(n * n * n) / o.force},
                  {"load", load()}};
      std::fprintf(stderr, "n %lld: %lld steps %s, %.1f MLUPS, wall %.1f s\n",
                   static_cast<long long>(n), static_cast<long long>(r.steps),
                   flow::statusName(r.status), r.mlups, r.wallS);
      rows.push_back(row);
      if (argc > 2) std::ofstream(argv[2]) << json({{"partial_rows", rows}}).dump(1) << '\n';
    }
    out["rows"] = rows;
    out["settings"] = "float32, tolerance 1e-5 per 100 steps, 2 threads, periodic, force 1e-6";
  } else if (mode == "bedres") {
    if (argc < 7) {
      std::fprintf(stderr,
                   "usage: bedres OUT BED.h5 VOXEL_MM_LIST Z0:Z1 WALLS_LIST [THREADS] "
                   "[RESERVOIR_LAYERS (0: automatic)]\n");
      return 2;
    }
    const Bed src = readBed(argv[3]);
    std::vector<double> voxels;
    for (char* t = std::strtok(argv[4], ","); t; t = std::strtok(nullptr, ","))
      voxels.push_back(std::atof(t));
    const auto [z0, z1] = flow::parseRoiMm(argv[5]);
    std::vector<std::string> walls;
    for (char* t = std::strtok(argv[6], ","); t; t = std::strtok(nullptr, ",")) walls.push_back(t);
    const int threads = argc > 7 ? std::atoi(argv[7]) : 2;
    const int layers = argc > 8 ? std::atoi(argv[8]) : 0;
    json rows = json::array();
    for (double h : voxels) {
      const auto tb = std::chrono::steady_clock::now();
      const Bed bed = flow::cropBedZ(redigitise(src, h, z0, z1), z0, z1);
      const double digitiseS =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - tb).count();
      for (const std::string& w : walls) {
        flow::FlowOptions o;
        o.walls = w == "interpolated" ? flow::Walls::Interpolated : flow::Walls::Halfway;
        o.lbm.threads = threads;
        o.reservoirLayers = layers;
        const double c0 = cpuSeconds();
        const flow::FlowReport rep = flow::computeFlow(bed, o, defaultMemoryBudget());
        const double cpu = cpuSeconds() - c0;
        json row = rep.json;
        row.erase("radial_profile");
        row.erase("convergence");
        row["voxel_mm"] = h;
        row["walls_requested"] = w;
        row["digitise_s"] = digitiseS;
        row["cpu_s"] = cpu;
        row["load"] = load();
        std::fprintf(
            stderr, "voxel %.3f %s: k %.5g mm2, porosity %.4f, %lld steps, %.1f s\n", h, w.c_str(),
            row["permeability_mm2"].get<double>(), row["porosity"].get<double>(),
            static_cast<long long>(row["steps"].get<std::int64_t>()), row["wall_s"].get<double>());
        rows.push_back(row);
        if (argc > 2) std::ofstream(argv[2]) << json({{"partial_rows", rows}}).dump(1) << '\n';
      }
    }
    out["bed"] = argv[3];
    out["bed_provenance_scene"] = src.provenance.value("scene", json());
    out["rows"] = rows;
    out["settings"] = "computeFlow defaults (walls + reservoirs of " +
                      (layers > 0 ? std::to_string(layers) + " layers" : std::string("0.6 d")) +
                      ", tau+ 1, float32, tolerance 1e-5), ROI " + std::string(argv[5]) + " mm, " +
                      std::to_string(threads) +
                      " threads; each voxel size re-digitises the same particle table";
  } else if (mode == "cellres") {
    if (argc < 6) {
      std::fprintf(stderr, "usage: cellres OUT SHAPE SOLID_FRACTION PER_D_LIST [THREADS]\n");
      return 2;
    }
    const std::string spec = argv[3];
    const double solid = std::atof(argv[4]);
    const int threads = argc > 6 ? std::atoi(argv[6]) : 2;
    const auto shape = packer::parseShape(spec);
    const double d = shape->characteristicDiameterMm();
    const double side = std::cbrt(shape->volumeMm3() / solid);
    json rows = json::array();
    for (char* t = std::strtok(argv[5], ","); t; t = std::strtok(nullptr, ",")) {
      // The cube is fixed in mm; n voxels across it set the resolution (d / h ~ the request).
      const std::int64_t n = std::llround(std::atof(t) * side / d);
      const Bed bed = periodicCell(spec, side, n);
      for (const flow::Walls w : {flow::Walls::Halfway, flow::Walls::Interpolated}) {
        flow::FlowOptions o;
        o.periodic = true;
        o.walls = w;
        o.lbm.threads = threads;
        o.lbm.tolerance = 1e-6;
        o.particleDiameterMm = d;
        const double c0 = cpuSeconds();
        const flow::FlowReport rep = flow::computeFlow(bed, o, defaultMemoryBudget());
        json row = {{"voxels_per_d", d * static_cast<double>(n) / side},
                    {"n", n},
                    {"walls", rep.json["walls"]},
                    {"porosity_digital", rep.json["porosity"]},
                    {"porosity_exact", 1.0 - shape->volumeMm3() / (side * side * side)},
                    {"permeability_mm2", rep.json["permeability_mm2"]},
                    {"tortuosity_hydraulic", rep.json["tortuosity_hydraulic"]},
                    {"interpolated_links", rep.json["interpolated_links"]},
                    {"mass_relative_change", rep.json["mass_relative_change"]},
                    {"status", rep.json["status"]},
                    {"steps", rep.json["steps"]},
                    {"wall_s", rep.json["wall_s"]},
                    {"cpu_s", cpuSeconds() - c0},
                    {"load", load()}};
        std::fprintf(stderr, "%s n %lld %s: k %.6g mm2, porosity %.4f, %lld steps\n", spec.c_str(),
                     static_cast<long long>(n), row["walls"].get<std::string>().c_str(),
                     row["permeability_mm2"].get<double>(), row["porosity_digital"].get<double>(),
                     static_cast<long long>(row["steps"].get<std::int64_t>()));
        rows.push_back(row);
        if (argc > 2) std::ofstream(argv[2]) << json({{"partial_rows", rows}}).dump(1) << '\n';
      }
    }
    out["shape"] = spec;
    out["solid_fraction"] = solid;
    out["side_mm"] = side;
    out["rows"] = rows;
    out["settings"] =
        "one particle tilted 0.7 rad about (1, 2, 0.5) in a periodic cube, flow along z, "
        "computeFlow (tau+ 1, float32, tolerance 1e-6), " +
        std::to_string(threads) + " threads";
  } else {
    std::fprintf(stderr, "unknown mode %s\n", mode.c_str());
    return 2;
  }
  out["load_end"] = load();
  out["total_wall_s"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out["cpu_model"] = "see /proc/cpuinfo; 2 cores shared";
  const std::string path = argc > 2 ? argv[2] : "";
  if (!path.empty())
    std::ofstream(path) << out.dump(2) << '\n';
  else
    std::printf("%s\n", out.dump(2).c_str());
  return 0;
}
