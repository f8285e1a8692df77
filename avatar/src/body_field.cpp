#include "mimic/avatar/body_field.h"

#include <algorithm>
#if defined(__AVX__)
#include <immintrin.h>
#endif
#include <array>
#include <cmath>
#include <limits>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtx/euler_angles.hpp>

#include "body_field_rays.h"

namespace mimic::avatar {

using namespace field_detail;

namespace {

glm::mat3 rotation_xyz(const glm::vec3& angles_rad) {
  // R = Rz · Ry · Rx: x applied first, matching the orientation_deg convention of the file.
  return glm::mat3(glm::eulerAngleZ(angles_rad.z) * glm::eulerAngleY(angles_rad.y) * glm::eulerAngleX(angles_rad.x));
}

PrimitiveState lerp_state(const PrimitiveState& a, const PrimitiveState& b, float u) {
  return {a.semi_axes_m + u * (b.semi_axes_m - a.semi_axes_m), a.center_m + u * (b.center_m - a.center_m),
          a.orientation_rad + u * (b.orientation_rad - a.orientation_rad)};
}

}  // namespace

glm::vec2 muscle_weights(float theta, float theta0, float theta_min, float theta_max, Falloff falloff) {
  if (theta >= theta0) {
    const float span = theta_max - theta0;
    const float t = span > 1e-6f ? std::clamp((theta - theta0) / span, 0.0f, 1.0f) : 0.0f;
    return {0.0f, falloff_value(falloff, t)};
  }
  const float span = theta0 - theta_min;
  const float t = span > 1e-6f ? std::clamp((theta0 - theta) / span, 0.0f, 1.0f) : 0.0f;
  return {falloff_value(falloff, t), 0.0f};
}

PrimitiveState deformed_state(const PrimitiveState& g0, const PrimitiveState& gmin, const PrimitiveState& gmax,
                              Falloff falloff, float theta, float theta0, float theta_min, float theta_max) {
  const glm::vec2 w = muscle_weights(theta, theta0, theta_min, theta_max, falloff);
  return theta >= theta0 ? lerp_state(g0, gmax, w.y) : lerp_state(g0, gmin, w.x);
}

Result<BodyField> BodyField::create(const BodyModel& model, const rig::Skeleton& skeleton) {
  BodyField f;
  const size_t n = model.primitives.size();
  if (n >= 65535) return fail(Errc::invalid_argument, "too many primitives");
  f.sources_.reserve(n);
  for (const Primitive& p : model.primitives) {
    Source s;
    s.joint = skeleton.find_joint(p.joint);
    if (s.joint < 0)
      return fail(Errc::invalid_argument, "primitive '" + p.name + "': skeleton has no joint '" + p.joint + "'");
    s.g0 = p.state;
    if (p.deformation) {
      s.dof = skeleton.find_dof(p.deformation->dof);
      if (s.dof < 0)
        return fail(Errc::invalid_argument,
                    "primitive '" + p.name + "': skeleton has no DOF '" + p.deformation->dof + "'");
      s.gmin = p.deformation->at_min;
      s.gmax = p.deformation->at_max;
      s.falloff = p.deformation->falloff;
      const rig::Dof& d = skeleton.dof(s.dof);
      s.theta0 = d.rest_rad;
      s.theta_min = d.min_rad;
      s.theta_max = d.max_rad;
    }
    f.sources_.push_back(s);
    const float r2 = p.influence * p.influence;
    f.r2_.push_back(r2);
    f.inv_r2_.push_back(1.0f / r2);
    const float base = 1.0f - 1.0f / r2;
    f.weight_norm_.push_back(p.weight / (base * base * base));
    f.cbrt_inv_wn_.push_back(std::cbrt(1.0f / f.weight_norm_.back()));
    f.groups_.push_back(p.groups);
    f.part_.push_back(p.part);
    f.hard_.push_back(p.kind == PrimitiveKind::ellipsoid ? 1 : 0);
  }
  f.unit_from_world_.resize(n);
  f.center_.resize(n);
  f.bound_radius_.resize(n);
  f.min_axis_.resize(n);
  // A valid initial frame: the zero posture.
  std::vector<rig::RigidTransform> w(skeleton.joint_count());
  const rig::Pose zero = skeleton.zero_pose();
  rig::forward_kinematics(skeleton, zero, w);
  f.update(w, zero.dof_rad);
  return f;
}

void BodyField::update(std::span<const rig::RigidTransform> world_from_joint, std::span<const float> dof_rad) {
  const size_t n = sources_.size();
  for (size_t i = 0; i < n; ++i) {
    const Source& s = sources_[i];
    const PrimitiveState st =
        s.dof < 0 ? s.g0
                  : deformed_state(s.g0, s.gmin, s.gmax, s.falloff, dof_rad[s.dof], s.theta0, s.theta_min, s.theta_max);
    const rig::RigidTransform& wj = world_from_joint[s.joint];
    const glm::mat3 world_rot = glm::mat3_cast(wj.rotation) * rotation_xyz(st.orientation_rad);
    const glm::vec3 inv_axes = 1.0f / st.semi_axes_m;
    // unit_from_world = S⁻¹ · Rᵀ: rows of Rᵀ are the primitive's axes in world.
    glm::mat3 m = glm::transpose(world_rot);
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) m[c][r] *= inv_axes[r];
    unit_from_world_[i] = m;
    center_[i] = wj.apply(st.center_m);
    const float max_axis = std::max({st.semi_axes_m.x, st.semi_axes_m.y, st.semi_axes_m.z});
    min_axis_[i] = std::min({st.semi_axes_m.x, st.semi_axes_m.y, st.semi_axes_m.z});
    bound_radius_[i] = (hard_[i] ? 1.0f : std::sqrt(r2_[i])) * max_axis;
  }
}

