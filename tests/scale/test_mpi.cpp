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
  if (j.contains("mes")) j["mes"].erase("seconds");
  return j;
}

// `voxpack phantom BED` as a raw-encoded detached NRRD DIR/NAME.nhdr (phantom writes gzip
// data, and the streamed reader needs raw); true when both steps succeeded.
bool rawPhantom(const std::filesystem::path& dir, const std::string& bed, const std::string& name,
                const std::string& options) {
  const auto grey = (dir / (name + ".nhdr")).string();
  return runShell(shellQuote(VOXPACK_BINARY) + " --quiet phantom " + shellQuote(bed) + " -o " +
                  shellQuote(grey) + " " + options + " </dev/null >/dev/null") == 0 &&
         runShell("gunzip -f " + shellQuote((dir / (name + ".raw.gz")).string()) +
                  " && sed -i 's/^encoding: gzip/encoding: raw/; "
                  "s/^data file: \\(.*\\)\\.gz$/data file: \\1/' " +
                  shellQuote(grey)) == 0;
}

// A bed file's provenance less what names the run: the output path, the timing, the ranks,
// and the passes (a float image under mpirun takes Otsu's bins pass, which one process
// skips; the same threshold).
json runlessProvenance(json p) {
  p.erase("command_line");
  p["ingest"].erase("timing_s");
  p["ingest"]["streamed"].erase("ranks");
  p["ingest"]["streamed"].erase("passes");
  return p;
}

}  // namespace

