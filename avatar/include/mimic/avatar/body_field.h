// The body's implicit surface for one frame: primitives moved rigidly with their joints and
// deformed by their reference DOF, packed as structure-of-arrays in world space.
//
// Field of a metaball i at p: w_i · g(r²), r² = |M_i (p − c_i)|² the squared ellipsoidal
// distance (1 on its ellipsoid), g(s) = ((1 − s/R_i²) / (1 − 1/R_i²))³ for s < R_i² and 0
// beyond (compact support R_i, the radius of influence in semi-axes). The surface is the
// iso-level 1 of the sum over a group's metaballs, united with the group's hard ellipsoids.
// Along a ray r² is quadratic in the ray parameter, so every term is a polynomial in t on a
// bounded interval: the ray caster brackets crossings on those intervals and refines them.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/avatar/body_model.h"
#include "mimic/rig/skeleton.h"
#include "mimic/rig/transform.h"

namespace mimic::avatar {

inline constexpr float kIsoLevel = 1.0f;

// Result of casting one ray: t along the (unit) direction, or a miss.
struct RayHit {
  float t = -1.0f;
  bool hit() const { return t >= 0.0f; }
};

// Where a ray looks for the surface near a point: the point at t_near along it, the search kept
// to t ∈ [t_min, t_max] (t_min ≤ t_near ≤ t_max).
struct RayNear {
  float t_near = 0.0f;
  float t_min = 0.0f;
  float t_max = std::numeric_limits<float>::infinity();
};

class BodyField {
 public:
  // Packs the model's primitives for the given skeleton (which must contain their joints and
  // deformation DOFs). Fails with the name of the first unresolvable reference.
  static Result<BodyField> create(const BodyModel& model, const rig::Skeleton& skeleton);

  // Moves and deforms every primitive for this frame. Never allocates.
  void update(std::span<const rig::RigidTransform> world_from_joint, std::span<const float> dof_rad);

  int size() const { return static_cast<int>(center_.size()); }
  GroupMask groups(int i) const { return groups_[i]; }
  RigidPart part(int i) const { return part_[i]; }
  bool hard(int i) const { return hard_[i] != 0; }
  const glm::vec3& center(int i) const { return center_[i]; }
  float bound_radius(int i) const { return bound_radius_[i]; }
  // World-space ellipsoid of primitive i this frame: p = center + world_from_unit · q, |q| = 1.
  glm::mat3 world_from_unit(int i) const { return glm::inverse(unit_from_world_[i]); }

  // Summed metaball field at p over primitives whose groups intersect `mask`.
  float field(const glm::vec3& p, GroupMask mask) const;
  // Inside the surface of `mask`: field ≥ 1 or inside one of its hard ellipsoids.
  bool inside(const glm::vec3& p, GroupMask mask) const;
  // Same, restricted to a rigid part's primitives.
  float field_of_part(const glm::vec3& p, RigidPart part) const;
  // Summed metaball field at p over the listed primitives (hard ellipsoids left out).
  float field_of(const glm::vec3& p, std::span<const uint16_t> candidates) const;

  // Indices of primitives in `mask` whose support reaches within `radius` of the plane
  // through `origin` with unit normal `normal` (a contour's candidates). Returns the count
  // written to `out` (truncated to out.size()).
  int candidates_near_plane(const glm::vec3& origin, const glm::vec3& normal, GroupMask mask,
                            std::span<uint16_t> out) const;
  int candidates_of_part(RigidPart part, std::span<uint16_t> out) const;

  // Outermost crossing of the surface along origin + t·dir, t ∈ [0, ∞), dir a unit vector,
  // using only the listed primitives. Robust: every primitive's peak along the ray and a step
  // no longer than a fraction of the thinnest primitive crossed are sampled before refining,
  // so thin parts are not stepped over; only t ≥ 0 is considered, so nothing behind the
  // origin is hit.
  RayHit cast_outermost(const glm::vec3& origin, const glm::vec3& dir, std::span<const uint16_t> candidates) const;

