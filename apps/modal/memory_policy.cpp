// The program's memory policy (docs/design.md, "Memory policy").
//
// A 10⁶-coordinate analysis allocates and frees buffers of tens to hundreds
// of MB thousands of times, and a 1000-coordinate dense one a few dozen n×n
// matrices. With glibc's defaults each large block is a fresh mmap, faulted in
// 4 KiB at a time on every reuse, which on a virtual machine costs
// microseconds per page. The policy, set when main starts (no second
// execution, nothing paid by a small scene):
//
// - glibc's malloc takes every block from its heap, none from a private mmap
//   (M_MMAP_MAX 0), never trims it (M_TRIM_THRESHOLD −1) and grows it 64 MiB at
//   a time (M_TOP_PAD; under an address-space limit at most 1/64 of it):
//   freed memory is reused without page faults;
// - a block of 1 MiB or more from the main heap has its fresh part (above
//   all the heap handed out before) faulted in by one
//   madvise(MADV_POPULATE_WRITE) instead of a fault per page (not with
//   MODAL_POPULATE=0 in the environment);
// - only with MODAL_HUGE_PAGES=1 in the environment: each time the heap has
//   grown, the new part is advised for transparent huge pages (madvise
//   MADV_HUGEPAGE: a system with THP "madvise", Debian's default, then backs
//   it with 2 MiB pages). The program's malloc, calloc and realloc call
//   glibc's and then look at the heap's end (sbrk(0), a variable read): one
//   comparison per call and one madvise per growth of the heap. Not by
//   default: on a virtual machine whose balloon driver reports freed pages to
//   its host (Firecracker's free page reporting), huge pages made a
//   1000-link chain 1.6–2.0 s against 0.3–0.4 s and a 10⁵-coordinate net
//   11.6–13.3 s against 6.1–8.6 s whenever the host had taken the pages back
//   (seconds after another process freed them), for 15 % where it had not
//   (docs/design.md, "Allocator").
//
// An allocation the system refuses many times in a row (the same size, from
// the same thread) is a library retrying it in a loop that never ends:
// Debian 12's OpenBLAS (0.3.21) asks again and again for its 128 MiB work
// buffer when malloc fails (OpenBLAS issue #5289, fixed in 0.3.30), so under
// an address-space limit (ulimit -v, a batch system's h_vmem) that a run
// reaches, the process spun at full CPU for ever. The program then ends as
// on any lack of memory: the outputs' temporaries removed, "out of memory"
// and exit status 4.
//
// With MODAL_JEMALLOC the program runs on jemalloc instead, configured by
// malloc_conf to keep freed memory (without that guard, and without huge pages). Under the sanitizers nothing is set.

#include "memory_policy.hpp"

#include <modal/pipeline.hpp>
#include <modal/report.hpp>

#include <unistd.h>

#include <cstdlib>  // defines __GLIBC__ on glibc
#include <cstring>

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
const char* malloc_conf = "dirty_decay_ms:-1,muzzy_decay_ms:-1";
}
void modal_program::set_memory_policy() {}

#elif defined(__GLIBC__) && !defined(MODAL_PROGRAM_SANITIZED)

#include <modal/core.hpp>

#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdio>

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

#ifndef MADV_POPULATE_WRITE
#define MADV_POPULATE_WRITE 23  // Linux 5.14
#endif

// Blocks from this size on are populated (their fresh pages faulted in by
// one madvise) when they are handed out; smaller ones fault as they are
// touched.
constexpr std::size_t populated_from = std::size_t{1} << 20;
std::atomic<bool> populating{false};
std::uintptr_t heap_start = 0;  // the main heap's start (sbrk(0) when the policy was set)
std::uintptr_t page_size = 4096;
// The main heap below here has been handed out before (its pages, once
// touched, stay: the heap is never trimmed) or populated.
std::atomic<std::uintptr_t> populated_end{0};

