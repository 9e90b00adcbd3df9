// Streamed ingest (issue 13, docs/scale.md): the bed written slab by slab with tiny
// slabs (--slab-voxels) equals in-memory ingest's byte for byte, for every option set the
// streamed path supports and every input kind it reads by slab; options and inputs
// without a streamed path are refused up front with exit 2 and the estimate.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_runner.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/random.hpp"
#include "voxpack/ingest/image_io.hpp"

namespace voxpack::test {
namespace {

namespace fs = std::filesystem;

// A grey XMT-like volume: overlapping spheres (solid, bright) in air (dark), Gaussian
// noise, and scattered single-voxel specks and holes so the clean-up has work.
std::vector<float> greyVolume(std::int64_t nz, std::int64_t ny, std::int64_t nx, std::uint64_t seed,
                              double noise = 22.0) {
  RandomStream rng(seed, 0);
  std::vector<float> v(static_cast<std::size_t>(nz * ny * nx), 60.0f);
  struct S {
    double x, y, z, r;
  };
  std::vector<S> spheres;
  for (int n = 0; n < 40; ++n)
    spheres.push_back(
        {rng.uniform(0, nx), rng.uniform(0, ny), rng.uniform(0, nz), rng.uniform(2.5, 5.0)});
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        const auto o = static_cast<std::size_t>((k * ny + j) * nx + i);
        for (const S& s : spheres) {
          const double dx = i - s.x, dy = j - s.y, dz = k - s.z;
          if (dx * dx + dy * dy + dz * dz < s.r * s.r) v[o] = 180.0f;
        }
        if (rng.uniform() < 0.004) v[o] = v[o] > 100.0f ? 30.0f : 220.0f;  // speck or hole
        v[o] = static_cast<float>(std::clamp(std::round(v[o] + noise * rng.normal()), 0.0, 255.0));
      }
  return v;
}

void putBytes(std::ofstream& f, const std::vector<float>& v, const std::string& type, bool big) {
  for (float x : v) {
    unsigned char b[8];
    std::size_t n = 0;
    if (type == "uint8") {
      b[0] = static_cast<std::uint8_t>(x);
      n = 1;
    } else if (type == "uint16") {
      const auto u = static_cast<std::uint16_t>(x * 200.0f);  // spread over 16 bits
      std::memcpy(b, &u, 2);
      n = 2;
    } else {
      const float g = x * 0.01f - 0.3f;  // non-integer grey values
      std::memcpy(b, &g, 4);
      n = 4;
    }
    if (big) std::reverse(b, b + n);
    f.write(reinterpret_cast<const char*>(b), static_cast<std::streamsize>(n));
  }
}

struct Dims {
  std::int64_t nz = 36, ny = 30, nx = 32;
};

// Attached raw NRRD (or detached .nhdr + .raw).
fs::path writeNrrd(const fs::path& dir, const std::string& name, const Dims& d,
                   const std::vector<float>& v, const std::string& type = "uint8", bool big = false,
                   bool detached = false) {
  const fs::path p = dir / (name + (detached ? ".nhdr" : ".nrrd"));
  std::ofstream f(p, std::ios::binary);
  f << "NRRD0004\n# test volume\ntype: " << type << "\ndimension: 3\nsizes: " << d.nx << " " << d.ny
    << " " << d.nz << "\nspacings: 0.2 0.2 0.25\n";
  if (type != "uint8") f << "endian: " << (big ? "big" : "little") << "\n";
  f << "encoding: raw\n";
  if (detached) {
    f << "data file: " << name << ".raw\n\n";
    std::ofstream r(dir / (name + ".raw"), std::ios::binary);
    putBytes(r, v, type, big);
  } else {
    f << "\n";
    putBytes(f, v, type, big);
  }
  return p;
}

fs::path writeMha(const fs::path& dir, const std::string& name, const Dims& d,
                  const std::vector<float>& v, const std::string& type, bool big) {
  const fs::path p = dir / (name + ".mha");
  std::ofstream f(p, std::ios::binary);
  f << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = "
    << (big ? "True" : "False") << "\nCompressedData = False\nElementSpacing = 0.2 0.2 0.25\n"
    << "DimSize = " << d.nx << " " << d.ny << " " << d.nz << "\nElementType = "
    << (type == "uint8"    ? "MET_UCHAR"
        : type == "uint16" ? "MET_USHORT"
                           : "MET_FLOAT")
    << "\nElementDataFile = LOCAL\n";
  putBytes(f, v, type, big);
  return p;
}

struct IngestRun {
  CliResult cli;
  Bed bed;
  nlohmann::json report;
};

IngestRun runIngest(const fs::path& in, const fs::path& out, std::vector<std::string> opts) {
  std::vector<std::string> args = {"--quiet", "ingest", in.string(), "-o", out.string(), "--json"};
  args.insert(args.end(), opts.begin(), opts.end());
  IngestRun r;
  r.cli = runVoxpack(args);
  if (r.cli.exitCode != 0) return r;
  r.bed = readBed(out);
  r.report = nlohmann::json::parse(r.cli.out);
  return r;
}

// The two beds agree voxel for voxel, and the report's numbers agree exactly.
void expectSameBed(const IngestRun& mem, const IngestRun& str, const std::string& what) {
  ASSERT_EQ(mem.cli.exitCode, 0) << what << ": " << mem.cli.err;
  ASSERT_EQ(str.cli.exitCode, 0) << what << ": " << str.cli.err;
  ASSERT_TRUE(str.report.contains("streamed")) << what << ": did not stream";
  EXPECT_FALSE(mem.report.contains("streamed")) << what;
  EXPECT_EQ(mem.bed.lattice(), str.bed.lattice()) << what;
  EXPECT_TRUE(mem.bed.indicator.values() == str.bed.indicator.values()) << what;
  ASSERT_EQ(mem.bed.mask.has_value(), str.bed.mask.has_value()) << what;
  if (mem.bed.mask) {
    EXPECT_TRUE(mem.bed.mask->values() == str.bed.mask->values()) << what;
  }
  EXPECT_EQ(mem.report["threshold"]["value"], str.report["threshold"]["value"]) << what;
  EXPECT_EQ(mem.report["cleanup"], str.report["cleanup"]) << what;
  EXPECT_EQ(mem.report["porosity"], str.report["porosity"]) << what;
  // The core region's numbers (report only) agree when in-memory ingest did not fit a
  // blur at the wall of a given column: it then widens the core margin, which the
  // streamed path (no wall-step fit) does not.
  if (mem.report["quality"]["blur_mm"].is_null()) {
    EXPECT_EQ(mem.report["threshold"]["porosity_segmented_region"],
              str.report["threshold"]["porosity_segmented_region"])
        << what;
    EXPECT_EQ(mem.report["quality"]["voxels_per_diameter"],
              str.report["quality"]["voxels_per_diameter"])
        << what;
  }
}

// In-memory ingest of a small grey NRRD against streamed ingest with slabs of 1, 4 and 11
// planes (one test per option set keeps each under 20 s).
void expectStreamedEqualsInMemory(const std::vector<std::string>& opts) {
  TempDir tmp;
  const Dims d;
  const fs::path in = writeNrrd(tmp.path(), "grey", d, greyVolume(d.nz, d.ny, d.nx, 3));
  std::string what;
  for (const auto& o : opts) what += o + " ";
  const IngestRun mem = runIngest(in, tmp / "m.h5", opts);
  for (const std::string planes : {"1", "4", "11"}) {
    auto s = opts;
    s.insert(s.end(), {"--slab-voxels", planes});
    const IngestRun str = runIngest(in, tmp / ("s" + planes + ".h5"), s);
    expectSameBed(mem, str, what + "--slab-voxels " + planes);
    if (str.cli.exitCode == 0) {
      EXPECT_EQ(str.report["streamed"]["slab_planes"].get<int>(), std::stoi(planes));
    }
  }
}

// Column axis near the image centre (voxel centres at 0.2 * i mm), radius 2.7 mm.
const std::string kColumn = "3.1,2.9,2.7";

TEST(StreamedIngest, EqualsInMemoryOtsuNoColumn) {
  expectStreamedEqualsInMemory({"--threshold", "otsu", "--column", "none"});
}

TEST(StreamedIngest, EqualsInMemoryOtsuExplicitColumn) {
  expectStreamedEqualsInMemory({"--threshold", "otsu", "--column", kColumn});
}

TEST(StreamedIngest, EqualsInMemoryKMeansMedianBox) {
  expectStreamedEqualsInMemory({"--threshold", "kmeans", "--column", kColumn, "--denoise",
                                "median-box", "--median-radius", "2"});
}

TEST(StreamedIngest, EqualsInMemoryManualThresholdBigCleanup) {
  expectStreamedEqualsInMemory({"--threshold", "120", "--column", "none", "--denoise", "none",
                                "--max-speck-voxels", "20", "--max-hole-voxels", "5"});
}

TEST(StreamedIngest, EqualsInMemoryNoCleanupVoidBright) {
  expectStreamedEqualsInMemory({"--threshold", "otsu", "--column", kColumn, "--max-speck-voxels",
                                "0", "--max-hole-voxels", "0", "--void", "bright"});
}

TEST(StreamedIngest, CleanupHaloIsNeededAndEnough) {
  // Specks of up to 20 voxels spanning slab boundaries: the streamed count equals the
  // whole-volume count, and in-memory really flips some (the test can fail).
  TempDir tmp;
  const Dims d;
  const fs::path in = writeNrrd(tmp.path(), "grey", d, greyVolume(d.nz, d.ny, d.nx, 9, 40.0));
  const std::vector<std::string> opts = {"--threshold",       "otsu", "--column",           "none",
                                         "--denoise",         "none", "--max-speck-voxels", "20",
                                         "--max-hole-voxels", "20"};
  const IngestRun mem = runIngest(in, tmp / "m.h5", opts);
  auto s = opts;
  s.insert(s.end(), {"--slab-voxels", "2"});
  const IngestRun str = runIngest(in, tmp / "s.h5", s);
  expectSameBed(mem, str, "specks 20, holes 20, slabs of 2");
  ASSERT_EQ(mem.cli.exitCode, 0);
  EXPECT_GT(mem.report["cleanup"]["specks_removed"].get<int>(), 10);
  EXPECT_GT(mem.report["cleanup"]["holes_filled"].get<int>(), 10);
}

TEST(StreamedIngest, EveryInputKindReadBySlab) {
  TempDir tmp;
  const Dims d;
  const std::vector<float> v = greyVolume(d.nz, d.ny, d.nx, 4);
  std::vector<fs::path> inputs = {
      writeNrrd(tmp.path(), "u16be", d, v, "uint16", true),
      writeNrrd(tmp.path(), "f32", d, v, "float", false),
      writeNrrd(tmp.path(), "detached", d, v, "uint8", false, true),
      writeMha(tmp.path(), "u16", d, v, "uint16", false),
      writeMha(tmp.path(), "f32be", d, v, "float", true),
  };
  // A folder of TIFF slices written by ingest's own writer.
  Lattice l;
  l.dims = {d.nz, d.ny, d.nx};
  Grid<float> g(l);
  g.values() = v;
  fs::create_directories(tmp / "tiffs");
  voxpack::ingest::writeSliceSeries(tmp / "tiffs", "slice", "tif", g,
                                    voxpack::ingest::PixelType::UInt8);
  inputs.push_back(tmp / "tiffs");
  int n = 0;
  for (const auto& in : inputs) {
    const std::vector<std::string> opts = {"--threshold", "otsu", "--column", "3,3,2.5"};
    const IngestRun mem = runIngest(in, tmp / ("m" + std::to_string(n) + ".h5"), opts);
    auto s = opts;
    s.insert(s.end(), {"--slab-voxels", "5"});
    const IngestRun str = runIngest(in, tmp / ("s" + std::to_string(n) + ".h5"), s);
    expectSameBed(mem, str, in.filename().string());
    ++n;
  }
}

TEST(StreamedIngest, StreamsByItselfPastTheBudget) {
  // 160^3: in memory about 79 MB (8 B/voxel and the process base); under 70 MiB it streams.
  TempDir tmp;
  const Dims d{160, 160, 160};
  const fs::path in = writeNrrd(tmp.path(), "big", d, greyVolume(d.nz, d.ny, d.nx, 5));
  const std::vector<std::string> opts = {"--threshold", "otsu", "--column", "none"};
  const IngestRun mem = runIngest(in, tmp / "m.h5", opts);
  std::vector<std::string> args = {
      "--quiet", "--memory-limit", "70M",  "ingest",   in.string(), "-o", (tmp / "s.h5").string(),
      "--json",  "--threshold",    "otsu", "--column", "none"};
  IngestRun str;
  str.cli = runVoxpack(args);
  ASSERT_EQ(str.cli.exitCode, 0) << str.cli.err;
  str.bed = readBed(tmp / "s.h5");
  str.report = nlohmann::json::parse(str.cli.out);
  expectSameBed(mem, str, "160^3 under --memory-limit 100M");
  EXPECT_GE(str.report["streamed"]["slabs"].get<int>(), 2);
  EXPECT_LE(str.report["streamed"]["memory_estimate_bytes"].get<std::uint64_t>(),
            std::uint64_t{70} << 20);
}

// A NRRD header declaring n^3 uint8 over a sparse data file (no disk is used).
fs::path hugeNrrd(const fs::path& dir, std::int64_t n, const std::string& encoding = "raw") {
  const fs::path p = dir / "huge.nhdr";
  std::ofstream f(p);
  f << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: " << n << " " << n << " " << n
    << "\nspacings: 0.05 0.05 0.05\nencoding: " << encoding << "\ndata file: huge.raw\n\n";
  f.close();
  std::ofstream(dir / "huge.raw").close();
  fs::resize_file(dir / "huge.raw", static_cast<std::uintmax_t>(n * n * n));
  return p;
}

TEST(StreamedIngest, OverBudgetWithoutStreamedPathIsRefusedUpFront) {
  TempDir tmp;
  const fs::path in = hugeNrrd(tmp.path(), 2048);
  struct Case {
    std::vector<std::string> opts;
    std::string says;
  };
  const std::vector<Case> cases = {
      // The default pipeline streams (column fit and volume threshold), but its sample slab
      // of 16 planes of 2048^2 does not fit 1G.
      {{}, "streamed in slabs of 1 planes"},
      {{"--threshold", "otsu", "--column", "none", "--labels"}, "watershed labels"},
      {{"--threshold", "otsu", "--column", "none", "--bias-correction", "n4"}, "N4"},
      {{"--threshold", "otsu", "--column", "none", "--denoise", "curvature"}, "curvature"},
      {{"--threshold", "otsu", "--column", "auto", "--resample", "0.1"}, "--resample"},
  };
  for (const auto& c : cases) {
    std::vector<std::string> args = {"--memory-limit", "1G", "ingest",
                                     in.string(),      "-o", (tmp / "out.h5").string()};
    args.insert(args.end(), c.opts.begin(), c.opts.end());
    const auto t0 = std::chrono::steady_clock::now();
    const CliResult r = runVoxpack(args);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(r.exitCode, 2) << c.says << ": " << r.err;
    EXPECT_LT(s, 5.0) << c.says;
    EXPECT_NE(r.err.find("error:"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("needs about"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("GiB"), std::string::npos) << r.err;  // the estimate (~232 GiB)
    EXPECT_NE(r.err.find("memory limit is 1"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(tmp / "out.h5"));
  }
}

TEST(StreamedIngest, GzipInputPastTheBudgetIsRefused) {
  TempDir tmp;
  const fs::path in = hugeNrrd(tmp.path(), 2048, "gzip");
  const auto t0 = std::chrono::steady_clock::now();
  const CliResult r =
      runVoxpack({"--memory-limit", "1G", "ingest", in.string(), "-o", (tmp / "out.h5").string(),
                  "--threshold", "otsu", "--column", "none"});
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  EXPECT_NE(r.err.find("gzip"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("needs about"), std::string::npos) << r.err;
}

TEST(StreamedIngest, SlabVoxelsWithoutStreamedPathIsAUsageError) {
  TempDir tmp;
  const Dims d;
  const fs::path in = writeNrrd(tmp.path(), "grey", d, greyVolume(d.nz, d.ny, d.nx, 3));
  const CliResult r =
      runVoxpack({"ingest", in.string(), "-o", (tmp / "o.h5").string(), "--slab-voxels", "4",
                  "--labels", "--threshold", "otsu", "--column", "none"});
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_NE(r.err.find("watershed labels"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(tmp / "o.h5"));
}

}  // namespace
}  // namespace voxpack::test
