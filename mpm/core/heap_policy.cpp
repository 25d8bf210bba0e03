#include "mpm/core/heap_policy.hpp"

#include <cstdlib>  // with glibc, defines __GLIBC__ (features.h)

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace pfm {

void keep_freed_memory() {
#if defined(__GLIBC__)
  // Setting either limit also stops glibc from adjusting them by itself.
  mallopt(M_TRIM_THRESHOLD, 512 * 1024 * 1024);
  mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);  // the largest glibc accepts on 64-bit systems
  // No block gets a mapping of its own: a large block freed stays in the heap for the next one.
  // (A thread arena that cannot hold a large block passes it to the main heap.)
  mallopt(M_MMAP_MAX, 0);
#endif
}

}  // namespace pfm