// Faults in the pages of a large block of the main heap that lie above
// everything handed out before, in one call instead of one page fault per
// page: on this project's machines (virtual machines whose host takes back
// freed memory) 500 MB touched page by page took 1.4–1.7 s, populated by
// madvise 0.7–0.8 s (docs/design.md, "Memory policy"). Blocks of the threads'
// own arenas (mapped apart from the main heap) and reused memory are left
// as they are; a kernel before 5.14 refuses the advice, which then stops.
void populate(void* block, std::size_t bytes) noexcept {
  if (block == nullptr || bytes < populated_from || !populating.load(std::memory_order_relaxed)) return;
  const auto from = reinterpret_cast<std::uintptr_t>(block);
  const std::uintptr_t to = from + bytes;
  if (from < heap_start || to > reinterpret_cast<std::uintptr_t>(sbrk(0))) return;  // not the main heap
  std::uintptr_t done = populated_end.load(std::memory_order_relaxed);
  if (to <= done) return;
  const std::uintptr_t start = std::max(from, done) & ~(page_size - 1);
  const std::uintptr_t stop = (to + page_size - 1) & ~(page_size - 1);
  const int saved = errno;  // a successful malloc leaves errno as it was
  if (madvise(reinterpret_cast<void*>(start), stop - start, MADV_POPULATE_WRITE) != 0 && errno == EINVAL)
    populating.store(false, std::memory_order_relaxed);
  errno = saved;
  // Another thread may have populated further meanwhile: keep the larger end.
  while (done < stop && !populated_end.compare_exchange_weak(done, stop, std::memory_order_relaxed)) {
  }
}

// A retry loop, not a caller that gives up: a program that is refused memory
// throws or reports at once, and the loop above runs thousands of times a
// second.
constexpr unsigned refusals_in_a_row = 1000;
thread_local std::size_t refused_bytes = 0;
thread_local unsigned refusals = 0;

[[noreturn]] void end_refused(std::size_t bytes) noexcept {
  char limit[96] = "";
  if (const double as = modal::address_space_limit(); as > 0)
    std::snprintf(limit, sizeof limit, "; the process's address space is limited to %.0f MB (ulimit -v)", as / 1e6);
  char text[384];
  std::snprintf(text, sizeof text,
                "modal: out of memory: the system refused an allocation of %.0f MB %u times in a row, which a "
                "library of this computation retries without end%s\n",
                static_cast<double>(bytes) / 1e6, refusals_in_a_row, limit);
  modal_program::end_now(text);
}

// `block` as glibc returned it for `bytes`, after counting a refusal.
void* counted(void* block, std::size_t bytes) noexcept {
  if (block != nullptr || bytes == 0) {
    refusals = 0;
    return block;
  }
  if (bytes != refused_bytes) {
    refused_bytes = bytes;
    refusals = 0;
  }
  if (++refusals >= refusals_in_a_row) end_refused(bytes);
  return nullptr;
}

}  // namespace

extern "C" void* malloc(std::size_t size) {
  void* block = __libc_malloc(size);
  follow_heap();
  populate(block, size);
  return counted(block, size);
}

extern "C" void* calloc(std::size_t count, std::size_t size) {
  void* block = __libc_calloc(count, size);
  follow_heap();
  std::size_t bytes = 0;
  if (__builtin_mul_overflow(count, size, &bytes)) return block;  // refused for its size, not retried
  populate(block, bytes);
  return counted(block, bytes);
}

extern "C" void* realloc(void* block, std::size_t size) {
  void* moved = __libc_realloc(block, size);
  follow_heap();
  populate(moved, size);
  return counted(moved, size);
}

void modal_program::set_memory_policy() {
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, -1);  // never
  // Under an address-space limit (ulimit -v) the pad is at most 1/64 of
  // it: glibc does not retry a refused growth without the pad, so a 64 MiB
  // pad made a 50 MB process fail under a 75 MB limit.
  double pad = 64 << 20;
  if (const double limit = modal::address_space_limit(); limit > 0) pad = std::min(pad, limit / 64);
  mallopt(M_TOP_PAD, static_cast<int>(pad));
  page_size = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  heap_start = reinterpret_cast<std::uintptr_t>(sbrk(0));
  populated_end.store(heap_start);
  const char* populate = std::getenv("MODAL_POPULATE");
  populating.store(populate == nullptr || std::strcmp(populate, "0") != 0);
  const char* huge = std::getenv("MODAL_HUGE_PAGES");
  if (huge == nullptr || std::strcmp(huge, "1") != 0) return;
  advised_end.store(reinterpret_cast<std::uintptr_t>(sbrk(0)));
  following.store(true);
}

#else

void modal_program::set_memory_policy() {}

#endif

void modal_program::end_now(const char* text) noexcept {
  modal::remove_output_temporaries();
  static_cast<void>(write(STDERR_FILENO, text, std::strlen(text)));
  _exit(static_cast<int>(modal::ExitStatus::numerical));
}
