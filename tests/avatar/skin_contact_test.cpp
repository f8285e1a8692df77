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
  size_t changed = 0;
  float largest_m = 0;
  std::set<std::string> changed_parts;
  for (size_t v = 0; v < on.size(); ++v) {
    if (on[v] == off[v]) continue;
    ++changed;
    changed_parts.insert(part[v]);
    largest_m = std::max(largest_m, glm::distance(on[v], off[v]));
    EXPECT_TRUE(giving.count(part[v])) << "vertex " << v << " of " << part[v] << " moved";
  }
  std::printf("arms pressed: %zu of %zu vertices pushed (%zu changed), at most %.1f mm\n", moved, on.size(), changed,
              1000 * largest_m);
  EXPECT_GT(changed, 10u);
  // The pushed vertices and the ring around them, which follows part of their push.
  EXPECT_GE(changed, moved / 2);
  EXPECT_LE(changed, 4 * moved);
  EXPECT_LT(changed, on.size() / 10);
  EXPECT_LE(largest_m, 0.0601f);
  EXPECT_TRUE(changed_parts.count("left_upper_arm") && changed_parts.count("right_upper_arm"));
  // Still one closed, outward envelope.
  Mesh m = body->rest_mesh();
  m.positions = on;
  const MeshTopology t = analyze_topology(m);
  EXPECT_TRUE(is_closed_oriented_manifold(t));
  EXPECT_GT(t.signed_volume, 0.0) << "faces must still wind outward";
  for (const glm::vec3& p : on) ASSERT_TRUE(std::isfinite(p.x + p.y + p.z));
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
