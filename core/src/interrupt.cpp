#include "voxpack/core/interrupt.hpp"

#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstring>

namespace voxpack {
namespace {
// Lock-free atomics are the only objects a signal handler may touch.
std::atomic<int> gSignal{0};

// Only async-signal-safe calls below (write, alarm, _exit).
void writeErr(const char* s) {
  const auto n = ::write(STDERR_FILENO, s, std::strlen(s));
  (void)n;
}

[[noreturn]] void hardExit(int sig) {
  writeErr(sig == SIGINT ? "error: interrupted (signal 2): no clean stop, exiting now\n"
                         : "error: interrupted (signal 15): no clean stop, exiting now\n");
  ::_exit(128 + sig);
}

extern "C" void onSignal(int sig) {
  // A second signal means the user has waited long enough for the clean stop.
  const int first = gSignal.exchange(sig, std::memory_order_relaxed);
  if (first != 0) hardExit(first);
  // Work stuck inside a library call (a corrupt HDF5 heap, a slow ITK filter) never
  // reaches a poll: the alarm ends the process after the grace period, so a single
  // SIGTERM (timeout, a batch scheduler) always ends the command within seconds.
  ::alarm(kInterruptGraceSeconds);
}

extern "C" void onAlarm(int) {
  const int sig = gSignal.load(std::memory_order_relaxed);
  hardExit(sig != 0 ? sig : SIGTERM);
}
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
  struct sigaction al {};
  al.sa_handler = onAlarm;
  sigemptyset(&al.sa_mask);
  al.sa_flags = SA_RESTART;
  sigaction(SIGALRM, &al, nullptr);
}

bool interruptRequested() { return gSignal.load(std::memory_order_relaxed) != 0; }

int interruptSignal() { return gSignal.load(std::memory_order_relaxed); }

}  // namespace voxpack
