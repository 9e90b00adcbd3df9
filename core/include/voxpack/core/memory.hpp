#pragma once
/// \file memory.hpp
/// The memory budget every command works within (`--memory-limit SIZE`): estimates are
/// made before allocating, and work past the limit streams or is refused up front.

#include <cstdint>
#include <string>

namespace voxpack {

/// A memory limit in bytes, passed to algorithms as a parameter.
struct MemoryBudget {
  std::uint64_t limitBytes = 0;  ///< 0 = no limit
  /// True when `bytes` fits (always true with no limit).
  bool fits(std::uint64_t bytes) const { return limitBytes == 0 || bytes <= limitBytes; }
};

/// Memory available now (MemAvailable of /proc/meminfo; 0 when unknown).
std::uint64_t availableMemoryBytes();

/// The default budget: 75 % of the memory available now.
MemoryBudget defaultMemoryBudget();

/// Parses "512M", "8G", "1.5G", "4096" (bytes), "2T"; K/M/G/T are powers of 1024, an
/// optional trailing "B"/"iB" is accepted. Throws UsageError naming `option`.
std::uint64_t parseMemorySize(const std::string& text, const std::string& option = "--memory-limit");

/// "1.25 GiB"-style text for messages.
std::string formatBytes(std::uint64_t bytes);

/// Throws ResourceError "WHAT needs about EST but the memory limit is LIMIT (--memory-limit)"
/// when `estimateBytes` does not fit in `budget`.
void requireWithinBudget(std::uint64_t estimateBytes, const MemoryBudget& budget,
                         const std::string& what);

/// a*b*c... without wrapping: throws FormatError naming `what` on overflow of 2^63.
std::uint64_t checkedProduct(std::initializer_list<std::uint64_t> factors, const std::string& what);

}  // namespace voxpack
