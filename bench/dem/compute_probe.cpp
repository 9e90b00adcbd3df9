// The machine's own two-thread efficiency at this moment: the time of a fixed arithmetic
// load on one thread over its time on each of two threads at once (1 = the two cores run as
// fast as one). No memory traffic, so it separates a host that slows both vCPUs from a
// program that slows itself (bench/dem/threads_modes.sh, docs/dem.md "Threads").
//   g++ -O3 -march=x86-64-v3 -fopenmp compute_probe.cpp -o compute_probe; compute_probe [N]
#include <omp.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

namespace {

// 64 independent multiply-add chains: enough to keep the vector units busy (throughput-bound,
// so a shared or throttled core shows).
double work(long n, double seed) {
  double a[64];
  for (int k = 0; k < 64; ++k) a[k] = seed + k;
  for (long i = 0; i < n; ++i)
    for (int k = 0; k < 64; ++k) a[k] = a[k] * 0.999999 + 1e-7;
  double s = 0;
  for (int k = 0; k < 64; ++k) s += a[k];
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  const long n = argc > 1 ? std::atol(argv[1]) : 400000000;
  volatile double sink = 0;
  const auto t0 = std::chrono::steady_clock::now();
  sink = sink + work(n, 1.0);
  const auto t1 = std::chrono::steady_clock::now();
#pragma omp parallel num_threads(2)
  {
    const double r = work(n, 1.0 + omp_get_thread_num());
#pragma omp atomic
    sink += r;
  }
  const auto t2 = std::chrono::steady_clock::now();
  const double one = std::chrono::duration<double>(t1 - t0).count();
  const double two = std::chrono::duration<double>(t2 - t1).count();
  std::printf("{\"one_thread_s\": %.4f, \"two_threads_s\": %.4f, \"efficiency\": %.4f}\n", one, two,
              one / two);
}
