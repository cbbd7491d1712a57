// The program's memory policy (docs/design.md, "Memory policy").
//
// A 10⁶-coordinate analysis allocates and frees buffers of tens to hundreds
// of MB thousands of times, and a 1000-coordinate dense one a few dozen n×n
// matrices. With glibc's defaults each large block is a fresh mmap, faulted in
// 4 KiB at a time on every reuse, which on a virtual machine costs
// microseconds per page, and dense kernels on 4 KiB pages miss the TLB. The
// policy, set when main starts (no environment variable, no second execution,
// nothing paid by a small scene):
//
// - glibc's malloc takes every block from its heap, none from a private mmap
//   (M_MMAP_MAX 0), never trims it (M_TRIM_THRESHOLD −1) and grows it 64 MiB at
//   a time (M_TOP_PAD): freed memory is reused without page faults;
// - each time the heap has grown, the new part is advised for transparent huge
//   pages (madvise MADV_HUGEPAGE: a system with THP "madvise", Debian's
//   default, then backs it with 2 MiB pages). glibc does this itself only when
//   its glibc.malloc.hugetlb tunable is set in the environment at start; here
//   the program's malloc, calloc and realloc call glibc's and then look at the
//   heap's end (sbrk(0), a variable read), so the work is one comparison per
//   call and one madvise per 64 MiB of growth.
//
// With MODAL_JEMALLOC the program runs on jemalloc instead, configured the same
// way by malloc_conf. Under the sanitizers nothing is set.

#include "memory_policy.hpp"

#include <cstdlib>  // defines __GLIBC__ on glibc

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define MODAL_PROGRAM_SANITIZED 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define MODAL_PROGRAM_SANITIZED 1
#endif

#if defined(MODAL_JEMALLOC) && !defined(MODAL_PROGRAM_SANITIZED)

extern "C" {
// Read by jemalloc when the process starts.
const char* malloc_conf = "thp:always,metadata_thp:auto,dirty_decay_ms:-1,muzzy_decay_ms:-1";
}
void modal_program::set_memory_policy() {}

#elif defined(__GLIBC__) && !defined(MODAL_PROGRAM_SANITIZED)

#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <cstddef>
#include <cstdint>

extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* block, std::size_t size);
}

namespace {

std::atomic<bool> following{false};
std::atomic<std::uintptr_t> advised_end{0};  // the heap up to here is advised

void follow_heap() noexcept {
  if (!following.load(std::memory_order_relaxed)) return;
  const auto end = reinterpret_cast<std::uintptr_t>(sbrk(0));
  std::uintptr_t advised = advised_end.load(std::memory_order_relaxed);
  if (end <= advised) return;
  if (!advised_end.compare_exchange_strong(advised, end)) return;  // another thread advises this growth
  const std::uintptr_t page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  const std::uintptr_t from = advised & ~(page - 1);
  // Advice only: a kernel without transparent huge pages refuses it, which changes nothing.
  static_cast<void>(madvise(reinterpret_cast<void*>(from), end - from, MADV_HUGEPAGE));
}

}  // namespace

extern "C" void* malloc(std::size_t size) {
  void* block = __libc_malloc(size);
  follow_heap();
  return block;
}

extern "C" void* calloc(std::size_t count, std::size_t size) {
  void* block = __libc_calloc(count, size);
  follow_heap();
  return block;
}

extern "C" void* realloc(void* block, std::size_t size) {
  void* moved = __libc_realloc(block, size);
  follow_heap();
  return moved;
}

void modal_program::set_memory_policy() {
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, -1);  // never
  mallopt(M_TOP_PAD, 64 << 20);
  advised_end.store(reinterpret_cast<std::uintptr_t>(sbrk(0)));
  following.store(true);
}

#else

void modal_program::set_memory_policy() {}

#endif
