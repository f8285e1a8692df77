// Rigid transforms (rotation then translation), named by the frames they map between,
// e.g. world_from_joint maps points in a joint's frame to world coordinates.
#pragma once

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace mimic::rig {

struct RigidTransform {
  glm::quat rotation{1.0f, 0.0f, 0.0f, 0.0f};  // unit quaternion
  glm::vec3 translation{0.0f};                 // metres

  glm::vec3 apply(const glm::vec3& p) const { return rotation * p + translation; }
  glm::vec3 apply_vector(const glm::vec3& v) const { return rotation * v; }
  RigidTransform operator*(const RigidTransform& rhs) const {
    return {rotation * rhs.rotation, rotation * rhs.translation + translation};
  }
  RigidTransform inverse() const {
    const glm::quat inv = glm::conjugate(rotation);
    return {inv, -(inv * translation)};
  }
};

}  // namespace mimic::rig
