#pragma once
// Private: what every streamed pass shares: unsigned sizes, the planning headroom and the
// z-slabs a rank owns (docs/scale.md).
#include <algorithm>
#include <cstdint>

#include "voxpack/core/communicator.hpp"
#include "voxpack/core/memory.hpp"

namespace voxpack::stats::stream_plan {

/// max(v, 0) as an unsigned size.
inline std::uint64_t u(std::int64_t v) {
  return static_cast<std::uint64_t>(std::max<std::int64_t>(v, 0));
}

/// Slabs are planned with 1/32 (3 %) of the estimate to spare, for what it does not model
/// (HDF5's chunk cache, allocator slack): at 2048³ under 6 GiB the peak RSS came 0.5 %
/// above the estimate (bench/results/scale_big_2048.json).
inline bool fitsWithHeadroom(const MemoryBudget& budget, std::uint64_t bytes) {
  return budget.fits(bytes + bytes / 32);
}

/// Slabs [s T, min((s+1) T, n)) and the contiguous block of them a rank owns: the slab
/// boundaries do not depend on the number of ranks.
struct Slabs {
  std::int64_t planes = 1, count = 0, first = 0, last = 0;  ///< this rank: [first, last)
  /// The slabs of `t` planes over `n` planes, and this rank's block of them.
  Slabs(std::int64_t n, std::int64_t t, const Communicator& comm)
      : planes(std::max<std::int64_t>(1, t)) {
    count = (n + planes - 1) / planes;
    first = count * comm.rank() / comm.size();
    last = count * (comm.rank() + 1) / comm.size();
  }
};

}  // namespace voxpack::stats::stream_plan
