#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "cli_runner.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/random.hpp"

using namespace voxpack;
using voxpack::test::TempDir;

namespace {

// A bed of non-overlapping labelled spheres on a jittered grid inside a cylinder mask:
// binary fields with the run structure of a real packed bed.
Bed sphereBed(std::int64_t nz, std::int64_t ny, std::int64_t nx, double radiusVox) {
  Bed bed;
  const Lattice l = Lattice::isotropic(nz, ny, nx, 0.2, Vec3(-0.2 * nx / 2, -0.2 * ny / 2, 0));
  bed.indicator = Grid<std::uint8_t>(l, 1);
  bed.mask = Grid<std::uint8_t>(l, 0);
  bed.labels = Grid<std::uint32_t>(l, 0);
  const double R = 0.5 * static_cast<double>(std::min(nx, ny)) - 1;
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        const double dx = i - nx / 2.0 + 0.5, dy = j - ny / 2.0 + 0.5;
        (*bed.mask)(k, j, i) = dx * dx + dy * dy <= R * R;
      }
  RandomStream rng(3);
  const double pitch = 2 * radiusVox + 1;
  std::uint32_t id = 0;
  for (double z = radiusVox; z + radiusVox < nz; z += pitch)
    for (double y = radiusVox; y + radiusVox < ny; y += pitch)
      for (double x = radiusVox; x + radiusVox < nx; x += pitch) {
        const double cx = x + rng.uniform(-0.4, 0.4), cy = y + rng.uniform(-0.4, 0.4),
                     cz = z + rng.uniform(-0.4, 0.4);
        ++id;
        for (auto k = static_cast<std::int64_t>(cz - radiusVox - 1); k <= cz + radiusVox + 1; ++k)
          for (auto j = static_cast<std::int64_t>(cy - radiusVox - 1); j <= cy + radiusVox + 1; ++j)
            for (auto i = static_cast<std::int64_t>(cx - radiusVox - 1); i <= cx + radiusVox + 1; ++i) {
              if (!l.contains(k, j, i)) continue;
              const double d2 = (i - cx) * (i - cx) + (j - cy) * (j - cy) + (k - cz) * (k - cz);
              if (d2 <= radiusVox * radiusVox) {
                bed.indicator(k, j, i) = 0;
                (*bed.labels)(k, j, i) = id;
              }
            }
        bed.particles.positionMm.push_back(l.centerMm(0, 0, 0) + 0.2 * Vec3(cx, cy, cz));
        bed.particles.orientation.push_back(Quat::UnitRandom());
        bed.particles.shape.push_back("sphere:d=" + std::to_string(0.4 * radiusVox));
      }
  bed.provenance = {{"test", "sphereBed"}, {"seed", 3}};
  return bed;
}

}  // namespace

TEST(BedFile, RoundTripLargeBedIsIdenticalAndCompressed) {
  TempDir tmp;
  const Bed bed = sphereBed(300, 200, 200, 9.5);
  const auto path = tmp / "bed.h5";
  writeBed(path, bed);
  const Bed back = readBed(path);
  EXPECT_EQ(back.lattice(), bed.lattice());
  EXPECT_EQ(back.indicator.values(), bed.indicator.values());
  ASSERT_TRUE(back.mask && back.labels);
  EXPECT_EQ(back.mask->values(), bed.mask->values());
  EXPECT_EQ(back.labels->values(), bed.labels->values());
  ASSERT_EQ(back.particles.size(), bed.particles.size());
  for (std::size_t n = 0; n < bed.particles.size(); ++n) {
    EXPECT_EQ(back.particles.positionMm[n], bed.particles.positionMm[n]);
    EXPECT_EQ(back.particles.orientation[n].coeffs(), bed.particles.orientation[n].coeffs());
    EXPECT_EQ(back.particles.shape[n], bed.particles.shape[n]);
  }
  EXPECT_EQ(back.provenance["seed"], 3);
  // Raw size: uint8 indicator + uint8 mask + uint32 labels = 6 bytes per voxel.
  const double raw = 6.0 * static_cast<double>(bed.lattice().size());
  const double onDisk = static_cast<double>(std::filesystem::file_size(path));
  RecordProperty("compression_ratio", std::to_string(onDisk / raw));
  EXPECT_LT(onDisk, raw / 4) << "file " << onDisk << " B vs raw " << raw << " B";
}

TEST(BedFile, WriteLeavesNoTemporaryBehind) {
  TempDir tmp;
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(Lattice::isotropic(1, 1, 1, 1.0), 1);
  writeBed(tmp / "one.h5", bed);
  EXPECT_EQ(voxpack::test::listDir(tmp.path()).size(), 1u);
  const Bed back = readBed(tmp / "one.h5");
  EXPECT_EQ(back.indicator.size(), 1u);
  EXPECT_FALSE(back.mask.has_value());
}

TEST(BedFile, RefusesValuesOtherThanZeroAndOneOnWrite) {
  TempDir tmp;
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(Lattice::isotropic(2, 2, 2, 1.0), 1);
  bed.indicator(1, 1, 1) = 7;
  EXPECT_THROW(writeBed(tmp / "bad.h5", bed), FormatError);
  EXPECT_TRUE(voxpack::test::listDir(tmp.path()).empty());
}

TEST(BedFile, UnwritableDirectoryIsIoError) {
  Bed bed;
  bed.indicator = Grid<std::uint8_t>(Lattice::isotropic(1, 1, 1, 1.0), 1);
  EXPECT_THROW(writeBed("/nonexistent-dir/x.h5", bed), IoError);
}

TEST(BedFile, MissingAndNonHdf5Files) {
  TempDir tmp;
  EXPECT_THROW(readBed(tmp / "nope.h5"), IoError);
  std::ofstream(tmp / "text.h5") << "hello, not hdf5\n";
  EXPECT_THROW(readBed(tmp / "text.h5"), IoError);
}
