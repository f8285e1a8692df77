// Finite-sample checks for values that come from outside (files, packets, sensors): a NaN or an
// infinity must be refused where it enters, never reach the solver or the skin.
#pragma once

#include <cmath>
#include <span>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace mimic {

inline bool all_finite(std::span<const float> values) noexcept {
  for (float v : values)
    if (!std::isfinite(v)) return false;
  return true;
}
inline bool all_finite(std::span<const double> values) noexcept {
  for (double v : values)
    if (!std::isfinite(v)) return false;
  return true;
}
template <glm::length_t N, class T, glm::qualifier Q>
bool all_finite(const glm::vec<N, T, Q>& v) noexcept {
  for (glm::length_t i = 0; i < N; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}
template <class T, glm::qualifier Q>
bool all_finite(const glm::qua<T, Q>& q) noexcept {
  return std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z) && std::isfinite(q.w);
}

}  // namespace mimic
