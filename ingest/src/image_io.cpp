// Reading and writing imaged volumes: input kinds (file, slice folder, DICOM folder,
// Bruker 2dseq), checks ITK does not make, atomic writes. ITK itself is behind
// itk_bridge.hpp.
#include "voxpack/ingest/image_io.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

#include "itk_bridge.hpp"
#include "text.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::ingest {
namespace fs = std::filesystem;

namespace {

using text::lower;
using text::trim;

std::size_t metComponentBytes(const std::string& metType) {
  static const std::map<std::string, std::size_t> sizes = {
      {"MET_CHAR", 1},      {"MET_UCHAR", 1},      {"MET_SHORT", 2}, {"MET_USHORT", 2},
      {"MET_INT", 4},       {"MET_UINT", 4},       {"MET_LONG", 4},  {"MET_ULONG", 4},
      {"MET_LONG_LONG", 8}, {"MET_ULONG_LONG", 8}, {"MET_FLOAT", 4}, {"MET_DOUBLE", 8}};
  const auto it = sizes.find(metType);
  return it == sizes.end() ? 0 : it->second;
}

// ITK's MetaImage reader takes a .mhd whose data file is gzip-compressed but whose header
// lacks `CompressedData = True`, and returns garbage without an error (docs/references.md).
// So the data file is checked against the header before ITK sees it: gzip magic bytes,
// and the exact byte count the header implies.
void checkMetaImageHeader(const fs::path& header) {
  std::ifstream in(header, std::ios::binary);
  if (!in) throw IoError(header.string() + ": cannot open");
  std::map<std::string, std::string> kv = text::metaImageFields(in);
  const auto dataIt = kv.find("elementdatafile");
  if (dataIt == kv.end()) throw FormatError(header.string() + ": no ElementDataFile in the header");
  const std::string dataName = dataIt->second;
  // A file list or a printf pattern ("slice%03d.raw 1 40 1") names many data files; ITK
  // 5.2 divides by the pattern's step without checking it (a fuzzed .mha with
  // 'ElementDataFile = LOCANibj 0%5JEleme' died with SIGFPE), and voxpack reads stacks as
  // folders of slices instead, so both are refused.
  if (dataName == "LIST" || dataName.find('%') != std::string::npos)
    throw FormatError(header.string() + ": ElementDataFile '" + dataName +
                      "' names a list or pattern of data files, which voxpack does not read "
                      "(give one data file, LOCAL, or a folder of slices)");
  if (dataName == "LOCAL") return;  // the data follows the header
  fs::path data = dataName;
  if (data.is_relative()) data = header.parent_path() / data;
  std::error_code ec;
  const auto bytes = fs::file_size(data, ec);
  if (ec) throw IoError(header.string() + ": its data file " + data.string() + " cannot be read");
  unsigned char magic[2] = {0, 0};
  {
    std::ifstream d(data, std::ios::binary);
    d.read(reinterpret_cast<char*>(magic), 2);
  }
  if (lower(kv["compresseddata"]) == "true") return;
  if (bytes >= 2 && magic[0] == 0x1f && magic[1] == 0x8b)
    throw FormatError(header.string() + ": data file " + data.filename().string() +
                      " is gzip-compressed but the header lacks 'CompressedData = True'");
  std::size_t expected = metComponentBytes(kv["elementtype"]);
  std::size_t channels = 1;
  if (kv.count("elementnumberofchannels")) {
    std::istringstream c(kv["elementnumberofchannels"]);
    c >> channels;
  }
  std::istringstream dims(kv["dimsize"]);
  std::size_t n = 0, count = 0;
  while (dims >> n) {
    expected *= n;
    ++count;
  }
  expected *= channels;
  if (count > 0 && expected > 0 && bytes != expected)
    throw FormatError(header.string() + ": data file " + data.filename().string() + " holds " +
                      std::to_string(bytes) + " bytes, the header describes " +
                      std::to_string(expected));
}

Grid<float> toGrid(bridge::Raw<float>&& r) {
  Lattice l;
  l.dims = r.dims;
  l.spacingMm = r.spacing;
  l.originMm = r.origin;
  Grid<float> g(l);
  g.values() = std::move(r.data);
  return g;
}

bool isSliceImageName(const fs::path& p) {
  static const std::vector<std::string> exts = {".tif",  ".tiff", ".png", ".bmp", ".jpg",
                                                ".jpeg", ".dcm",  ".ima", ".gipl"};
  const std::string e = lower(p.extension().string());
  return std::find(exts.begin(), exts.end(), e) != exts.end();
}

std::string sizeText(std::size_t nx, std::size_t ny) {
  return std::to_string(nx) + " x " + std::to_string(ny);
}

Lattice headerLattice(const bridge::Header& h, std::size_t slices) {
  Lattice l;
  l.dims = {static_cast<std::int64_t>(slices), static_cast<std::int64_t>(h.size[1]),
            static_cast<std::int64_t>(h.size[0])};
  l.spacingMm = {h.spacing[2], h.spacing[1], h.spacing[0]};
  return l;
}

Volume readSingleFile(const fs::path& file, const ReadOptions& options, Progress& progress) {
  const std::string ext = lower(file.extension().string());
  if (ext == ".mhd" || ext == ".mha") checkMetaImageHeader(file);
  const bridge::Header h = bridge::readHeader(file.string());
  if (h.metadata.count("voxpack_components"))
    throw FormatError(file.string() + ": has " + h.metadata.at("voxpack_components") +
                      " components per pixel; a scalar (grey) volume is needed");
  if (h.dimensions < 3 || h.size[2] < 2)
    throw FormatError(file.string() + ": is a 2-D image (" + sizeText(h.size[0], h.size[1]) +
                      "); give a 3-D file or a folder of slices");
  if (h.dimensions > 3 && h.size[3] > 1)
    throw FormatError(file.string() + ": is a " + std::to_string(h.dimensions) +
                      "-D image; only 3-D volumes are read");
  if (options.beforeAllocate) options.beforeAllocate(headerLattice(h, h.size[2]));
  progress.report("read", 0.0);
  Volume v;
  v.image = toGrid(bridge::readFile(file.string()));
  v.info.source = "file";
  v.info.imageIO = h.imageIO;
  v.info.componentType = h.componentType;
  v.info.files = {file.string()};
  v.info.metadata = h.metadata;
  progress.report("read", 1.0);
  return v;
}

Volume readSliceSeries(const fs::path& dir, std::vector<fs::path> files, const ReadOptions& options,
                       Progress& progress) {
  files = numericOrder(std::move(files));
  const bridge::Header first = bridge::readHeader(files.front().string());
  if (first.dimensions > 2 && first.size[2] > 1)
    throw FormatError(files.front().string() +
                      ": is itself a 3-D image; give that file, not the folder");
  const std::size_t nx = first.size[0], ny = first.size[1];
  Lattice l;
  l.dims = {static_cast<std::int64_t>(files.size()), static_cast<std::int64_t>(ny),
            static_cast<std::int64_t>(nx)};
  // Slices carry no z spacing: assume the in-plane pixel pitch (the user can override).
  l.spacingMm = {first.spacing[0], first.spacing[1], first.spacing[0]};
  l.originMm = {0.0, first.origin[1], first.origin[0]};
  if (options.beforeAllocate) options.beforeAllocate(l);
  Volume v;
  v.image = Grid<float>(l);
  for (std::size_t k = 0; k < files.size(); ++k) {
    const bridge::Header h = k == 0 ? first : bridge::readHeader(files[k].string());
    if (h.dimensions > 2 && h.size[2] > 1)
      throw FormatError(files[k].string() + ": is a 3-D image inside a slice folder");
    if (h.size[0] != nx || h.size[1] != ny)
      throw FormatError(dir.string() + ": slices differ in size: " +
                        files.front().filename().string() + " is " + sizeText(nx, ny) + ", " +
                        files[k].filename().string() + " is " + sizeText(h.size[0], h.size[1]));
    bridge::readSlice(files[k].string(), v.image.data() + k * nx * ny, nx * ny);
    progress.report("read", static_cast<double>(k + 1) / static_cast<double>(files.size()));
  }
  v.info.source = "slice-series";
  v.info.imageIO = first.imageIO;
  v.info.componentType = first.componentType;
  v.info.metadata = first.metadata;
  v.info.spacingFromFile = false;
  for (const auto& f : files) v.info.files.push_back(f.string());
  return v;
}

Volume readFolder(const fs::path& dir, const ReadOptions& options, Progress& progress) {
  if (fs::exists(dir / "2dseq")) {
    Volume v = readSingleFile(dir / "2dseq", options, progress);
    v.info.source = "bruker-2dseq";
    return v;
  }
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file() && e.path().filename().string().front() != '.')
      files.push_back(e.path());
  if (ec) throw IoError(dir.string() + ": cannot list the folder");
  if (files.empty()) throw IoError(dir.string() + ": the folder is empty");
  std::vector<fs::path> images;
  for (const auto& f : files)
    if (isSliceImageName(f)) images.push_back(f);
  // DICOM files often have no extension: probe the first file in numeric order.
  const fs::path probe = numericOrder(images.empty() ? files : images).front();
  if (bridge::isDicom(probe.string())) {
    Volume v;
    std::size_t series = 0;
    v.image =
        toGrid(bridge::readDicomSeries(dir.string(), v.info.files, v.info.componentType, series));
    v.info.source = "dicom-series";
    v.info.imageIO = "GDCMImageIO";
    if (options.beforeAllocate) options.beforeAllocate(v.image.lattice());
    if (series > 1)
      progress.message("warning: " + dir.string() + " holds " + std::to_string(series) +
                       " DICOM series; read the first");
    return v;
  }
  if (images.empty())
    throw FormatError(dir.string() + ": the folder holds no image slices (.tif, .png, ...)");
  if (images.size() < 2)
    throw FormatError(dir.string() + ": the folder holds one slice (a 2-D image)");
  return readSliceSeries(dir, images, options, progress);
}

}  // namespace

