// Ingest fidelity on phantoms of a known packed bed (issue 19's must-show): the bed density
// within 0.005 of the truth for MRI and XMT at 20 voxels per d, SNR 10, blur 1 voxel; the
// column radius within 0.1 voxel with and without a margin to the field of view; the first
// particle diameter of the radial profile within 0.03 RMSE.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <numbers>

#include "cli_runner.hpp"
#include "sphere_bed.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/ingest/image_io.hpp"
#include "voxpack/ingest/ingest.hpp"
#include "voxpack/ingest/phantom.hpp"
#include "voxpack/ingest/phases.hpp"
#include "voxpack/ingest/stream.hpp"

using namespace voxpack;
using namespace voxpack::ingest;
using namespace voxpack::test;

namespace {

// The scene: spheres of d = 20 voxels (0.1 mm voxels, d 2 mm) poured by the MC packer into
// a column of D = 5 d (radius 50 voxels), 4 d of bed. Packed once per test process.
constexpr double kVoxelMm = 0.1;
constexpr double kDiameterVox = 20.0;
constexpr double kColumnRadiusVox = 50.0;

const Bed& packedBed() {
  static const Bed bed = [] {
    TempDir dir;
    const auto out = dir / "bed.h5";
    const CliResult r = runVoxpack({"-q", "pack", "--mode", "mc", "--shape", "sphere:d=2",
                                    "--container", "cylinder:d=10,h=9", "--voxel-size", "0.1",
                                    "--fill-height", "8", "--seed", "1", "-o", out.string()});
    if (r.exitCode != 0) throw std::runtime_error("pack failed: " + r.err);
    return readBed(out);
  }();
  return bed;
}

// Axis of the packed bed's mask (x, y in mm) and its area-equivalent radius in voxels.
struct MaskGeometry {
  double xMm = 0, yMm = 0, radiusVox = 0;
};

MaskGeometry maskGeometry(const Bed& bed) {
  const Lattice& l = bed.lattice();
  const std::int64_t k = l.nz() / 2;
  double n = 0, sx = 0, sy = 0;
  for (std::int64_t j = 0; j < l.ny(); ++j)
    for (std::int64_t i = 0; i < l.nx(); ++i)
      if ((*bed.mask)(k, j, i)) {
        const Vec3 c = l.centerMm(k, j, i);
        n += 1;
        sx += c.x();
        sy += c.y();
      }
  return {sx / n, sy / n, std::sqrt(n / std::numbers::pi)};
}

// Packing density over slices [k0, k1] inside the bed's own mask.
double density(const Bed& bed, std::int64_t k0, std::int64_t k1) {
  const Lattice& l = bed.lattice();
  double in = 0, solid = 0;
  for (std::int64_t k = k0; k <= k1; ++k)
    for (std::int64_t j = 0; j < l.ny(); ++j)
      for (std::int64_t i = 0; i < l.nx(); ++i) {
        const std::size_t o = l.offset(k, j, i);
        if (bed.mask && !(*bed.mask)[o]) continue;
        in += 1;
        solid += bed.indicator[o] == 0;
      }
  return solid / in;
}

// Radial density in 1-voxel annuli about (x, y) over slices [k0, k1], each bed in its own
// mask; bins from the wall inwards over one particle diameter.
std::vector<double> nearWallProfile(const Bed& bed, const MaskGeometry& g, std::int64_t k0,
                                    std::int64_t k1) {
  const Lattice& l = bed.lattice();
  const int bins = static_cast<int>(kDiameterVox);
  std::vector<double> in(static_cast<std::size_t>(bins), 0), solid(in.size(), 0);
  for (std::int64_t k = k0; k <= k1; ++k)
    for (std::int64_t j = 0; j < l.ny(); ++j)
      for (std::int64_t i = 0; i < l.nx(); ++i) {
        const std::size_t o = l.offset(k, j, i);
        if (bed.mask && !(*bed.mask)[o]) continue;
        const Vec3 c = l.centerMm(k, j, i);
        const double fromWall = g.radiusVox - std::hypot(c.x() - g.xMm, c.y() - g.yMm) / kVoxelMm;
        const auto b = static_cast<int>(std::floor(fromWall));
        if (b < 0 || b >= bins) continue;
        in[static_cast<std::size_t>(b)] += 1;
        solid[static_cast<std::size_t>(b)] += bed.indicator[o] == 0;
      }
  std::vector<double> p;
  for (std::size_t b = 0; b < in.size(); ++b) p.push_back(in[b] > 0 ? solid[b] / in[b] : 0.0);
  return p;
}

// The test bed's packed slices one diameter in from its bottom and top, and the density of
// `truth` (the test bed, or a copy moved within its planes) over them.
struct InnerSlices {
  std::int64_t k0, k1;
  double density;
};
InnerSlices innerSlices(const Bed& truth) {
  std::int64_t k0 = 0, k1 = 0;
  packedRegionDensity(packedBed(), &k0, &k1);
  const auto trim = static_cast<std::int64_t>(kDiameterVox);
  return {k0 + trim, k1 - trim, density(truth, k0 + trim, k1 - trim)};
}

// The must-show image: SNR 10, blur 1 voxel, at the truth's voxel size.
PhantomOptions mustShowPhantom(Modality modality, std::uint64_t seed) {
  PhantomOptions po;
  po.modality = modality;
  po.snr = 10.0;
  po.blurMm = kVoxelMm;
  po.seed = seed;
  return po;
}

struct Fidelity {
  double truthDensity, density, radiusErrVox, profileRmse;
  IngestResult result;
};

// Images `truth` (phantom at SNR 10, blur 1 voxel), ingests it with the default pipeline
// and compares over the packed slices, one diameter in from the bed's bottom and top.
Fidelity run(const Bed& truth, Modality modality, std::uint64_t seed,
             const MaskGeometry* geometry = nullptr, int deconvolve = 0,
             const MaskGeometry* givenColumn = nullptr) {
  const PhantomOptions po = mustShowPhantom(modality, seed);
  IngestOptions io;
  io.voidPolarity = modality == Modality::Mri ? VoidPolarity::Bright : VoidPolarity::Dark;
  io.deconvolveIterations = deconvolve;
  if (givenColumn) {
    io.column = ColumnMode::Explicit;
    io.columnXMm = givenColumn->xMm;
    io.columnYMm = givenColumn->yMm;
    io.columnRadiusMm = givenColumn->radiusVox * kVoxelMm;
  }
  Volume v;
  v.image = makePhantom(truth, po, 2);
  v.info.source = "phantom";
  Fidelity f{0, 0, 0, 0, segmentVolume(std::move(v), io, 2)};
  std::int64_t k0 = 0, k1 = 0;
  packedRegionDensity(truth, &k0, &k1);
  const auto trim = static_cast<std::int64_t>(kDiameterVox);
  k0 += trim;
  k1 -= trim;
  f.truthDensity = density(truth, k0, k1);
  f.density = density(f.result.bed, k0, k1);
  // A cropped bed's mask is cut by the border: its geometry comes from the whole bed.
  const MaskGeometry g = geometry ? *geometry : maskGeometry(truth);
  f.radiusErrVox = f.result.column.radiusMm / kVoxelMm - g.radiusVox;
  const auto pt = nearWallProfile(truth, g, k0, k1);
  const auto pi = nearWallProfile(f.result.bed, g, k0, k1);
  double se = 0;
  for (std::size_t b = 0; b < pt.size(); ++b) se += (pt[b] - pi[b]) * (pt[b] - pi[b]);
  f.profileRmse = std::sqrt(se / static_cast<double>(pt.size()));
  std::cout << "[ measured ] slices " << k0 << ".." << k1 << ": truth density " << f.truthDensity
            << ", ingested " << f.density << " (bias " << f.density - f.truthDensity
            << "), radius error " << f.radiusErrVox << " voxel (+- "
            << f.result.column.radiusStdMm / kVoxelMm << "), near-wall RMSE " << f.profileRmse
            << ", blur " << f.result.quality.blurMm / kVoxelMm << " voxel, SNR "
            << f.result.quality.snr << ", d " << f.result.quality.voxelsPerDiameter
            << " voxels, threshold " << f.result.report["threshold"]["method"] << '\n';
  return f;
}

// The bed cut to a square field of view of half-width `halfVox` around the axis, so the
// column (radius 50 voxels) touches or leaves the image border.
Bed cropped(const Bed& bed, std::int64_t halfVox) {
  const Lattice& l = bed.lattice();
  const MaskGeometry g = maskGeometry(bed);
  const auto ci = static_cast<std::int64_t>(std::llround((g.xMm - l.originMm[2]) / kVoxelMm));
  const auto cj = static_cast<std::int64_t>(std::llround((g.yMm - l.originMm[1]) / kVoxelMm));
  Lattice c = l;
  c.dims = {l.nz(), 2 * halfVox, 2 * halfVox};
  c.originMm[2] = l.originMm[2] + static_cast<double>(ci - halfVox) * kVoxelMm;
  c.originMm[1] = l.originMm[1] + static_cast<double>(cj - halfVox) * kVoxelMm;
  Bed out;
  out.indicator = Grid<std::uint8_t>(c, 1);
  out.mask = Grid<std::uint8_t>(c, 0);
  for (std::int64_t k = 0; k < c.nz(); ++k)
    for (std::int64_t j = 0; j < c.ny(); ++j)
      for (std::int64_t i = 0; i < c.nx(); ++i) {
        const std::int64_t jj = cj - halfVox + j, ii = ci - halfVox + i;
        if (!l.contains(k, jj, ii)) continue;
        out.indicator(k, j, i) = bed.indicator(k, jj, ii);
        (*out.mask)(k, j, i) = (*bed.mask)(k, jj, ii);
      }
  return out;
}

// The test bed imaged at 10 voxels per d (0.2 mm), SNR 10, blur 1 image voxel; wallMm 0:
// the phantom's default wall.
PhantomOptions coarsePhantom(Modality modality, double wallMm, std::uint64_t seed) {
  PhantomOptions po;
  po.modality = modality;
  po.snr = 10.0;
  po.voxelSizeMm = 2 * kVoxelMm;
  po.blurMm = 2 * kVoxelMm;
  po.wallThicknessMm = wallMm;
  po.seed = seed;
  return po;
}

}  // namespace

