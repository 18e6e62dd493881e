// SPDX-License-Identifier: Apache-2.0
#include "allocator.hpp"

#include <cstdlib>
#include <new>

#if KILN_MIMALLOC
#include <mimalloc.h>

// Replacement global operator new (a C++ program may replace it; the executable's definition wins over
// every shared library's). Debian's libmimalloc also exports operator new, but its out-of-memory path
// aborts instead of throwing std::bad_alloc (the library is C and finds no new-handler), so a worker that
// reaches its memory limit would die instead of reporting "out-of-memory" and carrying on. These throw;
// delete stays mimalloc's, which frees what mi_malloc returned.
void* operator new(std::size_t size) {
  if (void* p = mi_malloc(size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  if (void* p = mi_malloc(size)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t size, std::align_val_t align) {
  if (void* p = mi_malloc_aligned(size, static_cast<std::size_t>(align))) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size, std::align_val_t align) {
  if (void* p = mi_malloc_aligned(size, static_cast<std::size_t>(align))) return p;
  throw std::bad_alloc();
}
#endif

namespace kiln {

std::string allocator_description() {
#if KILN_MIMALLOC
  void* probe = std::calloc(1, 64);  // calloc: GCC warns about passing uninitialized bytes
  bool served = mi_is_in_heap_region(probe);
  std::free(probe);
  int v = mi_version();
  std::string version = std::to_string(v / 100) + "." + std::to_string(v / 10 % 10) + "." + std::to_string(v % 10);
  return served ? "mimalloc " + version : "glibc malloc (mimalloc " + version + " linked but not serving malloc)";
#else
  return "glibc malloc";
#endif
}

}  // namespace kiln