PixelType parsePixelType(const std::string& name) {
  if (name == "uint8") return PixelType::UInt8;
  if (name == "uint16") return PixelType::UInt16;
  if (name == "float32" || name == "float") return PixelType::Float32;
  throw UsageError("pixel type '" + name + "': expected uint8, uint16 or float32");
}

std::vector<fs::path> numericOrder(std::vector<fs::path> files) {
  // Key: the last run of digits as a number (slice9 < slice10), then the name.
  auto key = [](const fs::path& p) {
    const std::string s = p.filename().string();
    const auto e = s.find_last_of("0123456789");
    if (e == std::string::npos) return std::make_pair(-1.0L, s);
    auto b = e;
    while (b > 0 && std::isdigit(static_cast<unsigned char>(s[b - 1]))) --b;
    long double v = 0;
    for (auto c = b; c <= e; ++c) v = v * 10 + (s[c] - '0');
    return std::make_pair(v, s);
  };
  std::stable_sort(files.begin(), files.end(),
                   [&](const fs::path& a, const fs::path& b) { return key(a) < key(b); });
  return files;
}

void writeDicomSeries(const fs::path& dir, const Grid<float>& image) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw IoError(dir.string() + ": not a folder");
  bridge::Raw<float> raw;
  raw.dims = image.lattice().dims;
  raw.spacing = image.lattice().spacingMm;
  raw.origin = image.lattice().originMm;
  raw.data = image.values();
  bridge::writeDicomSeries(dir.string(), raw);
}