TEST(Fidelity, MriDensityRadiusAndWallProfileAt20VoxelsPerD) {
  const Fidelity f = run(packedBed(), Modality::Mri, 11);
  ASSERT_TRUE(f.result.column.found) << f.result.column.note;
  EXPECT_FALSE(f.result.column.touchesBorder);
  EXPECT_NEAR(f.density, f.truthDensity, 0.005);
  // The MRI wall step is fitted on M^2 (unbiased under Rician noise): measured -0.026
  // voxel (it was -0.113 on the magnitude, whose convex noise floor bent the step).
  EXPECT_LE(std::abs(f.radiusErrVox), 0.1);
  // Goal 0.03. Measured 0.0156 with the wall's blur divided out of the grey values next to
  // it (0.0306 before: the first 0.1 d next to the dark wall read too solid), docs/ingest.md.
  EXPECT_LE(f.profileRmse, 0.02);
  // The provenance carries both porosities and the image quality.
  const auto& rep = f.result.report;
  EXPECT_EQ(rep["threshold"]["method"], "volume");
  EXPECT_TRUE(rep["threshold"].contains("mean_intensity_porosity"));
  EXPECT_EQ(rep["wall_blur_correction"]["applied"], true);
  // Aimed over the bed's slices (the MC bed's loose top and the headspace left out).
  EXPECT_EQ(rep["threshold"]["region"], "column, bed slices");
  std::int64_t k0 = 0, k1 = 0;
  packedRegionDensity(packedBed(), &k0, &k1);
  EXPECT_LE(rep["threshold"]["bed_slices"]["first"].get<std::int64_t>(), k0 + 2);
  EXPECT_GE(rep["threshold"]["bed_slices"]["last"].get<std::int64_t>(), k1 - 2);
  EXPECT_LT(rep["threshold"]["bed_slices"]["last"].get<std::int64_t>(),
            packedBed().lattice().nz() - 1);
  // The void level from the voxels deep in the void (Rician mean of 1000 at sigma 100:
  // 1005.0); the histogram's flank read 989 here.
  EXPECT_NEAR(rep["phases"]["void_level"].get<double>(), 1005.0, 5.0);
  // The reported sigma comes from voxel pairs deep in the void phase: measured SNR 9.7
  // for 10 (the histogram's Rayleigh mode read 8.7).
  EXPECT_NEAR(rep["quality"]["snr"].get<double>(), 10.0, 0.6);
  EXPECT_NEAR(rep["quality"]["blur_mm"].get<double>(), kVoxelMm, 0.3 * kVoxelMm);
  EXPECT_NEAR(rep["quality"]["voxels_per_diameter"].get<double>(), kDiameterVox,
              0.2 * kDiameterVox);
  EXPECT_GT(rep["column"]["radius_std_mm"].get<double>(), 0.0);
}

