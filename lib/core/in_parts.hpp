// Private to the library: work in two parts on the machine's two cores
// (docs/design.md, "Threads for the elements" and "Sparse solves in two
// parts").
#pragma once

#include <cstddef>
#include <exception>
#include <system_error>
#include <thread>

namespace modal::detail {

// f(0) and, with two parts, f(1) on a thread of its own (in turn where the
// machine has one core or no thread can be started); an exception of either
// is rethrown here after both have finished. The caller makes the parts
// independent and combines their results in a fixed order, so that what it
// computes never depends on the cores or on timing.
template <class F> void in_parts(std::size_t parts, F&& f) {
  if (parts < 2) {
    f(std::size_t{0});
    return;
  }
  std::exception_ptr failure;
  std::thread second;
  if (std::thread::hardware_concurrency() >= 2) {
    try {
      second = std::thread([&f, &failure] {
        try {
          f(std::size_t{1});
        } catch (...) {
          failure = std::current_exception();
        }
      });
    } catch (const std::system_error&) {  // no thread to be had: the parts in turn
    }
  }
  if (!second.joinable()) {
    f(std::size_t{0});
    f(std::size_t{1});
    return;
  }
  try {
    f(std::size_t{0});
  } catch (...) {
    second.join();
    throw;
  }
  second.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace modal::detail
