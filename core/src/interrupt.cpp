#include "voxpack/core/interrupt.hpp"

#include <atomic>
#include <csignal>

namespace voxpack {
namespace {
// Lock-free atomics are the only objects a signal handler may touch.
std::atomic<int> gSignal{0};
extern "C" void onSignal(int sig) { gSignal.store(sig, std::memory_order_relaxed); }
}  // namespace

void installInterruptHandlers() {
  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  // SA_RESTART: a signal during a read or write (HDF5, ITK) must not turn into an EINTR
  // I/O error; the command sees the flag at its next poll and stops cleanly.
  sa.sa_flags = SA_RESTART;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

bool interruptRequested() { return gSignal.load(std::memory_order_relaxed) != 0; }

int interruptSignal() { return gSignal.load(std::memory_order_relaxed); }

}  // namespace voxpack