// An uncompressed MetaImage of `g` (writeVolume compresses, and the streamed reader cannot
// seek in gzip): little-endian float32 or uint16 (rounded).
void writeRawMha(const std::filesystem::path& p, const Grid<float>& g, bool uint16) {
  const Lattice& l = g.lattice();
  std::ofstream f(p, std::ios::binary);
  f << std::setprecision(17) << "ObjectType = Image\nNDims = 3\nBinaryData = True\n"
    << "BinaryDataByteOrderMSB = False\nCompressedData = False\nOffset = " << l.originMm[2] << ' '
    << l.originMm[1] << ' ' << l.originMm[0] << "\nElementSpacing = " << l.spacingMm[2] << ' '
    << l.spacingMm[1] << ' ' << l.spacingMm[0] << "\nDimSize = " << l.nx() << ' ' << l.ny() << ' '
    << l.nz() << "\nElementType = " << (uint16 ? "MET_USHORT" : "MET_FLOAT")
    << "\nElementDataFile = LOCAL\n";
  for (float v : g.values()) {
    if (uint16) {
      const auto u = static_cast<std::uint16_t>(std::clamp(std::round(v), 0.0f, 65535.0f));
      f.write(reinterpret_cast<const char*>(&u), sizeof u);
    } else {
      f.write(reinterpret_cast<const char*>(&v), sizeof v);
    }
  }
}

// `truth` imaged as the must-show phantom and written raw to `p` (MRI as float, whose
// non-integer values take fine bins; XMT as 16-bit counts, exact values); its header.
VolumeHeader writeMustShowImage(const std::filesystem::path& p, const Bed& truth, Modality m,
                                std::uint64_t seed) {
  writeRawMha(p, makePhantom(truth, mustShowPhantom(m, seed), 2), m == Modality::Xmt);
  const auto header = readVolumeHeader(p, {});
  if (!header) throw std::runtime_error("no streamed header for " + p.string());
  return *header;
}

// The streamed path (--memory-limit, mpirun) aims the volume threshold with levels, blur and
// S_V read on a sample slab and the mean and order statistics of the whole bed (docs/
// scale.md): the must-show density bound holds there too, in slabs of 16 planes,
// on a float image (order statistics from fine bins) and a 16-bit one (exact counts), where
// Otsu on the same stream is off by several times as much.
TEST(Fidelity, StreamedVolumeThresholdKeepsTheDensityAt20VoxelsPerD) {
  const Bed& truth = packedBed();
  const MaskGeometry g = maskGeometry(truth);
  const auto [k0, k1, t] = innerSlices(truth);
  TempDir dir;
  for (Modality m : {Modality::Mri, Modality::Xmt}) {
    const VolumeHeader header =
        writeMustShowImage(dir / "phantom.mha", truth, m, m == Modality::Mri ? 21 : 22);
    double bias[2] = {0, 0};
    for (ThresholdMethod method : {ThresholdMethod::Auto, ThresholdMethod::Otsu}) {
      IngestOptions io;
      io.voidPolarity = m == Modality::Mri ? VoidPolarity::Bright : VoidPolarity::Dark;
      io.threshold = method;
      io.column = ColumnMode::Explicit;
      io.columnXMm = g.xMm;
      io.columnYMm = g.yMm;
      io.columnRadiusMm = g.radiusVox * kVoxelMm;
      const auto out = dir / "streamed.h5";
      const StreamedIngestResult r = ingestVolumeStreamed(header, io, out, 16, 2);
      const double b = density(readBed(out), k0, k1) - t;
      bias[method == ThresholdMethod::Auto ? 0 : 1] = b;
      std::cout << "[ measured ] streamed " << (m == Modality::Mri ? "MRI" : "XMT") << ", "
                << r.report["threshold"]["method"] << ": bias " << b << ", bed slices "
                << r.report["threshold"].value("bed_slices", nlohmann::json()) << ", blur "
                << r.report["quality"]["blur_mm"] << " mm, SNR " << r.report["quality"]["snr"]
                << ", " << r.report["threshold"].value("order_statistics", "") << '\n';
      if (method == ThresholdMethod::Auto) {
        EXPECT_EQ(r.report["threshold"]["method"], "volume");
        EXPECT_NEAR(r.report["quality"]["snr"].get<double>(), 10.0, 1.0);
        EXPECT_NEAR(r.report["quality"]["blur_mm"].get<double>(), kVoxelMm, 0.3 * kVoxelMm);
      }
    }
    EXPECT_LT(std::abs(bias[0]), 0.005);
    EXPECT_GT(std::abs(bias[1]), 2.0 * std::abs(bias[0]));
  }
}

// From the CLI (--slab-voxels forces the streamed path): the volume threshold's sums and
// counts do not depend on where the slabs are cut, so slabs of 4 and 11 planes give the
// same bed and the same threshold record; what the bed reads over the aimed region is what
// was aimed at (clean-up included, its shift measured on the sample slab).
TEST(Fidelity, StreamedVolumeThresholdIsTheSameForAnySlab) {
  const Bed& truth = packedBed();
  const MaskGeometry g = maskGeometry(truth);
  TempDir dir;
  const auto img = dir / "coarse.mha";
  writeRawMha(img, makePhantom(truth, coarsePhantom(Modality::Mri, 0.0, 15), 2), false);
  const std::string column = std::to_string(g.xMm) + "," + std::to_string(g.yMm) + "," +
                             std::to_string(g.radiusVox * kVoxelMm);
  nlohmann::json first;
  std::vector<std::uint8_t> bed;
  for (const std::string planes : {"4", "11"}) {
    const auto out = dir / ("s" + planes + ".h5");
    const CliResult r =
        runVoxpack({"--quiet", "ingest", img.string(), "-o", out.string(), "--json", "--void",
                    "bright", "--column", column, "--slab-voxels", planes});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto rep = nlohmann::json::parse(r.out);
    const auto& th = rep["threshold"];
    EXPECT_EQ(th["method"], "volume") << rep.dump();
    EXPECT_EQ(th["requested"], "auto");
    // The wall's blur divided out slab by slab, so aimed over the whole column.
    EXPECT_EQ(th["wall_blur_correction"]["applied"], true);
    EXPECT_EQ(th["region_ring_voxels"].get<int>(), 0);
    EXPECT_EQ(th["region"], "column, bed slices");
    EXPECT_EQ(rep["streamed"]["slab_planes"].get<int>(), std::stoi(planes));
    EXPECT_GE(rep["streamed"]["volume_sample"]["planes"].get<int>(), 16);
    EXPECT_NEAR(rep["quality"]["snr"].get<double>(), 10.0, 1.0);
    EXPECT_NEAR(th["porosity_segmented_region"].get<double>(), th["porosity_aimed"].get<double>(),
                0.003);
    const Bed b = readBed(out);
    if (first.is_null()) {
      first = th;
      bed = b.indicator.values();
    } else {
      EXPECT_EQ(th, first);
      EXPECT_TRUE(b.indicator.values() == bed);
    }
  }
}

