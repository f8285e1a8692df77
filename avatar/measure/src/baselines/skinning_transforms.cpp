#include "mimic/avatar/baselines/skinning_transforms.h"

#include <cassert>

namespace mimic::avatar::baselines {

SkinningMatrix to_skinning_matrix(const rig::RigidTransform& t) {
  const glm::mat3 r = glm::mat3_cast(t.rotation);  // column-major: r[column][row]
  SkinningMatrix a;
  for (int c = 0; c < 3; ++c) a.cols[c][0] = r[c][0], a.cols[c][1] = r[c][1], a.cols[c][2] = r[c][2], a.cols[c][3] = 0;
  a.cols[3][0] = t.translation.x, a.cols[3][1] = t.translation.y, a.cols[3][2] = t.translation.z, a.cols[3][3] = 0;
  return a;
}

DualQuat to_dual_quat(const rig::RigidTransform& t) {
  const glm::quat& q = t.rotation;
  // dual = ½ (0, t) q, the usual encoding of "rotate by q, then translate by t".
  const glm::quat d = 0.5f * (glm::quat(0.0f, t.translation.x, t.translation.y, t.translation.z) * q);
  return DualQuat{{q.x, q.y, q.z, q.w}, {d.x, d.y, d.z, d.w}};
}

void invert_transforms(std::span<const rig::RigidTransform> world_from_joint_rest,
                       std::span<rig::RigidTransform> joint_from_rest) {
  assert(world_from_joint_rest.size() == joint_from_rest.size());
  for (size_t j = 0; j < world_from_joint_rest.size() && j < joint_from_rest.size(); ++j)
    joint_from_rest[j] = world_from_joint_rest[j].inverse();
}

void skinning_transforms(std::span<const rig::RigidTransform> world_from_joint,
                         std::span<const rig::RigidTransform> joint_from_rest, std::span<SkinningMatrix> matrices,
                         std::span<DualQuat> dual_quats, std::span<glm::quat> rotations) {
  const size_t n = std::min(world_from_joint.size(), joint_from_rest.size());
  assert(matrices.empty() || matrices.size() == n);
  assert(dual_quats.empty() || dual_quats.size() == n);
  assert(rotations.empty() || rotations.size() == n);
  for (size_t j = 0; j < n; ++j) {
    rig::RigidTransform world_from_rest = world_from_joint[j] * joint_from_rest[j];
    world_from_rest.rotation = glm::normalize(world_from_rest.rotation);
    if (j < matrices.size()) matrices[j] = to_skinning_matrix(world_from_rest);
    if (j < dual_quats.size()) dual_quats[j] = to_dual_quat(world_from_rest);
    if (j < rotations.size()) rotations[j] = world_from_rest.rotation;
  }
}

}  // namespace mimic::avatar::baselines
