#include "voxpack/core/memory.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

#include "voxpack/core/errors.hpp"

namespace voxpack {

std::uint64_t availableMemoryBytes() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  std::uint64_t value = 0;
  std::string unit;
  while (in >> key >> value >> unit) {
    if (key == "MemAvailable:") return value * 1024ull;
  }
  return 0;
}

MemoryBudget defaultMemoryBudget() {
  const std::uint64_t avail = availableMemoryBytes();
  return MemoryBudget{avail == 0 ? 0 : avail / 4 * 3};
}

std::uint64_t parseMemorySize(const std::string& text, const std::string& option) {
  std::size_t pos = 0;
  double value = 0;
  try {
    value = std::stod(text, &pos);
  } catch (const std::exception&) {
    throw UsageError(option + ": '" + text + "' is not a size (e.g. 512M, 8G)");
  }
  std::string unit = text.substr(pos);
  for (char& c : unit) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (unit.size() >= 2 && unit.substr(unit.size() - 2) == "IB") unit.resize(unit.size() - 2);
  else if (!unit.empty() && unit.back() == 'B') unit.pop_back();
  double scale = 1;
  if (unit == "K") scale = 1024.0;
  else if (unit == "M") scale = 1024.0 * 1024;
  else if (unit == "G") scale = 1024.0 * 1024 * 1024;
  else if (unit == "T") scale = 1024.0 * 1024 * 1024 * 1024;
  else if (!unit.empty())
    throw UsageError(option + ": unknown unit in '" + text + "' (use K, M, G or T)");
  const double bytes = value * scale;
  if (!std::isfinite(bytes) || bytes <= 0 || bytes > 9.2e18)
    throw UsageError(option + ": '" + text + "' must be a positive size below 8 EiB");
  return static_cast<std::uint64_t>(bytes);
}

std::string formatBytes(std::uint64_t bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  double v = static_cast<double>(bytes);
  int u = 0;
  while (v >= 1024.0 && u < 6) {
    v /= 1024.0;
    ++u;
  }
  char buf[64];
  std::snprintf(buf, sizeof buf, u == 0 ? "%.0f %s" : "%.2f %s", v, units[u]);
  return buf;
}

void requireWithinBudget(std::uint64_t estimateBytes, const MemoryBudget& budget,
                         const std::string& what) {
  if (budget.fits(estimateBytes)) return;
  throw ResourceError(what + " needs about " + formatBytes(estimateBytes) +
                      " but the memory limit is " + formatBytes(budget.limitBytes) +
                      " (--memory-limit)");
}

std::uint64_t checkedProduct(std::initializer_list<std::uint64_t> factors,
                             const std::string& what) {
  constexpr std::uint64_t kMax = std::uint64_t{1} << 63;
  std::uint64_t p = 1;
  for (std::uint64_t f : factors) {
    if (f != 0 && p > kMax / f) throw FormatError(what + ": size overflows (product > 2^63)");
    p *= f;
  }
  return p;
}

}  // namespace voxpack