// The column fitted on the stream (the default --column auto past the memory budget):
// fitColumn's circles and refineColumn's wall step, slab by slab. The refinement's sums are
// the in-memory ones, so the column lands within a hundredth of a voxel of the in-memory fit
// (measured: the same to the last bit; the circles skip the speck and hole clean-up, which
// only seeds the refinement), within 0.1 voxel of the truth, and the density keeps the
// must-show bound; any slab size gives the same column to the last bit.
TEST(Fidelity, StreamedColumnFitMatchesTheInMemoryFit) {
  const Bed& truth = packedBed();
  const MaskGeometry g = maskGeometry(truth);
  const auto [k0, k1, t] = innerSlices(truth);
  TempDir dir;
  for (Modality m : {Modality::Mri, Modality::Xmt}) {
    SCOPED_TRACE(m == Modality::Mri ? "mri" : "xmt");
    const auto img = dir / "phantom.mha";
    const VolumeHeader header = writeMustShowImage(img, truth, m, m == Modality::Mri ? 31 : 32);
    IngestOptions io;
    io.voidPolarity = m == Modality::Mri ? VoidPolarity::Bright : VoidPolarity::Dark;
    Volume v;
    v.image = readVolume(img, {}).image;  // the file's (rounded, for XMT) values
    v.info.source = "phantom";
    const IngestResult mem = segmentVolume(std::move(v), io, 2);
    ASSERT_TRUE(mem.column.found) << mem.column.note;
    nlohmann::json first;
    for (std::int64_t slab : {16, 7}) {
      if (m == Modality::Xmt && slab != 16) continue;  // one slab size suffices for the sums
      const auto out = dir / "streamed.h5";
      const StreamedIngestResult r = ingestVolumeStreamed(header, io, out, slab, 2);
      ASSERT_TRUE(r.column.found) << r.column.note;
      EXPECT_TRUE(r.column.refined) << r.column.note;
      EXPECT_EQ(r.report["column"]["mode"], "auto");
      const double dr = (r.column.radiusMm - mem.column.radiusMm) / kVoxelMm;
      const double dx = (r.column.axisXMm - mem.column.axisXMm) / kVoxelMm;
      const double dy = (r.column.axisYMm - mem.column.axisYMm) / kVoxelMm;
      const double b = density(readBed(out), k0, k1) - t;
      std::cout << "[ measured ] streamed auto column, slabs of " << slab << ": radius "
                << r.column.radiusMm / kVoxelMm - g.radiusVox << " voxel from the truth, " << dr
                << " from in memory (axis " << dx << ", " << dy << "), blur "
                << r.column.blurMm / kVoxelMm << " voxel, density bias " << b << " (in memory "
                << density(mem.bed, k0, k1) - t << "), threshold "
                << r.report["threshold"]["method"] << '\n';
      EXPECT_LE(std::abs(dr), 0.01);
      EXPECT_LE(std::abs(dx), 0.01);
      EXPECT_LE(std::abs(dy), 0.01);
      EXPECT_NEAR(r.column.blurMm, mem.column.blurMm, 0.01 * kVoxelMm);
      EXPECT_LE(std::abs(r.column.radiusMm / kVoxelMm - g.radiusVox), 0.1);
      EXPECT_EQ(r.report["threshold"]["method"], "volume");
      EXPECT_LT(std::abs(b), 0.005);
      if (first.is_null())
        first = r.report["column"];
      else
        EXPECT_EQ(r.report["column"], first);
    }
  }
}

// The bed with each plane k moved along x by floor(k shiftVox / nz) voxels, the box widened
// by shiftVox: a column whose axis leans by shiftVox voxels over the image's height.
Bed tilted(const Bed& bed, std::int64_t shiftVox) {
  const Lattice& l = bed.lattice();
  Lattice t = l;
  t.dims[2] = l.nx() + shiftVox;
  Bed out;
  out.indicator = Grid<std::uint8_t>(t, 1);
  out.mask = Grid<std::uint8_t>(t, 0);
  for (std::int64_t k = 0; k < l.nz(); ++k) {
    const std::int64_t s = k * shiftVox / l.nz();
    for (std::int64_t j = 0; j < l.ny(); ++j)
      for (std::int64_t i = 0; i < l.nx(); ++i) {
        out.indicator(k, j, i + s) = bed.indicator(k, j, i);
        (*out.mask)(k, j, i + s) = (*bed.mask)(k, j, i);
      }
  }
  return out;
}

