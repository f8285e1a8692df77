#include "mimic/core/percentile.h"

#include <algorithm>
#include <cstddef>

namespace mimic {

double percentile_in_place(std::span<double> samples, double q) noexcept {
  if (samples.empty()) return 0;
  const double rank = std::clamp(q, 0.0, 1.0) * double(samples.size() - 1) + 0.5;
  const size_t k = std::min(samples.size() - 1, static_cast<size_t>(rank));
  std::nth_element(samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(k), samples.end());
  return samples[k];
}

}  // namespace mimic
