// Contact in the realtime skin, measured exactly (CGAL): with contact the pieces pass less
// through each other than without, and fold no more, on the arms pressed against the body and
// on sampled frames of the shared clips (docs/skin.md, "Contact"; the full sweep is `mimic
// intersect`). Each check fails on the tree without contact (on and off are then the same).
#include <gtest/gtest.h>

#include <cstdio>

#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/self_intersection.h"
#include "built_in_realtime_body.h"
#include "shared_clip_poses.h"

namespace mimic::avatar::skin_contact_exact_test {
namespace {

std::shared_ptr<const RealtimeBody> body_at(int lod) { return ::mimic::test::built_in_realtime_body(lod); }

struct Crossing {
  double frames = 0, pairs = 0, folds = 0, depth_mm = 0, worst_mm = 0;
  void add(const IntersectionReport& r) {
    ++frames, pairs += double(r.between_pairs), folds += double(r.fold_pairs), depth_mm += 1000 * r.deepest_envelope_m;
    worst_mm = std::max(worst_mm, 1000 * r.deepest_envelope_m);
  }
};

TEST(SkinContactExact, TheArmsPressedAgainstTheBodyStayNearlyOutsideIt) {
  const auto body = body_at(0);
  ASSERT_TRUE(body);
  auto checker = SelfIntersectionChecker::create(body->rest_mesh());
  ASSERT_TRUE(checker) << checker.error().what();
  RealtimeSkin skin(body);
  std::vector<glm::vec3> pos(body->vertex_count());
  const rig::Pose pose = standing_posture(body->skeleton());
  skin.evaluate(pose, pos, {}, true, false);
  const IntersectionReport off = checker->check(pos);
  skin.evaluate(pose, pos, {}, true, true);
  const IntersectionReport on = checker->check(pos);
  std::printf("arms pressed: between pieces %zu -> %zu pairs, %.1f mm (%s in %s) -> %.1f mm (%s in %s)\n",
              off.between_pairs, on.between_pairs, 1000 * off.deepest_envelope_m, off.deepest_envelope_part.c_str(),
              off.deepest_envelope_inside.c_str(), 1000 * on.deepest_envelope_m, on.deepest_envelope_part.c_str(),
              on.deepest_envelope_inside.c_str());
  // 549 -> 511 pairs, 31.3 -> 28.1 mm (a forearm in the hips, past the depths contact pushes).
  EXPECT_GT(off.deepest_envelope_m, 0.008);
  EXPECT_LT(on.deepest_envelope_m, off.deepest_envelope_m);
  EXPECT_LT(on.between_pairs, 0.96 * double(off.between_pairs));
}

TEST(SkinContactExact, SampledClipFramesCrossLessAndLessDeep) {
  for (int lod : {0, 3}) {
    const auto body = body_at(lod);
    ASSERT_TRUE(body);
    auto checker = SelfIntersectionChecker::create(body->rest_mesh());
    ASSERT_TRUE(checker) << checker.error().what();
    RealtimeSkin skin(body);
    std::vector<glm::vec3> pos(body->vertex_count());
    Crossing off, on;
    ::mimic::test::for_each_shared_clip_pose(body->skeleton(), 160, [&](const rig::Pose& pose) {
      skin.evaluate(pose, pos, {}, true, false);
      off.add(checker->check(pos));
      skin.evaluate(pose, pos, {}, true, true);
      on.add(checker->check(pos));
    });
    std::printf(
        "LOD %d, %.0f clip frames: between pieces %.1f -> %.1f pairs a frame, skin in skin %.2f -> %.2f mm "
        "a frame, at most %.1f -> %.1f mm; folds %.1f -> %.1f a frame\n",
        lod, on.frames, off.pairs / off.frames, on.pairs / on.frames, off.depth_mm / off.frames,
        on.depth_mm / on.frames, off.worst_mm, on.worst_mm, off.folds / off.frames, on.folds / on.frames);
    EXPECT_GT(on.frames, 50);
    // 129.8 -> 111.5 pairs and 13.9 -> 12.7 mm a frame at LOD 0, 12.7 -> 11.7 and 3.8 -> 3.6 mm at
    // LOD 3; folds 31.3 -> 31.5 and 4.4 -> 4.3.
    EXPECT_LT(on.pairs, (lod == 0 ? 0.9 : 0.95) * off.pairs) << "LOD " << lod;
    EXPECT_LT(on.depth_mm, (lod == 0 ? 0.95 : 0.98) * off.depth_mm) << "LOD " << lod;
    EXPECT_LE(on.worst_mm, off.worst_mm) << "LOD " << lod;
    EXPECT_LT(on.folds, off.folds + on.frames) << "LOD " << lod;
  }
}

}  // namespace
}  // namespace mimic::avatar::skin_contact_exact_test
