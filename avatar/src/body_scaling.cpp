#include <algorithm>
#include <cmath>
#include <set>

#include <glm/gtx/euler_angles.hpp>

#include "mimic/avatar/body_model.h"

namespace mimic::avatar {

namespace {

// Joints of the lower region: the pelvis and everything hanging from a hip.
std::set<std::string> lower_region(const rig::SkeletonDesc& d) {
  std::set<std::string> lower{d.joints.empty() ? "" : d.joints.front().name};
  bool grew = true;
  while (grew) {
    grew = false;
    for (const auto& j : d.joints) {
      const bool hip_chain =
          j.name.find("hip") != std::string::npos || (lower.count(j.parent) && j.parent != d.joints.front().name);
      if (!lower.count(j.name) && hip_chain) grew = lower.insert(j.name).second;
    }
  }
  return lower;
}

}  // namespace

int scaling_tag(const glm::vec3& axis_world) {
  const glm::vec3 a = glm::abs(axis_world);
  return a.x >= a.y && a.x >= a.z ? 0 : a.y >= a.z ? 1 : 2;
}

rig::Pose standing_posture(const rig::Skeleton& skeleton) {
  rig::Pose p = skeleton.zero_pose();
  std::vector<rig::RigidTransform> w(skeleton.joint_count());
  for (const char* side : {"l_", "r_"}) {
    const std::string s = side;
    const int dof = skeleton.find_dof(s + "shoulder_abduction");
    const int shoulder = skeleton.find_joint(s + "shoulder");
    if (dof < 0 || shoulder < 0) continue;
    // Whichever quarter turn lowers the upper arm's tip below the shoulder.
    for (float a : {-1.5707964f, 1.5707964f}) {
      p.dof_rad[dof] = a;
      rig::forward_kinematics(skeleton, p, w);
      if (w[shoulder].apply(skeleton.tip_m(shoulder)).y <
          w[shoulder].translation.y - 0.5f * glm::length(skeleton.tip_m(shoulder)))
        break;
      p.dof_rad[dof] = 0;
    }
  }
  return p;
}

rig::Pose relaxed_posture(const rig::Skeleton& skeleton) {
  // From the relaxed DOF values (θ0), the upper arms lowered most of the way: hanging straight
  // down they would press into the hips, so they stay 18° out, and the elbows bend a little.
  const rig::Pose down = standing_posture(skeleton);
  rig::Pose p = skeleton.rest_pose();
  constexpr float kArmDownFraction = 0.8f;
  constexpr float kElbowFlexion_rad = 0.2f;
  for (const char* side : {"l_", "r_"}) {
    const std::string s = side;
    if (const int dof = skeleton.find_dof(s + "shoulder_abduction"); dof >= 0)
      p.dof_rad[dof] = kArmDownFraction * down.dof_rad[dof];
    if (const int dof = skeleton.find_dof(s + "elbow_flexion"); dof >= 0)
      p.dof_rad[dof] = std::clamp(kElbowFlexion_rad, skeleton.dof(dof).min_rad, skeleton.dof(dof).max_rad);
  }
  return p;
}

Result<BodyModel> scale_body(const BodyModel& model, const BodyScaling& s) {
  for (float f :
       {s.total_height, s.frontal_scaling, s.high_lateral_scaling, s.low_lateral_scaling, s.spine_origin_ratio})
    if (!(f > 0.0f) || !std::isfinite(f) || f > 10.0f)
      return fail(Errc::invalid_argument, "scaling factors must be finite and in (0, 10]");
  auto skeleton = rig::Skeleton::build(model.skeleton);
  if (!skeleton) return tl::unexpected(skeleton.error());

  // Heights of the zero posture standing on the floor: spine origin and top of the head.
  const float origin_h = rig::standing_root_height_m(*skeleton);
  rig::Pose p = skeleton->zero_pose();
  p.root_position_m.y = origin_h;
  std::vector<rig::RigidTransform> w(skeleton->joint_count());
  rig::forward_kinematics(*skeleton, p, w);
  float top_h = 0;
  for (int j = 0; j < skeleton->joint_count(); ++j) top_h = std::max(top_h, w[j].apply(skeleton->tip_m(j)).y);
  if (!(top_h > origin_h)) return fail(Errc::invalid_argument, "skeleton has no height above its root");
  // Below the spine origin heights scale by the ratio; above, so that the total is kept.
  const float low_v = s.total_height * s.spine_origin_ratio;
  const float high_v = s.total_height * (top_h - s.spine_origin_ratio * origin_h) / (top_h - origin_h);
  if (!(high_v > 0.0f)) return fail(Errc::invalid_argument, "spine_origin_ratio leaves no room for the upper body");
  const glm::vec3 low_scale{s.total_height * s.low_lateral_scaling, low_v, s.total_height * s.frontal_scaling};
  const glm::vec3 high_scale{s.total_height * s.high_lateral_scaling, high_v, s.total_height * s.frontal_scaling};

  const std::set<std::string> lower = lower_region(model.skeleton);
  auto scale_of = [&](const std::string& joint) { return lower.count(joint) ? low_scale : high_scale; };

  // The operators act in the world frame of the standing posture, arms at the sides (the zero
  // posture is a T-pose: scaling it laterally would lengthen the arms, not widen the body).
  std::vector<rig::RigidTransform> standing(static_cast<size_t>(skeleton->joint_count()));
  rig::forward_kinematics(*skeleton, standing_posture(*skeleton), standing);
  auto world_rotation = [&](const std::string& joint) {
    const int j = skeleton->find_joint(joint);
    return j < 0 ? glm::mat3(1.0f) : glm::mat3_cast(standing[j].rotation);
  };
  // A vector of a joint's frame, scaled per world axis: W^T diag(k) W v.
  auto scaled = [](const glm::mat3& rot, const glm::vec3& k, const glm::vec3& v) {
    return glm::transpose(rot) * (k * (rot * v));
  };

  BodyModel out = model;
  for (auto& j : out.skeleton.joints) {
    const glm::vec3 k = scale_of(j.name);
    if (!j.parent.empty()) j.offset_m = scaled(world_rotation(j.parent), k, j.offset_m);
    j.tip_m = scaled(world_rotation(j.name), k, j.tip_m);
  }
  auto scale_state = [&](PrimitiveState& st, const glm::mat3& rot, const glm::vec3& k) {
    st.center_m = scaled(rot, k, st.center_m);
    // Each principal axis takes the factor of its dominant world direction.
    const glm::mat3 r = glm::mat3(glm::eulerAngleZ(st.orientation_rad.z) * glm::eulerAngleY(st.orientation_rad.y) *
                                  glm::eulerAngleX(st.orientation_rad.x));
    for (int a = 0; a < 3; ++a) st.semi_axes_m[a] *= k[scaling_tag(rot * r[a])];
  };
  for (auto& prim : out.primitives) {
    const glm::vec3 k = scale_of(prim.joint);
    const glm::mat3 rot = world_rotation(prim.joint);
    scale_state(prim.state, rot, k);
    if (prim.deformation) {
      scale_state(prim.deformation->at_min, rot, k);
      scale_state(prim.deformation->at_max, rot, k);
    }
  }
  if (auto st = validate(out); !st) return tl::unexpected(st.error());
  return out;
}

}  // namespace mimic::avatar