float BodyField::field(const glm::vec3& p, GroupMask mask) const {
  float sum = 0;
  for (int i = 0; i < size(); ++i) {
    if (!(groups_[i] & mask) || hard_[i]) continue;
    const glm::vec3 q = unit_from_world_[i] * (p - center_[i]);
    sum += term(glm::dot(q, q), inv_r2_[i], weight_norm_[i]);
  }
  return sum;
}

float BodyField::field_of_part(const glm::vec3& p, RigidPart part) const {
  float sum = 0;
  for (int i = 0; i < size(); ++i) {
    if (part_[i] != part || hard_[i]) continue;
    const glm::vec3 q = unit_from_world_[i] * (p - center_[i]);
    sum += term(glm::dot(q, q), inv_r2_[i], weight_norm_[i]);
  }
  return sum;
}

float BodyField::field_of(const glm::vec3& p, std::span<const uint16_t> candidates) const {
  float sum = 0;
  for (uint16_t i : candidates) {
    if (hard_[i]) continue;
    const glm::vec3 q = unit_from_world_[i] * (p - center_[i]);
    sum += term(glm::dot(q, q), inv_r2_[i], weight_norm_[i]);
  }
  return sum;
}

bool BodyField::inside(const glm::vec3& p, GroupMask mask) const {
  for (int i = 0; i < size(); ++i) {
    if (!(groups_[i] & mask) || !hard_[i]) continue;
    const glm::vec3 q = unit_from_world_[i] * (p - center_[i]);
    if (glm::dot(q, q) <= 1.0f) return true;
  }
  return field(p, mask) >= kIsoLevel;
}

int BodyField::candidates_near_plane(const glm::vec3& origin, const glm::vec3& normal, GroupMask mask,
                                     std::span<uint16_t> out) const {
  int n = 0;
  for (int i = 0; i < size() && n < static_cast<int>(out.size()); ++i) {
    if (!(groups_[i] & mask)) continue;
    if (std::abs(glm::dot(center_[i] - origin, normal)) >= bound_radius_[i]) continue;
    out[n++] = static_cast<uint16_t>(i);
  }
  return n;
}

int BodyField::candidates_of_part(RigidPart part, std::span<uint16_t> out) const {
  int n = 0;
  for (int i = 0; i < size() && n < static_cast<int>(out.size()); ++i)
    if (part_[i] == part) out[n++] = static_cast<uint16_t>(i);
  return n;
}

}  // namespace mimic::avatar
