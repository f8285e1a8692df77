// Joint angles from rotations: the DOF values of a joint that reproduce (or best approximate)
// a target local rotation, for a joint whose rotation is a product of DOF rotations
//   R = R(a0, θ0) · R(a1, θ1) · R(a2, θ2) …     (axes a_i unit vectors in the joint frame,
//                                                  each applied in the frame left by the previous)
// as in skeleton.h. Used by retargeting and by the tracker solver.
//
// Continuity: a rotation has many angle sets (every θ + 2πk, and for three axes a second Euler
// branch). Every function takes the values of an earlier frame (`previous`) and returns the
// solution nearest to them, so a sequence of nearby rotations gives a sequence of nearby angles
// that never flips at ±180°. Angles are therefore not wrapped into (−π, π].
//
// Exactness:
//  - 3 mutually orthogonal axes: exact (Euler decomposition; in gimbal lock θ0 keeps its
//    previous value and θ2 takes the rest).
//  - 1 axis: the closest rotation about the axis (the twist part of a swing–twist split).
//  - 2 axes, or any other set: best fit (least rotation angle between result and target),
//    found by exact per-axis minimisation from the Euler solution.
// No allocation; spans must all have axes.size() elements, 1 ≤ axes.size() ≤ kMaxJointDofs.
#pragma once

#include <span>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/rig/skeleton.h"

namespace mimic::rig {

inline constexpr int kMaxJointDofs = 6;

// R(a0, θ0) · R(a1, θ1) · … for the given axes and values.
glm::dquat rotation_from_dofs(std::span<const glm::dvec3> axes, std::span<const double> values_rad);

// DOF values that make rotation_from_dofs(axes, out) equal (or nearest) `target`.
// [in] axes, target (need not be normalised), previous_rad; [out] out_rad.
// lock_cos: for three orthogonal axes, the cosine of the middle angle under which the first and
// third axes count as aligned (gimbal lock): the first angle keeps its previous value and the
// third takes the rest of the rotation. Below the input's rounding noise the first angle is
// noise: a double's rounding moves that cosine by ~2e-8 at lock, a float's by ~4e-4, so a
// rotation that was computed in floats needs kFloatLockCos.
inline constexpr double kDoubleLockCos = 1e-7;
inline constexpr double kFloatLockCos = 1e-3;
void dofs_from_rotation(std::span<const glm::dvec3> axes, const glm::dquat& target,
                        std::span<const double> previous_rad, std::span<double> out_rad,
                        double lock_cos = kDoubleLockCos);

// 1 or 2 DOFs: values that turn direction `from` (joint frame, zero posture) onto `to` (same
// frame), e.g. a clavicle's link onto a measured shoulder position. Returns false (and the
// closest reachable direction) when `to` cannot be reached exactly. Twist about the link is
// whatever the axes imply.
bool dofs_aim(std::span<const glm::dvec3> axes, const glm::dvec3& from, const glm::dvec3& to,
              std::span<const double> previous_rad, std::span<double> out_rad);

// Skeleton joint j: solves its DOFs for a target local rotation (parent_from_joint without
// the offset). dof_rad is a whole Pose::dof_rad array: the joint's entries are read as the
// previous values and overwritten. Other entries are untouched.
void solve_joint_dofs(const Skeleton& skeleton, int joint, const glm::dquat& local, std::span<float> dof_rad);

// Nearest equivalent of an angle to a reference: angle + 2πk closest to `near_rad`.
double unwrap_near(double angle_rad, double near_rad);

}  // namespace mimic::rig
