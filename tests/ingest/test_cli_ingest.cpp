// `voxpack phantom` and `voxpack ingest` driven as a user would: formats, end to end,
// and every bad input (exit 2, one error line, no output file left behind).
#include <gtest/gtest.h>

#include <fstream>

#include "cli_runner.hpp"
#include "sphere_bed.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/ingest/image_io.hpp"

using namespace voxpack;
using namespace voxpack::ingest;
using namespace voxpack::test;

namespace {

// Two-phase test volume: a dark slab (solid) in a bright (void) box, 16 x 12 x 10.
Grid<float> slabVolume(double spacingMm) {
  Lattice l = Lattice::isotropic(16, 12, 10, spacingMm);
  l.originMm = {0.5, 1.5, -2.0};
  Grid<float> g(l, 200.0f);
  for (std::int64_t k = 5; k < 11; ++k)
    for (std::int64_t j = 0; j < 12; ++j)
      for (std::int64_t i = 0; i < 10; ++i) g(k, j, i) = 20.0f;
  return g;
}

void expectIngested(const std::filesystem::path& bedPath, const Grid<float>& img, double spacing) {
  const Bed bed = readBed(bedPath);
  ASSERT_EQ(bed.lattice().dims, img.lattice().dims);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(bed.lattice().spacingMm[a], spacing, 1e-6);
  for (std::size_t n = 0; n < img.size(); ++n)
    ASSERT_EQ(bed.indicator[n], img[n] > 100.0f ? 1 : 0) << n;
}

void expectRefused(const std::vector<std::string>& args, const std::filesystem::path& out,
                   const std::string& needle) {
  const CliResult r = runVoxpack(args);
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_EQ(countErrorLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out)) << out;
  if (std::filesystem::is_directory(out.parent_path())) {
    for (const auto& f : listDir(out.parent_path()))
      EXPECT_EQ(f.find(".voxpack-tmp"), std::string::npos) << f;
  }
}

}  // namespace

