// Contact in the realtime skin (docs/skin.md, "Contact"): where one piece passes into another's
// volume its vertices are pushed out onto that volume's surface. Properties on the default body:
// the initial pose is untouched, only vertices of the pieces that give way move and only by a
// bounded amount, everything else is bit for bit the frame without contact, a body built
// without the tables is the skin without contact, and frames are deterministic. How much less
// the skin passes through itself is measured exactly in tests/exact/skin_contact_exact_test.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <set>
#include <span>
#include <string>

#include "built_in_realtime_body.h"
#include "mimic/avatar/mesh_check.h"
#include "mimic/avatar/realtime_skin.h"

namespace mimic::avatar::skin_contact_test {
namespace {

std::shared_ptr<const RealtimeBody> body_with(bool contact, int lod = 0) {
  return ::mimic::test::built_in_realtime_body(lod, contact);
}

// The arms hanging straight down, pressed against the hips and the sides of the chest.
rig::Pose arms_pressed(const rig::Skeleton& sk) { return standing_posture(sk); }

// Which part each vertex belongs to (the first part whose triangles use it).
std::vector<std::string> part_of_vertex(const Mesh& m) {
  std::vector<std::string> part(m.positions.size());
  for (const MeshPart& p : m.parts)
    for (uint32_t t = p.first_triangle; t < p.first_triangle + p.triangle_count; ++t)
      for (int c = 0; c < 3; ++c)
        if (part[m.indices[3 * t + c]].empty()) part[m.indices[3 * t + c]] = p.name;
  return part;
}

TEST(SkinContact, TheInitialPoseIsUntouched) {
  const auto body = body_with(true);
  ASSERT_TRUE(body);
  EXPECT_EQ(body->contact_pairs(), 10u);  // realtime_contact.cpp kPairs
  EXPECT_GT(body->contact_vertices(), 1000u);
  RealtimeSkin skin(body);
  std::vector<glm::vec3> on(body->vertex_count()), off(body->vertex_count());
  skin.evaluate(body->skeleton().zero_pose(), on, {}, true, true);
  EXPECT_EQ(skin.contact_moved(), 0u);
  skin.evaluate(body->skeleton().zero_pose(), off, {}, true, false);
  EXPECT_EQ(on, off);
}

TEST(SkinContact, OnlyTheGivingPiecesMoveAndOnlyWhereTheyPressIn) {
  const auto body = body_with(true);
  ASSERT_TRUE(body);
  RealtimeSkin skin(body);
  const rig::Pose pose = arms_pressed(body->skeleton());
  std::vector<glm::vec3> on(body->vertex_count()), off(body->vertex_count());
  skin.evaluate(pose, off, {}, true, false);
  skin.evaluate(pose, on, {}, true, true);
  const size_t moved = skin.contact_moved();
  const std::vector<std::string> part = part_of_vertex(body->rest_mesh());
  const std::set<std::string> giving = {"left_upper_arm", "right_upper_arm", "left_lower_arm", "right_lower_arm",
                                        "left_upper_leg", "right_upper_leg", "left_lower_leg", "right_lower_leg"};
  const std::set<std::string> arms = {"left_upper_arm",  "right_upper_arm", "left_lower_arm",
                                      "right_lower_arm", "left_hand",       "right_hand"};
  // The hands pressed into the hips turn the arms off the body first, and the loops round the
  // shoulders (the torso's under the armpits, the neck's over the top) follow the arms: those move
  // wherever they are, near a shoulder; the rest only where it is pushed.
  std::vector<rig::RigidTransform> w(static_cast<size_t>(body->skeleton().joint_count()));
  rig::forward_kinematics(body->skeleton(), pose, w);
  const glm::vec3 shoulders[2] = {w[static_cast<size_t>(body->skeleton().find_joint("l_shoulder"))].translation,
                                  w[static_cast<size_t>(body->skeleton().find_joint("r_shoulder"))].translation};
  size_t changed = 0, changed_off_arms = 0;
  float largest_m = 0, largest_off_arms_m = 0;
  std::set<std::string> changed_parts;
  for (size_t v = 0; v < on.size(); ++v) {
    if (on[v] == off[v]) continue;
    ++changed;
    changed_parts.insert(part[v]);
    const float d = glm::distance(on[v], off[v]);
    largest_m = std::max(largest_m, d);
    if (arms.count(part[v])) continue;
    const bool shoulder_loop =
        (part[v] == "upper_torso" || part[v] == "neck") &&
        std::min(glm::distance(off[v], shoulders[0]), glm::distance(off[v], shoulders[1])) < 0.15f;
    EXPECT_TRUE(giving.count(part[v]) || shoulder_loop) << "vertex " << v << " of " << part[v] << " moved";
    if (shoulder_loop) continue;
    ++changed_off_arms;
    largest_off_arms_m = std::max(largest_off_arms_m, d);
  }
  std::printf(
      "arms pressed: %zu of %zu vertices pushed (%zu changed, %zu off the arms), at most %.1f mm (off the arms "
      "%.1f)\n",
      moved, on.size(), changed, changed_off_arms, 1000 * largest_m, 1000 * largest_off_arms_m);
  EXPECT_GT(changed, 10u);
  EXPECT_LT(changed, on.size() / 2);
  // Off the arms: the pushed vertices and the ring around them, which follows part of their push.
  EXPECT_LE(changed_off_arms, 4 * moved);
  EXPECT_LE(largest_off_arms_m, 0.0601f);
  // An arm turns by two rounds of 0.2 rad at most: its hand, 0.6 m from the shoulder, by 0.24 m.
  EXPECT_LE(largest_m, 0.24f);
  EXPECT_TRUE(changed_parts.count("left_hand") && changed_parts.count("right_hand"));
  EXPECT_TRUE(changed_parts.count("left_upper_arm") && changed_parts.count("right_upper_arm"));
  // Still one closed, outward envelope.
  Mesh m = body->rest_mesh();
  m.positions = on;
  const MeshTopology t = analyze_topology(m);
  EXPECT_TRUE(is_closed_oriented_manifold(t));
  EXPECT_GT(t.signed_volume, 0.0) << "faces must still wind outward";
  for (const glm::vec3& p : on) ASSERT_TRUE(std::isfinite(p.x + p.y + p.z));
}

// Vertices of one part of the mesh, by name.
std::vector<uint32_t> part_vertices(const Mesh& m, const std::string& name) {
  std::set<uint32_t> vs;
  for (const MeshPart& p : m.parts)
    if (p.name == name)
      for (uint32_t t = p.first_triangle; t < p.first_triangle + p.triangle_count; ++t)
        for (int c = 0; c < 3; ++c) vs.insert(m.indices[3 * t + c]);
  return {vs.begin(), vs.end()};
}

glm::vec3 centroid(std::span<const glm::vec3> pos, const std::vector<uint32_t>& vs) {
  glm::vec3 sum(0.0f);
  for (uint32_t v : vs) sum += pos[v];
  return sum / static_cast<float>(vs.size());
}

// The rigid hands cannot flatten: an arm whose hand presses into the hips turns about its shoulder
// off the body (docs/skin.md, "The arms keep off the body"). Brought in from 30° out to the arm
// pressed against the hip, half a degree a step, the left hand stays where it was while it is clear,
// then lies outside the hip (further out than without contact), and never jumps.
TEST(SkinContact, AHandPressedIntoTheHipTurnsTheArmOffTheBodyWithoutJumping) {
  const auto body = body_with(true);
  ASSERT_TRUE(body);
  const rig::Skeleton& sk = body->skeleton();
  RealtimeSkin skin(body);
  const std::vector<uint32_t> hand = part_vertices(body->rest_mesh(), "left_hand");
  ASSERT_GT(hand.size(), 20u);
  const int abduction = sk.find_dof("l_shoulder_abduction");
  ASSERT_GE(abduction, 0);
  rig::Pose pose = standing_posture(sk);
  const float pressed_rad = pose.dof_rad[static_cast<size_t>(abduction)];
  std::vector<glm::vec3> on(body->vertex_count()), off(body->vertex_count());
  glm::vec3 last_shift(0.0f);
  float largest_step_m = 0, first_turn_rad = 0;
  for (float out_deg = 30.0f; out_deg >= -0.25f; out_deg -= 0.5f) {
    pose.dof_rad[static_cast<size_t>(abduction)] = pressed_rad + glm::radians(std::max(out_deg, 0.0f));
    skin.evaluate(pose, on, {}, true, true);
    skin.evaluate(pose, off, {}, true, false);
    const glm::vec3 shift = centroid(on, hand) - centroid(off, hand);
    if (glm::length(shift) > 1e-6f && first_turn_rad == 0.0f) first_turn_rad = glm::radians(out_deg);
    if (out_deg > 29.9f) {
      EXPECT_EQ(glm::length(shift), 0.0f) << "a hand clear of the body stays";
    }
    largest_step_m = std::max(largest_step_m, glm::distance(shift, last_shift));
    last_shift = shift;
  }
  std::printf(
      "left hand pressed into the hip: moved out %.1f mm (x %+.1f mm), from %.1f deg out; largest change "
      "in a 0.5 deg step %.1f mm\n",
      1000 * glm::length(last_shift), 1000 * last_shift.x, glm::degrees(first_turn_rad), 1000 * largest_step_m);
  EXPECT_GT(first_turn_rad, 0.0f) << "the hand reaches the hip before the arm hangs";
  EXPECT_GT(last_shift.x, 0.01f) << "the left hand moves out to the left (+x), off the hip";
  EXPECT_LT(glm::length(last_shift), 0.1f);
  EXPECT_LT(largest_step_m, 0.01f) << "a half-degree step moves the hand's turn continuously";
}

TEST(SkinContact, ABodyWithoutTheTablesIsTheSkinWithoutContact) {
  const auto with = body_with(true);
  const auto without = body_with(false);
  ASSERT_TRUE(with && without);
  EXPECT_EQ(without->contact_pairs(), 0u);
  RealtimeSkin a(with), b(without);
  const rig::Pose pose = arms_pressed(with->skeleton());
  std::vector<glm::vec3> off(with->vertex_count()), none(with->vertex_count());
  a.evaluate(pose, off, {}, true, false);
  b.evaluate(pose, none, {}, true, true);
  EXPECT_EQ(off, none);
  EXPECT_EQ(b.contact_moved(), 0u);
}

TEST(SkinContact, FramesAreDeterministicAtEveryLod) {
  for (int lod = 0; lod < 4; ++lod) {
    const auto body = body_with(true, lod);
    ASSERT_TRUE(body);
    RealtimeSkin a(body), b(body);
    const rig::Pose pose = arms_pressed(body->skeleton());
    std::vector<glm::vec3> pa(body->vertex_count()), pb(body->vertex_count());
    a.evaluate(body->skeleton().zero_pose(), pa);
    a.evaluate(pose, pa);
    b.evaluate(pose, pb);
    EXPECT_EQ(pa, pb) << "LOD " << lod;
    EXPECT_GT(a.contact_moved(), 0u) << "LOD " << lod;
  }
}

}  // namespace
}  // namespace mimic::avatar::skin_contact_test
