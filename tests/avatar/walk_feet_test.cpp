// The built-in walk's feet on the floor, measured on the skin itself (not the joints): at every
// key `mimic export --motion walk` writes (30 a second over one lap), the lowest vertex of the
// body is within a few millimetres of the floor, as docs/bvh.md promises. At each heel rise the
// toes stay flat while the foot pitches about the ball; the forefoot must bend with them.
#include <gtest/gtest.h>

#include "mimic/avatar/body_model.h"
#include "mimic/rig/motion.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin.h"

namespace mimic::avatar::walk_feet_test {
namespace {

struct FloorContact {
  float lowest_m = 1e9f;        // the lowest vertex over all keys
  float highest_low_m = -1e9f;  // the largest per-key lowest vertex: a foot always down
  int keys = 0, keys_below_3mm = 0;
};

template <class Evaluate>
FloorContact walk_contact(const rig::Skeleton& skeleton, Evaluate&& lowest_vertex_at) {
  auto walk = rig::make_builtin_motion("walk", skeleton);
  EXPECT_TRUE(walk);
  FloorContact c;
  rig::Pose pose = skeleton.zero_pose();
  const double fps = 30;
  for (int k = 0; k / fps <= (*walk)->duration_s() + 1e-9; ++k) {
    (*walk)->sample(k / fps, pose);
    const float low = lowest_vertex_at(pose);
    c.lowest_m = std::min(c.lowest_m, low);
    c.highest_low_m = std::max(c.highest_low_m, low);
    c.keys_below_3mm += low < -0.003f;
    ++c.keys;
  }
  return c;
}

TEST(WalkFeet, TheRealtimeSkinStaysOnTheFloorAtEveryKey) {
  auto body = RealtimeBody::create(default_body_model(), RealtimeOptions{});
  ASSERT_TRUE(body) << body.error().what();
  RealtimeSkin skin(*body);
  Mesh mesh = (*body)->rest_mesh();
  const FloorContact c = walk_contact((*body)->skeleton(), [&](const rig::Pose& pose) {
    skin.evaluate(pose, mesh.positions);
    float low = 1e9f;
    for (const glm::vec3& p : mesh.positions) low = std::min(low, p.y);
    return low;
  });
  EXPECT_GE(c.keys, 198);
  std::printf(
      "[ figure ] built-in walk, realtime skin, %d keys: lowest vertex %.1f mm, highest per-key lowest %.1f mm\n",
      c.keys, c.lowest_m * 1e3, c.highest_low_m * 1e3);
  EXPECT_GT(c.lowest_m, -0.005f) << c.keys_below_3mm << " of " << c.keys << " keys have skin under the floor";
  EXPECT_LT(c.highest_low_m, 0.01f) << "a foot is always down";
}

TEST(WalkFeet, TheFullSkinStaysOnTheFloorAtEveryKey) {
  SkinOptions o;
  o.subdivision = 0;
  o.normals = false;
  auto skin = ImplicitSkin::create(default_body_model(), o);
  ASSERT_TRUE(skin) << skin.error().what();
  const FloorContact c = walk_contact(skin->skeleton(), [&](const rig::Pose& pose) {
    skin->evaluate(pose);
    float low = 1e9f;
    for (const glm::vec3& p : skin->mesh().positions) low = std::min(low, p.y);
    return low;
  });
  std::printf("[ figure ] built-in walk, full skin, %d keys: lowest vertex %.1f mm, highest per-key lowest %.1f mm\n",
              c.keys, c.lowest_m * 1e3, c.highest_low_m * 1e3);
  EXPECT_GT(c.lowest_m, -0.005f) << c.keys_below_3mm << " of " << c.keys << " keys have skin under the floor";
  EXPECT_LT(c.highest_low_m, 0.01f);
}

}  // namespace
}  // namespace mimic::avatar::walk_feet_test
