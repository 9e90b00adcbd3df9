// Bed files by hyperslab: the header alone, boxes and z-slabs read back equal the whole
// bed, and a bed written slab by slab equals one written whole.
#include <gtest/gtest.h>

#include "cli_runner.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/random.hpp"

using namespace voxpack;
using voxpack::test::TempDir;

namespace {
Bed randomBed() {
  Bed bed;
  Lattice l = Lattice::isotropic(21, 13, 11, 0.25, Vec3(1, 2, 3));
  l.spacingMm = {0.3, 0.25, 0.2};
  bed.indicator = Grid<std::uint8_t>(l, 1);
  bed.mask = Grid<std::uint8_t>(l, 1);
  bed.labels = Grid<std::uint32_t>(l, 0);
  RandomStream rng(11);
  for (std::size_t n = 0; n < bed.indicator.size(); ++n) {
    bed.indicator[n] = rng.uniform(0, 1) < 0.4 ? 0 : 1;
    (*bed.mask)[n] = rng.uniform(0, 1) < 0.9 ? 1 : 0;
    (*bed.labels)[n] = bed.indicator[n] ? 0 : static_cast<std::uint32_t>(1 + n % 7);
  }
  for (int p = 0; p < 7; ++p) {
    bed.particles.positionMm.emplace_back(p, 1, 2);
    bed.particles.orientation.push_back(Quat::Identity());
    bed.particles.shape.push_back("sphere:d=1");
  }
  bed.provenance = {{"test", "slabs"}};
  return bed;
}
}  // namespace

TEST(BedSlabs, HeaderReadsNoVolumeAndEstimatesTheRead) {
  TempDir tmp;
  const Bed bed = randomBed();
  writeBed(tmp / "b.h5", bed);
  const BedHeader h = readBedHeader(tmp / "b.h5");
  EXPECT_EQ(h.lattice, bed.lattice());
  EXPECT_TRUE(h.hasMask);
  EXPECT_TRUE(h.hasLabels);
  EXPECT_EQ(h.particles, 7u);
  EXPECT_EQ(h.provenance["test"], "slabs");
  EXPECT_EQ(bedMemoryBytes(h), 6 * bed.indicator.size() + particleTableBytes(h));
  EXPECT_THROW(readBed(tmp / "b.h5", MemoryBudget{1000}), ResourceError);
}

TEST(BedSlabs, SlabsAndBoxesEqualTheWholeBed) {
  TempDir tmp;
  const Bed bed = randomBed();
  writeBed(tmp / "b.h5", bed);
  BedSlabReader r(tmp / "b.h5");
  const Lattice& l = bed.lattice();
  for (std::int64_t z0 = 0; z0 < l.nz(); z0 += 4) {
    const std::int64_t z1 = std::min(l.nz(), z0 + 4);
    const auto slab = r.indicatorSlab(z0, z1);
    EXPECT_DOUBLE_EQ(slab.lattice().originMm[0], l.originMm[0] + z0 * l.spacingMm[0]);
    for (std::int64_t k = z0; k < z1; ++k)
      for (std::int64_t j = 0; j < l.ny(); ++j)
        for (std::int64_t i = 0; i < l.nx(); ++i)
          ASSERT_EQ(slab(k - z0, j, i), bed.indicator(k, j, i));
  }
  const VoxelBox box{{3, 2, 5}, {7, 4, 6}};
  const auto m = r.mask(box);
  const auto lab = r.labels(box);
  ASSERT_TRUE(m && lab);
  for (std::int64_t k = 0; k < 7; ++k)
    for (std::int64_t j = 0; j < 4; ++j)
      for (std::int64_t i = 0; i < 6; ++i) {
        ASSERT_EQ((*m)(k, j, i), (*bed.mask)(k + 3, j + 2, i + 5));
        ASSERT_EQ((*lab)(k, j, i), (*bed.labels)(k + 3, j + 2, i + 5));
      }
}