// A leaning column streamed: the fitted axis leans as in memory, so the wall rings, the core
// and the mask are made plane by plane (PlaneRings), and the density keeps its bound. The
// wall's blur is the whole column's fit, as in memory: a sample slab's own wall step read
// 0.11 mm for 0.10 on this staircase wall and moved the density by -0.004.
TEST(Fidelity, StreamedColumnFitFollowsALeaningAxis) {
  // 4 voxels over the 92 planes (2.5 degrees) in steps of whole voxels. At 6 (3.7 degrees)
  // the fit in memory loses the lean (slope -0.003 for 0.065: the circles of one slab of
  // 46 planes see a wall smeared over 3 voxels); streamed it is the same fit.
  const std::int64_t shift = 4;
  const Bed truth = tilted(packedBed(), shift);
  const std::int64_t nz = truth.lattice().nz();
  const auto [k0, k1, t] = innerSlices(truth);
  TempDir dir;
  const auto img = dir / "leaning.mha";
  const VolumeHeader header = writeMustShowImage(img, truth, Modality::Mri, 33);
  IngestOptions io;
  io.voidPolarity = VoidPolarity::Bright;
  Volume v = readVolume(img, {});
  const IngestResult mem = segmentVolume(std::move(v), io, 2);
  const auto out = dir / "streamed.h5";
  const StreamedIngestResult r = ingestVolumeStreamed(header, io, out, 16, 2);
  ASSERT_TRUE(r.column.found && mem.column.found);
  const double lean = static_cast<double>(shift) / static_cast<double>(nz);  // dx / dz
  const double b = density(readBed(out), k0, k1) - t, bm = density(mem.bed, k0, k1) - t;
  std::cout << "[ measured ] leaning column: slope " << r.column.slopeX << " (truth " << lean
            << ", in memory " << mem.column.slopeX << "), density bias streamed " << b
            << ", in memory " << bm << '\n';
  EXPECT_NEAR(r.column.slopeX, lean, 0.15 * lean);  // a staircase of whole voxels
  EXPECT_NEAR(r.column.slopeX, mem.column.slopeX, 1e-9);
  EXPECT_NEAR(r.column.axisXMm, mem.column.axisXMm, 0.01 * kVoxelMm);
  EXPECT_NEAR(r.column.radiusMm, mem.column.radiusMm, 0.01 * kVoxelMm);
  EXPECT_EQ(r.report["threshold"]["method"], "volume");
  EXPECT_LT(std::abs(b), 0.005);
  EXPECT_LT(std::abs(bm), 0.005);
  // The mask leans with the axis: its centre moves by the lean over the bed.
  const Bed streamed = readBed(out);
  auto maskCentreX = [&](std::int64_t k) {
    double n = 0, sx = 0;
    for (std::int64_t j = 0; j < streamed.lattice().ny(); ++j)
      for (std::int64_t i = 0; i < streamed.lattice().nx(); ++i)
        if ((*streamed.mask)(k, j, i)) {
          n += 1;
          sx += static_cast<double>(i);
        }
    return sx / n;
  };
  EXPECT_NEAR(maskCentreX(k1) - maskCentreX(k0), lean * static_cast<double>(k1 - k0), 0.5);
}

// --calibrate on the stream: the output bed over the volume threshold's sample slab is
// imaged and segmented in memory (a bed of the sample's size), its cut end left out. Its
// band agrees with the in-memory calibration of the whole bed (measured -0.0021 +- 0.0005
// over planes 47..78 against -0.0018 +- 0.0002, two phantoms each); Otsu streamed has no
// image quality to calibrate at and is refused.
TEST(Fidelity, StreamedCalibrationAgreesWithTheInMemoryOne) {
  const Bed& truth = packedBed();
  TempDir dir;
  const auto img = dir / "phantom.mha";
  const VolumeHeader header = writeMustShowImage(img, truth, Modality::Mri, 34);
  IngestOptions io;
  io.voidPolarity = VoidPolarity::Bright;
  io.calibrationRuns = 2;
  Volume v = readVolume(img, {});
  const IngestResult mem = segmentVolume(std::move(v), io, 2);
  const StreamedIngestResult r = ingestVolumeStreamed(header, io, dir / "s.h5", 16, 2);
  const auto& c = r.report["calibration"];
  const auto& cm = mem.report["calibration"];
  std::cout << "[ measured ] calibration streamed " << c["density_bias"] << " +- "
            << c["density_bias_std"] << " over planes " << c["region"]["first"] << ".."
            << c["region"]["last"] << ", in memory " << cm["density_bias"] << " +- "
            << cm["density_bias_std"] << '\n';
  ASSERT_TRUE(c["density_bias"].is_number()) << c.dump(1);
  EXPECT_EQ(c["n"].get<int>(), 2);
  EXPECT_EQ(c["region"]["first"], r.report["streamed"]["volume_sample"]["first"]);
  EXPECT_NEAR(c["snr"].get<double>(), r.report["quality"]["snr"].get<double>(), 1e-9);
  EXPECT_NEAR(c["density_bias"].get<double>(), cm["density_bias"].get<double>(), 0.003);
  EXPECT_EQ(readBed(dir / "s.h5").provenance["calibration"], c);
  io.threshold = ThresholdMethod::Otsu;
  EXPECT_THROW(ingestVolumeStreamed(header, io, dir / "o.h5", 16, 2), UsageError);
}

TEST(Fidelity, XmtDensityRadiusAndWallProfileAt20VoxelsPerD) {
  const Fidelity f = run(packedBed(), Modality::Xmt, 12);
  ASSERT_TRUE(f.result.column.found) << f.result.column.note;
  EXPECT_NEAR(f.density, f.truthDensity, 0.005);
  EXPECT_LE(std::abs(f.radiusErrVox), 0.1);
  EXPECT_LE(f.profileRmse, 0.02);  // measured 0.0140 (0.025 before the wall-blur correction)
  EXPECT_NEAR(f.result.report["quality"]["snr"].get<double>(), 10.0, 0.6);  // measured 9.97
}

// A column given on the command line keeps its geometry and takes the wall's blur and
// levels from the wall step: the XMT wall correction needs the wall's and the outside's grey
// levels, which were left at 0 (measured +0.027 here and a near-wall RMSE of 0.14 before).
TEST(Fidelity, XmtWithTheColumnGivenKeepsTheDensity) {
  const MaskGeometry g = maskGeometry(packedBed());
  const Fidelity f = run(packedBed(), Modality::Xmt, 12, nullptr, 0, &g);
  EXPECT_EQ(f.result.report["wall_blur_correction"]["applied"], true);
  EXPECT_NEAR(f.density, f.truthDensity, 0.005);
  EXPECT_LE(f.profileRmse, 0.03);
}

TEST(Fidelity, ColumnFillingTheFieldOfViewIsFound) {
  // Half-width 46 voxels: the column (radius 50) leaves the image on all four sides; the
  // corners still show the wall and the outside.
  for (Modality m : {Modality::Mri, Modality::Xmt}) {
    SCOPED_TRACE(m == Modality::Mri ? "mri" : "xmt");
    const MaskGeometry whole = maskGeometry(packedBed());
    const Fidelity f = run(cropped(packedBed(), 46), m, 13, &whole);
    ASSERT_TRUE(f.result.column.found) << f.result.column.note;
    EXPECT_TRUE(f.result.column.touchesBorder);
    EXPECT_LE(std::abs(f.radiusErrVox), 0.1);
    // Goal 0.005. Measured +0.0015 (MRI) and +0.0029 (XMT); MRI read -0.0067 before the
    // phase levels came from the voxels deep inside each phase and the wall's blur was
    // divided out (docs/ingest.md).
    EXPECT_NEAR(f.density, f.truthDensity, 0.005);
    EXPECT_LE(f.profileRmse, 0.02);  // measured 0.0144 / 0.0141 (0.025 / 0.022 before)
  }
}

