#include "mimic/rig/skeleton.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <glm/gtx/norm.hpp>

namespace mimic::rig {

namespace {

constexpr float kDeg = 3.14159265358979f / 180.0f;

DofDesc dof(std::string name, glm::vec3 axis, float min_deg, float max_deg, float rest_deg = 0) {
  return DofDesc{std::move(name), axis, min_deg * kDeg, max_deg * kDeg, rest_deg * kDeg};
}

glm::vec3 mirror_axis(glm::vec3 a) { return {a.x, -a.y, -a.z}; }
glm::vec3 mirror_point(glm::vec3 p) { return {-p.x, p.y, p.z}; }

// Adds a left joint and its mirror image on the right ("l_" -> "r_").
void add_pair(SkeletonDesc& d, JointDesc left) {
  JointDesc right = left;
  auto swap_side = [](const std::string& s) { return s.rfind("l_", 0) == 0 ? "r_" + s.substr(2) : s; };
  right.name = swap_side(left.name);
  right.parent = swap_side(left.parent);
  right.offset_m = mirror_point(left.offset_m);
  right.tip_m = mirror_point(left.tip_m);
  for (auto& f : right.dofs) {
    f.name = swap_side(f.name);
    f.axis = mirror_axis(f.axis);
  }
  d.joints.push_back(std::move(left));
  d.joints.push_back(std::move(right));
}

JointDesc joint(std::string name, std::string parent, glm::vec3 offset, glm::vec3 tip, std::vector<DofDesc> dofs) {
  return JointDesc{std::move(name), std::move(parent), offset, tip, std::move(dofs)};
}

// Spine-like joint: flexion (forward), lateral bend (to the left), twist (turn left).
std::vector<DofDesc> spine_dofs(const std::string& n, float flex, float ext, float bend, float twist) {
  return {dof(n + "_flexion", {1, 0, 0}, -ext, flex), dof(n + "_lateral_bend", {0, 0, -1}, -bend, bend),
          dof(n + "_twist", {0, 1, 0}, -twist, twist)};
}

}  // namespace

// Proportions follow an average adult (1.67 m): joint heights from the floor are pelvis 0.89,
// hips 0.867, knees 0.449, ankles 0.073, spine 0.937/1.098/1.251, neck 1.407, skull base 1.516.
SkeletonDesc default_skeleton_desc() {
  SkeletonDesc d;
  const glm::vec3 X{1, 0, 0}, Y{0, 1, 0}, Z{0, 0, 1};
  d.joints.push_back(joint("pelvis", "", {0, 0, 0}, {0, 0.047f, 0}, {}));
  d.joints.push_back(
      joint("spine_lower", "pelvis", {0, 0.047f, 0}, {0, 0.161f, 0.0f}, spine_dofs("spine_lower", 45, 30, 25, 20)));
  d.joints.push_back(
      joint("spine_mid", "spine_lower", {0, 0.161f, 0.0f}, {0, 0.153f, 0}, spine_dofs("spine_mid", 35, 20, 20, 25)));
  d.joints.push_back(
      joint("spine_upper", "spine_mid", {0, 0.153f, 0}, {0, 0.156f, 0}, spine_dofs("spine_upper", 25, 20, 15, 20)));
  d.joints.push_back(joint("neck", "spine_upper", {0, 0.156f, 0}, {0, 0.055f, 0}, spine_dofs("neck", 40, 40, 30, 45)));
  d.joints.push_back(
      joint("neck_upper", "neck", {0, 0.055f, 0}, {0, 0.054f, 0.0f}, spine_dofs("neck_upper", 30, 40, 20, 45)));
  d.joints.push_back(
      joint("head", "neck_upper", {0, 0.054f, 0.0f}, {0, 0.150f, 0.02f}, spine_dofs("head", 30, 40, 20, 30)));

  // Legs (left; the right side mirrors). Thigh and shin hang along −Y, the foot points +Z.
  add_pair(d, joint("l_hip", "pelvis", {0.110f, -0.023f, 0}, {0, -0.418f, 0},
                    {dof("l_hip_flexion", -X, -30, 130), dof("l_hip_abduction", Z, -35, 70),
                     dof("l_hip_rotation", -Y, -50, 50)}));
  add_pair(d, joint("l_knee", "l_hip", {0, -0.418f, 0}, {0, -0.376f, 0}, {dof("l_knee_flexion", X, -5, 155)}));
  add_pair(d, joint("l_ankle", "l_knee", {0, -0.376f, 0}, {0, -0.055f, 0.135f},
                    {dof("l_ankle_flexion", -X, -60, 40), dof("l_ankle_inversion", -Z, -30, 40),
                     dof("l_ankle_abduction", Y, -40, 40)}));
  add_pair(d, joint("l_toes", "l_ankle", {0, -0.055f, 0.135f}, {0, 0, 0.065f}, {dof("l_toes_flexion", X, -60, 50)}));

  // Arms. Clavicles hang off the upper spine; upper arm, forearm and hand lie along +X.
  add_pair(d, joint("l_clavicle", "spine_upper", {0.020f, 0.090f, 0.040f}, {0.148f, 0, -0.040f},
                    {dof("l_clavicle_elevation", Z, -15, 40), dof("l_clavicle_protraction", -Y, -25, 30)}));
  add_pair(d, joint("l_shoulder", "l_clavicle", {0.148f, 0, -0.040f}, {0.228f, 0, 0},
                    {dof("l_shoulder_flexion", -Y, -90, 180), dof("l_shoulder_abduction", Z, -135, 120),
                     dof("l_shoulder_twist", -X, -120, 120)}));
  add_pair(d, joint("l_elbow", "l_shoulder", {0.228f, 0, 0}, {0.226f, 0, 0},
                    {dof("l_elbow_flexion", -Y, -5, 155), dof("l_forearm_twist", X, -100, 100)}));
  add_pair(d, joint("l_wrist", "l_elbow", {0.226f, 0, 0}, {0.180f, 0, 0},
                    {dof("l_wrist_flexion", -Z, -80, 80), dof("l_wrist_deviation", -Y, -30, 40)}));
  (void)Y;
  return d;
}

Result<Skeleton> Skeleton::build(const SkeletonDesc& desc) {
  const int n = static_cast<int>(desc.joints.size());
  if (n == 0) return fail(Errc::invalid_argument, "skeleton has no joints");
  std::unordered_map<std::string, int> by_name;
  int root = -1;
  for (int i = 0; i < n; ++i) {
    const auto& j = desc.joints[i];
    if (j.name.empty()) return fail(Errc::invalid_argument, "joint " + std::to_string(i) + " has no name");
    if (!by_name.emplace(j.name, i).second)
      return fail(Errc::invalid_argument, "duplicate joint name '" + j.name + "'");
    if (j.parent.empty()) {
      if (root >= 0)
        return fail(Errc::invalid_argument, "two roots: '" + desc.joints[root].name + "' and '" + j.name + "'");
      root = i;
    }
  }
  if (root < 0) return fail(Errc::invalid_argument, "skeleton has no root joint");
  std::vector<int> parent_of(n, -1);
  for (int i = 0; i < n; ++i) {
    const auto& j = desc.joints[i];
    if (j.parent.empty()) continue;
    auto it = by_name.find(j.parent);
    if (it == by_name.end())
      return fail(Errc::invalid_argument, "joint '" + j.name + "' names unknown parent '" + j.parent + "'");
    parent_of[i] = it->second;
  }
  // Parents-first order by breadth-first walk from the root, keeping file order among siblings.
  std::vector<int> order;
  order.reserve(n);
  order.push_back(root);
  for (size_t k = 0; k < order.size(); ++k)
    for (int i = 0; i < n; ++i)
      if (parent_of[i] == order[k]) order.push_back(i);
  if (static_cast<int>(order.size()) != n)
    return fail(Errc::invalid_argument, "skeleton has a cycle or joints unreachable from the root");

  Skeleton s;
  std::vector<int> packed_of(n);
  for (int k = 0; k < n; ++k) packed_of[order[k]] = k;
  std::unordered_map<std::string, int> dof_names;
  s.dof_begin_.push_back(0);
  for (int k = 0; k < n; ++k) {
    const auto& j = desc.joints[order[k]];
    s.names_.push_back(j.name);
    s.parents_.push_back(parent_of[order[k]] < 0 ? -1 : packed_of[parent_of[order[k]]]);
    s.offsets_m_.push_back(j.offset_m);
    s.tips_m_.push_back(j.tip_m);
    for (const auto& f : j.dofs) {
      if (!dof_names.emplace(f.name, 0).second)
        return fail(Errc::invalid_argument, "duplicate DOF name '" + f.name + "'");
      const float len = glm::length(f.axis);
      if (!(std::abs(len - 1.0f) < 1e-3f))
        return fail(Errc::invalid_argument, "DOF '" + f.name + "' axis is not a unit vector");
      if (!(f.min_rad <= f.rest_rad && f.rest_rad <= f.max_rad))
        return fail(Errc::invalid_argument, "DOF '" + f.name + "' needs min <= rest <= max");
      s.dofs_.push_back(Dof{f.name, k, f.axis / len, f.min_rad, f.max_rad, f.rest_rad});
    }
    s.dof_begin_.push_back(static_cast<int>(s.dofs_.size()));
  }
  return s;
}

SkeletonDesc Skeleton::desc() const {
  SkeletonDesc d;
  for (int j = 0; j < joint_count(); ++j) {
    JointDesc jd{names_[j], parents_[j] < 0 ? "" : names_[parents_[j]], offsets_m_[j], tips_m_[j], {}};
    for (int i = dof_begin(j); i < dof_end(j); ++i) {
      const auto& f = dofs_[i];
      jd.dofs.push_back(DofDesc{f.name, f.axis, f.min_rad, f.max_rad, f.rest_rad});
    }
    d.joints.push_back(std::move(jd));
  }
  return d;
}

int Skeleton::find_joint(std::string_view name) const {
  for (int j = 0; j < joint_count(); ++j)
    if (names_[j] == name) return j;
  return -1;
}

int Skeleton::find_dof(std::string_view name) const {
  for (int i = 0; i < dof_count(); ++i)
    if (dofs_[i].name == name) return i;
  return -1;
}

Pose Skeleton::rest_pose() const {
  Pose p;
  p.dof_rad.resize(dofs_.size());
  for (size_t i = 0; i < dofs_.size(); ++i) p.dof_rad[i] = dofs_[i].rest_rad;
  return p;
}

Pose Skeleton::zero_pose() const {
  Pose p;
  p.dof_rad.assign(dofs_.size(), 0.0f);
  return p;
}

glm::quat Skeleton::local_rotation(int j, std::span<const float> dof_rad) const {
  glm::quat r(1, 0, 0, 0);
  for (int i = dof_begin_[j]; i < dof_begin_[j + 1]; ++i) r = r * glm::angleAxis(dof_rad[i], dofs_[i].axis);
  return r;
}

void forward_kinematics(const Skeleton& skeleton, const Pose& pose, std::span<RigidTransform> world_from_joint) {
  const int n = skeleton.joint_count();
  const std::span<const float> dofs(pose.dof_rad);
  for (int j = 0; j < n; ++j) {
    const glm::quat local = skeleton.local_rotation(j, dofs);
    const int p = skeleton.parent(j);
    if (p < 0) {
      world_from_joint[j].rotation = glm::normalize(pose.root_orientation) * local;
      world_from_joint[j].translation = pose.root_position_m + pose.root_orientation * skeleton.offset_m(j);
    } else {
      const RigidTransform& wp = world_from_joint[p];
      world_from_joint[j].rotation = wp.rotation * local;
      world_from_joint[j].translation = wp.apply(skeleton.offset_m(j));
    }
  }
}

void clamp_to_limits(const Skeleton& skeleton, Pose& pose) {
  for (int i = 0; i < skeleton.dof_count(); ++i) {
    const Dof& f = skeleton.dof(i);
    pose.dof_rad[i] = std::clamp(pose.dof_rad[i], f.min_rad, f.max_rad);
  }
}

namespace {

float length_of(const Skeleton& s, const char* joint) {
  const int j = s.find_joint(joint);
  return j < 0 ? 0.0f : glm::length(s.offset_m(j));
}

float tip_length_of(const Skeleton& s, const char* joint) {
  const int j = s.find_joint(joint);
  return j < 0 ? 0.0f : glm::length(s.tip_m(j));
}

// Scales joint `name`'s offset to `length` and its parent's tip along with it.
void set_offset_length(SkeletonDesc& d, const std::string& name, float length) {
  if (length <= 0) return;
  for (auto& j : d.joints) {
    if (j.name != name) continue;
    const float old = glm::length(j.offset_m);
    if (old <= 0) return;
    const glm::vec3 old_offset = j.offset_m;
    j.offset_m *= length / old;
    for (auto& p : d.joints)
      if (p.name == j.parent && glm::length2(p.tip_m - old_offset) < 1e-10f) p.tip_m = j.offset_m;
  }
}

void set_tip_length(SkeletonDesc& d, const std::string& name, float length) {
  if (length <= 0) return;
  for (auto& j : d.joints) {
    const float old = glm::length(j.tip_m);
    if (j.name == name && old > 0) j.tip_m *= length / old;
  }
}

}  // namespace

Proportions measure_proportions(const Skeleton& s) {
  Proportions p;
  const int lh = s.find_joint("l_hip"), rh = s.find_joint("r_hip");
  if (lh >= 0 && rh >= 0) p.hip_width_m = glm::length(s.offset_m(lh) - s.offset_m(rh));
  p.thigh_m = length_of(s, "l_knee");
  p.shin_m = length_of(s, "l_ankle");
  p.foot_m = length_of(s, "l_toes");
  p.spine_lower_m = length_of(s, "spine_mid");
  p.spine_mid_m = length_of(s, "spine_upper");
  p.spine_upper_m = length_of(s, "neck");
  p.neck_m = length_of(s, "neck_upper") + length_of(s, "head");
  p.head_m = tip_length_of(s, "head");
  const int ls = s.find_joint("l_shoulder"), rs = s.find_joint("r_shoulder");
  if (ls >= 0 && rs >= 0) {
    const int lc = s.parent(ls), rc = s.parent(rs);
    p.shoulder_width_m = glm::length((s.offset_m(lc) + s.offset_m(ls)) - (s.offset_m(rc) + s.offset_m(rs)));
  }
  p.upper_arm_m = length_of(s, "l_elbow");
  p.forearm_m = length_of(s, "l_wrist");
  p.hand_m = tip_length_of(s, "l_wrist");
  p.pelvis_height_m = standing_root_height_m(s);
  return p;
}

void apply_proportions(SkeletonDesc& d, const Proportions& p) {
  for (const char* side : {"l_", "r_"}) {
    const std::string s(side);
    if (p.hip_width_m > 0)
      for (auto& j : d.joints)
        if (j.name == s + "hip") j.offset_m.x = (s == "l_" ? 0.5f : -0.5f) * p.hip_width_m;
    set_offset_length(d, s + "knee", p.thigh_m);
    set_offset_length(d, s + "ankle", p.shin_m);
    set_offset_length(d, s + "toes", p.foot_m);
    set_offset_length(d, s + "elbow", p.upper_arm_m);
    set_offset_length(d, s + "wrist", p.forearm_m);
    set_tip_length(d, s + "wrist", p.hand_m);
    if (p.shoulder_width_m > 0) {
      // Shoulder joint x = clavicle x + shoulder offset x; keep the clavicle, move the shoulder.
      float clav_x = 0;
      for (auto& j : d.joints)
        if (j.name == s + "clavicle") clav_x = std::abs(j.offset_m.x);
      for (auto& j : d.joints)
        if (j.name == s + "shoulder") {
          const glm::vec3 old = j.offset_m;
          j.offset_m.x = (s == "l_" ? 1.0f : -1.0f) * std::max(0.0f, 0.5f * p.shoulder_width_m - clav_x);
          for (auto& c : d.joints)
            if (c.name == s + "clavicle" && glm::length2(c.tip_m - old) < 1e-10f) c.tip_m = j.offset_m;
        }
    }
  }
  set_offset_length(d, "spine_mid", p.spine_lower_m);
  set_offset_length(d, "spine_upper", p.spine_mid_m);
  set_offset_length(d, "neck", p.spine_upper_m);
  if (p.neck_m > 0) {
    set_offset_length(d, "neck_upper", 0.5f * p.neck_m);
    set_offset_length(d, "head", 0.5f * p.neck_m);
  }
  set_tip_length(d, "head", p.head_m);
}

float standing_root_height_m(const Skeleton& s) {
  const Pose zero = s.zero_pose();
  std::vector<RigidTransform> w(s.joint_count());
  forward_kinematics(s, zero, w);
  float lowest = 0;
  for (int j = 0; j < s.joint_count(); ++j) {
    lowest = std::min(lowest, w[j].translation.y);
    lowest = std::min(lowest, w[j].apply(s.tip_m(j)).y);
  }
  // Joint centres sit above the skin; the sole is about 1.8 cm below the toe joint.
  return -lowest + 0.018f;
}

}  // namespace mimic::rig
