// Counts heap allocations made by the calling thread (the program replaces the global operator
// new to do so), so `mimic run` can show that its realtime loop allocates nothing per frame.
#pragma once

#include <cstdint>

namespace mimic::app {

uint64_t thread_allocation_count() noexcept;

}  // namespace mimic::app
