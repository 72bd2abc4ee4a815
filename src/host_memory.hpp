#pragma once
// How the process takes large blocks of host memory. By default glibc serves an allocation above
// its mmap threshold (128 KB at first, raised as such blocks are freed, to at most 32 MB) with a
// fresh mmap and unmaps it when it is freed, so the next one is fresh pages again: each page faults
// on first touch and the kernel zeroes it. A reorder gathers every particle field into new storage
// and frees the old (permuted_particle_field), so with fields over 32 MB (4.2e6 particles) every
// reorder faulted all of them in anew: at 4.7e6 particles 171-177 ms a reorder, 61-65 ms with the
// freed blocks reused (docs/performance_history.md, "Reused host memory"). Served from the
// heap instead, a freed block is reused by the next allocation that fits, its pages already in
// place; the heap is not trimmed back, so the process keeps the memory it has used at its peak (a
// solver's use comes back to its peak every step or every reorder).
#include <climits>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace mpmflow {

// Large host allocations from the heap, freed blocks kept for reuse: called by the executables at
// their start, before any large allocation. Returns whether the C library took it (glibc: yes;
// elsewhere nothing is changed and it returns false).
inline bool reuse_freed_host_memory() {
#if defined(__GLIBC__)
  const bool no_mmap = mallopt(M_MMAP_MAX, 0) == 1;              // no allocation served by mmap
  const bool no_trim = mallopt(M_TRIM_THRESHOLD, INT_MAX) == 1;  // the heap's free top kept
  return no_mmap && no_trim;
#else
  return false;
#endif
}

}  // namespace mpmflow