TEST(Mpi, StatsEqualForOneTwoThreeRanks) {
  TempDir tmp;
  ColumnBed o;
  o.nz = 30;
  const auto f = (tmp / "bed.h5").string();
  writeBed(f, sphereColumn(o));
  const std::string args = " --quiet --threads 1 stats " + shellQuote(f) +
                           " --only axial,radial,s2,chords,mes,orientation --slab-voxels 3 ";
  // The mean empty space with a halo that holds every run, and with one that cuts some.
  for (const std::string halo : {"", " --mes-halo-planes 2"}) {
    const auto serial = (tmp / "serial.json").string();
    ASSERT_EQ(runShell(shellQuote(VOXPACK_BINARY) + args + halo + " -o " + shellQuote(serial)), 0);
    const json ref = values(readJsonFile(serial));
    EXPECT_EQ(ref["streamed"]["mes"]["exact"].get<bool>(), halo.empty()) << halo;
    for (int n : {1, 2, 3}) {
      const auto out = (tmp / ("np" + std::to_string(n) + ".json")).string();
      ASSERT_EQ(runShell(mpirun(n) + args + halo + " -o " + shellQuote(out) + " </dev/null"), 0)
          << n << " ranks" << halo;
      const json j = readJsonFile(out);
      EXPECT_EQ(j["streamed"]["ranks"], n);
      EXPECT_EQ(values(j), ref) << n << " ranks" << halo;
    }
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

// mpirun -np 2 and 3 ingest gives the bed of one process: the same indicator and mask, and
// the same provenance but for the timing and the rank count. The slabs go round the ranks
// and rank 0 writes them in order. uint8 grey values are summed as exact counts; float32
// ones send Otsu through its bins pass, also summed.
TEST(Mpi, IngestEqualsOneProcessForTwoAndThreeRanks) {
  TempDir tmp;
  ColumnBed o;
  o.nz = 30;
  const auto bed = (tmp / "bed.h5").string();
  writeBed(bed, sphereColumn(o));
  for (const std::string pixel : {"uint8", "float32"}) {
    const auto grey = (tmp / (pixel + ".nhdr")).string();
    ASSERT_TRUE(rawPhantom(tmp.path(), bed, pixel,
                           "--modality xmt --snr 8 --blur-mm 0.2 --seed 3 --pixel-type " + pixel));
    const std::string args = " --quiet --threads 1 ingest " + shellQuote(grey) +
                             " --threshold otsu --column 2.7,2.9,2.4 --slab-voxels 3 -o ";
    const auto serial = (tmp / (pixel + "_serial.h5")).string();
    ASSERT_EQ(runShell(shellQuote(VOXPACK_BINARY) + args + shellQuote(serial)), 0) << pixel;
    const Bed ref = readBed(serial);
    for (int n : {2, 3}) {
      const auto out = (tmp / (pixel + "_np" + std::to_string(n) + ".h5")).string();
      ASSERT_EQ(runShell(mpirun(n) + args + shellQuote(out) + " </dev/null"), 0)
          << pixel << ", " << n << " ranks";
      const Bed b = readBed(out);
      EXPECT_EQ(b.provenance["ingest"]["streamed"]["ranks"], n);
      EXPECT_EQ(b.provenance["ingest"]["streamed"]["slabs"], 10);
      EXPECT_EQ(b.indicator.values(), ref.indicator.values()) << pixel << ", " << n << " ranks";
      ASSERT_TRUE(b.mask && ref.mask);
      EXPECT_EQ(b.mask->values(), ref.mask->values());
      EXPECT_EQ(runlessProvenance(b.provenance), runlessProvenance(ref.provenance))
          << pixel << ", " << n;
    }
  }
  // What has no streamed path (here watershed labels, a flood over the whole image) is
  // refused under mpirun with exit 2, and no bed appears.
  const auto none = (tmp / "none.h5").string();
  EXPECT_EQ(runShell(mpirun(2) + " --quiet ingest " + shellQuote((tmp / "uint8.nhdr").string()) +
                     " --labels -o " + shellQuote(none) + " </dev/null 2>/dev/null"),
            2);
  EXPECT_FALSE(std::filesystem::exists(none));
}

// The volume threshold under mpirun (docs/scale.md, "The volume threshold, streamed"): every
// rank analyses the same sample slab; the per-plane sums come each from one rank and the
// counts (uint16: exact values; float32: fine bins) are integers, so 2 and 3 ranks cut at
// the threshold of one process and write its bed. The column given, and fitted (each column
// slab's circle and wall profiles from one rank, "The column, streamed") with --calibrate.
// An MC bed of spheres d 2 mm under a headspace, imaged as MRI at 10 voxels per d, SNR 10,
// blur 1 voxel.
TEST(Mpi, VolumeThresholdIngestEqualsOneProcess) {
  TempDir tmp;
  const std::string vox = shellQuote(VOXPACK_BINARY);
  const auto bed = (tmp / "bed.h5").string();
  ASSERT_EQ(runShell(vox +
                     " --quiet pack --mode mc --shape sphere:d=2 --container "
                     "cylinder:d=10,h=9 --voxel-size 0.1 --fill-height 8 --seed 1 -o " +
                     shellQuote(bed) + " </dev/null >/dev/null"),
            0);
  for (const std::string pixel : {"uint16", "float32"}) {
    const auto grey = (tmp / (pixel + ".nhdr")).string();
    ASSERT_TRUE(rawPhantom(tmp.path(), bed, pixel,
                           "--modality mri --snr 10 --blur-mm 0.2 --voxel-size 0.2 --seed 15 "
                           "--pixel-type " +
                               pixel));
    // The fitted column with a calibration (rank 0 calibrates on the sample slab it kept).
    for (const std::string column : {"0,0,5", "auto --calibrate 1"}) {
      const std::string args = " --quiet --threads 1 ingest " + shellQuote(grey) +
                               " --void bright --column " + column + " --slab-voxels 4 -o ";
      const auto serial = (tmp / (pixel + "_serial.h5")).string();
      ASSERT_EQ(runShell(vox + args + shellQuote(serial)), 0) << pixel;
      const Bed ref = readBed(serial);
      EXPECT_EQ(ref.provenance["ingest"]["threshold"]["method"], "volume")
          << pixel << ": " << ref.provenance["ingest"]["threshold"].dump();
      if (column != "0,0,5") {
        EXPECT_EQ(ref.provenance["ingest"]["column"]["refined"], true) << pixel;
        EXPECT_NEAR(ref.provenance["ingest"]["column"]["radius_mm"].get<double>(), 5.0, 0.02);
        EXPECT_TRUE(ref.provenance["calibration"]["density_bias"].is_number()) << pixel;
      }
      for (int n : {2, 3}) {
        const auto out = (tmp / (pixel + "_np" + std::to_string(n) + ".h5")).string();
        ASSERT_EQ(runShell(mpirun(n) + args + shellQuote(out) + " </dev/null"), 0)
            << pixel << ", " << column << ", " << n << " ranks";
        const Bed b = readBed(out);
        EXPECT_TRUE(b.indicator.values() == ref.indicator.values())
            << pixel << ", " << column << ", " << n;
        EXPECT_EQ(runlessProvenance(b.provenance), runlessProvenance(ref.provenance))
            << pixel << ", " << column << ", " << n << ": "
            << json::diff(runlessProvenance(ref.provenance), runlessProvenance(b.provenance))
                   .dump();
      }
    }
  }
}
