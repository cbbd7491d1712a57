// lib/core/memory.cpp — what the machine can give, and what a tree couples:
// the pieces of the up-front memory estimates (docs/design.md, "Memory policy").
#include "modal/core.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <malloc.h>
#include <sys/resource.h>

namespace modal {

double available_memory() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  double kilobytes = 0;
  std::string unit;
  while (in >> key >> kilobytes >> unit)
    if (key == "MemAvailable:") return kilobytes * 1024;
  return 0;
}

double address_space_limit() noexcept {
  rlimit limit{};
  if (getrlimit(RLIMIT_AS, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return 0;
  return static_cast<double>(limit.rlim_cur);
}

std::string format_bytes(double bytes) {
  const char* units[] = {"bytes", "kB", "MB", "GB", "TB", "PB", "EB"};
  std::size_t u = 0;
  while (bytes >= 1000 && u + 1 < std::size(units)) {
    bytes /= 1000;
    ++u;
  }
  char text[64];
  if (u == 0 && std::round(bytes) == 1) return "1 byte";
  std::snprintf(text, sizeof text, u == 0 ? "%.0f %s" : "%.3g %s", bytes, units[u]);
  return text;
}

namespace {
// "it would need about <bytes> of memory for <what>, more than the <have>
// <source>", or nothing when it fits.
std::optional<std::string> refusal(double bytes, const std::string& what, double have, const char* source) {
  if (have <= 0 || bytes <= have) return std::nullopt;
  return "it would need about " + format_bytes(bytes) + " of memory for " + what + ", more than the " +
         format_bytes(have) + " " + source;
}

// glibc's account of its main heap (mallinfo2): the bytes its blocks in use
// and its blocks mapped on their own hold, and the free bytes it keeps for
// reuse; zeros under another allocator (the sanitizers', jemalloc).
struct Heap {
  double in_use = 0, free = 0;
};
Heap heap() {
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
  const struct mallinfo2 info = mallinfo2();
  return {static_cast<double>(info.uordblks) + static_cast<double>(info.hblkhd), static_cast<double>(info.fordblks)};
#else
  return {};
#endif
}
}  // namespace

std::optional<std::string> memory_refusal(double bytes, const std::string& what, double limit) {
  if (limit > 0) return refusal(bytes, what, limit, "allowed (--max-memory)");
  return refusal(bytes, what, available_memory(), "this machine has available (MemAvailable in /proc/meminfo)");
}

double memory_in_use() { return heap().in_use; }

void check_allocation(double bytes, const std::string& what, double limit) {
  std::optional<std::string> refused;
  if (limit > 0) {
    const double held = memory_in_use();
    refused = memory_refusal(
        held + bytes, what + " (" + format_bytes(bytes) + ", with the " + format_bytes(held) + " already in use)", limit);
  } else if (const double have = available_memory(); have > 0) {
    refused = refusal(bytes, what, have + heap().free,
                      "this machine has available (MemAvailable in /proc/meminfo, and the free memory of the program's "
                      "heap)");
  }
  if (refused) throw OutOfMemory("out of memory, found before allocating: " + *refused);
}

double coupled_pairs(const System& s) {
  const auto& bodies = s.bodies();
  if (s.is_map()) return static_cast<double>(s.size()) * s.size();
  std::vector<double> path(bodies.size());  // coordinates that move body b (its joint's and its ancestors')
  double pairs = 0;
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const double own = s.joint_size(static_cast<int>(b));
    path[b] = own + (bodies[b].parent >= 0 ? path[static_cast<std::size_t>(bodies[b].parent)] : 0.0);
    pairs += own * (2 * path[b] - own);
  }
  const auto on_path = [&](const Attachment& a) { return a.body >= 0 ? path[static_cast<std::size_t>(a.body)] : 0.0; };
  for (const Spring& sp : s.springs()) pairs += 2 * on_path(sp.a) * on_path(sp.b);
  return std::min(pairs, static_cast<double>(s.size()) * s.size());
}

}  // namespace modal
