// Ingest of degenerate images: constant, all-NaN float, a single slice.
#include <cmath>
#include <limits>

#include "extremes_support.hpp"

using namespace voxpack::test;

namespace {

// A raw NRRD written by hand (the format is a text header + raw little-endian data), so
// this suite does not depend on ITK to make its inputs.
void writeNrrdFloat(const std::filesystem::path& p, int nz, int ny, int nx,
                    const std::vector<float>& v) {
  std::ofstream f(p, std::ios::binary);
  f << "NRRD0004\ntype: float\ndimension: 3\nsizes: " << nx << " " << ny << " " << nz
    << "\nspacings: 0.2 0.2 0.2\nencoding: raw\nendian: little\n\n";
  f.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * 4));
}

CliResult ingest(const TempDir& tmp, const std::filesystem::path& in,
                 const std::vector<std::string>& extra = {}) {
  std::vector<std::string> args = {"ingest", in.string(), "-o", (tmp / "out.h5").string(),
                                   "--quiet"};
  args.insert(args.end(), extra.begin(), extra.end());
  return runVoxpack(args);
}

}  // namespace

TEST(ExtremeIngest, ConstantImageIsRefusedOrOnePhase) {
  TempDir tmp;
  writeNrrdFloat(tmp / "const.nrrd", 16, 16, 16, std::vector<float>(16 * 16 * 16, 100.0f));
  const CliResult r = ingest(tmp, tmp / "const.nrrd", {"--column", "none"});
  expectCleanOutcome(r, "constant image");
  if (r.exitCode == 0) {
    const auto j =
        nlohmann::json::parse(runVoxpack({"info", (tmp / "out.h5").string(), "--json"}).out);
    const double phi = j["porosity"].get<double>();
    EXPECT_TRUE(phi == 0.0 || phi == 1.0) << "a constant image has one phase, got " << phi;
  } else {
    EXPECT_FALSE(std::filesystem::exists(tmp / "out.h5"));
  }
}

TEST(ExtremeIngest, AllNanImageIsRefused) {
  TempDir tmp;
  writeNrrdFloat(tmp / "nan.nrrd", 8, 8, 8,
                 std::vector<float>(512, std::numeric_limits<float>::quiet_NaN()));
  const CliResult r = ingest(tmp, tmp / "nan.nrrd", {"--column", "none"});
  expectRefusal(r, "", "all-NaN image");
  EXPECT_FALSE(std::filesystem::exists(tmp / "out.h5"));
}

TEST(ExtremeIngest, OneSliceIsHandled) {
  TempDir tmp;
  std::vector<float> v(1 * 20 * 20);
  for (int j = 0; j < 20; ++j)
    for (int i = 0; i < 20; ++i) v[static_cast<std::size_t>(j * 20 + i)] = (i < 10) ? 10.f : 200.f;
  writeNrrdFloat(tmp / "slice.nrrd", 1, 20, 20, v);
  const CliResult r = ingest(tmp, tmp / "slice.nrrd", {"--column", "none", "--void", "bright"});
  expectCleanOutcome(r, "one slice");
  if (r.exitCode == 0) {
    const auto j =
        nlohmann::json::parse(runVoxpack({"info", (tmp / "out.h5").string(), "--json"}).out);
    EXPECT_NEAR(j["porosity"].get<double>(), 0.5, 1e-12);
  }
}
