// The human skeleton: named joints in a tree, each with ordered rotational DOFs (named, with
// limits [min, max] and a relaxed value θ0), plus forward kinematics.
//
// Frames: +Y up, the body faces +Z, the character's left is +X, metres. Every joint frame is
// parallel to the world frame in the zero posture (all DOFs 0): a T-pose with arms along ±X,
// palms down, legs straight, feet pointing +Z. A joint's local rotation is the product of its
// DOF rotations in listed order, R = R(axis0, θ0) · R(axis1, θ1) · …, axes in the joint frame.
// Right-side axes mirror left-side ones: (x, y, z) -> (x, −y, −z), so equal angles give
// mirror-image postures.
//
// Authored form (SkeletonDesc: a list of joints naming their parents, editable, file-backed)
// is kept apart from the packed runtime form (Skeleton: flat arrays, parents before children).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/rig/transform.h"
#include "mimic/core/result.h"

namespace mimic::rig {

struct DofDesc {
  std::string name;         // e.g. "l_elbow_flexion"
  glm::vec3 axis{1, 0, 0};  // unit axis in the joint frame
  float min_rad = -3.14159265f;
  float max_rad = 3.14159265f;
  float rest_rad = 0.0f;  // θ0, the relaxed value
};

struct JointDesc {
  std::string name;          // e.g. "l_elbow"
  std::string parent;        // empty for the root
  glm::vec3 offset_m{0.0f};  // joint position in the parent frame, zero posture
  glm::vec3 tip_m{0.0f};     // far end of this joint's link in its own frame (the link's axis)
  std::vector<DofDesc> dofs;
};

struct SkeletonDesc {
  std::vector<JointDesc> joints;  // the root first; any order after (parents resolved by name)
};

struct Pose {
  glm::vec3 root_position_m{0.0f};                     // world position of the root joint
  glm::quat root_orientation{1.0f, 0.0f, 0.0f, 0.0f};  // world_from_root rotation
  std::vector<float> dof_rad;                          // one value per skeleton DOF
};

struct Dof {
  std::string name;
  int joint = -1;
  glm::vec3 axis{1, 0, 0};
  float min_rad = 0, max_rad = 0, rest_rad = 0;
};

class Skeleton {
 public:
  // Validates (unique names, one root, known parents, no cycles, unit axes, min ≤ θ0 ≤ max)
  // and packs the joints parents-first.
  static Result<Skeleton> build(const SkeletonDesc& desc);

  SkeletonDesc desc() const;  // back to the authored form

  int joint_count() const { return static_cast<int>(names_.size()); }
  int dof_count() const { return static_cast<int>(dofs_.size()); }
  int find_joint(std::string_view name) const;  // -1 if absent
  int find_dof(std::string_view name) const;    // -1 if absent

  const std::string& joint_name(int j) const { return names_[j]; }
  int parent(int j) const { return parents_[j]; }
  std::span<const int> parents() const { return parents_; }
  const glm::vec3& offset_m(int j) const { return offsets_m_[j]; }
  const glm::vec3& tip_m(int j) const { return tips_m_[j]; }
  int dof_begin(int j) const { return dof_begin_[j]; }
  int dof_end(int j) const { return dof_begin_[j + 1]; }
  const Dof& dof(int i) const { return dofs_[i]; }
  std::span<const Dof> dofs() const { return dofs_; }

  void set_offset_m(int j, const glm::vec3& offset) { offsets_m_[j] = offset; }
  void set_tip_m(int j, const glm::vec3& tip) { tips_m_[j] = tip; }

  // θ0 for every DOF, root at the origin with identity orientation.
  Pose rest_pose() const;
  // All DOFs zero (the T-pose the frames are defined in).
  Pose zero_pose() const;

  // Local rotation of joint j from its DOF values (dof_rad indexed by skeleton DOF).
  glm::quat local_rotation(int j, std::span<const float> dof_rad) const;

 private:
  std::vector<std::string> names_;
  std::vector<int> parents_;
  std::vector<glm::vec3> offsets_m_;
  std::vector<glm::vec3> tips_m_;
  std::vector<int> dof_begin_;  // joint_count + 1 entries
  std::vector<Dof> dofs_;
};

// world_from_joint[j] for every joint; world_from_joint.size() == skeleton.joint_count().
// Never allocates.
void forward_kinematics(const Skeleton& skeleton, const Pose& pose, std::span<RigidTransform> world_from_joint);

// Clamps every DOF into [min, max].
void clamp_to_limits(const Skeleton& skeleton, Pose& pose);

// Mimic's default adult skeleton (about 1.67 m tall) in the zero posture; see skeleton.cpp for
// the joint and DOF list.
SkeletonDesc default_skeleton_desc();

// Segment lengths that fit a skeleton to a performer. A zero entry keeps the default.
struct Proportions {
  float hip_width_m = 0;  // between hip joint centres
  float thigh_m = 0, shin_m = 0, foot_m = 0;
  float spine_lower_m = 0, spine_mid_m = 0, spine_upper_m = 0;
  float neck_m = 0, head_m = 0;
  float shoulder_width_m = 0;  // between shoulder joint centres
  float upper_arm_m = 0, forearm_m = 0, hand_m = 0;
  float pelvis_height_m = 0;  // root height above the floor in the zero posture
};

Proportions measure_proportions(const Skeleton& skeleton);
// Rescales each segment's offsets (and the child chain's tips) so its length matches.
void apply_proportions(SkeletonDesc& desc, const Proportions& proportions);

// Height of the root above the floor (lowest foot point) in the zero posture.
float standing_root_height_m(const Skeleton& skeleton);

}  // namespace mimic::rig
