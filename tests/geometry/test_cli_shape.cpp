// voxpack shape, driven through the built binary.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <sstream>

#include "cli_runner.hpp"
#include "stl_fixtures.hpp"

using namespace voxpack::test;

TEST(CliShape, JsonKeysAndNumbers) {
  const auto r = runVoxpack({"shape", "--shape", "sphere:d=50", "--voxel-size", "1", "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* k : {"volume_exact_mm3", "volume_digital_mm3", "volume_rel_error",
                        "surface_exact_mm2", "surface_digital_mm2", "surface_rel_error", "voxels"})
    ASSERT_TRUE(j.contains(k)) << k;
  EXPECT_LT(std::abs(j["volume_rel_error"].get<double>()), 0.005);
  EXPECT_GT(j["surface_rel_error"].get<double>(), 0.4);
  EXPECT_LT(j["surface_rel_error"].get<double>(), 0.6);
  EXPECT_DOUBLE_EQ(j["volume_digital_mm3"].get<double>(), j["voxels"].get<double>());
}

TEST(CliShape, IdentityPutsCylinderAxisAlongZ) {
  // d = 9.6, l = 3.6 voxels, centre on a voxel centre: 3 voxel centres along z, 9 along x.
  TempDir tmp;
  const auto out = tmp / "c.h5";
  const auto r = runVoxpack({"shape", "--shape", "cylinder:d=9.6,l=3.6", "--voxel-size", "1", "-o",
                             out.string(), "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto info = runVoxpack({"info", out.string(), "--json"});
  ASSERT_EQ(info.exitCode, 0) << info.err;
  const auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["dims"][0].get<int>(), 3 + 4);  // nz: 3 voxels + 2 x 2 margin
  EXPECT_EQ(j["dims"][2].get<int>(), 9 + 4);  // nx: centres -4..4
  EXPECT_EQ(j["particles"].get<int>(), 1);
  const auto shape = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["void_voxels"].get<std::size_t>() + shape["voxels"].get<std::size_t>(),
            j["voxels"].get<std::size_t>());
  // Rotating 90 degrees about x lays the axis along y.
  const auto r2 =
      runVoxpack({"shape", "--shape", "cylinder:d=9.6,l=3.6", "--voxel-size", "1", "--orientation",
                  "0.7071067811865476,0.7071067811865476,0,0", "-o", (tmp / "r.h5").string()});
  ASSERT_EQ(r2.exitCode, 0) << r2.err;
  const auto j2 =
      nlohmann::json::parse(runVoxpack({"info", (tmp / "r.h5").string(), "--json"}).out);
  EXPECT_EQ(j2["dims"][1].get<int>(), 3 + 4);
  EXPECT_EQ(j2["dims"][0].get<int>(), 9 + 4);
}

TEST(CliShape, TextOutput) {
  const auto r = runVoxpack({"shape", "--shape", "cylinder:d=5.4,l=3.8", "--voxel-size", "0.27"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("rel. error"), std::string::npos);
}

// Bad input: exit 2, one error line, no output file.
TEST(CliShape, BadInputExit2NoFile) {
  TempDir tmp;
  const std::string out = (tmp / "x.h5").string();
  std::string missingMesh = "mesh:";
  missingMesh.append((tmp / "missing.stl").string());
  const std::vector<std::vector<std::string>> cases = {
      {"--shape", "blob:d=1", "--voxel-size", "0.1"},
      {"--shape", "sphere", "--voxel-size", "0.1"},
      {"--shape", "sphere:d=0", "--voxel-size", "0.1"},
      {"--shape", "sphere:d=-2", "--voxel-size", "0.1"},
      {"--shape", "ring:d=5,di=5,l=2", "--voxel-size", "0.1"},
      {"--shape", "ring:d=5,di=7,l=2", "--voxel-size", "0.1"},
      {"--shape", "sphere:d=1", "--voxel-size", "0"},
      {"--shape", "sphere:d=1", "--voxel-size", "-1"},
      {"--shape", "sphere:d=1"},
      {"--shape", "sphere:d=1", "--voxel-size", "0.1", "--orientation", "0,0,0,0"},
      {"--shape", "sphere:d=1", "--voxel-size", "0.1", "--orientation", "1,0,0"},
      {"--shape", "sphere:d=1", "--voxel-size", "0.1", "--supersample", "0"},
      {"--shape", missingMesh, "--voxel-size", "0.1"},
  };
  for (const auto& c : cases) {
    std::vector<std::string> args{"shape"};
    args.insert(args.end(), c.begin(), c.end());
    args.emplace_back("-o");
    args.push_back(out);
    const auto r = runVoxpack(args);
    std::ostringstream joinedStream;
    for (const auto& a : args) joinedStream << a << ' ';
    const std::string joined = joinedStream.str();
    EXPECT_EQ(r.exitCode, 2) << joined << r.err;
    EXPECT_EQ(countErrorLines(r.err), 1) << joined << r.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << joined;
    EXPECT_TRUE(listDir(tmp.path()).empty()) << joined;
  }
}

TEST(CliShape, UnwritableOutputExit2) {
  const auto r = runVoxpack(
      {"shape", "--shape", "sphere:d=1", "--voxel-size", "0.1", "-o", "/nonexistent-dir/x.h5"});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(countErrorLines(r.err), 1);
  EXPECT_FALSE(std::filesystem::exists("/nonexistent-dir/x.h5"));
}

// STL shapes through the CLI: a good mesh works; open, garbage and missing STL files are
// refused with exit 2, one error line naming the file, and no output.
TEST(CliShape, StlMeshes) {
  TempDir tmp;
  // l = 2.1 = 21 voxel layers exactly: at identity the caps are parallel to the lattice
  // planes and a length off the layer grid would cost up to half a layer (2.5 %).
  // r = 1.52, not 1.5: a radius of exactly 15 voxels puts 12 lattice points (Pythagorean
  // triples 9-12-15) per layer on the circle, which a polygon inscribed in it excludes.
  writeBinaryStl(tmp / "cyl.stl", cylinderTriangles(1.52, 0, 2.1, 64));
  auto tris = boxTriangles(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1));
  tris.pop_back();
  writeAsciiStl(tmp / "open.stl", tris);
  {
    std::ofstream f(tmp / "garbage.stl");
    f << "GIF89a not a mesh";
  }
  const auto ok = runVoxpack(
      {"shape", "--shape", "mesh:" + (tmp / "cyl.stl").string(), "--voxel-size", "0.1", "--json"});
  ASSERT_EQ(ok.exitCode, 0) << ok.err;
  const auto j = nlohmann::json::parse(ok.out);
  EXPECT_LT(std::abs(j["volume_rel_error"].get<double>()), 0.01);
  for (const char* name : {"open.stl", "garbage.stl", "missing.stl"}) {
    const std::string path = (tmp / name).string();
    const std::string out = (tmp / "x.h5").string();
    const auto r =
        runVoxpack({"shape", "--shape", "mesh:" + path, "--voxel-size", "0.1", "-o", out});
    EXPECT_EQ(r.exitCode, 2) << name << r.err;
    EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out));
  }
}
