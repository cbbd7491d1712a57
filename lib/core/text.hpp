// Private to the library: how its messages write numbers and units.
#pragma once

#include "modal/core.hpp"

#include <cstdio>
#include <string>

namespace modal::text {

// v with `digits` significant digits (printf's %.*g): 0.00544, 1.7e+11.
inline std::string format_number(double v, int digits = 4) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, v);
  return buffer;
}

// The unit of the generalized force conjugate to a coordinate of kind k.
inline const char* force_unit(CoordinateKind k) { return k == CoordinateKind::length ? "N" : "N·m"; }

}  // namespace modal::text
