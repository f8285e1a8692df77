#include "mimic/avatar/bspline.h"

#include <algorithm>
#include <cassert>

namespace mimic::avatar {

std::vector<BsplineTap> periodic_cubic_taps(int controls, int per_span) {
  assert(controls >= 3 && per_span >= 1);
  std::vector<BsplineTap> taps(static_cast<size_t>(controls) * per_span);
  for (int j = 0; j < controls; ++j)
    for (int k = 0; k < per_span; ++k) {
      const float t = static_cast<float>(k) / static_cast<float>(per_span);
      const float t2 = t * t, t3 = t2 * t;
      BsplineTap& tap = taps[static_cast<size_t>(j) * per_span + k];
      tap.weight = {(1 - t) * (1 - t) * (1 - t) / 6.0f, (3 * t3 - 6 * t2 + 4) / 6.0f,
                    (-3 * t3 + 3 * t2 + 3 * t + 1) / 6.0f, t3 / 6.0f};
      for (int m = 0; m < 4; ++m) tap.index[m] = static_cast<uint32_t>(((j - 1 + m) % controls + controls) % controls);
    }
  return taps;
}

std::vector<BsplineTap> clamped_cubic_taps(int controls, int samples) {
  assert(controls >= 2 && samples >= 2);
  const int p = std::min(3, controls - 1);
  // Knots: p+1 zeros, 1 … n−p−1, p+1 copies of n−p (n = controls).
  const int n = controls;
  std::vector<float> knots;
  for (int i = 0; i <= p; ++i) knots.push_back(0.0f);
  for (int i = 1; i < n - p; ++i) knots.push_back(static_cast<float>(i));
  for (int i = 0; i <= p; ++i) knots.push_back(static_cast<float>(n - p));
  const float u_max = static_cast<float>(n - p);
  std::vector<BsplineTap> taps(samples);
  for (int s = 0; s < samples; ++s) {
    const float u = u_max * static_cast<float>(s) / static_cast<float>(samples - 1);
    // Span index: knots[span] ≤ u < knots[span+1], the last span closed at u_max.
    int span = p;
    while (span < n - 1 && u >= knots[span + 1]) ++span;
    // Cox–de Boor, the triangular table of the p+1 non-zero basis functions.
    float basis[4] = {1, 0, 0, 0}, left[4] = {}, right[4] = {};
    for (int j = 1; j <= p; ++j) {
      left[j] = u - knots[span + 1 - j];
      right[j] = knots[span + j] - u;
      float saved = 0;
      for (int r = 0; r < j; ++r) {
        const float denom = right[r + 1] + left[j - r];
        const float temp = denom != 0.0f ? basis[r] / denom : 0.0f;
        basis[r] = saved + right[r + 1] * temp;
        saved = left[j - r] * temp;
      }
      basis[j] = saved;
    }
    BsplineTap& tap = taps[s];
    for (int m = 0; m < 4; ++m) {
      const int idx = span - p + std::min(m, p);
      tap.index[m] = static_cast<uint32_t>(idx);
      tap.weight[m] = m <= p ? basis[m] : 0.0f;
    }
  }
  // Exact ends: interpolation of the first and last control points.
  taps.front() = BsplineTap{{0, 0, 0, 0}, {1, 0, 0, 0}};
  const uint32_t last = static_cast<uint32_t>(n - 1);
  taps.back() = BsplineTap{{last, last, last, last}, {1, 0, 0, 0}};
  return taps;
}

}  // namespace mimic::avatar
