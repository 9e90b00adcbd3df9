#include "voxpack/core/spec.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "voxpack/core/errors.hpp"

namespace voxpack {

double parseDouble(const std::string& text, const char* what) {
  const char* b = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(b, &end);
  if (text.empty() || end == b || *end != '\0' || errno == ERANGE || !std::isfinite(v))
    throw InputError(std::string(what) + ": '" + text + "' is not a finite number");
  return v;
}

ParsedSpec parseSpec(const std::string& text, const char* what) {
  ParsedSpec s;
  s.text = text;
  const auto colon = text.find(':');
  s.name = text.substr(0, colon);
  if (s.name.empty()) throw InputError(std::string(what) + " '" + text + "': missing type name");
  if (colon == std::string::npos) return s;
  std::string rest = text.substr(colon + 1);
  std::size_t pos = 0;
  while (pos <= rest.size()) {
    const auto comma = rest.find(',', pos);
    const std::string item = rest.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
    if (!item.empty()) {
      const auto eq = item.find('=');
      if (eq == std::string::npos) {
        if (s.positional)
          throw InputError(std::string(what) + " '" + text + "': unexpected item '" + item + "'");
        s.positional = item;
      } else {
        const std::string key = item.substr(0, eq);
        if (key.empty())
          throw InputError(std::string(what) + " '" + text + "': empty key in '" + item + "'");
        if (s.values.count(key))
          throw InputError(std::string(what) + " '" + text + "': '" + key + "' given twice");
        s.values[key] = item.substr(eq + 1);
      }
    }
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return s;
}

double ParsedSpec::positive(const std::string& key) const {
  const auto it = values.find(key);
  if (it == values.end())
    throw InputError("'" + text + "': missing size '" + key + "'");
  const double v = parseDouble(it->second, ("'" + text + "' " + key).c_str());
  if (!(v > 0)) throw InputError("'" + text + "': " + key + " must be > 0, got " + it->second);
  return v;
}

double ParsedSpec::number(const std::string& key, double fallback) const {
  const auto it = values.find(key);
  if (it == values.end()) return fallback;
  return parseDouble(it->second, ("'" + text + "' " + key).c_str());
}

void ParsedSpec::allowOnly(const std::vector<std::string>& allowed) const {
  for (const auto& [k, v] : values) {
    bool ok = false;
    for (const auto& a : allowed) ok = ok || a == k;
    if (!ok) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      throw InputError("'" + text + "': unknown key '" + k + "' (expected " + list + ")");
    }
  }
}

std::vector<double> parseNumberList(const std::string& text, std::size_t n, const char* what) {
  std::vector<double> out;
  std::size_t pos = 0;
  while (true) {
    const auto comma = text.find(',', pos);
    out.push_back(parseDouble(text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos), what));
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  if (out.size() != n)
    throw InputError(std::string(what) + ": expected " + std::to_string(n) + " comma-separated numbers, got '" + text + "'");
  return out;
}

}  // namespace voxpack