TEST(CliIngest, EachFormatKeepsItsSpacing) {
  TempDir dir;
  const Grid<float> img = slabVolume(0.3);
  for (const std::string ext : {"nrrd", "mha", "nii.gz"}) {
    SCOPED_TRACE(ext);
    const auto in = dir / ("vol." + ext);
    writeVolume(in, img, PixelType::UInt16);
    const auto out = dir / ("vol-" + ext + ".h5");
    const CliResult r = runVoxpack(
        {"-q", "ingest", in.string(), "-o", out.string(), "--void", "bright", "--column", "none"});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    expectIngested(out, img, 0.3);
    const Bed bed = readBed(out);
    EXPECT_NEAR(bed.lattice().originMm[0], 0.5, 1e-5);
    EXPECT_FALSE(bed.mask.has_value());
  }
  // A TIFF series holds no z spacing: --voxel-size gives it.
  std::filesystem::create_directory(dir / "tiff");
  writeSliceSeries(dir / "tiff", "img", "tif", img, PixelType::UInt8);
  const auto out = dir / "tiff.h5";
  const CliResult r = runVoxpack({"-q", "ingest", (dir / "tiff").string(), "-o", out.string(),
                                  "--void", "bright", "--column", "none", "--voxel-size", "0.3"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  expectIngested(out, img, 0.3);
}

TEST(CliIngest, PhantomThenIngestEndToEnd) {
  TempDir dir;
  const Bed truth = makeSphereBed(64, 28.0, 6.0, 0.25, 9);
  writeBed(dir / "bed.h5", truth);
  CliResult r = runVoxpack({"-q", "phantom", (dir / "bed.h5").string(), "--modality", "mri",
                            "--snr", "10", "--blur-mm", "0.25", "--bias", "0.2", "--seed", "3",
                            "-o", (dir / "ph.nrrd").string(), "--pixel-type", "uint16"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const Volume ph = readVolume(dir / "ph.nrrd", {});
  EXPECT_EQ(ph.info.metadata.at("voxpack_void"), "bright");
  EXPECT_EQ(ph.image.lattice(), truth.lattice());
  r = runVoxpack({"ingest", (dir / "ph.nrrd").string(), "-o", (dir / "seg.h5").string(), "--json"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto report = nlohmann::json::parse(r.out);
  EXPECT_EQ(report["threshold"]["void"], "bright");  // from the phantom's header
  EXPECT_TRUE(report["column"]["found"].get<bool>());
  const Bed seg = readBed(dir / "seg.h5");
  ASSERT_TRUE(seg.mask.has_value());
  EXPECT_EQ(seg.lattice(), truth.lattice());
  EXPECT_NEAR(report["column"]["radius_mm"].get<double>(), 28.0 * 0.25, 0.25);
  EXPECT_NEAR(summarize(seg).porosity, summarize(truth).porosity, 0.02);
  const auto& prov = seg.provenance;
  EXPECT_EQ(prov["command"], "ingest");
  EXPECT_TRUE(prov.contains("command_line"));
  EXPECT_TRUE(prov["ingest"]["threshold"].contains("value"));
  EXPECT_EQ(prov["ingest"]["input"], (dir / "ph.nrrd").string());
}

// The two switches of the volume threshold reach the pipeline and its provenance: the
// wall-blur correction off, and the median skipped below a coarseness the bed is under.
TEST(CliIngest, WallBlurAndMedianSwitches) {
  TempDir dir;
  const Bed truth = makeSphereBed(64, 28.0, 6.0, 0.25, 9);
  writeBed(dir / "bed.h5", truth);
  CliResult r = runVoxpack({"-q", "phantom", (dir / "bed.h5").string(), "--modality", "mri",
                            "--snr", "10", "--blur-mm", "0.25", "--seed", "3", "-o",
                            (dir / "ph.nrrd").string(), "--pixel-type", "uint16"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto ingest = [&](std::vector<std::string> extra) {
    std::vector<std::string> args{"ingest", (dir / "ph.nrrd").string(), "-o",
                                  (dir / "seg.h5").string(), "--json"};
    args.insert(args.end(), extra.begin(), extra.end());
    const CliResult res = runVoxpack(args);
    EXPECT_EQ(res.exitCode, 0) << res.err;
    return nlohmann::json::parse(res.out);
  };
  const auto base = ingest({});
  ASSERT_EQ(base["threshold"]["method"], "volume");
  EXPECT_TRUE(base["options"]["wall_blur_correction"].get<bool>());
  EXPECT_TRUE(base["wall_blur_correction"]["applied"].get<bool>());
  const auto off = ingest({"--no-wall-blur-correction", "--median-min-voxels-per-d", "1000"});
  EXPECT_FALSE(off["options"]["wall_blur_correction"].get<bool>());
  EXPECT_FALSE(off["wall_blur_correction"]["applied"].get<bool>());
  EXPECT_DOUBLE_EQ(off["options"]["median_min_voxels_per_d"].get<double>(), 1000.0);
  EXPECT_NE(off["options"]["denoise_note"].get<std::string>().find("median not used"),
            std::string::npos);
  EXPECT_NE(off["porosity"].get<double>(), base["porosity"].get<double>());
  const CliResult bad = runVoxpack({"-q", "ingest", (dir / "ph.nrrd").string(), "-o",
                                    (dir / "bad.h5").string(), "--median-min-voxels-per-d", "-1"});
  EXPECT_EQ(bad.exitCode, 2) << bad.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.h5"));
}

// --volume-region and --column-wall-mm reach the pipeline and its provenance; bad values
// are usage errors.
TEST(CliIngest, VolumeRegionAndColumnWallSwitches) {
  TempDir dir;
  const Bed truth = makeSphereBed(64, 28.0, 6.0, 0.25, 9);
  writeBed(dir / "bed.h5", truth);
  CliResult r =
      runVoxpack({"-q", "phantom", (dir / "bed.h5").string(), "--modality", "xmt", "--snr", "10",
                  "--blur-mm", "0.25", "--seed", "3", "-o", (dir / "ph.nrrd").string()});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto ingest = [&](std::vector<std::string> extra, int code = 0) {
    std::vector<std::string> args{"ingest", (dir / "ph.nrrd").string(), "-o",
                                  (dir / "seg.h5").string(), "--json"};
    args.insert(args.end(), extra.begin(), extra.end());
    const CliResult res = runVoxpack(args);
    EXPECT_EQ(res.exitCode, code) << res.err;
    return code == 0 ? nlohmann::json::parse(res.out) : nlohmann::json();
  };
  const auto base = ingest({});
  EXPECT_TRUE(base["options"]["volume_over_bed_slices"].get<bool>());
  EXPECT_DOUBLE_EQ(base["options"]["column_wall_mm"].get<double>(), 0.0);
  const auto col = ingest({"--volume-region", "column", "--column-wall-mm", "0.5"});
  EXPECT_FALSE(col["options"]["volume_over_bed_slices"].get<bool>());
  EXPECT_TRUE(col["threshold"]["bed_slices"].is_null());
  EXPECT_EQ(col["threshold"]["region"].get<std::string>().find("bed slices"), std::string::npos);
  EXPECT_DOUBLE_EQ(col["options"]["column_wall_mm"].get<double>(), 0.5);
  ASSERT_TRUE(col["column"]["found"].get<bool>());
  ASSERT_TRUE(col["column"]["refined"].get<bool>());
  EXPECT_NEAR(col["column"]["wall_thickness_mm"].get<double>(), 0.5, 1e-9);  // held
  ingest({"--volume-region", "slab"}, 2);
  ingest({"--column-wall-mm", "-1"}, 2);
  // The phase levels: the deep voxels' mean by default, the tail fit on request; both
  // reported per phase with the ball they were read in.
  EXPECT_EQ(base["options"]["phase_level"], "mean");
  const auto& sd = base["phases"]["solid_deep"];
  EXPECT_DOUBLE_EQ(sd["level"].get<double>(), sd["mean"].get<double>());
  EXPECT_DOUBLE_EQ(base["phases"]["solid_level"].get<double>(), sd["level"].get<double>());
  EXPECT_GE(sd["ball_radius_voxels"].get<double>(), 2.0);
  EXPECT_GT(sd["voxels"].get<std::size_t>(), 0u);
  // The bed's slices leave its ends out (a floor's blur reads as solid), so they start
  // after the image's first slice.
  EXPECT_GT(base["threshold"]["bed_slices"]["first"].get<int>(), 0);
  const auto tail = ingest({"--phase-level", "tail"});
  EXPECT_EQ(tail["options"]["phase_level"], "tail");
  EXPECT_NE(tail["phases"]["solid_deep"]["level"].get<double>(),
            tail["phases"]["solid_deep"]["mean"].get<double>());
  ingest({"--phase-level", "median"}, 2);
  // The MRI edge correction's S_V re-read: a threshold in voxels of interface jitter (an XMT
  // image has no edge correction, so nothing is read again).
  EXPECT_DOUBLE_EQ(base["options"]["surface_reread_max_jitter"].get<double>(), 0.3);
  EXPECT_FALSE(base["threshold"]["mean_intensity_porosity"]["surface_reread"].get<bool>());
  const auto never = ingest({"--surface-reread-max-jitter", "0"});
  EXPECT_DOUBLE_EQ(never["options"]["surface_reread_max_jitter"].get<double>(), 0.0);
  ingest({"--surface-reread-max-jitter", "-1"}, 2);
}

TEST(CliIngest, ResampleAndExplicitColumn) {
  TempDir dir;
  const Grid<float> img = slabVolume(0.3);
  writeVolume(dir / "v.nrrd", img, PixelType::Float32);
  const auto out = dir / "r.h5";
  const CliResult r =
      runVoxpack({"-q", "ingest", (dir / "v.nrrd").string(), "-o", out.string(), "--void", "bright",
                  "--resample", "0.6", "--column", "-0.65,3.15,1.0"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const Bed bed = readBed(out);
  EXPECT_EQ(bed.lattice().dims, (std::array<std::int64_t, 3>{8, 6, 5}));
  EXPECT_DOUBLE_EQ(bed.lattice().spacingMm[0], 0.6);
  ASSERT_TRUE(bed.mask.has_value());
}

TEST(CliIngest, BadInputsAreRefusedCleanly) {
  TempDir dir;
  const auto out = dir / "out.h5";
  expectRefused({"ingest", (dir / "missing.nrrd").string(), "-o", out.string()}, out,
                "missing.nrrd");
  std::filesystem::create_directory(dir / "empty");
  expectRefused({"ingest", (dir / "empty").string(), "-o", out.string()}, out, "empty");
  std::ofstream(dir / "corrupt.nrrd") << "NRRD0004\ntype: banana\nsizes: x y\n\n"
                                      << std::string(100, '\x01');
  expectRefused({"ingest", (dir / "corrupt.nrrd").string(), "-o", out.string()}, out,
                "corrupt.nrrd");
  std::ofstream(dir / "short.nrrd") << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 10 10 10\n"
                                       "encoding: raw\n\n"
                                    << std::string(100, '\x01');
  expectRefused({"ingest", (dir / "short.nrrd").string(), "-o", out.string()}, out, "short.nrrd");
  // Slices of different sizes.
  std::filesystem::create_directory(dir / "ragged");
  Grid<float> a(Lattice::isotropic(1, 8, 8, 1.0), 5.0f), b(Lattice::isotropic(1, 9, 8, 1.0), 5.0f);
  writeVolume(dir / "ragged" / "s0.tif", a, PixelType::UInt8);
  writeVolume(dir / "ragged" / "s1.tif", a, PixelType::UInt8);
  writeVolume(dir / "ragged" / "s2.tif", b, PixelType::UInt8);
  expectRefused({"ingest", (dir / "ragged").string(), "-o", out.string()}, out, "differ");
  // A 2-D image.
  writeVolume(dir / "flat.png", a, PixelType::UInt8);
  expectRefused({"ingest", (dir / "flat.png").string(), "-o", out.string()}, out, "2-D");
  // .mhd naming gzip data without CompressedData = True.
  std::ofstream(dir / "v.raw", std::ios::binary) << std::string(4 * 4 * 4, '\x07');
  ASSERT_EQ(runShell("gzip " + shellQuote((dir / "v.raw").string())), 0);
  std::ofstream(dir / "gz.mhd") << "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\n"
                                   "ElementType = MET_UCHAR\nElementDataFile = v.raw.gz\n";
  expectRefused({"ingest", (dir / "gz.mhd").string(), "-o", out.string()}, out, "CompressedData");
  // Bad option values.
  writeVolume(dir / "ok.nrrd", slabVolume(0.3), PixelType::UInt8);
  expectRefused({"ingest", (dir / "ok.nrrd").string(), "-o", out.string(), "--threshold", "abc"},
                out, "--threshold");
  expectRefused({"ingest", (dir / "ok.nrrd").string(), "-o", out.string(), "--column", "1,2"}, out,
                "--column");
  expectRefused({"ingest", (dir / "ok.nrrd").string(), "-o", (dir / "no" / "x.h5").string()},
                dir / "no" / "x.h5", "no");
}

TEST(CliPhantom, BadInputsAreRefusedCleanly) {
  TempDir dir;
  const auto out = dir / "ph.nrrd";
  expectRefused({"phantom", (dir / "missing.h5").string(), "--modality", "mri", "--snr", "10",
                 "--seed", "1", "-o", out.string()},
                out, "missing.h5");
  writeBed(dir / "bed.h5", makeSphereBed(16, 6.0, 2.0, 0.5, 1, 50));
  const auto odd = dir / "ph.unknownext";
  expectRefused({"phantom", (dir / "bed.h5").string(), "--modality", "mri", "--snr", "10", "--seed",
                 "1", "-o", odd.string()},
                odd, "extension");
  expectRefused({"phantom", (dir / "bed.h5").string(), "--modality", "pet", "--snr", "10", "--seed",
                 "1", "-o", out.string()},
                out, "modality");
  expectRefused({"phantom", (dir / "bed.h5").string(), "--modality", "xmt", "--snr", "-1", "--seed",
                 "1", "-o", out.string()},
                out, "snr");
}
