// Per-frame joint transforms in the forms the baseline skinning jobs read: the skinning
// transform of joint j maps a rest-posture point to its posed position,
//   world_from_rest[j] = world_from_joint[j] × joint_from_rest[j]   (joint_from_rest = inverse
// of the joint's rest world transform), packed as a column-major affine matrix (LBS, CoR), a unit dual
// quaternion (DQS) and a unit quaternion (CoR).
#pragma once

#include <span>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/rig/transform.h"

namespace mimic::avatar::baselines {

// An affine transform as four columns of four floats (x, y, z, 0): the linear part's columns
// then the translation, p' = cols[0]·x + cols[1]·y + cols[2]·z + cols[3] — the layout of
// ozz-animation's Float4x4, so a 256-bit register holds two columns.
struct alignas(32) SkinningMatrix {
  float cols[4][4];
};

// Unit dual quaternion, real part (rotation) and dual part, each stored x, y, z, w.
struct alignas(32) DualQuat {
  float real[4];
  float dual[4];
};

SkinningMatrix to_skinning_matrix(const rig::RigidTransform& t);
DualQuat to_dual_quat(const rig::RigidTransform& t);

// joint_from_rest[j] = inverse(world_from_joint_rest[j]), once per body. Sizes must match.
void invert_transforms(std::span<const rig::RigidTransform> world_from_joint_rest,
                       std::span<rig::RigidTransform> joint_from_rest);

// The skinning transforms of one frame, written into the spans that are not empty (each either
// empty or joint-sized). Never allocates.
void skinning_transforms(std::span<const rig::RigidTransform> world_from_joint,
                         std::span<const rig::RigidTransform> joint_from_rest, std::span<SkinningMatrix> matrices,
                         std::span<DualQuat> dual_quats, std::span<glm::quat> rotations);

}  // namespace mimic::avatar::baselines
