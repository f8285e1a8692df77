// A junction loop that follows part of its limb's swing (loop_follow.h): measured once in the
// initial pose, moved each frame by both methods.
#include "loop_follow.h"

#include <algorithm>
#include <cmath>
#include <glm/gtx/quaternion.hpp>

namespace mimic::avatar::skin_detail {

const LoopFollowRule* loop_follow_rule(std::string_view joint_name) {
  for (const LoopFollowRule& k : kLoopFollowRules)
    if (joint_name.ends_with(k.joint_suffix)) return &k;
  return nullptr;
}

LoopFollow measure_loop_follow(const ContourLayout::Data& layout, std::span<const Chain> chains,
                               std::span<const glm::vec3> ctrl, std::span<const rig::RigidTransform> w,
                               const Ring& driven, const LoopFollowRule& rule) {
  LoopFollow lf;
  const Ring& s = layout.rings[static_cast<size_t>(driven.s_ring)];
  lf.joint = chains[static_cast<size_t>(s.chain)].nodes.front().joint;
  lf.parent = layout.skeleton.parent(lf.joint);
  if (lf.parent < 0 || driven.goal.empty()) return lf;
  lf.gain = rule.gain, lf.power = rule.power, lf.far_side = rule.far_side;
  const rig::RigidTransform& pw = w[static_cast<size_t>(lf.parent)];
  const rig::RigidTransform parent_from_world = pw.inverse();
  lf.tip = safe_normalize(layout.skeleton.tip_m(lf.joint), {0, -1, 0});
  lf.axis = glm::conjugate(pw.rotation) * (w[static_cast<size_t>(lf.joint)].rotation * lf.tip);
  lf.pivot = parent_from_world.apply(w[static_cast<size_t>(lf.joint)].translation);
  lf.slots = driven.goal;
  glm::vec3 centre(0.0f), centre_world(0.0f);
  for (uint32_t slot : lf.slots) centre += parent_from_world.apply(ctrl[slot]), centre_world += ctrl[slot];
  centre /= static_cast<float>(lf.slots.size());
  centre_world /= static_cast<float>(lf.slots.size());
  // The torso's star ring holding most of the loop, and its neighbour further into the torso:
  // the star ring after it on its surface, else the one before.
  int loop_ring = -1;
  size_t most = 0;
  for (size_t ri = 0; ri < layout.rings.size(); ++ri) {
    const Ring& t = layout.rings[ri];
    if (t.kind != RingKind::star || t.chain != kTorsoChain) continue;
    size_t n = 0;
    for (uint32_t slot : lf.slots) n += std::find(t.slots.begin(), t.slots.end(), slot) != t.slots.end() ? 1 : 0;
    if (n > most) most = n, loop_ring = static_cast<int>(ri);
  }
  if (loop_ring >= 0 && rule.capped)
    for (const Surface& surface : layout.surfaces) {
      int before = -1, prev = -1;
      bool found = false;
      for (int id : surface.rows) {
        if (id < 0 || layout.rings[static_cast<size_t>(id)].kind != RingKind::star) continue;
        if (id == loop_ring) found = true, before = prev;
        if (prev == loop_ring) lf.cap_ring = id;
        prev = id;
      }
      if (found && lf.cap_ring < 0) lf.cap_ring = before;
      if (found) break;
    }
  Plane cap{};
  if (lf.cap_ring >= 0) {
    const Ring& src = layout.rings[static_cast<size_t>(lf.cap_ring)];
    cap = ring_plane(chains[kTorsoChain], src.segment, src.u);
    lf.cap_side = glm::dot(centre_world - cap.origin, cap.normal) < 0.0f ? 1.0f : -1.0f;
  }
  Plane limb{};
  if (rule.capped) {
    limb = ring_plane(chains[static_cast<size_t>(s.chain)], s.segment, s.u);
    lf.limb_cap = true;
    lf.limb_side = glm::dot(centre_world - limb.origin, limb.normal) < 0.0f ? -1.0f : 1.0f;
  }
  for (uint32_t slot : lf.slots) {
    if (lf.limb_cap) {
      // A point already at or past S's plane in the initial pose keeps where it is there: the
      // initial pose stays the full method's.
      const float short_by = lf.limb_side * glm::dot(ctrl[slot] - limb.origin, limb.normal);
      lf.limb_room.push_back(short_by > 0.0f ? kLoopLimbRoom * short_by : short_by);
    }
    glm::vec3 dir = parent_from_world.apply(ctrl[slot]) - centre;
    dir -= glm::dot(dir, lf.axis) * lf.axis;
    lf.dir.push_back(safe_normalize(dir, glm::vec3(0.0f)));
    const float below = lf.cap_ring >= 0 ? -lf.cap_side * glm::dot(ctrl[slot] - cap.origin, cap.normal) : 0.0f;
    lf.room.push_back(kLoopFollowCapRoom * std::max(below, 0.0f));
  }
  return lf;
}

namespace {

// Keeps every loop point on the loop's side of the limb's first ring, short of its plane by its
// room: with the thigh raised, the groin's points would lie beyond S along the thigh and the band
// from them to S would run back through S's strip. The move never takes a point past its room
// under the torso's next ring (an abducted thigh's S faces up along the side of the hip): what
// would rise past it is taken off, and the point slides along that ring's plane.
void cap_by_limb(const LoopFollow& lf, const glm::vec3& down, const glm::vec3& cap_origin, const glm::vec3& cap_normal,
                 const glm::vec3& limb_origin, const glm::vec3& limb_normal, std::span<glm::vec3> pos,
                 std::span<uint8_t> from_ray) {
  for (size_t k = 0; k < lf.slots.size(); ++k) {
    glm::vec3& p = pos[lf.slots[k]];
    const float short_by = lf.limb_side * glm::dot(p - limb_origin, limb_normal);
    if (short_by >= lf.limb_room[k]) continue;
    glm::vec3 move = (lf.limb_room[k] - short_by) * lf.limb_side * limb_normal;
    move -= glm::dot(move, down) * down;
    if (lf.cap_ring >= 0) {
      const float below = std::max(-lf.cap_side * glm::dot(p - cap_origin, cap_normal) - lf.room[k], 0.0f);
      const float rise = lf.cap_side * glm::dot(move, cap_normal);
      if (rise > below) move -= ((rise - below) * lf.cap_side) * cap_normal;
    }
    p += move;
    if (!from_ray.empty()) from_ray[lf.slots[k]] = 0;
  }
}

float follow_swing(const LoopFollow& lf, std::span<const rig::RigidTransform> world_from_joint,
                   const glm::vec3& cap_origin, const glm::vec3& cap_normal, std::span<glm::vec3> pos,
                   std::span<uint8_t> from_ray) {
  const rig::RigidTransform& parent = world_from_joint[static_cast<size_t>(lf.parent)];
  const glm::quat parent_from_world = glm::conjugate(parent.rotation);
  const glm::vec3 axis = parent_from_world * (world_from_joint[static_cast<size_t>(lf.joint)].rotation * lf.tip);
  const glm::vec3 across = axis - glm::dot(axis, lf.axis) * lf.axis;
  const float across_len = glm::length(across);
  // On its rest axis (twist alone) the loop stays; swung straight back, it fades out.
  if (across_len < 1e-6f) return glm::dot(axis, lf.axis) > 0.0f ? 1.0f : 0.0f;
  const glm::vec3 bend = across / across_len;
  const glm::quat swing = glm::rotation(lf.axis, axis);
  // Past the arm hanging at the side (the arm across the body) the swung loop would cut into
  // the chest: the follow fades out between 95 and 120 degrees of swing.
  const float fade = band_follow_fade(std::acos(std::clamp(glm::dot(axis, lf.axis), -1.0f, 1.0f)));
  if (fade <= 0.0f) return 0.0f;
  for (size_t k = 0; k < lf.slots.size(); ++k) {
    const float c = glm::dot(lf.dir[k], bend);
    const float near = lf.far_side > 0.0f ? lf.far_side + (1.0f - lf.far_side) * 0.5f * (1.0f + c)
                       : c <= 0.0f        ? 0.0f
                       : lf.power == 1.0f ? c
                                          : std::pow(c, lf.power);
    if (near <= 0.0f) continue;
    const float share = fade * lf.gain * near;
    glm::vec3& p = pos[lf.slots[k]];
    const glm::vec3 local = parent_from_world * (p - parent.translation);
    const glm::vec3 swung = lf.pivot + swing * (local - lf.pivot);
    const glm::vec3 move = parent.rotation * (share * (swung - local));
    float kept = 1.0f;
    if (lf.cap_ring >= 0) {
      // Short of the next ring's plane by the point's room: the share of the move that keeps it.
      const float below = -lf.cap_side * glm::dot(p - cap_origin, cap_normal) - lf.room[k];
      const float rise = lf.cap_side * glm::dot(move, cap_normal);
      // Moving away from the plane (rise ≤ 0) never crosses it; a point already in its room stays.
      if (rise > 0.0f) kept = std::clamp(below / rise, 0.0f, 1.0f);
    }
    p += kept * move;
    if (kept > 0.0f && !from_ray.empty()) from_ray[lf.slots[k]] = 0;
  }
  return fade;
}

}  // namespace

float follow_loop(const LoopFollow& lf, std::span<const rig::RigidTransform> world_from_joint,
                  const glm::vec3& cap_origin, const glm::vec3& cap_normal, const glm::vec3& limb_origin,
                  const glm::vec3& limb_normal, std::span<glm::vec3> pos, std::span<uint8_t> from_ray) {
  const float fade = follow_swing(lf, world_from_joint, cap_origin, cap_normal, pos, from_ray);
  if (lf.limb_cap) {
    // Across the parent's rest axis of the limb (down the pelvis): the loop keeps its height.
    const glm::vec3 down = world_from_joint[static_cast<size_t>(lf.parent)].rotation * lf.axis;
    cap_by_limb(lf, down, cap_origin, cap_normal, limb_origin, limb_normal, pos, from_ray);
  }
  return fade;
}

}  // namespace mimic::avatar::skin_detail
