// The program's libraries loaded on first use (docs/design.md, "Start-up").
//
// The program `modal` links the C and C++ run-time libraries, fmt and toml++
// as usual; LAPACK/BLAS (OpenBLAS), CHOLMOD, MUMPS, GSL, NLopt and MuJoCo are
// loaded only when a function of theirs is first called, so that a small
// scene or `modal --version` does not pay for loading them (OpenBLAS alone
// starts its threads when it is loaded). cmake/modal_lazy_generate.cmake
// writes, from libmodal's own references, one stub per function they provide
// and the tables below; the first call of a stub lands in modal_lazy_resolve.
// The library (libmodal, the Python module) links them as usual.

#include "memory_policy.hpp"

#include <dlfcn.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstring>
#include <mutex>

namespace {

struct Function {
  const char* name;
  long library;
};
struct Data {
  const char* name;
  long library;
  void* address;  // the program's definition, which the library binds to
  long bytes;
  long copy;  // 1: initialized in the library, copied when it is loaded
};
struct Counts {
  long libraries, functions, data;
};

}  // namespace

extern "C" {
extern void* modal_lazy_slots[];
extern const char* const modal_lazy_libraries[];
extern const Function modal_lazy_functions[];
extern const Data modal_lazy_data[];
extern const Counts modal_lazy_counts;
void* modal_lazy_resolve(long index);
}

namespace {

std::mutex loading;
void* handles[64] = {};

[[noreturn]] void cannot_load(const char* what, const char* library, const char* symbol, const char* why) {
  // No exception can pass the stub that called; end the process as an
  // unknown failure does (exit 4), leaving no partial output.
  char text[1024];
  std::snprintf(text, sizeof text, "modal: cannot %s %s from %s, which this computation needs: %s\n", what, symbol,
                library, why != nullptr ? why : "unknown reason");
  modal_program::end_now(text);
}

// Loads library l (once) and fills the program's copies of its initialized data.
void* load(long l) {
  if (handles[l] != nullptr) return handles[l];
  const char* soname = modal_lazy_libraries[l];
  void* h = dlopen(soname, RTLD_LAZY | RTLD_GLOBAL);
  if (h == nullptr) cannot_load("load", soname, "anything", dlerror());
  for (long i = 0; i < modal_lazy_counts.data; ++i) {
    const Data& d = modal_lazy_data[i];
    if (d.library != l || d.copy == 0) continue;
    const void* original = dlsym(h, d.name);
    if (original == nullptr) cannot_load("find", soname, d.name, dlerror());
    // dlsym on the handle finds the library's own, still initialized, copy;
    // the library itself was bound to the program's definition.
    if (original != d.address) std::memcpy(d.address, original, static_cast<std::size_t>(d.bytes));
  }
  handles[l] = h;
  return h;
}

}  // namespace

extern "C" void* modal_lazy_resolve(long index) {
  const std::lock_guard<std::mutex> lock(loading);
  const Function& f = modal_lazy_functions[index];
  if (f.library < 0 || f.library >= static_cast<long>(sizeof handles / sizeof handles[0]))
    cannot_load("load", "a library", f.name, "library index out of range");
  void* h = load(f.library);
  void* address = dlsym(h, f.name);
  if (address == nullptr) cannot_load("find", modal_lazy_libraries[f.library], f.name, dlerror());
  __atomic_store_n(&modal_lazy_slots[index], address, __ATOMIC_RELEASE);
  return address;
}
