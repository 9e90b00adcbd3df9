// `voxpack export` from the command line: the NRRD round trip through `voxpack ingest`, and
// refusals (exit 2, one error line, no output left behind).
#include <gtest/gtest.h>

#include <filesystem>

#include "cli_runner.hpp"
#include "voxpack/core/bed_file.hpp"
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
