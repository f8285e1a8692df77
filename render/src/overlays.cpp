#include "mimic/render/overlays.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace mimic::render {
namespace {

glm::vec3 to_world(const glm::mat4& m, const glm::vec3& p) { return glm::vec3(m * glm::vec4(p, 1.0f)); }

constexpr float kTau = 6.2831853f;

}  // namespace

bool parse_overlays(std::string_view list, unsigned& mask) {
  mask = 0;
  while (!list.empty()) {
    const size_t comma = list.find(',');
    const std::string_view name = list.substr(0, comma);
    if (name == "skeleton")
      mask |= kOverlaySkeleton;
    else if (name == "primitives")
      mask |= kOverlayPrimitives;
    else if (name == "contours")
      mask |= kOverlayContours;
    else if (name == "rays")
      mask |= kOverlayRays;
    else if (name == "sensors")
      mask |= kOverlaySensors;
    else if (name == "all")
      mask |= 0x1f;
    else if (name != "none" && !name.empty())
      return false;
    if (comma == std::string_view::npos) break;
    list.remove_prefix(comma + 1);
  }
  return true;
}

void append_skeleton(const rig::Skeleton& skeleton, const rig::Pose& pose, const glm::mat4& world_from_body,
                     Lines& out) {
  std::vector<rig::RigidTransform> world_from_joint(skeleton.joint_count());
  rig::forward_kinematics(skeleton, pose, world_from_joint);
  const glm::vec4 bone{0.10f, 0.75f, 0.30f, 1.0f}, joint{1.0f, 1.0f, 1.0f, 1.0f};
  for (int j = 0; j < skeleton.joint_count(); ++j) {
    const glm::vec3 p = to_world(world_from_body, world_from_joint[j].translation);
    const int parent = skeleton.parent(j);
    if (parent >= 0) out.add(to_world(world_from_body, world_from_joint[parent].translation), p, bone);
    // End links have a tip beyond their joint (head top, finger tips, toes).
    if (glm::length(skeleton.tip_m(j)) > 1e-4f)
      out.add(p, to_world(world_from_body, world_from_joint[j].apply(skeleton.tip_m(j))),
              bone * glm::vec4(1, 1, 1, 0.6f));
    const float s = 0.012f;
    out.add(p - glm::vec3(s, 0, 0), p + glm::vec3(s, 0, 0), joint);
    out.add(p - glm::vec3(0, s, 0), p + glm::vec3(0, s, 0), joint);
    out.add(p - glm::vec3(0, 0, s), p + glm::vec3(0, 0, s), joint);
  }
}

float deformation_amount(const avatar::Deformation& d, const rig::Dof& dof, float theta_rad) {
  float t = 0.0f;
  if (theta_rad >= dof.rest_rad) {
    const float span = dof.max_rad - dof.rest_rad;
    t = span > 1e-6f ? (theta_rad - dof.rest_rad) / span : 0.0f;
  } else {
    const float span = dof.rest_rad - dof.min_rad;
    t = span > 1e-6f ? (dof.rest_rad - theta_rad) / span : 0.0f;
  }
  t = std::clamp(t, 0.0f, 1.0f);
  switch (d.falloff) {
    case avatar::Falloff::linear: return t;
    case avatar::Falloff::parabolic: return t * t;
    case avatar::Falloff::hyperbolic: return std::sqrt(t);
  }
  return t;
}

