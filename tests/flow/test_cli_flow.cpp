// `voxpack flow` through the binary: keys, statuses, exit codes, --field, --csv, --roi-mm.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <fstream>

#include "cli_runner.hpp"
#include "flow_fixtures.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/json_util.hpp"

namespace voxpack::test {
namespace {

// A small column (radius 7 voxels of 0.5 mm) with a few solid spheres inside.
Bed smallColumn() {
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(Lattice::isotropic(20, 16, 16, 0.5), 1);
  bed.mask = Grid<std::uint8_t>(bed.indicator.lattice(), 0);
  for (std::int64_t k = 0; k < 20; ++k)
    for (std::int64_t j = 0; j < 16; ++j)
      for (std::int64_t i = 0; i < 16; ++i) {
        (*bed.mask)(k, j, i) = std::hypot(j - 7.5, i - 7.5) < 7.0 ? 1 : 0;
        for (int s = 0; s < 3; ++s) {
          const double cz = 3 + 7 * s, cy = 7.5 + (s - 1) * 2.0, cx = 7.5 - (s - 1) * 2.0;
          if (std::hypot(std::hypot(k - cz, j - cy), i - cx) < 3.5) bed.indicator(k, j, i) = 0;
        }
      }
  return bed;
}

TEST(FlowCli, WritesEveryKey) {
  TempDir tmp;
  writeBed(tmp / "bed.h5", smallColumn());
  const CliResult r = runVoxpack(
      {"flow", (tmp / "bed.h5").string(), "-o", (tmp / "flow.json").string(), "--tolerance", "1e-5",
       "--csv", (tmp / "csv").string(), "--field", (tmp / "field.h5").string(), "--quiet"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json j = readJsonFile(tmp / "flow.json");
  for (const char* key :
       {"permeability_mm2", "permeability_darcy", "porosity", "superficial_velocity",
        "interstitial_velocity", "tortuosity_hydraulic", "reynolds", "steps", "converged", "status",
        "residual", "mlups", "wall_s", "radial_profile", "wall_flow_share",
        "specific_surface_mm_inv", "pressure_gradient"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["status"], "converged");
  EXPECT_EQ(j["lattice"]["streaming"], "aa");  // halfway walls: one lattice, in place
  EXPECT_GT(j["permeability_mm2"].get<double>(), 0.0);
  EXPECT_NEAR(j["permeability_darcy"].get<double>() * 9.869233e-7,
              j["permeability_mm2"].get<double>(), 1e-9 * j["permeability_mm2"].get<double>());
  EXPECT_GT(j["tortuosity_hydraulic"].get<double>(), 1.0);
  EXPECT_GT(j["wall_flow_share"].get<double>(), 0.0);
  EXPECT_LE(j["wall_flow_share"].get<double>(), 1.0);
  EXPECT_GT(j["pressure_gradient"]["darcy_pa_m"].get<double>(), 0.0);
  EXPECT_GT(j["pressure_gradient"]["ergun_pa_m"].get<double>(), 0.0);
  EXPECT_GT(j["pressure_gradient"]["eisfeld_schnitzlein_pa_m"].get<double>(), 0.0);
  EXPECT_TRUE(std::filesystem::exists(tmp / "csv" / "radial_profile.csv"));
  EXPECT_TRUE(std::filesystem::exists(tmp / "field.xdmf"));
  // The field file is a bed file with velocity and pressure beside it.
  const Bed back = readBed(tmp / "field.h5");
  EXPECT_EQ(back.lattice().dims, smallColumn().lattice().dims);
  const hid_t f = H5Fopen((tmp / "field.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  EXPECT_GT(H5Lexists(f, "/velocity", H5P_DEFAULT), 0);
  EXPECT_GT(H5Lexists(f, "/pressure", H5P_DEFAULT), 0);
  H5Fclose(f);
}

TEST(FlowCli, BlockedIsExitZeroAndAllSolidIsRefused) {
  TempDir tmp;
  Bed bed = smallColumn();
  for (std::int64_t j = 0; j < 16; ++j)
    for (std::int64_t i = 0; i < 16; ++i) bed.indicator(10, j, i) = 0;
  writeBed(tmp / "blocked.h5", bed);
  CliResult r = runVoxpack(
      {"flow", (tmp / "blocked.h5").string(), "-o", (tmp / "b.json").string(), "--quiet"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const nlohmann::json j = readJsonFile(tmp / "b.json");
  EXPECT_EQ(j["status"], "blocked");
  EXPECT_EQ(j["permeability_mm2"].get<double>(), 0.0);
  bed.indicator.fill(0);
  writeBed(tmp / "solid.h5", bed);
  r = runVoxpack({"flow", (tmp / "solid.h5").string(), "-o", (tmp / "s.json").string()});
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
  EXPECT_FALSE(std::filesystem::exists(tmp / "s.json"));
}

TEST(FlowCli, NotConvergedRoiAndBadOptions) {
  TempDir tmp;
  writeBed(tmp / "bed.h5", smallColumn());
  const std::string in = (tmp / "bed.h5").string(), out = (tmp / "f.json").string();
  CliResult r =
      runVoxpack({"flow", in, "-o", out, "--max-steps", "30", "--check-interval", "10", "--quiet"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  nlohmann::json j = readJsonFile(out);
  EXPECT_EQ(j["status"], "not_converged");
  EXPECT_EQ(j["steps"].get<int>(), 30);
  EXPECT_GT(j["residual"].get<double>(), 1e-5);
  r = runVoxpack(
      {"flow", in, "-o", out, "--roi-mm", "2:6", "--axis", "z", "--max-steps", "20", "--quiet"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  j = readJsonFile(out);
  EXPECT_EQ(j["dims"][0].get<int>(), 9);  // centres 2.0 .. 6.0 mm at 0.5 mm
  for (const std::vector<std::string>& bad : {std::vector<std::string>{"--roi-mm", "5:1"},
                                              {"--roi-mm", "100:200"},
                                              {"--axis", "w"},
                                              {"--memory-limit", "64K"},
                                              {"--periodic", "--mirror"}}) {
    std::vector<std::string> args = {"flow", in, "-o", (tmp / "bad.json").string()};
    args.insert(args.end(), bad.begin(), bad.end());
    r = runVoxpack(args);
    EXPECT_EQ(r.exitCode, 2) << bad[0] << " " << r.err;
    EXPECT_FALSE(std::filesystem::exists(tmp / "bad.json"));
  }
}

}  // namespace
}  // namespace voxpack::test