// Richardson-Lucy with the blur fitted at the wall (--deconvolve 10) on the same MRI
// phantoms: the near-wall band the blur darkens is restored, so the first d of the radial
// profile meets the 0.03 RMSE goal (measured 0.0171 and 0.0191; the default pipeline, which
// now divides the wall's blur out, reads 0.0156 and 0.0144). Density: -0.0003 and +0.0014
// (it was -0.0069 and -0.0075 while the phase levels came from the histogram's flanks).
TEST(Fidelity, DeconvolutionRestoresTheNearWallProfileOnMri) {
  const Fidelity margin = run(packedBed(), Modality::Mri, 11, nullptr, 10);
  ASSERT_TRUE(margin.result.column.found);
  EXPECT_LE(margin.profileRmse, 0.03);
  EXPECT_NEAR(margin.density, margin.truthDensity, 0.005);
  const auto& d = margin.result.report["deconvolution"];
  EXPECT_EQ(d["method"], "richardson-lucy");
  EXPECT_NEAR(d["psf_sigma_mm"].get<double>(), kVoxelMm, 0.3 * kVoxelMm);
  const MaskGeometry whole = maskGeometry(packedBed());
  const Fidelity cut = run(cropped(packedBed(), 46), Modality::Mri, 13, &whole, 10);
  ASSERT_TRUE(cut.result.column.found);
  EXPECT_LE(cut.profileRmse, 0.03);
  EXPECT_NEAR(cut.density, cut.truthDensity, 0.005);
}

// At 10 voxels per d (0.2 mm voxels) a threshold aimed over the whole column left the bed
// too solid (the blurred, curved interfaces of the bed need a different cut from the
// headspace above it): aimed over the bed's slices the bias meets the 0.015 goal at
// 10 voxels per d.
TEST(Fidelity, VolumeThresholdAimedOverTheBedAt10VoxelsPerD) {
  const Bed& truth = packedBed();
  const Grid<float> image = makePhantom(truth, coarsePhantom(Modality::Mri, 0.0, 14), 2);
  // The ROI in mm: the truth's packed slices less one d at each end.
  std::int64_t k0 = 0, k1 = 0;
  packedRegionDensity(truth, &k0, &k1);
  const Lattice& lt = truth.lattice();
  const double z0 = lt.centerMm(k0, 0, 0).z() + 2.0, z1 = lt.centerMm(k1, 0, 0).z() - 2.0;
  auto roiDensity = [&](const Bed& b) {
    const Lattice& l = b.lattice();
    std::int64_t a = -1, e = -1;
    for (std::int64_t k = 0; k < l.nz(); ++k) {
      const double z = l.centerMm(k, 0, 0).z();
      if (z < z0 || z > z1) continue;
      if (a < 0) a = k;
      e = k;
    }
    return density(b, a, e);
  };
  const double t = roiDensity(truth);
  double bias[2];
  for (int aimAtBed : {1, 0}) {
    IngestOptions io;
    io.voidPolarity = VoidPolarity::Bright;
    io.volumeOverBedSlices = aimAtBed != 0;
    Volume v;
    v.image = image;
    v.info.source = "phantom";
    const IngestResult r = segmentVolume(std::move(v), io, 2);
    ASSERT_EQ(r.report["threshold"]["method"], "volume");
    bias[aimAtBed] = roiDensity(r.bed) - t;
    std::cout << "[ measured ] 10 voxels per d, aimed over the "
              << (aimAtBed ? "bed's slices" : "whole column") << ": bias " << bias[aimAtBed]
              << ", region " << r.report["threshold"]["region"] << '\n';
  }
  EXPECT_LT(std::abs(bias[1]), 0.015);
  // Measured +0.0077 against +0.0130 (column-wide, the too-solid one).
  EXPECT_GT(bias[0], bias[1] + 0.003);
}

// MRI: the Rician edge correction scales with the interface density S_V. The preliminary
// segmentation is median-filtered and misses the gaps the blur closed; below 18 voxels per d
// the threshold cuts the raw image, and S_V read on that segmentation is nearer the truth's
// (2 P_L over the truth's packed slices, per image voxel), so the larger one is used. At SNR
// 5 noise roughens that segmentation's interfaces (a crossing moves by ~0.5 voxel): its S_V
// exceeds the truth's, and the preliminary one is kept.
TEST(Fidelity, MriEdgeCorrectionReadsTheInterfacesOnTheSegmentation) {
  const Bed& truth = packedBed();
  std::int64_t k0 = 0, k1 = 0;
  packedRegionDensity(truth, &k0, &k1);
  Grid<std::uint8_t> region = *truth.mask;
  const Lattice& lt = truth.lattice();
  for (std::int64_t k = 0; k < lt.nz(); ++k)
    if (k < k0 || k > k1)
      for (std::int64_t j = 0; j < lt.ny(); ++j)
        for (std::int64_t i = 0; i < lt.nx(); ++i) region(k, j, i) = 0;
  const double truthSv = 2.0 * surfaceDensityPerVoxel(truth.indicator, &region);  // 0.2 mm
  auto ingest = [&](double snr, double maxJitter) {
    PhantomOptions po = coarsePhantom(Modality::Mri, 0.0, 14);
    po.snr = snr;
    Volume v;
    v.image = makePhantom(truth, po, 2);
    v.info.source = "phantom";
    IngestOptions io;
    io.voidPolarity = VoidPolarity::Bright;
    io.surfaceRereadMaxJitter = maxJitter;
    const IngestResult r = segmentVolume(std::move(v), io, 2);
    const nlohmann::json m = r.report["threshold"]["mean_intensity_porosity"];
    std::cout << "[ measured ] SNR " << snr << ", max jitter " << maxJitter << ": jitter "
              << m["edge_jitter_voxels"] << ", S_V per image voxel: preliminary "
              << m["surface_per_voxel_preliminary"] << ", used " << m["surface_per_voxel"]
              << ", truth " << truthSv << "; porosity " << m["porosity"] << " (raw " << m["raw"]
              << ")\n";
    EXPECT_LT(m["edge_bias_voxels"].get<double>(), 0.0);
    EXPECT_NEAR(m["porosity"].get<double>(),
                m["raw"].get<double>() -
                    m["edge_bias_voxels"].get<double>() * m["surface_per_voxel"].get<double>(),
                1e-12);
    return m;
  };
  const nlohmann::json snr10 = ingest(10.0, IngestOptions{}.surfaceRereadMaxJitter);
  const double prelim = snr10["surface_per_voxel_preliminary"].get<double>();
  const double used = snr10["surface_per_voxel"].get<double>();
  EXPECT_TRUE(snr10["surface_reread"].get<bool>());
  EXPECT_GT(used, prelim);
  EXPECT_LT(std::abs(used - truthSv), std::abs(prelim - truthSv));
  const nlohmann::json snr5 = ingest(5.0, IngestOptions{}.surfaceRereadMaxJitter);
  EXPECT_FALSE(snr5["surface_reread"].get<bool>());
  EXPECT_GT(snr5["edge_jitter_voxels"].get<double>(), 0.3);
  EXPECT_EQ(snr5["surface_per_voxel"], snr5["surface_per_voxel_preliminary"]);
  const nlohmann::json forced = ingest(5.0, 10.0);  // read again whatever the noise
  EXPECT_TRUE(forced["surface_reread"].get<bool>());
  EXPECT_GT(forced["surface_per_voxel"].get<double>(), truthSv);
}

