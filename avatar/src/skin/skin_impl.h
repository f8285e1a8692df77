// Internals of the implicit skin (skin.h) shared by its files (not a public header): the ray
// caster that samples a layout's contours on the metaball surface (ray_contours.cpp; the layout's
// build uses it too, in the zero posture) and ImplicitSkin::Impl, one skin's per-frame state.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include "contour_layout_data.h"
#include "loop_follow.h"
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
  // Per boundary-driven point, 1 / |G − S|² in the zero posture (0 until remember_rest_columns),
  // and P, the point its ray searches around (driven_ring).
  std::vector<float> rest_inv_len2;
  std::vector<glm::vec3> driven_p;
  // A shoulder's band twists with the arm, as the realtime method's does (BandTwist there): per
  // S ring, the power of (1 − α) that gives a driven ring its share of the twist (0: none) and
  // the twist the band had in the zero posture; per chain, the limb's swing from its
  // zero-posture direction this frame (set by the skin). Empty (no twist) until
  // remember_rest_columns: the layout's build casts the zero posture without.
  std::vector<float> band_twist_power, band_twist_rest_rad, chain_swing_rad;
  // This frame's twist of the band whose driven rings are being cast (they come one after
  // another and share it; −1: none yet this frame, see new_frame).
  int twist_s_ring = -1;
  float twist_phi_rad = 0;
  glm::vec3 twist_origin{0.0f}, twist_axis{0.0f, 0.0f, 1.0f};

  // Control points for `control_points` slots, per-ring scratch for rings of `widest` points.
  void size_for(size_t control_points, size_t widest);
  // Before a frame's rings: its statistics and the per-band twist start afresh.
  void new_frame() {
    stats = {};
    twist_s_ring = -1;
  }
  void compute_ring(const ContourLayout::Data& layout, const BodyField& field, std::span<const Chain> chains,
                    const Ring& r);
  // Takes the columns of the last frame (the zero posture) as the rest the driven rays' search
  // windows shrink from, and its shoulders' bands as untwisted.
  void remember_rest_columns(const ContourLayout::Data& layout, std::span<const Chain> chains);

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
  // The twist of driven ring r's band this frame (radians, before the taper and fade).
  float band_twist_rad(const ContourLayout::Data& layout, std::span<const Chain> chains, const Ring& r,
                       glm::vec3& origin, glm::vec3& axis) const;
  // P for each point of driven ring r into driven_p: S + α(G − S), and for a shoulder's band S
  // turned back by the band's twist φ, blended, then turned by (1 − α)^power·φ about the band's
  // axis (the columns become helices, most of the turn next to S).
  void driven_targets(const ContourLayout::Data& layout, std::span<const Chain> chains, const Ring& r);
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
  // The shoulders' and hips' loops that follow their limbs (loop_follow.h), and per ring the
  // follow moved before it is cast (the first of the limb's driven rings; −1 for none).
  std::vector<skin_detail::LoopFollow> follows;
  std::vector<int> follow_before_ring;

  Mesh mesh;
  std::vector<glm::vec3> scratch_grid, scratch_rows, scratch_poly;
  SkinTimings timings;

  Impl(ContourLayout layout_in, BodyField field_in, bool normals_in);
  void tilt_limb_roots();
  // The loop follows from the contours of the last frame (the zero posture).
  void measure_loop_follows();
  void cast_contours();
  void evaluate_bspline();
  void update_normals();
};

}  // namespace mimic::avatar
