#include "mimic/avatar/skin_lod.h"

#include <gtest/gtest.h>

#include <array>
#include <map>
#include <random>

#include "mimic/rig/bvh.h"
#include "mimic/avatar/mesh_check.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/rig/retarget.h"
#include "mimic/avatar/skin.h"
#include "mimic/avatar/texture_layout.h"
#include "test_data.h"

namespace mimic::avatar::skin_lod_test {
namespace {

// LOD 0: about 9,600 triangles of skin and 5,000 of head, hands and feet (rigid_part_mesh.h).
TEST(SkinLod, FourLevelsFromAboutFifteenThousandToAboutEightHundredTriangles) {
  size_t previous = SIZE_MAX;
  for (int lod = 0; lod < kSkinLodCount; ++lod) {
    const BodyModel model = with_skin_lod(default_body_model(), lod);
    ASSERT_TRUE(validate(model)) << "LOD " << lod;
    SkinOptions o;
    o.subdivision = 0;
    auto skin = ImplicitSkin::create(model, o);
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
      EXPECT_NEAR(static_cast<double>(m.triangle_count()), 14600.0, 1500.0);
    }
    if (lod == kSkinLodCount - 1) {
      EXPECT_NEAR(static_cast<double>(m.triangle_count()), 750.0, 200.0);
    }
    EXPECT_EQ(m.parts.size(), 16u) << "every piece at every LOD";
  }
}

// The body is authored mirror-symmetric, and so is its skin in the zero posture, piece for piece,
// at every LOD: the left leg's columns once went round evenly while the right's faced its loop
// (the rule that widens a loop's narrow gaps read a loop and its mirror image differently), up
// to 2.1 cm apart at LOD 0. The rigid head is meshed on its own grid and left out.
TEST(SkinLod, EverySkinPieceMirrorsItsTwinAtEveryLod) {
  for (int lod = 0; lod < kSkinLodCount; ++lod) {
    SkinOptions o;
    o.subdivision = 0;
    auto skin = ImplicitSkin::create(with_skin_lod(default_body_model(), lod), o);
    ASSERT_TRUE(skin) << skin.error().what();
    const Mesh& m = skin->mesh();
    std::vector<glm::vec3> points;
    std::vector<char> seen(m.positions.size(), 0);
    for (const MeshPart& part : m.parts) {
      if (part.name == "head" || part.name.find("hand") != std::string::npos ||
          part.name.find("foot") != std::string::npos)
        continue;
      for (uint32_t t = part.first_triangle; t < part.first_triangle + part.triangle_count; ++t)
        for (int k = 0; k < 3; ++k)
          if (const uint32_t v = m.indices[3 * t + k]; !seen[v]) seen[v] = 1, points.push_back(m.positions[v]);
    }
    ASSERT_GT(points.size(), 100u) << "LOD " << lod;
    float worst_m = 0;
    glm::vec3 worst_at(0.0f);
    for (const glm::vec3& p : points) {
      const glm::vec3 mirrored(-p.x, p.y, p.z);
      float nearest = 1e9f;
      for (const glm::vec3& q : points) nearest = std::min(nearest, glm::distance(mirrored, q));
      if (nearest > worst_m) worst_m = nearest, worst_at = p;
    }
    EXPECT_LT(worst_m, 0.001f) << "LOD " << lod << ": a skin vertex at (" << worst_at.x << ", " << worst_at.y << ", "
                               << worst_at.z << ") is " << 1000 * worst_m << " mm from any mirror image";
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

// The pieces of the sample below, for naming and for varying one at a time.
constexpr std::array<std::pair<const char*, int SkinPieceLods::*>, 5> kPieces = {{{"torso", &SkinPieceLods::torso},
                                                                                  {"neck", &SkinPieceLods::neck},
                                                                                  {"arms", &SkinPieceLods::arms},
                                                                                  {"legs", &SkinPieceLods::legs},
                                                                                  {"rigid", &SkinPieceLods::rigid}}};

// Per-piece LOD combinations (4^5 in all): the whole body at each LOD, each piece alone at
// each LOD against the rest at every other, and a seeded random set.
std::vector<SkinPieceLods> lod_sample(int random_count = 12) {
  std::vector<SkinPieceLods> out;
  for (int lod = 0; lod < kSkinLodCount; ++lod) out.push_back(SkinPieceLods::whole(lod));
  for (const auto& piece : kPieces)
    for (int own = 0; own < kSkinLodCount; ++own)
      for (int rest = 0; rest < kSkinLodCount; ++rest) {
        if (own == rest) continue;
        SkinPieceLods l = SkinPieceLods::whole(rest);
        l.*piece.second = own;
        out.push_back(l);
      }
  std::mt19937 rng(10);
  std::uniform_int_distribution<int> level(0, kSkinLodCount - 1);
  for (int i = 0; i < random_count; ++i) out.push_back({level(rng), level(rng), level(rng), level(rng), level(rng)});
  return out;
}

ImplicitSkin full_skin(const SkinPieceLods& lods, int subdivision = 0) {
  SkinOptions o;
  o.subdivision = subdivision;
  o.normals = false;
  auto skin = ImplicitSkin::create(with_skin_lods(default_body_model(), lods), o);
  EXPECT_TRUE(skin) << skin_lods_name(lods) << ": " << skin.error().what();
  return std::move(*skin);
}

// One closed (every edge shared by exactly two triangles), consistently oriented, outward
// envelope plus the five rigid parts; no degenerate triangle.
::testing::AssertionResult sound(const Mesh& m) {
  const MeshTopology t = analyze_topology(m);
  if (!is_closed_oriented_manifold(t))
    return ::testing::AssertionFailure() << "not closed: " << t.boundary_edges << " boundary, " << t.non_manifold_edges
                                         << " non-manifold, " << t.inconsistent_edges << " flipped edges";
  if (t.components != 6u) return ::testing::AssertionFailure() << t.components << " components";
  if (t.degenerate_triangles != 0u) return ::testing::AssertionFailure() << t.degenerate_triangles << " degenerate";
  if (!(t.signed_volume > 0.030))
    return ::testing::AssertionFailure() << "volume " << t.signed_volume << " m3 (inward?)";
  for (const glm::vec3& p : m.positions)
    if (!std::isfinite(p.x + p.y + p.z)) return ::testing::AssertionFailure() << "non-finite vertex";
  return ::testing::AssertionSuccess();
}

size_t points_of(const ImplicitSkin& skin, const std::string& ring) {
  for (const auto& c : skin.contours())
    if (c.name == ring) return c.points.size();
  ADD_FAILURE() << "no ring " << ring;
  return 0;
}

std::map<std::string, uint32_t> triangles_per_part(const Mesh& m) {
  std::map<std::string, uint32_t> out;
  for (const MeshPart& p : m.parts) out[p.name] = p.triangle_count;
  return out;
}

// A limb at its own LOD takes that LOD's points per contour after its first ray-cast ring (the
// loop, its boundary-driven rings and that first ring keep the loop's count, set by the torso),
// and its own contours per link; the torso and the rigid parts depend on their own LOD only.
TEST(SkinLod, EachPieceTakesItsOwnPointsPerContourAndContoursPerLink) {
  std::array<ImplicitSkin*, kSkinLodCount> whole{};
  std::vector<ImplicitSkin> wholes;
  for (int lod = 0; lod < kSkinLodCount; ++lod) wholes.push_back(full_skin(SkinPieceLods::whole(lod)));
  for (int lod = 0; lod < kSkinLodCount; ++lod) whole[lod] = &wholes[lod];
  EXPECT_EQ(points_of(*whole[0], "l_arm_1"), 24u);
  EXPECT_EQ(points_of(*whole[3], "l_arm_1"), 4u);
  const char* torso_parts[] = {"lower_torso", "upper_torso"};
  const char* rigid_parts[] = {"head", "left_hand", "right_foot"};
  int mixed = 0;
  for (const SkinPieceLods& l : lod_sample()) {
    const std::string what = skin_lods_name(l);
    const ImplicitSkin skin = full_skin(l);
    const auto tris = triangles_per_part(skin.mesh());
    const auto torso_tris = triangles_per_part(whole[l.torso]->mesh());
    const auto rigid_tris = triangles_per_part(whole[l.rigid]->mesh());
    for (const char* p : torso_parts) EXPECT_EQ(tris.at(p), torso_tris.at(p)) << what << " " << p;
    for (const char* p : rigid_parts) EXPECT_EQ(tris.at(p), rigid_tris.at(p)) << what << " " << p;
    EXPECT_EQ(points_of(skin, "torso_0"), points_of(*whole[l.torso], "torso_0")) << what;
    for (auto [limb, lod] :
         {std::pair{"neck", l.neck}, {"l_arm", l.arms}, {"r_arm", l.arms}, {"l_leg", l.legs}, {"r_leg", l.legs}}) {
      const std::string first = std::string(limb) + "_0", own = std::string(limb) + "_1";
      EXPECT_EQ(points_of(skin, first), points_of(*whole[l.torso], first))
          << what << ": " << limb << " starts at its loop's count";
      EXPECT_EQ(points_of(skin, own), points_of(*whole[lod], own)) << what << ": " << limb << " at its own LOD";
      if (points_of(skin, first) != points_of(skin, own)) ++mixed;
    }
  }
  EXPECT_GT(mixed, 100) << "most combinations have limbs whose points change along them";
}

// Making one piece coarser never adds triangles, and every piece alone changes the count.
TEST(SkinLod, EachPieceAloneReducesTheTriangles) {
  for (const auto& [name, member] : kPieces)
    for (int rest = 0; rest < kSkinLodCount; ++rest) {
      size_t previous = SIZE_MAX;
      for (int own = 0; own < kSkinLodCount; ++own) {
        SkinPieceLods l = SkinPieceLods::whole(rest);
        l.*member = own;
        const size_t n = full_skin(l).mesh().triangle_count();
        EXPECT_LT(n, previous) << name << "=" << own << " on the rest at " << rest;
        previous = n;
      }
    }
}

// Every sampled combination, rest pose: the full method (contour points, and B-spline smoothed)
// and the realtime method give one closed, consistently oriented, outward envelope; no two
// vertices coincide (pieces meet on shared points, not on copies), and the realtime method's
// initial pose is the full method's, vertex for vertex.
TEST(SkinLod, EveryCombinationIsClosedOrientedAndOutwardAtRest) {
  for (const SkinPieceLods& l : lod_sample()) {
    const std::string what = skin_lods_name(l);
    const ImplicitSkin contour = full_skin(l, 0);
    ASSERT_TRUE(sound(contour.mesh())) << what << " full, contour points";
    EXPECT_EQ(contour.stats().missed_rays, 0) << what;
    EXPECT_EQ(weld_by_position(contour.mesh(), 1e-5f).positions.size(), contour.mesh().positions.size()) << what;
    const ImplicitSkin smooth = full_skin(l, 2);
    ASSERT_TRUE(sound(smooth.mesh())) << what << " full, B-spline";
    auto body = RealtimeBody::create(with_skin_lods(default_body_model(), l));
    ASSERT_TRUE(body) << what << ": " << body.error().what();
    RealtimeSkin skin(*body);
    Mesh m = (*body)->rest_mesh();
    skin.evaluate((*body)->skeleton().zero_pose(), m.positions);
    ASSERT_TRUE(sound(m)) << what << " realtime";
    ASSERT_EQ(m.indices, contour.mesh().indices) << what;
    float worst = 0;
    for (size_t v = 0; v < m.positions.size(); ++v)
      worst = std::max(worst, glm::distance(m.positions[v], contour.mesh().positions[v]));
    EXPECT_LT(worst, 1e-5f) << what;
  }
}

// Poses of every shared clip, with pieces at different LODs: both methods stay closed,
// oriented and outward where pieces at different LODs meet.
TEST(SkinLod, MixedLodsStayClosedThroughTheSharedClips) {
  std::vector<rig::Pose> poses;
  const rig::Skeleton skeleton = *rig::Skeleton::build(default_body_model().skeleton);
  for (const char* id : test::kShared_clips) {
    auto clip = rig::load_bvh(test::clip_path(id));
    ASSERT_TRUE(clip) << clip.error().what();
    auto r = rig::retarget_bvh(*clip);
    ASSERT_TRUE(r) << r.error().what();
    for (size_t f = 0; f < r->poses.size(); f += 160)
      poses.push_back(rig::transfer_pose(r->skeleton, r->poses[f], skeleton));
  }
  ASSERT_GT(poses.size(), 40u);
  // Each piece alone at the far end from the rest, and a random set.
  std::vector<SkinPieceLods> sample;
  for (const auto& piece : kPieces)
    for (int own : {0, kSkinLodCount - 1}) {
      SkinPieceLods l = SkinPieceLods::whole(kSkinLodCount - 1 - own);
      l.*piece.second = own;
      sample.push_back(l);
    }
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> level(0, kSkinLodCount - 1);
  for (int i = 0; i < 4; ++i) sample.push_back({level(rng), level(rng), level(rng), level(rng), level(rng)});
  for (const SkinPieceLods& l : sample) {
    const std::string what = skin_lods_name(l);
    ImplicitSkin full = full_skin(l);
    auto body = RealtimeBody::create(with_skin_lods(default_body_model(), l));
    ASSERT_TRUE(body) << body.error().what();
    RealtimeSkin skin(*body);
    Mesh m = (*body)->rest_mesh();
    for (size_t i = 0; i < poses.size(); ++i) {
      full.evaluate(poses[i]);
      ASSERT_TRUE(sound(full.mesh())) << what << " full, pose " << i;
      skin.evaluate(poses[i], m.positions);
      ASSERT_TRUE(sound(m)) << what << " realtime, pose " << i;
    }
  }
}

// Texture coordinates on the zipper strips: u around each ring on its own row (0 → 1), v along
// the piece; no triangle spans the wrap, none folds over another (every one turns the same way
// in (u, v)), and the uncapped pieces (torso pieces, upper limbs with their transition strips)
// tile their unit square exactly.
TEST(SkinLod, TextureCoordinatesOnTheTransitionStrips) {
  for (const SkinPieceLods& l : {SkinPieceLods{0, 3, 3, 3, 0}, SkinPieceLods{3, 0, 0, 0, 3}}) {
    const ImplicitSkin s = full_skin(l);
    const Mesh& m = s.mesh();
    const TextureLayout t = texture_layout(s);
    ASSERT_EQ(t.indices.size(), m.indices.size());
    for (size_t k = 0; k < t.indices.size(); ++k) ASSERT_EQ(t.source[t.indices[k]], m.indices[k]) << k;
    EXPECT_GT(t.source.size(), m.positions.size()) << "seams split";
    for (const MeshPart& p : m.parts) {
      glm::vec2 lo(1e9f), hi(-1e9f);
      double area = 0;
      for (uint32_t k = 3 * p.first_triangle; k < 3 * (p.first_triangle + p.triangle_count); k += 3) {
        const glm::vec2 a = t.uv[t.indices[k]], b = t.uv[t.indices[k + 1]], c = t.uv[t.indices[k + 2]];
        const double twice = static_cast<double>((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
        ASSERT_GT(twice, 0.0) << skin_lods_name(l) << " " << p.name << " triangle " << k / 3 << " folds in (u, v)";
        area += 0.5 * twice;
        glm::vec2 tlo(1e9f), thi(-1e9f);
        for (uint32_t corner = 0; corner < 3; ++corner) {
          const glm::vec2 uv = t.uv[t.indices[k + corner]];
          ASSERT_TRUE(uv.x >= 0 && uv.x <= 1 && uv.y >= 0 && uv.y <= 1) << p.name;
          tlo = glm::min(tlo, uv), thi = glm::max(thi, uv);
        }
        // A coarse row's step is up to a quarter turn (4 points), so a zipper triangle can span
        // about that much of u, never the wrap.
        ASSERT_LE(thi.x - tlo.x, 0.3f) << skin_lods_name(l) << " " << p.name << " triangle " << k / 3;
        ASSERT_LE(thi.y - tlo.y, 0.5f) << p.name;  // a coarse lower torso has two steps
        lo = glm::min(lo, tlo), hi = glm::max(hi, thi);
      }
      EXPECT_FLOAT_EQ(lo.x, 0.0f) << p.name;
      EXPECT_FLOAT_EQ(hi.x, 1.0f) << p.name;
      EXPECT_FLOAT_EQ(lo.y, 0.0f) << p.name;
      EXPECT_FLOAT_EQ(hi.y, 1.0f) << p.name;
      if (p.name.find("torso") != std::string::npos || p.name.find("upper") != std::string::npos) {
        EXPECT_NEAR(area, 1.0, 1e-5) << skin_lods_name(l) << " " << p.name;
      }
    }
  }
}

TEST(SkinLod, LayoutsOfPiecesAtTheirOwnLods) {
  const SkinLayout base = default_body_model().skin;
  for (int lod = 0; lod < kSkinLodCount; ++lod) {
    BodyModel a = default_body_model(), b = default_body_model();
    a.skin = skin_layout_for_lods(base, SkinPieceLods::whole(lod));
    b.skin = skin_layout_for_lod(base, lod);
    EXPECT_EQ(to_json(a), to_json(b));
    EXPECT_EQ(a.skin.arm_points, 0) << "the whole body at one LOD has no transition band";
  }
  const SkinLayout l = skin_layout_for_lods(base, {0, 1, 3, 2, 0});
  EXPECT_EQ(l.torso_points, base.torso_points);
  EXPECT_EQ(l.arm_points, 4);
  EXPECT_EQ(l.upper_leg_contours, skin_layout_for_lod(base, 2).upper_leg_contours);
  EXPECT_EQ(l.rigid_points, base.rigid_points);
  // A body at its own LOD is a body file like any other: it round-trips, and is a new layout.
  BodyModel model = default_body_model();
  model.skin = l;
  ASSERT_TRUE(validate(model));
  auto back = body_model_from_json(to_json(model));
  ASSERT_TRUE(back) << back.error().what();
  EXPECT_EQ(back->skin.arm_points, 4);
  EXPECT_EQ(to_json(*back), to_json(model));
  EXPECT_EQ(to_json(default_body_model()).find("arm_points"), std::string::npos) << "files of whole bodies unchanged";
  EXPECT_EQ(skin_layout_for_lods(l, {}).arm_points, 4) << "LOD 0 everywhere keeps a layout as it is";
  model.skin.arm_points = 2;
  EXPECT_FALSE(validate(model));
}

TEST(SkinLod, ParsesTheWholeBodyOrEachPiece) {
  EXPECT_EQ(*parse_skin_lods("2"), SkinPieceLods::whole(2));
  EXPECT_EQ(*parse_skin_lods("torso=0,arms=2,legs=1"), (SkinPieceLods{0, 0, 2, 1, 0}));
  EXPECT_EQ(*parse_skin_lods("arms=0,all=3"), (SkinPieceLods{3, 3, 0, 3, 3}));
  EXPECT_EQ(skin_lods_name({0, 0, 2, 1, 0}), "torso=0,neck=0,arms=2,legs=1,rigid=0");
  EXPECT_EQ(skin_lods_name(SkinPieceLods::whole(3)), "3");
  for (const char* bad :
       {"", "4", "-1", "x", "arms=4", "hands=1", "arms", "arms=1,arms=2", "arms=1,,legs=2", "arms=1x"}) {
    auto r = parse_skin_lods(bad);
    EXPECT_FALSE(r) << bad;
  }
  EXPECT_NE(parse_skin_lods("hands=1").error().message.find("hands"), std::string::npos);
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
      auto clip = rig::load_bvh(test::clip_path(id));
      ASSERT_TRUE(clip) << clip.error().what();
      auto r = rig::retarget_bvh(*clip);
      ASSERT_TRUE(r) << r.error().what();
      for (size_t f = 0; f < r->poses.size(); f += 80) {
        skin.evaluate(rig::transfer_pose(r->skeleton, r->poses[f], (*body)->skeleton()), m.positions);
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
}  // namespace mimic::avatar::skin_lod_test
