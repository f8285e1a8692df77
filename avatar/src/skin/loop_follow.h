// A shoulder's or hip's junction loop that follows part of its limb's swing, in both methods
// (the realtime skin moves its loop's vertices, the full method its cast control points). Not a
// public header.
#pragma once

#include <span>
#include <string_view>
#include <vector>

#include "contour_layout_data.h"

namespace mimic::avatar::skin_detail {

// Per limb root (by the joint's name): how much of the swing the loop follows, and how much the
// shoulder's band twists. Measured over the shared clips' frames (mimic intersect, every 80th
// frame, LOD 0, realtime): the shoulders' bands twisting with the arm (power 2, most of the turn
// next to S) took 33.7 to 24.2 folds a frame (power 1: 25.2, with 8.8 more pairs between pieces;
// the hips' bands gain nothing from a twist). The hips' loop is the torso's lowest star ring:
// moved with the thigh it crossed the ring above (the torso's contours 6–12 mm through each
// other), so it is capped by that ring's plane, each point kept short of it by 15% of its rest
// distance from it: 24.3 → 16.5 folds a frame (gain 0.5 and 30%: 18.5; uncapped 17.3, crossing).
// The full method's shoulder loops do not follow (`in_full_method`): the full method is the
// surface `fit` and `compare` measure, posed like the reference mesh with the arms down, and
// the armpit points swung with the arm took its chest girth from −1.0% to −5.3% of the mesh's
// (the fit holds 3%).
// The shoulders' far side turns too (`far_side`: its share against the near side's, the share
// linear in dir · bend between): with the near side alone the far side stayed where the T-pose
// cast it, and with the arm hanging forward the band's back spanned 150 mm across and 80 mm down
// and folded. Far side at 0.35: 16.5 / 8.0 / 3.9 / 1.9 → 14.3 / 5.0 / 2.5 / 0.6 folds a frame at
// LODs 0–3, frames folding 71 / 70 / 58 / 54 → 60 / 48 / 38 / 15 of 124, the relaxed posture clean
// at every LOD (no pairs between pieces either: 4 before). The neck's loop holds the shoulder's
// top points, and more of the far side folds the neck's band in many frames: at 0.5, 13.6 / 4.6 /
// 2.3 / 0.6 folds a frame but 88 frames folding at LOD 0; the whole loop (1), 12.5 / 3.5 / 1.9 /
// 0.5, the relaxed posture 3 folds and 25 pairs. At 0.3 the relaxed posture's 4 pairs stay; with
// the points the neck's loop holds taking the near side's share alone, 16.6 at LOD 0.
// The hips' far side at 0.25, their cap holding every point short of the torso's next ring as
// before: 14.3 / 5.0 / 2.5 / 0.6 → 14.2 / 4.1 / 1.6 / 0.5 folds a frame, frames folding 60 / 48 /
// 38 / 15 → 60 / 45 / 27 / 15, the torso's contours crossing in none of the clips' every 10th
// frame at any LOD (at 0.35 they crossed by 1.2 mm, 02_06 frame 1720; at 0.15 the folds are 14.1
// / 4.2 / 1.7 / 0.5, at 0.5 and 1 no fewer). The full method's loops move their near side alone
// (ImplicitSkin::Impl::measure_loop_follows): the far side moved the hips' girths `fit` measures.
struct LoopFollowRule {
  std::string_view joint_suffix;
  float gain, power, twist_power;
  bool capped, in_full_method;
  float far_side;
};
inline constexpr LoopFollowRule kLoopFollowRules[] = {{"shoulder", 0.5f, 1.0f, 2.0f, false, false, 0.35f},
                                                      {"hip", 0.7f, 1.0f, 0.0f, true, true, 0.25f}};
inline constexpr float kLoopFollowCapRoom = 0.15f;
// A hip's loop stays on the torso's side of the thigh's first ring S, short of its plane by this
// share of its rest distance from it: with the thigh raised, the groin's side of the loop (cast in
// the T-pose in front of the hip) lay beyond S along the thigh, and the band from it ran back
// through S's strip. The point moves across the pelvis's vertical (never up or down it) and never
// past its room under the torso's next ring. Every 10th clip frame, realtime LOD 0: 6.6 folds a
// frame without; 5.4 at 0.3, 4.8 at 0.5, 3.9 at 0.8, the pairs between pieces 29.4 → 30.0 / 31.7 /
// 34.9 (the lower belly left where it is, the thigh's top meets it). Moved straight along S's
// normal instead, 4.5 at 0.3, but the torso's lowest ring crossed the next by up to 32 mm.
inline constexpr float kLoopLimbRoom = 0.5f;
// The rule for a limb whose first joint is `joint_name`, or nullptr (the neck keeps its loop).
const LoopFollowRule* loop_follow_rule(std::string_view joint_name);

// A junction loop (the torso's points G a limb's boundary-driven rings run to) follows part of
// the limb's swing about the joint, most on the side the limb swings towards. The loop is cast in the
// initial pose: with the arm hanging (the thigh raised) its armpit (groin) points stay where the
// limb's inner side was, outside the limb's first ring S, and the band between them folds. A
// point's share of the swing is gain · max(0, c)^power, or with a far side f, gain · (f + (1 − f)
// · (1 + c) / 2): c = dir · bend, dir its rest direction from the loop's centre across the limb,
// bend the direction the limb's axis has moved (both in the parent joint's frame). None in the
// initial pose.
struct LoopFollow {
  int joint = -1, parent = -1;
  glm::vec3 pivot{0.0f}, axis{0.0f};  // the joint and the limb's rest axis, in the parent's frame
  glm::vec3 tip{0.0f};                // the limb's axis in the joint's frame
  float gain = 0, power = 1;
  float far_side = 0;  // LoopFollowRule::far_side
  // The torso's star ring next to the loop's (−1: none): a moved point stops short of its plane
  // by its `room` (metres), so the loop never crosses it; `cap_side` is the sign of the loop's
  // side of that plane.
  int cap_ring = -1;
  float cap_side = 1;
  std::vector<uint32_t> slots;  // the loop's points, as the driven ring's `goal`
  std::vector<glm::vec3> dir;   // per point
  std::vector<float> room;      // per point
  // The limb's first ring S (capped loops): every point stays on the loop's side of its plane,
  // short of it by `limb_room` (metres), so the band never runs back through S.
  bool limb_cap = false;
  float limb_side = 1;
  std::vector<float> limb_room;  // per point

