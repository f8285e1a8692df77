// Heap allocations made by the calling thread, counted by replacing the global allocation
// functions. Only programs that link `mimic::alloc_counter` (the mimic program, the test binaries
// that check realtime paths) replace them; libraries never do, so a host program keeps its own.
#pragma once

#include <cstdint>

namespace mimic {

// Allocations by this thread since it started; compare two readings around the code checked.
uint64_t thread_allocation_count() noexcept;

}  // namespace mimic
