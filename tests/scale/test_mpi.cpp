// mpirun -np 1/2/3 on loopback gives the JSON values of one process (registered only in
// VOXPACK_MPI builds; docs/scale.md).
#include <gtest/gtest.h>

#include "cli_runner.hpp"
#include "scale_fixtures.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/json_util.hpp"

using namespace voxpack;
using namespace voxpack::test;
using nlohmann::json;

namespace {

std::string mpirun(int ranks) {
  return std::string(VOXPACK_MPIRUN) +
         " --oversubscribe --allow-run-as-root --mca btl self,vader " + "-np " +
         std::to_string(ranks) + " " + shellQuote(VOXPACK_BINARY);
}

// The values: everything but what names the run itself.
json values(json j) {
  j.erase("command_line");
  if (j.contains("streamed")) j["streamed"].erase("ranks");
  if (j.contains("options")) j["options"].erase("threads");
  // The default limit is 75 % of the memory available at the moment each run starts.
  if (j.contains("memory_estimate_bytes")) j["memory_estimate_bytes"].erase("limit");
  return j;
}

}  // namespace

TEST(Mpi, StatsEqualForOneTwoThreeRanks) {
  TempDir tmp;
  ColumnBed o;
  o.nz = 30;
  const auto f = (tmp / "bed.h5").string();
  writeBed(f, sphereColumn(o));
  const std::string args = " --quiet --threads 1 stats " + shellQuote(f) +
                           " --only axial,radial,s2,chords,orientation --slab-voxels 3 -o ";
  const auto serial = (tmp / "serial.json").string();
  ASSERT_EQ(runShell(shellQuote(VOXPACK_BINARY) + args + shellQuote(serial)), 0);
  const json ref = values(readJsonFile(serial));
  for (int n : {1, 2, 3}) {
    const auto out = (tmp / ("np" + std::to_string(n) + ".json")).string();
    ASSERT_EQ(runShell(mpirun(n) + args + shellQuote(out) + " </dev/null"), 0) << n << " ranks";
    const json j = readJsonFile(out);
    EXPECT_EQ(j["streamed"]["ranks"], n);
    EXPECT_EQ(values(j), ref) << n << " ranks";
  }
}

TEST(Mpi, InfoEqualForTwoRanks) {
  TempDir tmp;
  ColumnBed o;
  const auto f = (tmp / "bed.h5").string();
  writeBed(f, sphereColumn(o));
  const CliResult one = runVoxpack({"info", f, "--json", "--slab-voxels", "4"});
  ASSERT_EQ(one.exitCode, 0) << one.err;
  const auto out = (tmp / "info.txt").string();
  ASSERT_EQ(runShell(mpirun(2) + " info " + shellQuote(f) + " --json --slab-voxels 4 >" +
                     shellQuote(out) + " </dev/null"),
            0);
  std::ifstream in(out);
  const json two = json::parse(in);
  EXPECT_EQ(two, json::parse(one.out));
}

TEST(Mpi, OneFailingRankEndsTheRunWithExit2) {
  TempDir tmp;
  const int rc = runShell(mpirun(2) + " stats " + shellQuote((tmp / "missing.h5").string()) +
                          " --only axial -o " + shellQuote((tmp / "x.json").string()) +
                          " </dev/null >/dev/null 2>&1");
  EXPECT_NE(rc, 0);
  EXPECT_FALSE(std::filesystem::exists(tmp / "x.json"));
}
