// The program's memory policy (docs/design.md, "Memory policy").
#pragma once

namespace modal_program {

// Called first in main: freed memory kept for reuse, large blocks on
// transparent huge pages. Does nothing under the sanitizers, which bring their
// own allocator.
void set_memory_policy();

// Ends the process at once as a failed computation (exit status 4): the
// outputs' temporaries removed, then `text` (whole lines, ending in a
// newline) written to standard error. For the places no exception can leave
// (an allocator, an atexit function, a signal handler, a lazy-loading
// trampoline): it allocates nothing.
[[noreturn]] void end_now(const char* text) noexcept;

}  // namespace modal_program