std::vector<std::string> registeredImageIOs() { return bridge::registerFactories(); }

Volume readVolume(const fs::path& input, const ReadOptions& options, Progress& progress) {
  if (options.voxelSizeMm < 0.0 || !std::isfinite(options.voxelSizeMm))
    throw UsageError("--voxel-size must be a positive length in mm");
  std::error_code ec;
  if (!fs::exists(input, ec)) throw IoError(input.string() + ": no such file or folder");
  Volume v;
  if (fs::is_directory(input, ec)) {
    v = readFolder(input, options, progress);
  } else {
    v = readSingleFile(input, options, progress);
    if (input.filename() == "2dseq") v.info.source = "bruker-2dseq";
  }
  if (options.voxelSizeMm > 0.0) {
    Lattice l = v.image.lattice();
    // The first voxel centre stays where the file put it; only the pitch changes.
    l.spacingMm = {options.voxelSizeMm, options.voxelSizeMm, options.voxelSizeMm};
    v.image.setLattice(l);
    v.info.spacingFromFile = false;
  } else if (v.info.source == "slice-series") {
    progress.message("warning: " + input.string() +
                     ": slices carry no z spacing; using the in-plane pixel size " +
                     std::to_string(v.image.lattice().spacingMm[2]) +
                     " mm (pass --voxel-size to set it)");
  }
  for (float x : v.image.values())
    if (!std::isfinite(x)) throw FormatError(input.string() + ": holds NaN or infinite values");
  v.image.lattice().validate(input.string().c_str());
  return v;
}

