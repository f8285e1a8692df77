// The geometry of a junction band swept as a tube (the realtime skin's shoulders, band_sweep.h).
// Not a public header.
//
// A band joins a loop G to a limb's first ring S, column by column. Swept, each of its rings
// lies in its own plane, centred on a cubic Hermite curve from G's centre (leaving along G's
// normal) to S's (arriving along S's), its plane turned from G's towards S's evenly along the
// band, its axes carried from G's without turning about the plane's normal (parallel
// transport). In that plane a point is placed in polar form: its column's radius and height
// blended from G's point (in G's plane) and S's (in S's), its angle turned from G's direction
// towards S's by the column's turn in the initial pose (share t, 0 at G, 1 at S) and by this
// frame's turn against that (share t³, most of it next to S). This frame's turn is one for the
// band, the columns' mean, each column keeping its own about it; of the mean only the limb's
// twist about its own axis is tapered (twist_in_band), the swing's part whole. Both ends
// star-shaped in their planes, every ring is too.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "contour_layout_data.h"

namespace mimic::avatar::skin_detail {

inline constexpr int kSweepMaxRings = 8;
// Fewer points a ring than this (LOD 3's four) do not draw a ring the polar blend keeps round.
inline constexpr uint32_t kSweepMinColumns = 8;

// atan2 within 1e-5 rad (a polynomial and quadrant selects).
float approx_atan2(float y, float x);
// (cos a, sin a) within 1e-6 (a polynomial and quadrant selects).
void approx_cos_sin(float a_rad, float& c, float& s);
// The share of this frame's turn a ring at t takes.
inline float sweep_twist_share(float t) { return t * t * t; }

// How much of a band is the swept one (the rest the straight blend), for the limb's twist and
// the loop's follow fade (band_follow_fade). Near half a turn of twist the swept band winds the
// skin round the short band (the arm raised and twisted to its limit: 419 folds, where the band
// of straight columns turned about its own axis folds 45); with the arm swung across the body
// (past 120°) its ends face each other and it loops through the chest (75–77 folds with the arm
// swung 180° forward, 50–51 straight).
inline float sweep_share(float twist_rad, float fade) {
  constexpr float kFrom_rad = 1.745f, kTo_rad = 2.443f;  // 100°, 140°
  return std::clamp((kTo_rad - std::abs(twist_rad)) / (kTo_rad - kFrom_rad), 0.0f, 1.0f) * fade;
}

// An angle at most one turn outside [−π, π] brought into it.
inline float wrap_angle(float a) { return a > kPi ? a - kTwoPi : a < -kPi ? a + kTwoPi : a; }

// A limb's twist about its own axis against the initial pose (swing-twist about `rest_axis`,
// in the parent's frame), from its joint's rotation in the parent's frame now (`local`) and in
// the initial pose (`rest_local_inv`, inverted), radians.
inline float limb_twist_rad(const glm::quat& local, const glm::quat& rest_local_inv, const glm::vec3& rest_axis) {
  const glm::quat q = local * rest_local_inv;
  return wrap_angle(2.0f * std::atan2(glm::dot(glm::vec3(q.x, q.y, q.z), rest_axis), q.w));
}

// The band's two ends this frame, gathered column by column (n points each), and the signs that
// orient their Newell normals along the band (sweep_signs in the initial pose).
struct SweepEnds {
  const glm::vec3* g = nullptr;
  const glm::vec3* s = nullptr;
  uint32_t n = 0;
  float sign_g = 1, sign_s = 1;
};
void sweep_signs(SweepEnds& e);

struct SweepPlane {
  glm::vec3 c, x, y, n;
  float t;
};

// Per column (caller's arrays of n): G's unit direction and radius in its plane, heights, S's
// radius, and the turn this frame the rings take (scaled by sweep_twist_share).
struct SweepColumns {
  float* ug_x;
  float* ug_y;
  float* r_g;
  float* h_g;
  float* r_s;
  float* h_s;
  float* turn;
};

// The ring planes for rings at `t` (rings ≤ kSweepMaxRings) and the columns' polar form;
// `rest_cos`, `rest_sin`: each column's turn in the initial pose (nullptr: none, and `turn`
// receives each column's whole turn), `twist_rad` the limb's twist about its own axis against
// the initial pose. Eight columns at a time where the build has AVX2 and FMA and `vectorised`.
void sweep_geometry(const SweepEnds& e, const float* t, int rings, const float* rest_cos, const float* rest_sin,
                    float twist_rad, bool vectorised, SweepPlane* planes, const SweepColumns& col);

// One ring's points into out[0..n): `rest_turn` each column's turn in the initial pose; the
// polar offsets `off_r`, `off_a`, `off_h` (radius, angle, height; nullptr: none) scaled by
// `shrink` per column. Eight at a time where the build has AVX2 and FMA and `vectorised`.
void sweep_ring_points(const SweepPlane& p, const SweepColumns& col, uint32_t n, const float* rest_turn,
                       const float* shrink, const float* off_r, const float* off_a, const float* off_h, bool vectorised,
                       glm::vec3* out);

// The polar offsets that give `point` back from ring p's blend of column j (the inverse of
// sweep_ring_points at shrink 1).
glm::vec3 sweep_offset(const SweepPlane& p, const SweepColumns& col, uint32_t j, float rest_turn,
                       const glm::vec3& point);

}  // namespace mimic::avatar::skin_detail
