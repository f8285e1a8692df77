// Rotation vectors (axis · angle, radians) and back, for the solver's filters and IK.
#pragma once

#include <cmath>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "fast_trig.h"

namespace mimic::solver::detail {

// Of a unit quaternion, the shorter way round (|angle| ≤ π).
inline glm::vec3 rotation_vector(glm::quat q) {
  if (q.w < 0) q = -q;
  const glm::vec3 v(q.x, q.y, q.z);
  const float s = glm::length(v);
  if (s < 1e-8f) return 2.0f * v;
  return v * (2.0f * std::atan2(s, q.w) / s);
}

inline glm::quat exp_rotation(const glm::vec3& rv) {
  const float angle = glm::length(rv);
  if (angle < 1e-8f) return glm::normalize(glm::quat(1.0f, 0.5f * rv.x, 0.5f * rv.y, 0.5f * rv.z));
  float s, c;
  half_sincos(0.5f * angle, s, c);
  const glm::vec3 v = rv * (s / angle);
  return glm::quat(c, v.x, v.y, v.z);
}

}  // namespace mimic::solver::detail
