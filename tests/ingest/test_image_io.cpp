// Readers and writers: every format round-trips values, dims, spacing and origin; the
// reader refuses what it cannot trust.
#include <gtest/gtest.h>

#include <fstream>

#include "cli_runner.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/ingest/image_io.hpp"

using namespace voxpack;
using namespace voxpack::ingest;
using voxpack::test::TempDir;

namespace {

// A small anisotropic volume with distinct integer values (exact in every pixel type).
Grid<float> rampVolume() {
  Lattice l;
  l.dims = {6, 5, 7};
  l.spacingMm = {0.5, 0.3, 0.2};
  l.originMm = {1.0, -2.0, 3.5};
  Grid<float> g(l);
  for (std::size_t n = 0; n < g.size(); ++n) g[n] = static_cast<float>((n * 37) % 251);
  return g;
}

void expectSameValues(const Grid<float>& a, const Grid<float>& b) {
  ASSERT_EQ(a.lattice().dims, b.lattice().dims);
  for (std::size_t n = 0; n < a.size(); ++n) ASSERT_EQ(a[n], b[n]) << "voxel " << n;
}

}  // namespace

TEST(IngestIo, RequiredReadersAreRegistered) {
  const auto names = registeredImageIOs();
  for (const char* want : {"NrrdImageIO", "MetaImageIO", "NiftiImageIO", "TIFFImageIO",
                           "GDCMImageIO", "Bruker2dseqImageIO", "VTKImageIO", "PNGImageIO"})
    EXPECT_NE(std::find(names.begin(), names.end(), want), names.end())
        << want << " missing; registered: " << ::testing::PrintToString(names);
}

TEST(IngestIo, ThreeDFormatsKeepValuesSpacingAndOrigin) {
  TempDir dir;
  const Grid<float> g = rampVolume();
  for (const std::string ext : {"nrrd", "mha", "mhd", "nii.gz", "nii", "vtk"}) {
    for (PixelType t : {PixelType::UInt8, PixelType::UInt16, PixelType::Float32}) {
      const auto path = dir / ("v." + ext);
      writeVolume(path, g, t);
      const Volume v = readVolume(path, {});
      SCOPED_TRACE(ext);
      expectSameValues(g, v.image);
      for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(v.image.lattice().spacingMm[a], g.lattice().spacingMm[a], 1e-6);
        EXPECT_NEAR(v.image.lattice().originMm[a], g.lattice().originMm[a], 1e-5);
      }
      EXPECT_EQ(v.info.source, "file");
    }
  }
}

TEST(IngestIo, WriteLeavesNoTemporaryFiles) {
  TempDir dir;
  writeVolume(dir / "a.mhd", rampVolume(), PixelType::UInt16);
  const auto files = voxpack::test::listDir(dir.path());
  EXPECT_EQ(files.size(), 2u);  // a.mhd and its data file
  for (const auto& f : files) EXPECT_EQ(f.rfind(".voxpack-tmp", 0), std::string::npos) << f;
}

TEST(IngestIo, TiffSeriesInNumericOrderWithVoxelSizeOverride) {
  TempDir dir;
  const Grid<float> g = rampVolume();
  std::filesystem::create_directory(dir / "stack");
  writeSliceSeries(dir / "stack", "slice", "tif", g, PixelType::UInt16);
  // Rename to unpadded numbers so that text order (slice10 < slice2) would be wrong.
  for (int k = 0; k < 6; ++k) {
    char from[32];
    std::snprintf(from, sizeof from, "slice%04d.tif", k);
    std::filesystem::rename(dir / "stack" / from,
                            dir / "stack" / ("s" + std::to_string(k * 5) + ".tif"));
  }
  const Volume v = readVolume(dir / "stack", {.voxelSizeMm = 0.25});
  expectSameValues(g, v.image);
  for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(v.image.lattice().spacingMm[a], 0.25);
  EXPECT_EQ(v.info.source, "slice-series");
  EXPECT_EQ(v.info.files.size(), 6u);
}

TEST(IngestIo, MultipageTiffReadsAsVolume) {
  TempDir dir;
  const Grid<float> g = rampVolume();
  writeVolume(dir / "stack.tif", g, PixelType::UInt8);
  const Volume v = readVolume(dir / "stack.tif", {.voxelSizeMm = 0.1});
  expectSameValues(g, v.image);
}

TEST(IngestIo, DicomSeriesFolder) {
  TempDir dir;
  const Grid<float> g = rampVolume();
  std::filesystem::create_directory(dir / "dicom");
  writeDicomSeries(dir / "dicom", g);
  const Volume v = readVolume(dir / "dicom", {});
  EXPECT_EQ(v.info.source, "dicom-series");
  expectSameValues(g, v.image);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(v.image.lattice().spacingMm[a], g.lattice().spacingMm[a], 1e-4) << a;
    EXPECT_NEAR(v.image.lattice().originMm[a], g.lattice().originMm[a], 1e-4) << a;
  }
}

TEST(IngestIo, NumericOrderUsesTheLastNumber) {
  const auto v = numericOrder({"a/img10.tif", "a/img9.tif", "a/img100.tif", "a/img0.tif"});
  EXPECT_EQ(v[0].filename(), "img0.tif");
  EXPECT_EQ(v[1].filename(), "img9.tif");
  EXPECT_EQ(v[2].filename(), "img10.tif");
  EXPECT_EQ(v[3].filename(), "img100.tif");
}

TEST(IngestIo, RefusesTwoDimensionalImage) {
  TempDir dir;
  Grid<float> g = rampVolume();
  Lattice l = g.lattice();
  l.dims = {1, 5, 7};
  Grid<float> slice(l, 3.0f);
  writeVolume(dir / "flat.nrrd", slice, PixelType::UInt8);
  writeVolume(dir / "flat.png", slice, PixelType::UInt8);
  EXPECT_THROW(readVolume(dir / "flat.nrrd", {}), FormatError);
  EXPECT_THROW(readVolume(dir / "flat.png", {}), FormatError);
}

TEST(IngestIo, RefusesGzipDataWithoutCompressedDataKey) {
  // A .mhd naming a gzip file without `CompressedData = True`: ITK would read the
  // compressed bytes as pixels without complaint (docs/references.md).
  TempDir dir;
  std::ofstream(dir / "v.raw", std::ios::binary) << std::string(4 * 4 * 4, '\x07');
  ASSERT_EQ(voxpack::test::runShell("gzip " + voxpack::test::shellQuote((dir / "v.raw").string())),
            0);
  std::ofstream(dir / "v.mhd") << "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\n"
                                  "ElementType = MET_UCHAR\nElementDataFile = v.raw.gz\n";
  try {
    readVolume(dir / "v.mhd", {});
    FAIL() << "garbage accepted";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("CompressedData"), std::string::npos) << e.what();
  }
}

TEST(IngestIo, RefusesShortRawData) {
  TempDir dir;
  std::ofstream(dir / "v.mhd") << "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\n"
                                  "ElementType = MET_UCHAR\nElementDataFile = v.raw\n";
  std::ofstream(dir / "v.raw") << std::string(40, 'x');
  EXPECT_THROW(readVolume(dir / "v.mhd", {}), FormatError);
}

TEST(IngestIo, MissingAndEmptyInputs) {
  TempDir dir;
  EXPECT_THROW(readVolume(dir / "nothing.nrrd", {}), IoError);
  std::filesystem::create_directory(dir / "empty");
  EXPECT_THROW(readVolume(dir / "empty", {}), IoError);
}