// An XMT column wall thinner than the wall fit resolves (2.5 voxels; here 1 voxel at 10
// voxels per d) fits any thickness up to that floor: at the floor (the fit before
// 2026-12-07, reproduced by holding 2.5 voxels) the step sits too far in and the radius reads
// short. Flagged as unresolved, the wall is held at the middle of the range (1.25 voxels),
// and a known thickness (--column-wall-mm) holds the true one.
TEST(Fidelity, ThinXmtWallIsHeldMidRangeOrAtItsKnownThickness) {
  const Bed& truth = packedBed();
  const PhantomOptions po = coarsePhantom(Modality::Xmt, 0.2, 15);
  const Grid<float> image = makePhantom(truth, po, 2);
  const double trueRadiusVox = maskGeometry(truth).radiusVox * kVoxelMm / po.voxelSizeMm;
  const char* names[3] = {"fitted (unresolved)", "held at the floor", "known"};
  const double held[3] = {0.0, 2.5 * po.voxelSizeMm, po.wallThicknessMm};
  double err[3];
  for (int c = 0; c < 3; ++c) {
    IngestOptions io;
    io.voidPolarity = VoidPolarity::Dark;
    io.columnWallMm = held[c];
    Volume v;
    v.image = image;
    v.info.source = "phantom";
    const IngestResult r = segmentVolume(std::move(v), io, 2);
    ASSERT_TRUE(r.column.found && r.column.refined) << r.column.note;
    err[c] = r.column.radiusMm / po.voxelSizeMm - trueRadiusVox;
    std::cout << "[ measured ] wall " << names[c] << ": radius error " << err[c] << " voxel, wall "
              << r.column.wallThicknessMm / po.voxelSizeMm << " voxel\n";
    if (c == 0) {
      EXPECT_FALSE(r.column.wallResolved);
      EXPECT_FALSE(r.report["column"]["wall_resolved"].get<bool>());
      EXPECT_NEAR(r.column.wallThicknessMm / po.voxelSizeMm, 1.25, 1e-9);
      EXPECT_NE(r.column.note.find("not resolved"), std::string::npos) << r.column.note;
    } else {
      EXPECT_TRUE(r.column.wallResolved);  // a held thickness is not flagged
    }
  }
  // Measured: see the output above; the floor reads short by about half of (2.5 - 1) voxels.
  EXPECT_LT(std::abs(err[0]), 0.3);
  EXPECT_LT(err[1], -0.4);
  EXPECT_LT(std::abs(err[2]), 0.3);
}

// The solid level of an XMT image at 10 voxels per d, read deep inside the solid of a plain
// threshold. Pellets touching (or nearly) read as one solid once blurred, and the voxels of
// their necks read low: the axis test ("solid along +-x, y, z") keeps many of them, a
// Euclidean ball does not. Same bits for 1 and 2 threads; a strided sample (a 2000^3 scan
// looks at a few slices) still reads the level.
TEST(Fidelity, XmtSolidLevelIsReadInABallDeepInsideTheSolid) {
  const Grid<float> image = makePhantom(packedBed(), coarsePhantom(Modality::Xmt, 0.0, 16), 2);
  Grid<std::uint8_t> ind(image.lattice(), 0);
  for (std::size_t n = 0; n < image.size(); ++n) ind[n] = image[n] <= 600.0f;  // void dark
  const InteriorStats axis = phaseInteriorStats(image, ind, nullptr, 0, 2);
  DeepLevelOptions o;
  o.threads = 1;
  const DeepLevel one = phaseDeepLevel(image, ind, nullptr, 0, o);
  o.threads = 2;
  const DeepLevel two = phaseDeepLevel(image, ind, nullptr, 0, o);
  o.oneSided = true;
  const DeepLevel tail = phaseDeepLevel(image, ind, nullptr, 0, o);
  o.oneSided = false;
  o.maxExamined = 12 * static_cast<std::size_t>(image.lattice().ny() * image.lattice().nx());
  o.minVoxels = 300;
  const DeepLevel strided = phaseDeepLevel(image, ind, nullptr, 0, o);
  DeepLevelOptions ov;
  ov.upper = false;
  const DeepLevel pore = phaseDeepLevel(image, ind, nullptr, 1, ov);
  std::cout << "[ measured ] solid level 1000: axis depth 2 mean " << axis.mean << " ("
            << axis.pairs << " pairs), ball " << one.radius << " mean " << one.level << " ("
            << one.voxels << " voxels), tail fit " << tail.level << ", every "
            << strided.sliceStride << "th slice " << strided.level << " (" << strided.voxels
            << "); void level 200: " << pore.level << '\n';
  EXPECT_EQ(one.level, two.level);
  EXPECT_EQ(one.voxels, two.voxels);
  EXPECT_NEAR(one.level, 1000.0, 8.0);
  EXPECT_LT(axis.mean, one.level - 10.0);
  EXPECT_NEAR(tail.level, 1000.0, 8.0);
  EXPECT_GT(strided.sliceStride, 1);
  EXPECT_LT(strided.voxels, one.voxels);
  EXPECT_NEAR(strided.level, 1000.0, 15.0);
  EXPECT_NEAR(pore.level, 200.0, 5.0);
  EXPECT_NEAR(one.sigma, 80.0, 8.0);  // the phase's own noise: (1000 - 200) / SNR 10
}

