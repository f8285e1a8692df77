// atan2 in float without a libm call: the limbs' decompositions take three per joint, dozens per
// frame, and libm's exactly rounded atan2f/asinf were a tenth of a frame. Within 3·10⁻⁷ rad of the
// exact angle over the whole plane (libm's float result: 2.5·10⁻⁷), the same signs and quadrants
// (atan2(±0, −1) = ±π, atan2(0, 0) = 0).
#pragma once

#include <algorithm>
#include <cmath>

namespace mimic::solver::detail {

inline float fast_atan2(float y, float x) {
  const float ax = std::abs(x), ay = std::abs(y);
  const float hi = std::max(ax, ay), lo = std::min(ax, ay);
  const float t = hi > 0 ? lo / hi : 0.0f;  // tan of the angle from the nearer axis, 0 … 1
  // Past tan(π/8), atan(t) = π/4 + atan((t − 1)/(t + 1)): the polynomial then spans ±tan(π/8).
  const bool far = t > 0.41421356f;
  const float u = far ? (t - 1.0f) / (t + 1.0f) : t;
  const float z = u * u;
  float r = (((8.05374449538e-2f * z - 1.38776856032e-1f) * z + 1.99777106478e-1f) * z - 3.33329491539e-1f) * z * u + u;
  if (far) r += 0.78539816339744831f;
  if (ay > ax) r = 1.57079632679489662f - r;
  if (x < 0 || (x == 0 && std::signbit(x) && ay == 0)) r = 3.14159265358979324f - r;
  return std::copysign(r, y);
}

}  // namespace mimic::solver::detail