TEST(BedSlabs, WrittenSlabBySlabEqualsWrittenWhole) {
  TempDir tmp;
  const Bed bed = randomBed();
  const Lattice& l = bed.lattice();
  {
    BedSlabWriter w(tmp / "s.h5", l, true, true);
    EXPECT_FALSE(std::filesystem::exists(tmp / "s.h5"));  // appears only at finish()
    for (std::int64_t z0 = 0; z0 < l.nz(); z0 += 5) {
      const std::int64_t z1 = std::min(l.nz(), z0 + 5);
      const VoxelBox box{{z0, 0, 0}, {z1 - z0, l.ny(), l.nx()}};
      Grid<std::uint8_t> ind(subLattice(l, box)), m(ind.lattice());
      Grid<std::uint32_t> lab(ind.lattice());
      for (std::int64_t k = z0; k < z1; ++k)
        for (std::int64_t j = 0; j < l.ny(); ++j)
          for (std::int64_t i = 0; i < l.nx(); ++i) {
            ind(k - z0, j, i) = bed.indicator(k, j, i);
            m(k - z0, j, i) = (*bed.mask)(k, j, i);
            lab(k - z0, j, i) = (*bed.labels)(k, j, i);
          }
      w.writeIndicator(z0, ind);
      w.writeMask(z0, m);
      w.writeLabels(z0, lab);
    }
    w.finish(bed.particles, bed.provenance);
  }
  const Bed back = readBed(tmp / "s.h5");
  EXPECT_EQ(back.indicator.values(), bed.indicator.values());
  EXPECT_EQ(back.mask->values(), bed.mask->values());
  EXPECT_EQ(back.labels->values(), bed.labels->values());
  EXPECT_EQ(back.particles.shape, bed.particles.shape);
  EXPECT_EQ(back.provenance["test"], "slabs");
}

TEST(BedSlabs, AbandonedWriterLeavesNoFile) {
  TempDir tmp;
  { BedSlabWriter w(tmp / "gone.h5", Lattice::isotropic(4, 4, 4, 1.0), false, false); }
  EXPECT_FALSE(std::filesystem::exists(tmp / "gone.h5"));
  EXPECT_TRUE(test::listDir(tmp.path()).empty());
}

// voxpack inflates and unshuffles the chunks itself (core/src/hdf5_guard.cpp): a box that
// crosses chunk edges on every axis (chunks are 16 x 128 x 128) reads back what was
// written, for the uint8 indicator and the shuffled uint32 labels, and so does the whole.
TEST(BedSlabs, BoxesAcrossChunkEdgesEqualWhatWasWritten) {
  TempDir tmp;
  Bed bed;
  const Lattice l = Lattice::isotropic(20, 140, 131, 0.1, Vec3(0, 0, 0));
  bed.indicator = Grid<std::uint8_t>(l, 1);
  bed.labels = Grid<std::uint32_t>(l, 0);
  RandomStream rng(5);
  for (std::size_t n = 0; n < bed.indicator.size(); ++n) {
    bed.indicator[n] = rng.uniform(0, 1) < 0.5 ? 0 : 1;
    (*bed.labels)[n] = static_cast<std::uint32_t>(rng.uniform(0, 1) * 4e9);
  }
  writeBed(tmp / "b.h5", bed);
  BedSlabReader r(tmp / "b.h5");
  const VoxelBox box{{9, 120, 100}, {11, 20, 31}};
  const auto ind = r.indicator(box);
  const auto lab = r.labels(box);
  ASSERT_TRUE(lab);
  for (std::int64_t k = 0; k < 11; ++k)
    for (std::int64_t j = 0; j < 20; ++j)
      for (std::int64_t i = 0; i < 31; ++i) {
        ASSERT_EQ(ind(k, j, i), bed.indicator(k + 9, j + 120, i + 100));
        ASSERT_EQ((*lab)(k, j, i), (*bed.labels)(k + 9, j + 120, i + 100));
      }
  const Bed back = readBed(tmp / "b.h5");
  EXPECT_EQ(back.indicator.values(), bed.indicator.values());
  EXPECT_EQ(back.labels->values(), bed.labels->values());
}
