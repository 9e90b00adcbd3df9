// `voxpack export` from the command line: the NRRD round trip through `voxpack ingest`, and
// refusals (exit 2, one error line, no output left behind).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli_runner.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/packer/digitise.hpp"
#include "voxpack/packer/shape.hpp"

namespace voxpack::test {
namespace {

namespace fs = std::filesystem;

// Two spheres digitised by the voxel-centre test on a small anisotropic lattice with an
// origin away from zero (so spacing and origin both have to survive the round trip).
Bed twoSpheres(bool particles) {
  Lattice l;
  l.dims = {18, 20, 22};
  l.spacingMm = {0.3, 0.25, 0.25};
  l.originMm = {1.15, -2.4, -2.6};
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(l, 1);
  const auto s = packer::parseShape("sphere:d=2.5");
  const std::vector<Vec3> c = {{-1, 0, 3}, {1.5, 0, 3}};
  for (std::int64_t k = 0; k < l.nz(); ++k)
    for (std::int64_t j = 0; j < l.ny(); ++j)
      for (std::int64_t i = 0; i < l.nx(); ++i)
        for (const Vec3& p : c)
          if (s->inside(l.centerMm(k, j, i) - p)) bed.indicator(k, j, i) = 0;
  if (particles)
    for (const Vec3& p : c) {
      bed.particles.positionMm.push_back(p);
      bed.particles.orientation.push_back(Quat::Identity());
      bed.particles.shape.push_back("sphere:d=2.5");
    }
  return bed;
}

TEST(CliExport, NrrdRoundTripThroughIngestKeepsTheIndicator) {
  TempDir tmp;
  const Bed bed = twoSpheres(true);
  writeBed(tmp / "bed.h5", bed);
  for (const char* ext : {"nrrd", "mha"}) {
    SCOPED_TRACE(ext);
    const std::string img = (tmp / (std::string("bed.") + ext)).string();
    auto r =
        runVoxpack({"export", (tmp / "bed.h5").string(), "--format", ext, "-o", img, "--quiet"});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // A pure threshold: no denoising, no bias correction, no column crop, no speck/hole cleanup.
    r = runVoxpack({"ingest", img, "-o", (tmp / "back.h5").string(), "--void", "bright",
                    "--threshold", "0.5", "--column", "none", "--denoise", "none",
                    "--bias-correction", "none", "--max-speck-voxels", "0", "--max-hole-voxels",
                    "0", "--quiet"});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const Bed back = readBed(tmp / "back.h5");
    EXPECT_EQ(back.lattice().dims, bed.lattice().dims);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(back.lattice().spacingMm[a], bed.lattice().spacingMm[a], 1e-6);
      EXPECT_NEAR(back.lattice().originMm[a], bed.lattice().originMm[a], 1e-6);
    }
    EXPECT_TRUE(back.indicator.values() == bed.indicator.values());
  }
}

// The pose table reproduces a packed bed: a Monte Carlo bed of tilted cylinders packed by
// `voxpack pack`, exported to CSV, read back here (a test helper standing in for a
// `pack --from CSV`), and every particle re-digitised at its CSV pose on the bed's lattice
// gives exactly the bed's labels. The poses must come back bit-exact for this to hold
// (a pose off by one ulp can flip a voxel centre lying on the surface).
TEST(CliExport, CsvPoseTableReproducesAPackedBed) {
  TempDir tmp;
  const std::string bed = (tmp / "mc.h5").string(), csv = (tmp / "mc.csv").string();
  auto r = runVoxpack({"pack", "--mode", "mc", "--shape", "cylinder:d=2,l=1.4", "--container",
                       "cylinder:d=8,h=8", "--voxel-size", "0.2", "--count", "12", "--seed", "7",
                       "-o", bed, "--quiet"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  r = runVoxpack({"export", bed, "--format", "csv", "-o", csv, "--quiet"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const Bed packed = readBed(bed);
  ASSERT_TRUE(packed.labels.has_value());
  const Lattice& lat = packed.lattice();
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // header
  Grid<std::uint32_t> labels(lat, 0);
  std::size_t rows = 0;
  while (std::getline(in, line)) {
    // id,"shape spec",x,y,z,qw,qx,qy,qz,volume
    const auto q0 = line.find('"'), q1 = line.find('"', q0 + 1);
    ASSERT_NE(q1, std::string::npos) << line;
    const std::uint32_t id = static_cast<std::uint32_t>(std::stoul(line.substr(0, q0 - 1)));
    const std::string spec = line.substr(q0 + 1, q1 - q0 - 1);
    std::istringstream rest(line.substr(q1 + 2));
    double v[7];
    std::string cell;
    for (double& x : v) {
      ASSERT_TRUE(std::getline(rest, cell, ','));
      x = std::stod(cell);
    }
    ASSERT_EQ(id, rows + 1);
    EXPECT_EQ(spec, packed.particles.shape[rows]);
    EXPECT_EQ(Vec3(v[0], v[1], v[2]), packed.particles.positionMm[rows]);  // bit-exact
    const auto shape = packer::parseShape(spec);
    const auto dp = packer::digitise(*shape, Vec3(v[0], v[1], v[2]),
                                     Quat(v[3], v[4], v[5], v[6]).normalized(), lat);
    for (const auto& vox : dp.voxels)
      if (vox.k >= 0 && vox.k < lat.nz() && vox.j >= 0 && vox.j < lat.ny() && vox.i >= 0 &&
          vox.i < lat.nx())
        labels(vox.k, vox.j, vox.i) = id;
    ++rows;
  }
  EXPECT_EQ(rows, packed.particles.size());
  EXPECT_GT(rows, 5u);
  std::size_t differ = 0, solid = 0;
  for (std::size_t n = 0; n < labels.values().size(); ++n) {
    differ += labels.values()[n] != packed.labels->values()[n];
    solid += labels.values()[n] != 0;
  }
  EXPECT_GT(solid, 1000u);
  EXPECT_EQ(differ, 0u) << "of " << solid << " solid voxels";
}

TEST(CliExport, RefusesBadInputWithExit2AndNoOutput) {
  TempDir tmp;
  writeBed(tmp / "imaged.h5", twoSpheres(false));
  const std::string bed = (tmp / "imaged.h5").string();
  auto r = runVoxpack({"export", bed, "--format", "png", "-o", (tmp / "x.png").string()});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("--format"), std::string::npos) << r.err;
  // An imaged bed has no particle table: stl needs --surface, csv/vtk refuse.
  for (const char* f : {"stl", "csv", "vtk"}) {
    const fs::path out = tmp / (std::string("x.") + f);
    r = runVoxpack({"export", bed, "--format", f, "-o", out.string()});
    EXPECT_EQ(r.exitCode, 2) << f << ": " << r.err;
    EXPECT_FALSE(fs::exists(out)) << f;
  }
  r = runVoxpack({"export", (tmp / "missing.h5").string(), "--format", "xdmf"});
  EXPECT_EQ(r.exitCode, 2);
  r = runVoxpack(
      {"export", bed, "--format", "stl", "--contacts", "glue", "-o", (tmp / "y.stl").string()});
  EXPECT_EQ(r.exitCode, 2);
  r = runVoxpack({"export", bed, "--format", "nrrd", "-o", (tmp / "y.png").string()});
  EXPECT_EQ(r.exitCode, 2);
  // No temporary file is left beside the outputs.
  for (const auto& e : fs::directory_iterator(tmp.path()))
    EXPECT_NE(e.path().filename().string().rfind(".voxpack", 0), 0u) << e.path();
}

TEST(CliExport, SurfaceOfAnImagedBedIsClosed) {
  TempDir tmp;
  writeBed(tmp / "imaged.h5", twoSpheres(false));
  const fs::path out = tmp / "iso.stl";
  auto r = runVoxpack({"export", (tmp / "imaged.h5").string(), "--format", "stl", "--surface", "-o",
                       out.string(), "--json", "--quiet"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_TRUE(fs::exists(out));
  EXPECT_NE(r.out.find("\"triangles\""), std::string::npos);
}

}  // namespace
}  // namespace voxpack::test
