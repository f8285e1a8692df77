// Rotations to named DOF values: a joint's local rotation R = R(a0, θ0) · R(a1, θ1) · R(a2, θ2)
// (axes in the joint frame, as in rig/skeleton.h) is decomposed back into θ.
//
// The decomposition itself is rig/joint_angles.h's (exact Euler for three orthogonal axes,
// the twist for one, the best fit for two), nearest the previous values; on top of it this adds
// the joint limits: of that solution, the other Euler branch and every angle ± 2π, the candidate
// inside the limits and nearest the previous values wins, so a joint passing ±180° or gimbal
// lock neither flips nor lands outside its range when an equivalent inside exists. Never
// allocates.
#pragma once

#include <span>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/rig/skeleton.h"

namespace mimic::solver {

// Signed angle of the twist of q about the unit axis (swing–twist decomposition q = swing·twist),
// in (−π, π].
float twist_angle_rad(const glm::quat& q, const glm::vec3& axis);

// Decomposes `local` over 1–3 mutually orthogonal unit axes (axes.size() == angles.size()).
// [in] angles_rad: previous values (the warm start); [out] the new values. With fewer than three
// axes, the nearest rotation the axes can express (one axis: the twist about it).
// min_rad/max_rad (same size, may be empty) steer the branch choice; values are not clamped.
void angles_from_rotation(const glm::quat& local, std::span<const glm::vec3> axes, std::span<float> angles_rad,
                          std::span<const float> min_rad = {}, std::span<const float> max_rad = {});

// Joint j's DOFs from its local rotation, written into dof_rad (indexed by skeleton DOF, the
// current values are the warm start), clamped to the joint limits.
void joint_dofs_from_rotation(const rig::Skeleton& skeleton, int joint, const glm::quat& local,
                              std::span<float> dof_rad);

// Up to three skeleton DOFs (indices, in the order their rotations compose, possibly spanning
// joints along one chain) from one rotation, clamped to their limits. Used for forearm twist +
// wrist, which together orient the hand.
void dofs_from_rotation(const rig::Skeleton& skeleton, std::span<const int> dofs, const glm::quat& rotation,
                        std::span<float> dof_rad);

}  // namespace mimic::solver
