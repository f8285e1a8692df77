#include "mimic/avatar/appearance.h"

#include <algorithm>
#include <cmath>

namespace mimic::avatar {
namespace {

// 0 well below `edge`, 1 well above, a smooth ramp `width` wide across it.
float above(float value, float edge, float width) {
  const float t = std::clamp((value - edge) / width + 0.5f, 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

struct Landmarks {
  float waist_y = 0, thigh_hem_y = 0, ankle_y = 0;
  glm::vec3 neck{0.0f};
  float shoulder_x = 0, sleeve_hem_x = 0;  // |x| of the shoulder joints and of the sleeves' hem
  bool top = false, shorts = false, shoes = false;
};

Landmarks landmarks(const rig::Skeleton& skeleton) {
  std::vector<rig::RigidTransform> joints(static_cast<size_t>(skeleton.joint_count()));
  rig::forward_kinematics(skeleton, skeleton.zero_pose(), joints);
  auto at = [&](const char* name, glm::vec3& out) {
    const int j = skeleton.find_joint(name);
    if (j >= 0) out = joints[static_cast<size_t>(j)].translation;
    return j >= 0;
  };
  Landmarks m;
  glm::vec3 lower, mid, hip, knee, ankle, shoulder, elbow;
  const bool spine = at("spine_lower", lower) && at("spine_mid", mid);
  // The waist (the narrowest girth, near the navel) lies a little under halfway up the lumbar link.
  if (spine) m.waist_y = lower.y + 0.45f * (mid.y - lower.y);
  if (spine && at("l_hip", hip) && at("l_knee", knee)) {
    m.shorts = true;
    m.thigh_hem_y = hip.y + 0.42f * (knee.y - hip.y);  // shorts end part way down the thigh
  }
  if (at("l_ankle", ankle)) {
    m.shoes = true;
    m.ankle_y = ankle.y + 0.01f;
  }
  if (spine && at("neck", m.neck) && at("l_shoulder", shoulder) && at("l_elbow", elbow)) {
    m.top = true;
    m.shoulder_x = std::abs(shoulder.x);
    m.sleeve_hem_x = m.shoulder_x + 0.4f * std::abs(elbow.x - shoulder.x);  // short sleeves
  }
  return m;
}

}  // namespace

std::vector<glm::vec3> clothing_albedo(const rig::Skeleton& skeleton, std::span<const glm::vec3> zero_pose_positions_m,
                                       const Wardrobe& wardrobe) {
  const Landmarks m = landmarks(skeleton);
  const float e = std::max(wardrobe.edge_m, 1e-3f);
  std::vector<glm::vec3> albedo;
  albedo.reserve(zero_pose_positions_m.size());
  for (const glm::vec3& p : zero_pose_positions_m) {
    glm::vec3 c = wardrobe.skin;
    if (m.shorts) {
      // Up to just over the waist, where the top's hem overlaps it.
      const float s = above(p.y, m.thigh_hem_y, e) * (1.0f - above(p.y, m.waist_y + 0.02f, e));
      c = glm::mix(c, wardrobe.shorts, s);
    }
    if (m.top) {
      // The neckline: a round collar behind, a rounded scoop in front, rising as a parabola
      // away from the middle so the shoulders stay covered.
      const float r = std::abs(p.x - m.neck.x);
      const float front = above(p.z - m.neck.z, 0.03f, 0.08f);
      const float collar_y = m.neck.y - 0.025f - 0.035f * front + 5.0f * r * r;
      const float s = above(p.y, m.waist_y - 0.005f, e) * (1.0f - above(p.y, collar_y, e)) *
                      (1.0f - above(std::abs(p.x), m.sleeve_hem_x, e));
      c = glm::mix(c, wardrobe.top, s);
    }
    if (m.shoes && wardrobe.wear_shoes) c = glm::mix(c, wardrobe.shoes, 1.0f - above(p.y, m.ankle_y, e));
    albedo.push_back(c);
  }
  return albedo;
}

}  // namespace mimic::avatar
