// lib/simulate/messages.hpp — internal to the simulate stage: numbers in
// error messages, shared by simulate.cpp and amplitude.cpp.
#pragma once

#include <sstream>
#include <string>

namespace modal::simulate_detail {

inline std::string number(double v) {  // 6 significant digits, for messages
  std::ostringstream out;
  out << v;
  return out.str();
}

}  // namespace modal::simulate_detail
