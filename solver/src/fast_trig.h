// Trigonometry in float without libm calls, for the solve's hot paths (a call and its exact
// rounding cost more there than the few ulps these give up).
#pragma once

#include <algorithm>
#include <cmath>

namespace mimic::solver::detail {

// The limbs' decompositions take three per joint, dozens per frame (libm's atan2f/asinf were a
// tenth of a frame). Within 3·10⁻⁷ rad of the exact angle over the whole plane (libm's float
// result: 2.5·10⁻⁷), the same signs and quadrants (atan2(±0, −1) = ±π, atan2(0, 0) = 0).
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

// sin and cos of a half angle: Taylor to the 13th and 14th power within ±π/2 (every DOF's half
// angle inside its limits), within 1.1·10⁻⁷ of the exact values (libm's float sincosf: 3·10⁻⁸),
// inline instead of a call that was a thirtieth of a frame; libm beyond.
inline void half_sincos(float h, float& s, float& c) {
  if (!(std::abs(h) <= 1.5707964f)) {
    s = std::sin(h), c = std::cos(h);
    return;
  }
  const float z = h * h;
  s = h + h * z *
              (-1.66666667e-1f +
               z * (8.33333333e-3f +
                    z * (-1.98412698e-4f + z * (2.75573192e-6f + z * (-2.50521084e-8f + z * 1.60590438e-10f)))));
  c = 1.0f +
      z * (-0.5f + z * (4.16666667e-2f +
                        z * (-1.38888889e-3f + z * (2.48015873e-5f + z * (-2.75573192e-7f + z * 2.08767570e-9f)))));
}

}  // namespace mimic::solver::detail
