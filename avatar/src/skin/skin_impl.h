// Internals of the implicit skin (skin.h) shared by its files (not a public header): the ray
// caster that samples a layout's contours on the metaball surface (ray_contours.cpp; the layout's
// build uses it too, in the zero posture) and ImplicitSkin::Impl, one skin's per-frame state.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include "contour_layout_data.h"
#include "mimic/avatar/skin.h"
#include "mimic/core/clock.h"

namespace mimic::avatar {

namespace skin_detail {

// Microseconds since `t0_s` (steady_now_s()), for the stage timings.
inline double micros_since(double t0_s) { return (steady_now_s() - t0_s) * 1e6; }

// The contours of one frame: each ring of a layout ray-cast on the field, given the chains of
// the frame. Sized once (size_for), so compute_ring never allocates.
struct RingCaster {
  // Control points (metres, world) and, per point, the origin of the ray that produced it and
  // whether it hit the surface.
  std::vector<glm::vec3> ctrl, ctrl_origin;
  std::vector<uint8_t> ctrl_hit;
  SkinStats stats;

  std::vector<uint16_t> candidates;
  std::vector<RayHit> star_hits;
  std::vector<glm::vec3> ray_origins, ray_dirs, ray_fallbacks;  // a ring's rays, cast together
  std::vector<RayNear> ray_nears;
  std::vector<float> arc_r, arc_spike;  // a bridge's radii, while it spans hollows (span_arc)
  std::vector<uint32_t> arc_hull;
  // Per boundary-driven point, 1 / |G − S|² in the zero posture (0 until remember_rest_columns).
  std::vector<float> rest_inv_len2;

  // Control points for `control_points` slots, per-ring scratch for rings of `widest` points.
  void size_for(size_t control_points, size_t widest);
  void compute_ring(const ContourLayout::Data& layout, const BodyField& field, std::span<const Chain> chains,
                    const Ring& r);
  // Takes the columns of the last frame (the zero posture) as the rest the driven rays' search
  // windows shrink from.
  void remember_rest_columns(const ContourLayout::Data& layout);
  // A boundary-driven ring's point P = S + α(G − S) from its S point and its loop's point.
  glm::vec3 driven_target(const Ring& r, uint32_t s_slot, uint32_t goal_slot) const {
    return ctrl[s_slot] + r.alpha * (ctrl[goal_slot] - ctrl[s_slot]);
  }

 private:
  void star_ring(const ContourLayout::Data& layout, const BodyField& field, std::span<const Chain> chains,
                 const Ring& r);
  void driven_ring(const ContourLayout::Data& layout, const BodyField& field, std::span<const Chain> chains,
                   const Ring& r);
  void arc_ring(const ContourLayout::Data& layout, const BodyField& field, std::span<const Chain> chains,
                const Ring& r);
  void store(uint32_t slot, const glm::vec3& origin, const glm::vec3& dir, RayHit hit, const glm::vec3& fallback);
  int gather(const BodyField& field, GroupMask mask);
  void span_arc(size_t m, const Directions& dir);
};

}  // namespace skin_detail

struct ImplicitSkin::Impl {
  ContourLayout layout;
  const ContourLayout::Data& L;  // layout.data()
  bool normals = true;
  BodyField field;

  std::vector<rig::RigidTransform> world_from_joint;
  std::vector<Chain> chains;  // the layout's, updated each frame
  // A limb's first link as it lay in its parent's frame in the zero posture: the limb's first
  // ring plane leans to the bisector of that and the link (see tilt_limb_roots).
  struct LimbRoot {
    size_t chain = 0;
    int parent = -1;
    glm::vec3 rest_dir_in_parent{0.0f};
  };
  std::vector<LimbRoot> limb_roots;
  RingCaster caster;

  Mesh mesh;
  std::vector<glm::vec3> scratch_grid, scratch_rows, scratch_poly;
  SkinTimings timings;

  Impl(ContourLayout layout_in, BodyField field_in, bool normals_in);
  void tilt_limb_roots();
  void evaluate_bspline();
  void update_normals();
};

}  // namespace mimic::avatar
