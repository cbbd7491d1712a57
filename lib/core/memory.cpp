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

std::optional<std::string> memory_refusal(double bytes, const std::string& what, double limit) {
  const bool set = limit > 0;
  const double have = set ? limit : available_memory();
  if (have <= 0 || bytes <= have) return std::nullopt;
  return "it would need about " + format_bytes(bytes) + " of memory for " + what + ", more than the " +
         format_bytes(have) +
         (set ? " allowed (--max-memory)" : " this machine has available (MemAvailable in /proc/meminfo)");
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
