// A folder of baseline TIFF slices (8-bit grey, uncompressed, one strip), written by hand:
// the format needs a 12-entry header and nothing else, and ITK stays inside ingest/.
// Calibration follows ImageJ: X/YResolution = pixels per unit, ResolutionUnit = none, and
// the ImageDescription "ImageJ=...\nunit=mm\nspacing=SZ\n" that Fiji reads for the unit
// and the slice spacing (ImageJ's TiffDecoder/FileOpener).
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>

#include "voxpack/core/errors.hpp"
#include "voxpack/export/formats.hpp"

namespace voxpack::exporter {
namespace fs = std::filesystem;
namespace {

void put16(std::vector<std::uint8_t>& b, std::size_t at, std::uint16_t v) {
  b[at] = static_cast<std::uint8_t>(v & 0xff);
  b[at + 1] = static_cast<std::uint8_t>(v >> 8);
}
void put32(std::vector<std::uint8_t>& b, std::size_t at, std::uint32_t v) {
  for (int s = 0; s < 4; ++s) b[at + s] = static_cast<std::uint8_t>((v >> (8 * s)) & 0xff);
}

// Pixels per mm as a TIFF rational num/den with num < 2^32.
std::pair<std::uint32_t, std::uint32_t> rational(double spacingMm) {
  const double ppmm = 1.0 / spacingMm;
  std::uint32_t den = 1000000;
  while (den > 1 && ppmm * den > 4.0e9) den /= 10;
  const double num = std::max(1.0, std::round(ppmm * den));
  return {static_cast<std::uint32_t>(std::min(num, 4.0e9)), den};
}

std::vector<std::uint8_t> tiffHeader(std::uint32_t width, std::uint32_t height, double sx,
                                     double sy, double sz) {
  char desc[160];
  std::snprintf(desc, sizeof desc, "ImageJ=1.11a\nunit=mm\nspacing=%.12g\n", sz);
  const std::size_t descLen = std::strlen(desc) + 1;
  const int entries = 13;
  const std::size_t ifd = 8, ifdSize = 2 + 12 * entries + 4;
  const std::size_t xres = ifd + ifdSize, yres = xres + 8, text = yres + 8;
  const std::size_t pixels = text + descLen;
  std::vector<std::uint8_t> b(pixels, 0);
  b[0] = 'I';
  b[1] = 'I';
  put16(b, 2, 42);
  put32(b, 4, static_cast<std::uint32_t>(ifd));
  put16(b, ifd, entries);
  std::size_t at = ifd + 2;
  auto entry = [&](std::uint16_t tag, std::uint16_t type, std::uint32_t count,
                   std::uint32_t value) {
    put16(b, at, tag);
    put16(b, at + 2, type);
    put32(b, at + 4, count);
    if (type == 3 && count == 1)
      put16(b, at + 8, static_cast<std::uint16_t>(value));
    else
      put32(b, at + 8, value);
    at += 12;
  };
  const std::uint16_t SHORT = 3, LONG = 4, RATIONAL = 5, ASCII = 2;
  entry(256, LONG, 1, width);
  entry(257, LONG, 1, height);
  entry(258, SHORT, 1, 8);
  entry(259, SHORT, 1, 1);  // no compression
  entry(262, SHORT, 1, 1);  // BlackIsZero
  entry(270, ASCII, static_cast<std::uint32_t>(descLen), static_cast<std::uint32_t>(text));
  entry(273, LONG, 1, static_cast<std::uint32_t>(pixels));
  entry(277, SHORT, 1, 1);
  entry(278, LONG, 1, height);
  entry(279, LONG, 1, width * height);
  entry(282, RATIONAL, 1, static_cast<std::uint32_t>(xres));
  entry(283, RATIONAL, 1, static_cast<std::uint32_t>(yres));
  entry(296, SHORT, 1, 1);  // no absolute unit (ImageJ keeps the unit in the description)
  put32(b, at, 0);          // no next IFD
  const auto rx = rational(sx), ry = rational(sy);
  put32(b, xres, rx.first);
  put32(b, xres + 4, rx.second);
  put32(b, yres, ry.first);
  put32(b, yres + 4, ry.second);
  std::memcpy(b.data() + text, desc, descLen);
  return b;
}

bool isSliceName(const fs::path& p) {
  const std::string n = p.filename().string();
  return n.rfind("slice_", 0) == 0 && p.extension() == ".tif";
}

}  // namespace

void writeTiffStack(const Grid<std::uint8_t>& indicator, const fs::path& dir, Progress& progress) {
  const Lattice& l = indicator.lattice();
  if (l.nx() > 65535 || l.ny() > 65535)
    throw InputError(dir.string() + ": slices larger than 65535 pixels are not written");
  std::error_code ec;
  const fs::path target = fs::absolute(dir);
  if (fs::exists(target, ec)) {
    if (!fs::is_directory(target, ec))
      throw UsageError(dir.string() + ": exists and is not a folder");
    for (const auto& e : fs::directory_iterator(target))
      if (!isSliceName(e.path()))
        throw UsageError(dir.string() + ": folder holds other files than slice_*.tif (" +
                         e.path().filename().string() + "); choose a new folder");
  }
  const fs::path parent = target.parent_path();
  if (!fs::is_directory(parent, ec))
    throw IoError(dir.string() + ": the parent folder does not exist");
  std::random_device rd;
  const fs::path tmp =
      parent / (".voxpack-tmp-" + std::to_string(getpid()) + "-" + std::to_string(rd()));
  fs::create_directory(tmp, ec);
  if (ec) throw IoError(tmp.string() + ": cannot create (" + ec.message() + ")");
  struct Cleanup {
    fs::path p;
    bool keep = false;
    ~Cleanup() {
      std::error_code e;
      if (!keep) fs::remove_all(p, e);
    }
  } cleanup{tmp};
  const auto nx = static_cast<std::uint32_t>(l.nx()), ny = static_cast<std::uint32_t>(l.ny());
  const std::vector<std::uint8_t> header =
      tiffHeader(nx, ny, l.spacingMm[2], l.spacingMm[1], l.spacingMm[0]);
  std::vector<char> row(static_cast<std::size_t>(nx) * ny);
  for (std::int64_t k = 0; k < l.nz(); ++k) {
    if (progress.cancelled()) throw Cancelled("export cancelled");
    const std::uint8_t* src = indicator.data() + l.offset(k, 0, 0);
    for (std::size_t n = 0; n < row.size(); ++n) row[n] = static_cast<char>(src[n] ? 255 : 0);
    char name[32];
    std::snprintf(name, sizeof name, "slice_%04lld.tif", static_cast<long long>(k));
    std::ofstream f(tmp / name, std::ios::binary);
    f.write(reinterpret_cast<const char*>(header.data()),
            static_cast<std::streamsize>(header.size()));
    f.write(row.data(), static_cast<std::streamsize>(row.size()));
    if (!f) throw IoError((tmp / name).string() + ": write failed");
    progress.report("tiff", static_cast<double>(k + 1) / static_cast<double>(l.nz()));
  }
  // Swap the finished folder in; an old stack of slices moves aside first.
  if (fs::exists(target, ec)) {
    const fs::path old = tmp.string() + "-old";
    fs::rename(target, old, ec);
    if (ec) throw IoError(dir.string() + ": cannot replace (" + ec.message() + ")");
    fs::rename(tmp, target, ec);
    if (ec) throw IoError(dir.string() + ": cannot replace (" + ec.message() + ")");
    fs::remove_all(old, ec);
  } else {
    fs::rename(tmp, target, ec);
    if (ec) throw IoError(dir.string() + ": cannot create (" + ec.message() + ")");
  }
  cleanup.keep = true;
}

}  // namespace voxpack::exporter
