#include "mimic/solver/two_bone_ik.h"

#include <algorithm>
#include <cmath>

#include "mimic/core/finite.h"

namespace mimic::solver {

namespace {

// Distance start→end for a middle bend θ (law of cosines; θ = 0 is straight).
float reach_for_bend(float a, float b, float bend) {
  return std::sqrt(std::max(0.0f, a * a + b * b + 2.0f * a * b * std::cos(bend)));
}

// Any unit vector perpendicular to n.
glm::vec3 any_perpendicular(const glm::vec3& n) {
  const glm::vec3 helper = std::abs(n.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
  return glm::normalize(glm::cross(n, helper));
}

}  // namespace

bool TwoBoneIkJob::Validate() const {
  return upper_m > 0 && lower_m > 0 && std::isfinite(upper_m) && std::isfinite(lower_m) && all_finite(start_m) &&
         all_finite(target_m) && all_finite(pole_dir) && min_bend_rad <= max_bend_rad;
}

bool TwoBoneIkJob::Run() {
  if (!Validate()) return false;
  const float a = upper_m, b = lower_m;
  const float lo_bend = std::clamp(min_bend_rad, 0.0f, 3.14159265f);
  const float hi_bend = std::clamp(max_bend_rad, lo_bend, 3.14159265f);
  const float max_reach = reach_for_bend(a, b, lo_bend);
  const float min_reach = reach_for_bend(a, b, hi_bend);

  glm::vec3 to_target = target_m - start_m;
  const float dist = glm::length(to_target);
  // Direction to the target; a target on the start joint leaves the direction to the pole.
  glm::vec3 axis;
  if (dist > 1e-7f) {
    axis = to_target / dist;
  } else {
    const float pl = glm::length(pole_dir);
    axis = pl > 1e-7f ? pole_dir / pl : glm::vec3(0, -1, 0);
  }
  const float d = std::clamp(dist, min_reach, max_reach);
  end_m = start_m + axis * d;
  reached = std::abs(d - dist) < 1e-4f;

  // Middle joint: angle at the start joint between the axis and the upper link.
  const float cos_start = std::clamp((a * a + d * d - b * b) / (2.0f * a * std::max(d, 1e-7f)), -1.0f, 1.0f);
  const float sin_start = std::sqrt(std::max(0.0f, 1.0f - cos_start * cos_start));
  glm::vec3 pole = pole_dir - axis * glm::dot(pole_dir, axis);
  const float pole_len = glm::length(pole);
  pole = pole_len > 1e-6f ? pole / pole_len : any_perpendicular(axis);
  mid_m = start_m + a * (cos_start * axis + sin_start * pole);

  const float cos_bend = std::clamp((d * d - a * a - b * b) / (2.0f * a * b), -1.0f, 1.0f);
  bend_rad = std::acos(cos_bend);
  return true;
}

}  // namespace mimic::solver
