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

// The joints' world rotations in the standing posture, arms at the sides: the frame the
// operators act in (the zero posture is a T-pose: scaling it laterally would lengthen the arms,
// not widen the body).
struct StandingFrames {
  const rig::Skeleton& skeleton;
  std::vector<rig::RigidTransform> world;
  explicit StandingFrames(const rig::Skeleton& s) : skeleton(s), world(static_cast<size_t>(s.joint_count())) {
    rig::forward_kinematics(s, standing_posture(s), world);
  }
  glm::mat3 rotation(const std::string& joint) const {
    const int j = skeleton.find_joint(joint);
    return j < 0 ? glm::mat3(1.0f) : glm::mat3_cast(world[j].rotation);
  }
};

// A vector of a joint's frame, scaled per world axis: W^T diag(k) W v.
glm::vec3 scaled(const glm::mat3& rot, const glm::vec3& k, const glm::vec3& v) {
  return glm::transpose(rot) * (k * (rot * v));
}

// Centre scaled about the joint and moved by `shift_world`; each principal axis takes the
// factor of its dominant world direction. Deformed states alike.
void scale_primitive(Primitive& prim, const glm::mat3& rot, const glm::vec3& k, const glm::vec3& shift_world) {
  auto scale_state = [&](PrimitiveState& st) {
    st.center_m = scaled(rot, k, st.center_m) + glm::transpose(rot) * shift_world;
    const glm::mat3 r = glm::mat3(glm::eulerAngleZ(st.orientation_rad.z) * glm::eulerAngleY(st.orientation_rad.y) *
                                  glm::eulerAngleX(st.orientation_rad.x));
    for (int a = 0; a < 3; ++a) st.semi_axes_m[a] *= k[scaling_tag(rot * r[a])];
  };
  scale_state(prim.state);
  if (prim.deformation) scale_state(prim.deformation->at_min), scale_state(prim.deformation->at_max);
}

bool valid_factor(float f) { return f > 0.0f && std::isfinite(f) && f <= 10.0f; }

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
    if (!valid_factor(f)) return fail(Errc::invalid_argument, "scaling factors must be finite and in (0, 10]");
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

  const StandingFrames frames(*skeleton);
  BodyModel out = model;
  for (auto& j : out.skeleton.joints) {
    const glm::vec3 k = scale_of(j.name);
    if (!j.parent.empty()) j.offset_m = scaled(frames.rotation(j.parent), k, j.offset_m);
    j.tip_m = scaled(frames.rotation(j.name), k, j.tip_m);
  }
  for (auto& prim : out.primitives) scale_primitive(prim, frames.rotation(prim.joint), scale_of(prim.joint), {});
  // The crotch ring hangs a distance below the pelvis joint that scales with the legs' heights:
  // kept at the adult's 8.5 cm, a child's ring reached into the thighs and folded them.
  out.skin.crotch_drop_m *= low_v;
  if (auto st = validate(out); !st) return tl::unexpected(st.error());
  return out;
}

}  // namespace mimic::avatar

namespace mimic::avatar {

Result<BodyModel> reshape_body(const BodyModel& model, std::span<const ShapeChange> changes) {
  auto skeleton = rig::Skeleton::build(model.skeleton);
  if (!skeleton) return tl::unexpected(skeleton.error());
  const StandingFrames frames(*skeleton);
  BodyModel out = model;
  for (const ShapeChange& c : changes) {
    if (!valid_factor(c.scale.x) || !valid_factor(c.scale.y) || !valid_factor(c.scale.z) ||
        !std::isfinite(glm::dot(c.shift_m, c.shift_m)))
      return fail(Errc::invalid_argument, "shape change of '" + std::string(c.primitives) + "': bad factor or shift");
    std::string_view rest = c.primitives;
    while (!rest.empty()) {
      const size_t space = rest.find(' ');
      const std::string token(rest.substr(0, space));
      rest = space == std::string_view::npos ? std::string_view() : rest.substr(space + 1);
      if (token.empty()) continue;
      const auto part = token.rfind("part:", 0) == 0 ? rigid_part_from_name(token.substr(5)) : std::nullopt;
      const bool left = token.rfind("l_", 0) == 0;
      const std::string right = left ? "r_" + token.substr(2) : std::string();
      int matched = 0;
      for (Primitive& p : out.primitives) {
        const bool mirror = left && p.name == right;
        if (!(part ? p.part == *part : p.name == token || mirror)) continue;
        const glm::vec3 shift = mirror ? glm::vec3(-c.shift_m.x, c.shift_m.y, c.shift_m.z) : c.shift_m;
        scale_primitive(p, frames.rotation(p.joint), c.scale, shift);
        ++matched;
      }
      if (matched == 0) return fail(Errc::invalid_argument, "shape change: no primitive '" + token + "'");
    }
  }
  if (auto st = validate(out); !st) return tl::unexpected(st.error());
  return out;
}

}  // namespace mimic::avatar
