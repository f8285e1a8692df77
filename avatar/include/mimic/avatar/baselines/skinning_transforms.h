// Per-frame joint transforms in the forms the baseline skinning jobs read: the skinning
// transform of joint j maps a rest-posture point to its posed position,
//   world_from_rest[j] = world_from_joint[j] × joint_from_rest[j]   (joint_from_rest = inverse
// of the joint's rest world transform), packed as a 3×4 matrix (LBS, CoR), a unit dual
// quaternion (DQS) and a unit quaternion (CoR).
#pragma once

#include <span>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/avatar/transform.h"

namespace mimic::avatar::baselines {

// Row-major 3×4 affine matrix: x' = m[0]x + m[1]y + m[2]z + m[3], y' = m[4]… , z' = m[8]… .
struct alignas(16) Affine3x4 {
  float m[12];
};

// Unit dual quaternion, real part (rotation) and dual part, each stored x, y, z, w.
struct alignas(32) DualQuat {
  float real[4];
  float dual[4];
};

Affine3x4 to_affine(const RigidTransform& t);
DualQuat to_dual_quat(const RigidTransform& t);

// joint_from_rest[j] = inverse(world_from_joint_rest[j]), once per body. Sizes must match.
void invert_transforms(std::span<const RigidTransform> world_from_joint_rest, std::span<RigidTransform> joint_from_rest);

// The skinning transforms of one frame, written into the spans that are not empty (each either
// empty or joint-sized). Never allocates.
void skinning_transforms(std::span<const RigidTransform> world_from_joint, std::span<const RigidTransform> joint_from_rest,
                         std::span<Affine3x4> matrices, std::span<DualQuat> dual_quats, std::span<glm::quat> rotations);

}  // namespace mimic::avatar::baselines
