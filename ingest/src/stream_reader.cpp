// Header-only reads and z-slab reads of imaged volumes for the streamed ingest path.
// The header (lattice, metadata, component type) comes from ITK's ReadImageInformation,
// exactly as readVolume sees it. ITK 5.2's NrrdImageIO cannot stream (it reads the whole
// file through teem), so for raw-encoded NRRD and uncompressed MetaImage the voxel data's
// offset is found from the header text and whole planes are read with pread; slice
// folders are read file by file. Gzip data cannot seek and is refused past the budget.
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "itk_bridge.hpp"
#include "text.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/ingest/stream.hpp"

namespace voxpack::ingest {
namespace fs = std::filesystem;
namespace {

using text::lower;
using text::trim;

// NRRD type names (the teem spec's synonyms) -> bytes and kind.
bool nrrdType(const std::string& t, int& bytes, char& kind) {
  static const std::map<std::string, std::pair<int, char>> types = {
      {"signed char", {1, 's'}},
      {"int8", {1, 's'}},
      {"int8_t", {1, 's'}},
      {"uchar", {1, 'u'}},
      {"unsigned char", {1, 'u'}},
      {"uint8", {1, 'u'}},
      {"uint8_t", {1, 'u'}},
      {"short", {2, 's'}},
      {"short int", {2, 's'}},
      {"signed short", {2, 's'}},
      {"signed short int", {2, 's'}},
      {"int16", {2, 's'}},
      {"int16_t", {2, 's'}},
      {"ushort", {2, 'u'}},
      {"unsigned short", {2, 'u'}},
      {"unsigned short int", {2, 'u'}},
      {"uint16", {2, 'u'}},
      {"uint16_t", {2, 'u'}},
      {"int", {4, 's'}},
      {"signed int", {4, 's'}},
      {"int32", {4, 's'}},
      {"int32_t", {4, 's'}},
      {"uint", {4, 'u'}},
      {"unsigned int", {4, 'u'}},
      {"uint32", {4, 'u'}},
      {"uint32_t", {4, 'u'}},
      {"longlong", {8, 's'}},
      {"long long", {8, 's'}},
      {"long long int", {8, 's'}},
      {"signed long long", {8, 's'}},
      {"signed long long int", {8, 's'}},
      {"int64", {8, 's'}},
      {"int64_t", {8, 's'}},
      {"ulonglong", {8, 'u'}},
      {"unsigned long long", {8, 'u'}},
      {"unsigned long long int", {8, 'u'}},
      {"uint64", {8, 'u'}},
      {"uint64_t", {8, 'u'}},
      {"float", {4, 'f'}},
      {"double", {8, 'f'}}};
  const auto it = types.find(lower(t));
  if (it == types.end()) return false;
  bytes = it->second.first;
  kind = it->second.second;
  return true;
}

bool metType(const std::string& t, int& bytes, char& kind) {
  static const std::map<std::string, std::pair<int, char>> types = {
      {"MET_CHAR", {1, 's'}},       {"MET_UCHAR", {1, 'u'}}, {"MET_SHORT", {2, 's'}},
      {"MET_USHORT", {2, 'u'}},     {"MET_INT", {4, 's'}},   {"MET_UINT", {4, 'u'}},
      {"MET_LONG", {4, 's'}},       {"MET_ULONG", {4, 'u'}}, {"MET_LONG_LONG", {8, 's'}},
      {"MET_ULONG_LONG", {8, 'u'}}, {"MET_FLOAT", {4, 'f'}}, {"MET_DOUBLE", {8, 'f'}}};
  const auto it = types.find(t);
  if (it == types.end()) return false;
  bytes = it->second.first;
  kind = it->second.second;
  return true;
}

std::uint64_t fileBytes(const fs::path& p) {
  std::error_code ec;
  const auto n = fs::file_size(p, ec);
  if (ec) throw IoError(p.string() + ": cannot read its size");
  return n;
}

// The data location of a NRRD header (attached .nrrd or detached .nhdr).
StreamSource nrrdSource(const fs::path& file, std::uint64_t voxels) {
  StreamSource s;
  std::ifstream in(file, std::ios::binary);
  if (!in) throw IoError(file.string() + ": cannot open");
  std::map<std::string, std::string> kv;
  std::string line;
  std::uint64_t pos = 0;
  bool first = true;
  while (std::getline(in, line)) {
    pos += line.size() + 1;
    if (first) {
      first = false;
      if (line.rfind("NRRD", 0) != 0) {
        s.whyNot = "not a NRRD header";
        return s;
      }
      continue;
    }
    if (trim(line).empty()) break;  // the blank line ends the header
    if (line[0] == '#' || line.find(":=") != std::string::npos) continue;
    const auto c = line.find(':');
    if (c == std::string::npos) continue;
    kv[lower(trim(line.substr(0, c)))] = trim(line.substr(c + 1));
  }
  auto get = [&](std::initializer_list<const char*> keys) -> std::string {
    for (const char* k : keys)
      if (kv.count(k)) return kv[k];
    return {};
  };
  const std::string encoding = lower(get({"encoding"}));
  if (encoding != "raw") {
    s.whyNot = encoding + "-encoded NRRD (only raw encoding can be read by slab)";
    return s;
  }
  if (!nrrdType(get({"type"}), s.componentBytes, s.componentKind)) {
    s.whyNot = "NRRD type '" + get({"type"}) + "'";
    return s;
  }
  s.bigEndian = lower(get({"endian"})) == "big";
  if (!get({"line skip", "lineskip"}).empty() && get({"line skip", "lineskip"}) != "0") {
    s.whyNot = "NRRD line skip";
    return s;
  }
  const std::string dataFile = get({"data file", "datafile"});
  long long byteSkip = 0;
  if (!get({"byte skip", "byteskip"}).empty())
    byteSkip = std::stoll(get({"byte skip", "byteskip"}));
  const std::uint64_t need = voxels * static_cast<std::uint64_t>(s.componentBytes);
  if (dataFile.empty()) {
    s.dataFile = file;
    s.dataOffset = pos + static_cast<std::uint64_t>(std::max(0LL, byteSkip));
  } else {
    if (dataFile.find(' ') != std::string::npos || lower(dataFile).rfind("list", 0) == 0) {
      s.whyNot = "NRRD with several data files";
      return s;
    }
    s.dataFile =
        fs::path(dataFile).is_relative() ? file.parent_path() / dataFile : fs::path(dataFile);
    s.dataOffset = static_cast<std::uint64_t>(std::max(0LL, byteSkip));
  }
  const std::uint64_t have = fileBytes(s.dataFile);
  if (byteSkip == -1) s.dataOffset = have >= need ? have - need : 0;
  if (have < s.dataOffset + need)
    throw FormatError(file.string() + ": data holds " + std::to_string(have) +
                      " bytes, the header describes " + std::to_string(s.dataOffset + need));
  s.kind = StreamSource::Kind::Raw;
  return s;
}

// The data location of a MetaImage header (.mha with LOCAL data or .mhd + raw file).
StreamSource metaSource(const fs::path& file, std::uint64_t voxels) {
  StreamSource s;
  std::ifstream in(file, std::ios::binary);
  if (!in) throw IoError(file.string() + ": cannot open");
  std::uint64_t pos = 0;
  std::map<std::string, std::string> kv = text::metaImageFields(in, &pos);
  if (lower(kv["compresseddata"]) == "true") {
    s.whyNot = "compressed MetaImage (gzip cannot seek)";
    return s;
  }
  if (!metType(kv["elementtype"], s.componentBytes, s.componentKind)) {
    s.whyNot = "MetaImage element type '" + kv["elementtype"] + "'";
    return s;
  }
  s.bigEndian =
      lower(kv["binarydatabyteordermsb"]) == "true" || lower(kv["elementbyteordermsb"]) == "true";
  const std::string data = kv["elementdatafile"];
  const std::uint64_t need = voxels * static_cast<std::uint64_t>(s.componentBytes);
  long long headerSize = kv.count("headersize") ? std::stoll(kv["headersize"]) : 0;
  if (data == "LOCAL") {
    s.dataFile = file;
    s.dataOffset = pos;
  } else if (data.empty() || data == "LIST" || data.find('%') != std::string::npos ||
             data.find(' ') != std::string::npos) {
    s.whyNot = "MetaImage with several data files";
    return s;
  } else {
    s.dataFile = fs::path(data).is_relative() ? file.parent_path() / data : fs::path(data);
    s.dataOffset = static_cast<std::uint64_t>(std::max(0LL, headerSize));
  }
  const std::uint64_t have = fileBytes(s.dataFile);
  if (headerSize == -1) s.dataOffset = have >= need ? have - need : 0;
  if (have < s.dataOffset + need)
    throw FormatError(file.string() + ": data holds " + std::to_string(have) +
                      " bytes, the header describes " + std::to_string(s.dataOffset + need));
  s.kind = StreamSource::Kind::Raw;
  return s;
}

bool isSliceImageName(const fs::path& p) {
  static const std::vector<std::string> exts = {".tif",  ".tiff", ".png", ".bmp", ".jpg",
                                                ".jpeg", ".dcm",  ".ima", ".gipl"};
  const std::string e = lower(p.extension().string());
  return std::find(exts.begin(), exts.end(), e) != exts.end();
}

std::optional<VolumeHeader> singleFileHeader(const fs::path& file) {
  const bridge::Header h = bridge::readHeader(file.string());
  if (h.metadata.count("voxpack_components"))
    throw FormatError(file.string() + ": has " + h.metadata.at("voxpack_components") +
                      " components per pixel; a scalar (grey) volume is needed");
  if (h.dimensions < 3 || h.size[2] < 2)
    throw FormatError(file.string() + ": is a 2-D image; give a 3-D file or a folder of slices");
  if (h.dimensions > 3 && h.size[3] > 1)
    throw FormatError(file.string() + ": is a " + std::to_string(h.dimensions) +
                      "-D image; only 3-D volumes are read");
  VolumeHeader v;
  v.lattice.dims = {static_cast<std::int64_t>(h.size[2]), static_cast<std::int64_t>(h.size[1]),
                    static_cast<std::int64_t>(h.size[0])};
  v.lattice.spacingMm = {h.spacing[2], h.spacing[1], h.spacing[0]};
  v.lattice.originMm = {h.origin[2], h.origin[1], h.origin[0]};
  v.info.source = file.filename() == "2dseq" ? "bruker-2dseq" : "file";
  v.info.imageIO = h.imageIO;
  v.info.componentType = h.componentType;
  v.info.files = {file.string()};
  v.info.metadata = h.metadata;
  const std::uint64_t voxels = v.lattice.size();
  if (h.dimensions != 3) {
    v.source.whyNot = "a " + std::to_string(h.dimensions) + "-D file";
  } else if (h.imageIO == "NrrdImageIO") {
    v.source = nrrdSource(file, voxels);
  } else if (h.imageIO == "MetaImageIO") {
    v.source = metaSource(file, voxels);
  } else {
    v.source.whyNot = h.imageIO +
                      " files cannot be read by slab (NRRD raw, MetaImage or a "
                      "folder of slices can)";
  }
  return v;
}

}  // namespace

std::optional<VolumeHeader> readVolumeHeader(const fs::path& input, const ReadOptions& options) {
  if (options.voxelSizeMm < 0.0 || !std::isfinite(options.voxelSizeMm))
    throw UsageError("--voxel-size must be a positive length in mm");
  std::error_code ec;
  if (!fs::exists(input, ec)) throw IoError(input.string() + ": no such file or folder");
  std::optional<VolumeHeader> v;
  if (!fs::is_directory(input, ec)) {
    v = singleFileHeader(input);
  } else if (fs::exists(input / "2dseq")) {
    v = singleFileHeader(input / "2dseq");
    v->info.source = "bruker-2dseq";
  } else {
    std::vector<fs::path> files, images;
    for (const auto& e : fs::directory_iterator(input, ec))
      if (e.is_regular_file() && e.path().filename().string().front() != '.')
        files.push_back(e.path());
    if (ec) throw IoError(input.string() + ": cannot list the folder");
    if (files.empty()) throw IoError(input.string() + ": the folder is empty");
    for (const auto& f : files)
      if (isSliceImageName(f)) images.push_back(f);
    const fs::path probe = numericOrder(images.empty() ? files : images).front();
    if (bridge::isDicom(probe.string())) return std::nullopt;  // known only once read
    if (images.size() < 2)
      throw FormatError(input.string() + ": the folder holds fewer than two image slices");
    images = numericOrder(std::move(images));
    const bridge::Header first = bridge::readHeader(images.front().string());
    if (first.dimensions > 2 && first.size[2] > 1)
      throw FormatError(images.front().string() +
                        ": is itself a 3-D image; give that file, not the folder");
    v.emplace();
    v->lattice.dims = {static_cast<std::int64_t>(images.size()),
                       static_cast<std::int64_t>(first.size[1]),
                       static_cast<std::int64_t>(first.size[0])};
    // As readVolume: slices carry no z spacing, the in-plane pitch is assumed.
    v->lattice.spacingMm = {first.spacing[0], first.spacing[1], first.spacing[0]};
    v->lattice.originMm = {0.0, first.origin[1], first.origin[0]};
    v->info.source = "slice-series";
    v->info.imageIO = first.imageIO;
    v->info.componentType = first.componentType;
    v->info.metadata = first.metadata;
    v->info.spacingFromFile = false;
    for (const auto& f : images) v->info.files.push_back(f.string());
    v->source.kind = StreamSource::Kind::Slices;
    v->source.slices = images;
  }
  if (options.voxelSizeMm > 0.0) {
    v->lattice.spacingMm = {options.voxelSizeMm, options.voxelSizeMm, options.voxelSizeMm};
    v->info.spacingFromFile = false;
  }
  v->lattice.validate(input.string().c_str());
  return v;
}

Grid<float> readVolumeSlab(const VolumeHeader& h, std::int64_t z0, std::int64_t z1) {
  const Lattice& l = h.lattice;
  if (z0 < 0 || z1 > l.nz() || z0 >= z1) throw InputError("slab planes out of range");
  Lattice sub = l;
  sub.dims[0] = z1 - z0;
  sub.originMm[0] = l.originMm[0] + static_cast<double>(z0) * l.spacingMm[0];
  Grid<float> g(sub);
  const auto plane = static_cast<std::size_t>(l.ny() * l.nx());
  const std::string name = h.info.files.empty() ? std::string("input") : h.info.files.front();
  if (h.source.kind == StreamSource::Kind::Slices) {
    for (std::int64_t k = z0; k < z1; ++k) {
      const fs::path& f = h.source.slices[static_cast<std::size_t>(k)];
      const bridge::Header fh = bridge::readHeader(f.string());
      if (fh.size[0] != static_cast<std::size_t>(l.nx()) ||
          fh.size[1] != static_cast<std::size_t>(l.ny()))
        throw FormatError(f.string() + ": slice size differs from the first slice's");
      bridge::readSlice(f.string(), g.data() + static_cast<std::size_t>(k - z0) * plane, plane);
    }
  } else if (h.source.kind == StreamSource::Kind::Raw) {
    const int fd = ::open(h.source.dataFile.c_str(), O_RDONLY);
    if (fd < 0) throw IoError(h.source.dataFile.string() + ": cannot open");
    const auto b = static_cast<std::size_t>(h.source.componentBytes);
    std::vector<unsigned char> buf(plane * b);
    try {
      for (std::int64_t k = z0; k < z1; ++k) {
        std::size_t done = 0;
        const std::uint64_t at = h.source.dataOffset + static_cast<std::uint64_t>(k) * plane * b;
        while (done < buf.size()) {
          const ssize_t n =
              ::pread(fd, buf.data() + done, buf.size() - done, static_cast<off_t>(at + done));
          if (n <= 0)
            throw IoError(h.source.dataFile.string() + ": short read at plane " +
                          std::to_string(k));
          done += static_cast<std::size_t>(n);
        }
        const bool swap = b > 1 && h.source.bigEndian;  // this host is little-endian
        if (swap)
          for (std::size_t p = 0; p < plane; ++p) std::reverse(&buf[p * b], &buf[p * b] + b);
        float* dst = g.data() + static_cast<std::size_t>(k - z0) * plane;
        const unsigned char* src = buf.data();
        // The same static_cast ITK's ConvertPixelBuffer applies to scalar components.
        auto convert = [&](auto tag) {
          using T = decltype(tag);
          for (std::size_t p = 0; p < plane; ++p) {
            T v;
            std::memcpy(&v, src + p * b, sizeof(T));
            dst[p] = static_cast<float>(v);
          }
        };
        const char kind = h.source.componentKind;
        if (kind == 'f') {
          if (b == 4)
            convert(float{});
          else
            convert(double{});
        } else if (kind == 'u') {
          if (b == 1)
            convert(std::uint8_t{});
          else if (b == 2)
            convert(std::uint16_t{});
          else if (b == 4)
            convert(std::uint32_t{});
          else
            convert(std::uint64_t{});
        } else {
          if (b == 1)
            convert(std::int8_t{});
          else if (b == 2)
            convert(std::int16_t{});
          else if (b == 4)
            convert(std::int32_t{});
          else
            convert(std::int64_t{});
        }
      }
    } catch (...) {
      ::close(fd);
      throw;
    }
    ::close(fd);
  } else {
    throw InputError(name + ": cannot be read by slab: " + h.source.whyNot);
  }
  for (float x : g.values())
    if (!std::isfinite(x)) throw FormatError(name + ": holds NaN or infinite values");
  return g;
}

}  // namespace voxpack::ingest
