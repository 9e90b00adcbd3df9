#pragma once
/// \file spec.hpp
/// Parsing of "name:key=value,key=value" specs (shapes, containers) and of number lists.

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace voxpack {

/// A parsed "name:k=v,k=v" spec. A bare value without '=' (e.g. a file path in
/// "mesh:part.stl,scale=2") is stored as `positional`.
struct ParsedSpec {
  std::string name;                          ///< text before ':'
  std::optional<std::string> positional;     ///< first item without '='
  std::map<std::string, std::string> values; ///< key -> raw value
  std::string text;                          ///< the original spec, for messages

  /// A required positive finite number (InputError naming the spec otherwise).
  double positive(const std::string& key) const;
  /// An optional number with a default.
  double number(const std::string& key, double fallback) const;
  /// True when key is present.
  bool has(const std::string& key) const { return values.count(key) != 0; }
  /// Throws InputError when a key outside `allowed` is present.
  void allowOnly(const std::vector<std::string>& allowed) const;
};

/// Parses a spec; throws InputError on an empty name or a malformed item.
ParsedSpec parseSpec(const std::string& text, const char* what);

/// Parses "a,b,c" into exactly `n` finite doubles (InputError otherwise).
std::vector<double> parseNumberList(const std::string& text, std::size_t n, const char* what);

/// Parses a finite double (InputError naming `what` otherwise).
double parseDouble(const std::string& text, const char* what);

}  // namespace voxpack
