#pragma once
// Small text helpers of the header parsers (image_io.cpp, stream_reader.cpp, itk_io.cpp).
#include <cctype>
#include <cstdint>
#include <istream>
#include <map>
#include <string>

namespace voxpack::ingest::text {

/// s in lower case (ASCII).
inline std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

/// s without leading and trailing blanks, tabs and line ends.
inline std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

/// The `key = value` fields of a MetaImage header up to ElementDataFile (its last key),
/// keys in lower case, values trimmed; *headerBytes (if given) gets the bytes read, which
/// is where LOCAL data begins. A header is a few hundred bytes; past 1 MiB (an .mha's
/// voxels) the key is not coming, so no more is read.
inline std::map<std::string, std::string> metaImageFields(std::istream& in,
                                                          std::uint64_t* headerBytes = nullptr) {
  std::map<std::string, std::string> kv;
  std::string line;
  std::uint64_t read = 0;
  while (read < (std::uint64_t{1} << 20) && std::getline(in, line)) {
    read += line.size() + 1;
    if (headerBytes) *headerBytes = read;
    const auto eq = line.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = lower(trim(line.substr(0, eq)));
    kv[key] = trim(line.substr(eq + 1));
    if (key == "elementdatafile") break;
  }
  return kv;
}

}  // namespace voxpack::ingest::text
