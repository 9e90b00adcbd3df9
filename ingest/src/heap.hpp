#pragma once
// Returning freed heap pages (not public): shared by the in-memory and streamed pipelines.
#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace voxpack::ingest {

/// Returns the heap's free pages to the system where the C library can (glibc's
/// malloc_trim, which also trims the threads' arenas); elsewhere a no-op. A stage that frees
/// many buffers leaves their pages to the heap, and the next stage's allocations land beside
/// them, so the resident peak would be the sum of the two.
inline void releaseFreedHeap() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

}  // namespace voxpack::ingest