  // A star of rays from one origin within a plane: ray j runs along cos_a[j]·front + sin_a[j]·left
  // (front, left orthonormal; a contour's angles are fixed, so their cosines and sines are kept).
  // Same result as cast_outermost per ray, with the per-primitive work shared by the contour.
  void cast_star(const glm::vec3& origin, const glm::vec3& front, const glm::vec3& left, std::span<const float> cos_a,
                 std::span<const float> sin_a, std::span<const uint16_t> candidates, std::span<RayHit> hits) const;
  // Rays of their own (origins[j] + t·dirs[j], unit dirs), eight at a time in lock-step: the
  // same result as cast_outermost per ray.
  void cast_rays(std::span<const glm::vec3> origins, std::span<const glm::vec3> dirs,
                 std::span<const uint16_t> candidates, std::span<RayHit> hits) const;

  // Where the solid around the point origin + near.t_near·dir ends along the ray, searched
  // within [t_min, t_max] with the same march as cast_outermost: from a point outside, the first
  // crossing inwards (the surface beneath it), from a point inside the first one outwards, so the
  // surface of another part of the body further along the ray is never taken. Where the window
  // is inside throughout the hit is t_max exactly (the surface lies beyond it: the caller tells
  // the two apart by t == t_max); a point outside with no solid beneath it in the window is a
  // miss. A hard ellipsoid's exit within the window (clamped to t_max) is taken when nearer the
  // point.
  RayHit cast_nearest(const glm::vec3& origin, const glm::vec3& dir, std::span<const uint16_t> candidates,
                      RayNear near) const;
  // The same for rays of their own, eight at a time in lock-step (one RayNear per ray).
  void cast_rays_nearest(std::span<const glm::vec3> origins, std::span<const glm::vec3> dirs,
                         std::span<const RayNear> nears, std::span<const uint16_t> candidates,
                         std::span<RayHit> hits) const;

 private:
  // Up to eight rays in lock-step: the outermost crossing of each, or with `nears` (one per
  // ray) the crossing nearest each ray's point.
  template <class Quadratic>
  void cast_lanes(std::span<const uint16_t> candidates, int n, Quadratic&& quadratic, std::span<const RayNear> nears,
                  std::span<RayHit> out) const;
  // The quadratic |q0 + t·q1|² = a t² + 2 b t + c of primitive idx along the ray in its unit
  // frame; false when the ray passes outside its bounding sphere or wholly behind the origin.
  bool ray_quadratic(uint16_t idx, const glm::vec3& origin, const glm::vec3& dir, float& a, float& b, float& c) const;
  void cast_rays_lanes(std::span<const glm::vec3> origins, std::span<const glm::vec3> dirs,
                       std::span<const uint16_t> candidates, std::span<const RayNear> nears,
                       std::span<RayHit> hits) const;
  struct Source {
    int joint = -1;
    int dof = -1;  // reference DOF of a deformable primitive, -1 when rigid
    PrimitiveState g0, gmin, gmax;
    Falloff falloff = Falloff::linear;
    float theta0 = 0, theta_min = 0, theta_max = 0;
  };
  std::vector<Source> sources_;
  // Packed, per frame.
  std::vector<glm::mat3> unit_from_world_;
  std::vector<glm::vec3> center_;
  std::vector<float> weight_norm_;   // w / (1 − 1/R²)³
  std::vector<float> cbrt_inv_wn_;   // (1 / weight_norm)^(1/3)
  std::vector<float> inv_r2_;        // 1/R²
  std::vector<float> r2_;            // R²
  std::vector<float> bound_radius_;  // R · max semi-axis
  std::vector<float> min_axis_;      // smallest semi-axis
  std::vector<GroupMask> groups_;
  std::vector<RigidPart> part_;
  std::vector<uint8_t> hard_;
};

// The paper's interpolation weights at DOF value θ: (f(t) towards θmin, f(t) towards θmax), the
// one on the other side of θ0 zero. The primitives (deformed_state) and the realtime skin's
// muscle terms both use it.
glm::vec2 muscle_weights(float theta, float theta0, float theta_min, float theta_max, Falloff falloff);

// State of a deformable primitive at DOF value θ (the paper's interpolation).
PrimitiveState deformed_state(const PrimitiveState& g0, const PrimitiveState& gmin, const PrimitiveState& gmax,
                              Falloff falloff, float theta, float theta0, float theta_min, float theta_max);

}  // namespace mimic::avatar
