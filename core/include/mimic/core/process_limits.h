// The process's descriptor budget: every network session holds one, and a server that accepts
// past the limit fails accept() with EMFILE until a descriptor is freed.
#pragma once

#include <cstddef>

namespace mimic {

// The soft RLIMIT_NOFILE (how many descriptors this process may hold now).
size_t descriptor_limit() noexcept;

// Raises the soft limit to the hard one where the hard limit allows more (no privilege needed);
// returns the soft limit now in force.
size_t raise_descriptor_limit() noexcept;

// Lowers the calling thread's nice value to `nice` (e.g. -10) when that is a raise and the system
// permits it (CAP_SYS_NICE or RLIMIT_NICE); threads it starts later inherit it. False if refused.
bool raise_thread_nice(int nice) noexcept;

}  // namespace mimic