void append_primitives(const avatar::ImplicitSkin& skin, const avatar::BodyModel& model, const rig::Pose& pose,
                       const glm::mat4& world_from_body, Lines& out) {
  const avatar::BodyField& field = skin.field();
  const rig::Skeleton& skeleton = skin.skeleton();
  constexpr int kSegments = 24;
  for (int i = 0; i < field.size(); ++i) {
    glm::vec4 color = field.hard(i) ? glm::vec4(0.45f, 0.45f, 0.48f, 0.8f) : glm::vec4(0.95f, 0.62f, 0.10f, 0.8f);
    if (i < static_cast<int>(model.primitives.size()) && model.primitives[i].deformation) {
      const int dof = skeleton.find_dof(model.primitives[i].deformation->dof);
      if (dof >= 0 && dof < static_cast<int>(pose.dof_rad.size())) {
        const float f = deformation_amount(*model.primitives[i].deformation, skeleton.dof(dof), pose.dof_rad[dof]);
        color = glm::vec4(glm::mix(glm::vec3(0.15f, 0.35f, 1.0f), glm::vec3(1.0f, 0.1f, 0.1f), f), 1.0f);
      }
    }
    // world_from_unit maps the unit sphere onto the ellipsoid (semi-axes included).
    const glm::mat3 m = field.world_from_unit(i);
    const glm::vec3 c = field.center(i);
    for (int axis = 0; axis < 3; ++axis) {
      const glm::vec3 u = m[(axis + 1) % 3], v = m[(axis + 2) % 3];
      glm::vec3 prev = c + u;
      for (int k = 1; k <= kSegments; ++k) {
        const float a = kTau * static_cast<float>(k) / kSegments;
        const glm::vec3 p = c + std::cos(a) * u + std::sin(a) * v;
        out.add(to_world(world_from_body, prev), to_world(world_from_body, p), color);
        prev = p;
      }
    }
  }
}

void append_contours(const avatar::ImplicitSkin& skin, const glm::mat4& world_from_body, Lines& out) {
  const glm::vec4 color{0.05f, 0.05f, 0.10f, 0.9f};
  for (const auto& ring : skin.contours()) {
    const size_t n = ring.points.size();
    for (size_t k = 0; k < n; ++k)
      out.add(to_world(world_from_body, ring.points[k]), to_world(world_from_body, ring.points[(k + 1) % n]), color);
  }
}

void append_rays(const avatar::ImplicitSkin& skin, int ring, const glm::mat4& world_from_body, Lines& out) {
  const auto rings = skin.contours();
  if (rings.empty()) return;
  const auto& r = rings[static_cast<size_t>(std::clamp(ring, 0, static_cast<int>(rings.size()) - 1))];
  const glm::vec4 ray{0.85f, 0.10f, 0.65f, 1.0f}, hit{1.0f, 0.9f, 0.1f, 1.0f};
  for (size_t k = 0; k < r.points.size() && k < r.ray_origins.size(); ++k) {
    const glm::vec3 o = to_world(world_from_body, r.ray_origins[k]);
    const glm::vec3 p = to_world(world_from_body, r.points[k]);
    out.add(o, p, ray);
    const float s = 0.006f;
    out.add(p - glm::vec3(s, 0, 0), p + glm::vec3(s, 0, 0), hit);
    out.add(p - glm::vec3(0, s, 0), p + glm::vec3(0, s, 0), hit);
    out.add(p - glm::vec3(0, 0, s), p + glm::vec3(0, 0, s), hit);
  }
}

void append_sensors(std::span<const SensorMark> sensors, Lines& out) {
  const float axis_m = 0.08f;
  for (const SensorMark& s : sensors) {
    const glm::mat3 r = glm::mat3_cast(s.orientation);
    out.add(s.position_m, s.position_m + axis_m * r[0], {1, 0.1f, 0.1f, 1});
    out.add(s.position_m, s.position_m + axis_m * r[1], {0.1f, 0.8f, 0.1f, 1});
    out.add(s.position_m, s.position_m + axis_m * r[2], {0.1f, 0.3f, 1, 1});
    if (!s.stale) continue;
    const float h = 0.04f;
    const glm::vec4 stale{1.0f, 0.0f, 1.0f, 1.0f};
    for (int a = 0; a < 3; ++a)
      for (int sa : {-1, 1})
        for (int sb : {-1, 1}) {
          glm::vec3 p(0.0f), q(0.0f);
          p[(a + 1) % 3] = q[(a + 1) % 3] = static_cast<float>(sa) * h;
          p[(a + 2) % 3] = q[(a + 2) % 3] = static_cast<float>(sb) * h;
          p[a] = -h;
          q[a] = h;
          out.add(s.position_m + p, s.position_m + q, stale);
        }
  }
}

}  // namespace mimic::render
