#include "mimic/avatar/skin_lod.h"

#include <gtest/gtest.h>

#include "mimic/avatar/bvh.h"
#include "mimic/avatar/mesh_check.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/retarget.h"
#include "mimic/avatar/skin.h"
#include "test_data.h"

namespace mimic::avatar {
namespace {

TEST(SkinLod, FourLevelsFromAboutTenThousandToAboutThreeHundredTriangles) {
  size_t previous = SIZE_MAX;
  for (int lod = 0; lod < kSkinLodCount; ++lod) {
    const BodyModel model = with_skin_lod(default_body_model(), lod);
    ASSERT_TRUE(validate(model)) << "LOD " << lod;
    SkinOptions o;
    o.subdivision = 0;
    auto skin = BodySkin::create(model, o);
    ASSERT_TRUE(skin) << skin.error().what();
    const Mesh& m = skin->mesh();
    const MeshTopology t = analyze_topology(m);
    EXPECT_TRUE(is_closed_oriented_manifold(t)) << "LOD " << lod << ": closed, no crack where pieces meet";
    EXPECT_EQ(t.components, 6u) << "LOD " << lod;
    EXPECT_GT(t.signed_volume, 0.040) << "LOD " << lod << ": coarse polygons cut into the body a little";
    EXPECT_EQ(skin->stats().missed_rays, 0) << "LOD " << lod;
    EXPECT_LT(m.triangle_count(), previous) << "LOD " << lod;
    previous = m.triangle_count();
    if (lod == 0) {
      EXPECT_NEAR(static_cast<double>(m.triangle_count()), 10000.0, 1500.0);
    }
    if (lod == kSkinLodCount - 1) {
      EXPECT_NEAR(static_cast<double>(m.triangle_count()), 300.0, 150.0);
    }
    EXPECT_EQ(m.parts.size(), 16u) << "every piece at every LOD";
  }
}

TEST(SkinLod, FewerContoursPerLinkAndFewerPointsPerContour) {
  const SkinLayout base = default_body_model().skin;
  const SkinLayout coarse = skin_layout_for_lod(base, kSkinLodCount - 1);
  EXPECT_LT(coarse.torso_points, base.torso_points);
  EXPECT_LT(coarse.shoulder_bridge, base.shoulder_bridge);
  EXPECT_LT(coarse.upper_arm_contours, base.upper_arm_contours);
  EXPECT_LT(coarse.lower_leg_contours, base.lower_leg_contours);
  EXPECT_LT(coarse.rigid_points, base.rigid_points);
  EXPECT_EQ(skin_layout_for_lod(base, 0).torso_points, base.torso_points);
  EXPECT_EQ(skin_layout_for_lod(base, 99).torso_points, coarse.torso_points) << "clamped";
}

// Pieces at different contour LODs (fine arms, coarse legs and torso) still make one closed
// envelope, and the counts move per piece.
TEST(SkinLod, PiecesAtTheirOwnLodsStillClose) {
  const SkinLayout base = default_body_model().skin;
  SkinPieceLods lods;
  lods.points = 1;
  lods.arms = 0;
  lods.legs = 3;
  lods.torso = 2;
  lods.neck = 1;
  lods.rigid = 2;
  const SkinLayout l = skin_layout_for_lods(base, lods);
  EXPECT_EQ(l.upper_arm_contours, base.upper_arm_contours);
  EXPECT_LT(l.upper_leg_contours, skin_layout_for_lod(base, 1).upper_leg_contours);
  EXPECT_EQ(l.torso_points, skin_layout_for_lod(base, 1).torso_points);
  BodyModel model = default_body_model();
  model.skin = l;
  ASSERT_TRUE(validate(model));
  SkinOptions o;
  o.subdivision = 0;
  auto skin = BodySkin::create(model, o);
  ASSERT_TRUE(skin) << skin.error().what();
  const MeshTopology t = analyze_topology(skin->mesh());
  EXPECT_TRUE(is_closed_oriented_manifold(t));
  EXPECT_EQ(t.components, 6u);
  RealtimeOptions ro;
  auto body = RealtimeBody::create(model, ro);
  ASSERT_TRUE(body);
  EXPECT_EQ((*body)->vertex_count(), skin->mesh().positions.size());
  for (int lod = 0; lod < kSkinLodCount; ++lod) {
    const SkinLayout same = skin_layout_for_lods(base, {lod, lod, lod, lod, lod, lod});
    EXPECT_EQ(same.torso_points, skin_layout_for_lod(base, lod).torso_points);
    EXPECT_EQ(same.lower_leg_contours, skin_layout_for_lod(base, lod).lower_leg_contours);
  }
}

// The realtime method at every LOD through the shared clips: one closed, outward envelope and
// the same rigid parts in every frame.
TEST(SkinLod, RealtimeEveryLodStaysClosedThroughTheSharedClips) {
  for (int lod = 1; lod < kSkinLodCount; ++lod) {
    RealtimeOptions o;
    o.lod = lod;
    auto body = RealtimeBody::create(default_body_model(), o);
    ASSERT_TRUE(body) << body.error().what();
    RealtimeSkin skin(*body);
    Mesh m = (*body)->rest_mesh();
    int poses = 0;
    for (const char* id : test::kShared_clips) {
      auto clip = load_bvh(test::clip_path(id));
      ASSERT_TRUE(clip) << clip.error().what();
      auto r = retarget_bvh(*clip);
      ASSERT_TRUE(r) << r.error().what();
      for (size_t f = 0; f < r->poses.size(); f += 80) {
        skin.evaluate(transfer_pose(r->skeleton, r->poses[f], (*body)->skeleton()), m.positions);
        const MeshTopology t = analyze_topology(m);
        ASSERT_TRUE(is_closed_oriented_manifold(t)) << "LOD " << lod << " " << id << " frame " << f;
        ASSERT_EQ(t.components, 6u);
        ASSERT_GT(t.signed_volume, 0.035) << "LOD " << lod << " " << id << " frame " << f;
        for (const glm::vec3& p : m.positions) ASSERT_TRUE(std::isfinite(p.x + p.y + p.z));
        ++poses;
      }
    }
    EXPECT_GT(poses, 100);
  }
}

TEST(SkinLod, ChoosesByScreenHeightWithHysteresis) {
  EXPECT_EQ(choose_lod(1000.0f), 0);
  EXPECT_EQ(choose_lod(300.0f), 1);
  EXPECT_EQ(choose_lod(100.0f), 2);
  EXPECT_EQ(choose_lod(10.0f), 3);
  // Around the 200 px threshold between LOD 1 and 2: each keeps itself within ±10%.
  EXPECT_EQ(choose_lod(190.0f, 1), 1);
  EXPECT_EQ(choose_lod(175.0f, 1), 2);
  EXPECT_EQ(choose_lod(210.0f, 2), 2);
  EXPECT_EQ(choose_lod(225.0f, 2), 1);
  // A slow approach changes level once per threshold, never back and forth.
  int lod = -1, changes = 0;
  for (float px = 20.0f; px < 1000.0f; px *= 1.01f) {
    const int next = choose_lod(px + (changes % 2 ? 3.0f : -3.0f), lod);  // a little jitter
    if (lod >= 0 && next != lod) ++changes;
    EXPECT_LE(next, lod < 0 ? 3 : lod) << "only finer as the avatar grows";
    lod = next;
  }
  EXPECT_EQ(changes, 3);
  EXPECT_EQ(lod, 0);
}

TEST(SkinLod, ChoosesByDistance) {
  // 1.7 m at 1 m fills a 1080-px 60° view; at 30 m it is about 50 px high.
  EXPECT_EQ(choose_lod_at_distance(1.0f), 0);
  EXPECT_EQ(choose_lod_at_distance(30.0f), 3);
  EXPECT_LT(choose_lod_at_distance(3.0f), choose_lod_at_distance(12.0f));
  EXPECT_EQ(choose_lod_at_distance(0.0f), 0) << "at the camera: finest";
}

}  // namespace
}  // namespace mimic::avatar
