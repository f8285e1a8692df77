// Order statistics of measured samples (latencies, frame times), for benchmarks and status lines.
#pragma once

#include <span>

namespace mimic {

// The q-quantile (0 ≤ q ≤ 1) of `samples` by nearest rank; reorders them (nth_element), 0 when
// there are none. Allocates nothing.
double percentile_in_place(std::span<double> samples, double q) noexcept;

}  // namespace mimic
