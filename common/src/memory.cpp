#include "vmsim/common/memory.hpp"

#include <cstdlib>  // defines __GLIBC__ where the C library is glibc

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace vmsim {

void keep_freed_memory_in_process() {
#if defined(__GLIBC__)
  // Blocks up to 32 MB (glibc's largest setting on 64-bit) come from the heap, not a fresh
  // mapping each, and the heap's top is given back only beyond 1 GB of free space.
  mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024);
#endif
}

void return_freed_memory_to_system() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

}  // namespace vmsim
