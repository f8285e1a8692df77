// Turning about a DOF's axis. The skeleton's axes are nearly all coordinate axes (±x, ±y, ±z),
// about which a rotation multiplies out in half the arithmetic of a general one — and the solve
// turns about every DOF several times a frame (the least squares' FK, the placed joints).
#pragma once

#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "fast_trig.h"
#include "mimic/solver/least_squares_ik.h"

namespace mimic::solver::detail {

inline AxisKind axis_kind(const glm::vec3& a) {
  for (uint8_t k = 0; k < 3; ++k)
    if (std::abs(a[k]) == 1.0f && a[(k + 1) % 3] == 0.0f && a[(k + 2) % 3] == 0.0f) return {k, a[k]};
  return {};
}

// r·R(axis, angle_rad), and r·axis when `axis_world` is given: (c, s·e_k) multiplied out, and
// the rotation's k-th column.
inline glm::quat turned(const glm::quat& r, const glm::vec3& axis, AxisKind kind, float angle_rad,
                        glm::vec3* axis_world = nullptr) {
  if (kind.axis == 3) {
    if (axis_world) *axis_world = r * axis;
    return r * glm::angleAxis(angle_rad, axis);
  }
  float s, c;
  half_sincos(0.5f * angle_rad, s, c);
  s *= kind.sign;
  const float w = r.w, x = r.x, y = r.y, z = r.z;
  switch (kind.axis) {
    case 0:
      if (axis_world)
        *axis_world = kind.sign * glm::vec3(1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y));
      return glm::quat(w * c - x * s, x * c + w * s, y * c + z * s, z * c - y * s);
    case 1:
      if (axis_world)
        *axis_world = kind.sign * glm::vec3(2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x));
      return glm::quat(w * c - y * s, x * c - z * s, y * c + w * s, z * c + x * s);
    default:
      if (axis_world)
        *axis_world = kind.sign * glm::vec3(2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y));
      return glm::quat(w * c - z * s, x * c + y * s, y * c - x * s, z * c + w * s);
  }
}

}  // namespace mimic::solver::detail
