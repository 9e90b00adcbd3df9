#pragma once
// Small text helpers of the header parsers (image_io.cpp, stream_reader.cpp, itk_io.cpp).
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <istream>
#include <map>
#include <string>
#include <vector>

namespace voxpack::ingest::text {

/// s in lower case (ASCII).
inline std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

/// s without leading and trailing white space.
inline std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n\f\v");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n\f\v");
  return s.substr(b, e - b + 1);
}

/// One `key = value` line of a MetaImage header, split as MetaIO splits it: the key ends
/// at the first '=' or ':' and at a NUL byte (MetaIO compares keys as C strings), both
/// sides lose their white space, and keys are in lower case.
struct MetaField {
  std::string key, value;
};

/// The fields of a MetaImage header in file order, up to ElementDataFile (its last key);
/// *headerBytes (if given) gets the bytes they span, which is where LOCAL data begins. Only
/// the first 1 MiB is read: a header is a few hundred bytes and past it come an .mha's
/// voxels, so a line without an end cannot make this read the whole file.
inline std::vector<MetaField> metaImageFieldList(std::istream& in,
                                                 std::uint64_t* headerBytes = nullptr) {
  std::string buf(std::size_t{1} << 20, '\0');
  in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
  buf.resize(static_cast<std::size_t>(std::max<std::streamsize>(0, in.gcount())));
  std::vector<MetaField> fields;
  std::size_t at = 0;
  while (at < buf.size()) {
    const std::size_t nl = buf.find('\n', at);
    const std::string line = buf.substr(at, nl == std::string::npos ? std::string::npos : nl - at);
    at = nl == std::string::npos ? buf.size() : nl + 1;
    if (headerBytes) *headerBytes = at;
    const auto sep = line.find_first_of("=:");
    if (sep == std::string::npos) continue;
    const std::string key = line.substr(0, sep);
    fields.push_back({lower(trim(key.substr(0, key.find('\0')))), trim(line.substr(sep + 1))});
    if (fields.back().key == "elementdatafile") break;
  }
  return fields;
}

/// The same fields as a map (a repeated key keeps its last value).
inline std::map<std::string, std::string> metaImageFields(std::istream& in,
                                                          std::uint64_t* headerBytes = nullptr) {
  std::map<std::string, std::string> kv;
  for (auto& f : metaImageFieldList(in, headerBytes)) kv[f.key] = std::move(f.value);
  return kv;
}

}  // namespace voxpack::ingest::text
