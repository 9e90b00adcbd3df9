#pragma once
/// \file parallel.hpp
/// Threading as a parameter: a thread count that algorithms receive explicitly.

namespace voxpack {

/// Resolves a user thread count: <= 0 means all hardware threads; clamped to >= 1.
int resolveThreads(int requested);

}  // namespace voxpack
