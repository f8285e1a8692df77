#include "mimic/avatar/wearer_body.h"

#include <algorithm>
#include <cmath>

#include <glm/gtx/euler_angles.hpp>

namespace mimic::avatar {

namespace {

rig::JointDesc* find(rig::SkeletonDesc& d, const std::string& name) {
  for (auto& j : d.joints)
    if (j.name == name) return &j;
  return nullptr;
}

// A primitive follows its link's new length: the part of its centre along the link, and a
// semi-axis lying along it (within 37°), scale with the link.
void follow_link(PrimitiveState& st, const glm::vec3& u, float s) {
  st.center_m += (s - 1.0f) * glm::dot(st.center_m, u) * u;
  const glm::mat3 r = glm::mat3(glm::eulerAngleZ(st.orientation_rad.z) * glm::eulerAngleY(st.orientation_rad.y) *
                                glm::eulerAngleX(st.orientation_rad.x));
  for (int a = 0; a < 3; ++a)
    if (std::abs(glm::dot(r[a], u)) > 0.8f) st.semi_axes_m[a] *= s;
}

// The link of `joint` (its tip and the offset of `child`) scaled by `s`, its primitives following.
void scale_link(BodyModel& m, const std::string& joint, const std::string& child, float s) {
  rig::JointDesc* j = find(m.skeleton, joint);
  rig::JointDesc* c = find(m.skeleton, child);
  if (!j || !c || !(glm::length(c->offset_m) > 1e-6f)) return;
  const glm::vec3 u = glm::normalize(c->offset_m);
  c->offset_m *= s;
  if (glm::length(j->tip_m - c->offset_m / s) < 1e-5f) j->tip_m = c->offset_m;
  for (Primitive& p : m.primitives) {
    if (p.joint != joint) continue;
    follow_link(p.state, u, s);
    if (p.deformation) follow_link(p.deformation->at_min, u, s), follow_link(p.deformation->at_max, u, s);
  }
}

float ratio(float wearer, float reference) { return reference > 1e-6f ? wearer / reference : 1.0f; }

}  // namespace

SkeletonBuild measure_build(const rig::Skeleton& skeleton) {
  SkeletonBuild b;
  b.limbs = rig::measure_proportions(skeleton);
  b.root_height_m = rig::standing_root_height_m(skeleton);
  rig::Pose p = skeleton.zero_pose();
  p.root_position_m = {0, b.root_height_m, 0};
  std::vector<rig::RigidTransform> w(static_cast<size_t>(skeleton.joint_count()));
  rig::forward_kinematics(skeleton, p, w);
  for (int j = 0; j < skeleton.joint_count(); ++j) b.height_m = std::max(b.height_m, w[j].apply(skeleton.tip_m(j)).y);
  return b;
}

WearerRatios wearer_ratios(const SkeletonBuild& w, const SkeletonBuild& r) {
  WearerRatios out;
  out.height = ratio(w.height_m, r.height_m);
  out.root_height = ratio(w.root_height_m, r.root_height_m);
  out.shoulder_width = ratio(w.limbs.shoulder_width_m, r.limbs.shoulder_width_m);
  out.hip_width = ratio(w.limbs.hip_width_m, r.limbs.hip_width_m);
  // A stand-still marks the shoulder, hand, hip and foot, not where along the limb the elbow or
  // knee bends: each limb's segments take the whole limb's ratio (the body keeps its split).
  out.upper_arm = out.forearm = ratio(w.limbs.upper_arm_m + w.limbs.forearm_m, r.limbs.upper_arm_m + r.limbs.forearm_m);
  out.thigh = out.shin = ratio(w.limbs.thigh_m + w.limbs.shin_m, r.limbs.thigh_m + r.limbs.shin_m);
  return out;
}

BodyScaling scaling_for(const WearerRatios& r) {
  BodyScaling s;
  s.total_height = r.height;
  s.spine_origin_ratio = r.root_height / r.height;
  s.high_lateral_scaling = r.shoulder_width / r.height;
  s.low_lateral_scaling = r.hip_width / r.height;
  s.frontal_scaling = 0.5f * (s.high_lateral_scaling + s.low_lateral_scaling);
  return s;
}

Result<BodyModel> wearer_body(const BodyModel& base, const WearerRatios& r) {
  for (float f : {r.height, r.root_height, r.shoulder_width, r.hip_width, r.upper_arm, r.forearm, r.thigh, r.shin})
    if (!(f > 0.0f) || !std::isfinite(f) || f > 10.0f)
      return fail(Errc::invalid_argument, "wearer body: proportions must be finite and positive");
  auto base_skeleton = rig::Skeleton::build(base.skeleton);
  if (!base_skeleton) return tl::unexpected(base_skeleton.error());
  const rig::Proportions before = rig::measure_proportions(*base_skeleton);
  auto scaled = scale_body(base, scaling_for(r));
  if (!scaled) return scaled;
  auto scaled_skeleton = rig::Skeleton::build(scaled->skeleton);
  if (!scaled_skeleton) return tl::unexpected(scaled_skeleton.error());
  const rig::Proportions now = rig::measure_proportions(*scaled_skeleton);
  // The operators scale the limbs with the height; each limb is then set to its own ratio.
  for (const char* side : {"l_", "r_"}) {
    const std::string s = side;
    scale_link(*scaled, s + "shoulder", s + "elbow", ratio(before.upper_arm_m * r.upper_arm, now.upper_arm_m));
    scale_link(*scaled, s + "elbow", s + "wrist", ratio(before.forearm_m * r.forearm, now.forearm_m));
    scale_link(*scaled, s + "hip", s + "knee", ratio(before.thigh_m * r.thigh, now.thigh_m));
    scale_link(*scaled, s + "knee", s + "ankle", ratio(before.shin_m * r.shin, now.shin_m));
  }
  if (auto st = validate(*scaled); !st) return tl::unexpected(st.error());
  return scaled;
}

}  // namespace mimic::avatar
