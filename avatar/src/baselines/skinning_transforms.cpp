#include "mimic/avatar/baselines/skinning_transforms.h"

#include <cassert>

namespace mimic::avatar::baselines {

Affine3x4 to_affine(const RigidTransform& t) {
  const glm::mat3 r = glm::mat3_cast(t.rotation);  // column-major: r[column][row]
  Affine3x4 a;
  for (int row = 0; row < 3; ++row) {
    a.m[row * 4 + 0] = r[0][row];
    a.m[row * 4 + 1] = r[1][row];
    a.m[row * 4 + 2] = r[2][row];
    a.m[row * 4 + 3] = t.translation[row];
  }
  return a;
}

DualQuat to_dual_quat(const RigidTransform& t) {
  const glm::quat& q = t.rotation;
  // dual = ½ (0, t) q, the usual encoding of "rotate by q, then translate by t".
  const glm::quat d = 0.5f * (glm::quat(0.0f, t.translation.x, t.translation.y, t.translation.z) * q);
  return DualQuat{{q.x, q.y, q.z, q.w}, {d.x, d.y, d.z, d.w}};
}

void invert_transforms(std::span<const RigidTransform> world_from_joint_rest, std::span<RigidTransform> joint_from_rest) {
  assert(world_from_joint_rest.size() == joint_from_rest.size());
  for (size_t j = 0; j < world_from_joint_rest.size() && j < joint_from_rest.size(); ++j)
    joint_from_rest[j] = world_from_joint_rest[j].inverse();
}

void skinning_transforms(std::span<const RigidTransform> world_from_joint, std::span<const RigidTransform> joint_from_rest,
                         std::span<Affine3x4> matrices, std::span<DualQuat> dual_quats, std::span<glm::quat> rotations) {
  const size_t n = std::min(world_from_joint.size(), joint_from_rest.size());
  assert(matrices.empty() || matrices.size() == n);
  assert(dual_quats.empty() || dual_quats.size() == n);
  assert(rotations.empty() || rotations.size() == n);
  for (size_t j = 0; j < n; ++j) {
    RigidTransform world_from_rest = world_from_joint[j] * joint_from_rest[j];
    world_from_rest.rotation = glm::normalize(world_from_rest.rotation);
    if (j < matrices.size()) matrices[j] = to_affine(world_from_rest);
    if (j < dual_quats.size()) dual_quats[j] = to_dual_quat(world_from_rest);
    if (j < rotations.size()) rotations[j] = world_from_rest.rotation;
  }
}

}  // namespace mimic::avatar::baselines