// Why the tail fit is not the default: under a smooth gain field (the phantom's +-20 %) the
// deep voxels spread by the gain, not only by the noise, and a normal of the noise's width
// fitted to their upper tail reads the bright side of the field; their mean is the level
// at the mean gain. Without the field the two agree. Measured: 996.3 / 995.9 without,
// 1063.9 / 1121.9 with (the field's mean over the deep voxels is 1.064 here).
TEST(Fidelity, TailLevelReadsTheBrightSideOfABiasField) {
  double gap[2];
  for (int field : {0, 1}) {
    PhantomOptions po = coarsePhantom(Modality::Xmt, 0.0, 17);
    po.biasFraction = field ? 0.2 : 0.0;
    const Grid<float> image = makePhantom(packedBed(), po, 2);
    Grid<std::uint8_t> ind(image.lattice(), 0);
    for (std::size_t n = 0; n < image.size(); ++n) ind[n] = image[n] <= 600.0f;
    DeepLevelOptions o;
    o.threads = 2;
    const DeepLevel mean = phaseDeepLevel(image, ind, nullptr, 0, o);
    o.oneSided = true;
    const DeepLevel tail = phaseDeepLevel(image, ind, nullptr, 0, o);
    gap[field] = tail.level - mean.level;
    std::cout << "[ measured ] gain field " << po.biasFraction << ": solid level mean "
              << mean.level << ", tail " << tail.level << '\n';
  }
  EXPECT_LT(std::abs(gap[0]), 10.0);
  EXPECT_GT(gap[1], 30.0);
}

// A gap the preliminary segmentation closed: horizontal sheets through a solid block that
// read 700 instead of 1000 (flat faces of pellets stacked with a sub-voxel gap, still above
// any threshold), every 10th slice, noise sigma 80. Every voxel is "solid", so the ball keeps the
// sheets; their 26 neighbours dip against the reference around them, and the dip test leaves
// them out. Under a gain ramp (0.8 to 1.2 along x) the level stays the mean gain's.
struct SheetCase {
  DeepLevel kept, one, all;  // dip test on 2 and 1 threads; no dip test
};
template <class Solid>
SheetCase sheetedSolid(const Lattice& l, bool ramp, std::uint64_t seed, Solid solid) {
  Grid<float> image(l, 0.0f);
  Grid<std::uint8_t> ind(l, 1);
  RandomStream rng(seed, 0);
  for (std::int64_t k = 0; k < l.nz(); ++k)
    for (std::int64_t j = 0; j < l.ny(); ++j)
      for (std::int64_t i = 0; i < l.nx(); ++i) {
        const bool in = solid(k, j, i);
        const double gain = ramp ? 0.8 + 0.4 * static_cast<double>(i) / 43.0 : 1.0;
        const double v = in ? (k % 10 == 5 ? 700.0 : 1000.0) : 200.0;
        image(k, j, i) = static_cast<float>(gain * v + 80.0 * rng.normal());
        ind(k, j, i) = in ? 0 : 1;
      }
  DeepLevelOptions o;
  o.fallbackSigma = 80.0;
  o.threads = 2;
  SheetCase r;
  r.kept = phaseDeepLevel(image, ind, nullptr, 0, o);
  o.threads = 1;
  r.one = phaseDeepLevel(image, ind, nullptr, 0, o);
  o.dipSigmas = 0.0;
  r.all = phaseDeepLevel(image, ind, nullptr, 0, o);
  std::cout << "[ measured ] gain ramp " << ramp << ": all deep voxels " << r.all.level << " ("
            << r.all.voxels << ", ball " << r.all.radius << "), dip test " << r.kept.level << " ("
            << r.kept.voxels << ", " << r.kept.dipExcluded << " left out)\n";
  return r;
}

// A 40^3 block: the cube's corners are deep. Measured: all deep voxels 964.2, with the dip
// test 999.1 (no ramp) and 1002.1 (ramp).
TEST(Fidelity, DipTestLeavesOutTheSheetOfAClosedGap) {
  const Lattice l = Lattice::isotropic(44, 44, 44, 0.1);
  for (bool ramp : {false, true}) {
    const SheetCase r =
        sheetedSolid(l, ramp, 5, [](std::int64_t k, std::int64_t j, std::int64_t i) {
          return k >= 2 && j >= 2 && i >= 2 && k < 42 && j < 42 && i < 42;
        });
    // The true level over the deep voxels: 1000 times the mean gain of the block's core.
    const double truth = ramp ? 1000.0 * (0.8 + 0.4 * 21.5 / 43.0) : 1000.0;
    EXPECT_LT(r.all.level, truth - 10.0);
    EXPECT_NEAR(r.kept.level, truth, 4.0);
    EXPECT_GT(r.kept.dipExcluded, 0u);
    EXPECT_EQ(r.kept.level, r.one.level);  // any thread count, the same bits
  }
}

// Pellets ~10 voxels across (10 voxels per d): rods of 10 x 10 voxels along z. No corner of
// the dip test's cube is deep, so the reference is the mean of the cube's deep voxels.
// Measured: all deep voxels 969.2 / 960.2, dip test 999.3 / 987.4 (truth 1000 / 990.7).
TEST(Fidelity, DipTestOnSmallPelletsReadsTheCubeAroundTheVoxel) {
  const Lattice l = Lattice::isotropic(104, 44, 44, 0.1);
  auto inRod = [](std::int64_t v) { return v >= 2 && v < 40 && (v - 2) % 14 < 10; };
  for (bool ramp : {false, true}) {
    const SheetCase r =
        sheetedSolid(l, ramp, 6, [&](std::int64_t k, std::int64_t j, std::int64_t i) {
          return k >= 2 && k < 102 && inRod(j) && inRod(i);
        });
    // The deep voxels are the rods' central 4 x 4 columns (i = 5..8, 19..22, 33..36).
    const double truth = ramp ? 1000.0 * (0.8 + 0.4 * 20.5 / 43.0) : 1000.0;
    ASSERT_EQ(r.all.radius, 3.5);  // the cube's corners lie 4 voxels out: outside the rods
    EXPECT_LT(r.all.level, truth - 10.0);
    EXPECT_NEAR(r.kept.level, truth, 4.0);
    EXPECT_GT(r.kept.dipExcluded, 0u);
    EXPECT_EQ(r.kept.level, r.one.level);  // any thread count, the same bits
  }
}
