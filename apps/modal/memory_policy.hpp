// The program's memory policy (docs/design.md, "Memory policy").
#pragma once

namespace modal_program {

// Called first in main: freed memory kept for reuse, large blocks on
// transparent huge pages. Does nothing under the sanitizers, which bring their
// own allocator.
void set_memory_policy();

}  // namespace modal_program