void writeVolume(const fs::path& path, const Grid<float>& image, PixelType type,
                 const std::map<std::string, std::string>& metadata) {
  const fs::path target = fs::absolute(path);
  const fs::path dir = target.parent_path();
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw IoError(path.string() + ": the output folder does not exist");
  if (!bridge::canWrite(target.string()))
    throw UsageError(path.string() +
                     ": no image writer for this extension (try .nrrd, .mha, "
                     ".nii.gz, .tif)");
  bridge::Raw<float> raw;
  const Lattice& l = image.lattice();
  raw.dims = l.dims;
  raw.spacing = l.spacingMm;
  raw.origin = l.originMm;
  raw.data.resize(image.size());
  const float hi = type == PixelType::UInt8 ? 255.0f : 65535.0f;
  for (std::size_t n = 0; n < image.size(); ++n) {
    const float v = image[n];
    raw.data[n] = type == PixelType::Float32
                      ? v
                      : (std::isfinite(v) ? std::clamp(std::round(v), 0.0f, hi) : 0.0f);
  }
  // Multi-file formats (.mhd + .raw, .hdr + .img) name their data file after the header,
  // so every file is written under its final name into a private folder and moved out,
  // the named target last: no reader ever sees a partial image, and an error leaves none.
  std::random_device rd;
  const fs::path tmp =
      dir / (".voxpack-tmp-" + std::to_string(getpid()) + "-" + std::to_string(rd()));
  fs::create_directory(tmp, ec);
  if (ec) throw IoError(path.string() + ": cannot write into " + dir.string());
  try {
    bridge::write((tmp / target.filename()).string(), raw,
                  type == PixelType::UInt8    ? 0
                  : type == PixelType::UInt16 ? 1
                                              : 2,
                  metadata);
    for (const auto& e : fs::directory_iterator(tmp))
      if (e.path().filename() != target.filename()) fs::rename(e.path(), dir / e.path().filename());
    fs::rename(tmp / target.filename(), target);
    fs::remove_all(tmp, ec);
  } catch (const fs::filesystem_error& e) {
    fs::remove_all(tmp, ec);
    throw IoError(path.string() + ": cannot write: " + e.what());
  } catch (...) {
    fs::remove_all(tmp, ec);
    throw;
  }
}

void writeSliceSeries(const fs::path& dir, const std::string& prefix, const std::string& extension,
                      const Grid<float>& image, PixelType type) {
  const Lattice& l = image.lattice();
  Lattice slice = l;
  slice.dims = {1, l.dims[1], l.dims[2]};
  for (std::int64_t k = 0; k < l.dims[0]; ++k) {
    Grid<float> s(slice);
    const float* src = image.data() + l.offset(k, 0, 0);
    std::copy(src, src + s.size(), s.data());
    char name[32];
    std::snprintf(name, sizeof name, "%04lld", static_cast<long long>(k));
    writeVolume(dir / (prefix + name + "." + extension), s, type);
  }
}

}  // namespace voxpack::ingest