  size_t heap_bytes() const {
    return slots.capacity() * 4 + dir.capacity() * sizeof(glm::vec3) + room.capacity() * 4 + limb_room.capacity() * 4;
  }
};

// The follow of driven ring `driven`'s loop, from the contours `ctrl` cast in the initial pose
// (`world_from_joint` its joints, `chains` its chains).
LoopFollow measure_loop_follow(const ContourLayout::Data& layout, std::span<const Chain> chains,
                               std::span<const glm::vec3> ctrl, std::span<const rig::RigidTransform> world_from_joint,
                               const Ring& driven, const LoopFollowRule& rule);

// Moves the loop's points in `pos` for this frame's joints, each stopping short of the cap ring's
// plane (`cap_origin`, `cap_normal`: this frame's); returns the fade (band_follow_fade of the
// swing; 1 on the rest axis, 0 swung straight back). A capped loop then stays on its side of the
// limb's first ring (`limb_origin`, `limb_normal`: this frame's plane of S). A point it moves is
// no longer where its ray found the surface: its flag in `from_ray`, when given, is cleared.
float follow_loop(const LoopFollow& lf, std::span<const rig::RigidTransform> world_from_joint,
                  const glm::vec3& cap_origin, const glm::vec3& cap_normal, const glm::vec3& limb_origin,
                  const glm::vec3& limb_normal, std::span<glm::vec3> pos, std::span<uint8_t> from_ray = {});

}  // namespace mimic::avatar::skin_detail
