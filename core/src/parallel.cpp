#include "voxpack/core/parallel.hpp"

#include <thread>

namespace voxpack {

int resolveThreads(int requested) {
  if (requested > 0) return requested;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1 : static_cast<int>(hw);
}

}  // namespace voxpack
