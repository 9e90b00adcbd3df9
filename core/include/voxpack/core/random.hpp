#pragma once
/// \file random.hpp
/// Seeded random streams. A stream is identified by (seed, streamId); work split over
/// threads draws from streams keyed by the work item (particle, slice...), never by the
/// thread, so results do not depend on the thread count.

#include <cstdint>
#include <limits>

namespace voxpack {

/// SplitMix64 step: a good 64-bit mixer used to derive stream states.
std::uint64_t splitmix64(std::uint64_t& state);

/// xoshiro256** generator seeded from (seed, streamId) through SplitMix64.
class RandomStream {
 public:
  using result_type = std::uint64_t;  ///< for <random> distributions
  /// Stream `streamId` of seed `seed`; distinct ids give independent sequences.
  explicit RandomStream(std::uint64_t seed, std::uint64_t streamId = 0);
  static constexpr result_type min() { return 0; }  ///< UniformRandomBitGenerator
  static constexpr result_type max() { return std::numeric_limits<result_type>::max(); }
  result_type operator()();  ///< next 64 random bits
  /// Uniform double in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>((*this)() >> 11) * 0x1.0p-53; }
  /// Uniform double in [a, b).
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  /// Uniform integer in [0, n) without modulo bias; n > 0.
  std::uint64_t below(std::uint64_t n);
  /// Standard normal deviate (Box-Muller, no cached state so streams stay simple).
  double normal();

 private:
  std::uint64_t s_[4];
};

}  // namespace voxpack
