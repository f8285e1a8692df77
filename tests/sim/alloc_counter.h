// Counts heap allocations made by this test binary (operator new is replaced in
// alloc_counter.cpp), so tests can check that realtime paths never allocate.
#pragma once

#include <cstddef>

namespace mimic::test {
size_t allocation_count();
}
