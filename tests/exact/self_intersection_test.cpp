#include "mimic/avatar/self_intersection.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

#include "mimic/avatar/mesh_check.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin.h"
#include "mimic/rig/bvh.h"
#include "mimic/rig/motion.h"
#include "mimic/rig/retarget.h"
#include "test_data.h"

namespace mimic::avatar::self_intersection_test {
namespace {

// Appends an axis-aligned box (outward, counter-clockwise) as a part of its own.
void add_box(Mesh& m, const std::string& name, glm::vec3 centre, glm::vec3 half) {
  const auto base = static_cast<uint32_t>(m.positions.size());
  for (int i = 0; i < 8; ++i)
    m.positions.push_back(centre + half * glm::vec3(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1));
  const uint32_t faces[12][3] = {{0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}, {0, 1, 5}, {0, 5, 4},
                                 {2, 6, 7}, {2, 7, 3}, {0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}};
  m.parts.push_back({name, static_cast<uint32_t>(m.triangle_count()), 12});
  for (const auto& f : faces)
    for (uint32_t i : f) m.indices.push_back(base + i);
}

// A closed UV sphere of radius r (metres), one part, wound outward.
Mesh sphere(float r, int rings = 12, int around = 16) {
  Mesh m;
  m.positions.push_back({0, r, 0});
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < around; ++j) {
      const float theta = float(M_PI) * float(i) / float(rings), phi = 2 * float(M_PI) * float(j) / float(around);
      m.positions.push_back(
          {r * std::sin(theta) * std::cos(phi), r * std::cos(theta), r * std::sin(theta) * std::sin(phi)});
    }
  m.positions.push_back({0, -r, 0});
  const auto south = static_cast<uint32_t>(m.positions.size() - 1);
  auto at = [&](int i, int j) { return static_cast<uint32_t>(1 + (i - 1) * around + (j % around)); };
  for (int j = 0; j < around; ++j) {
    m.indices.insert(m.indices.end(), {0u, at(1, j + 1), at(1, j)});
    m.indices.insert(m.indices.end(), {south, at(rings - 1, j), at(rings - 1, j + 1)});
    for (int i = 1; i + 1 < rings; ++i) {
      m.indices.insert(m.indices.end(), {at(i, j), at(i, j + 1), at(i + 1, j + 1)});
      m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j + 1), at(i + 1, j)});
    }
  }
  if (analyze_topology(m).signed_volume < 0)
    for (size_t t = 0; t < m.triangle_count(); ++t) std::swap(m.indices[3 * t + 1], m.indices[3 * t + 2]);
  m.parts.push_back({"ball", 0, static_cast<uint32_t>(m.triangle_count())});
  return m;
}

IntersectionReport check(const Mesh& m, const IntersectionRules& rules = IntersectionRules::none()) {
  auto checker = SelfIntersectionChecker::create(m, rules);
  EXPECT_TRUE(checker) << checker.error().what();
  return checker ? checker->check(m.positions) : IntersectionReport{};
}

TEST(SelfIntersection, AClosedSphereHasNone) {
  const Mesh m = sphere(0.1f);
  ASSERT_TRUE(is_closed_oriented_manifold(analyze_topology(m)));
  const IntersectionReport r = check(m);
  EXPECT_EQ(r.fold_pairs, 0u);
  EXPECT_EQ(r.between_pairs, 0u);
  EXPECT_EQ(r.deepest_m, 0.0);
  EXPECT_TRUE(r.by_parts.empty());
  EXPECT_GT(r.sharpest_crease_deg, 5.0);  // a polyhedron's edges, not a fold
  EXPECT_LT(r.sharpest_crease_deg, 30.0);
}

TEST(SelfIntersection, InterpenetratingBoxesGivePairsAndTheirDepth) {
  // B's near face is 30 mm inside A: 30 mm from A's +x face, 50 mm from its sides.
  Mesh m;
  add_box(m, "a", {0, 0, 0}, {0.1f, 0.1f, 0.1f});
  add_box(m, "b", {0.17f, 0, 0}, {0.1f, 0.05f, 0.05f});
  const IntersectionReport r = check(m);
  EXPECT_EQ(r.fold_pairs, 0u);
  EXPECT_GT(r.between_pairs, 0u);
  ASSERT_EQ(r.by_parts.size(), 1u);
  EXPECT_EQ(r.by_parts[0].a, "a");
  EXPECT_EQ(r.by_parts[0].b, "b");
  EXPECT_NEAR(r.deepest_m, 0.030, 1e-6);
  EXPECT_EQ(r.deepest_part, "b");
  EXPECT_EQ(r.deepest_inside, "a");
  EXPECT_NEAR(r.sharpest_crease_deg, 90.0, 1e-3);

  // Apart, nothing; by design (the rules name the pair), counted apart and no depth.
  Mesh apart;
  add_box(apart, "a", {0, 0, 0}, {0.1f, 0.1f, 0.1f});
  add_box(apart, "b", {0.25f, 0, 0}, {0.1f, 0.05f, 0.05f});
  EXPECT_EQ(check(apart).between_pairs, 0u);
  IntersectionRules rules;
  rules.by_design = {{"b", "a"}};
  const IntersectionReport designed = check(m, rules);
  EXPECT_EQ(designed.between_pairs, 0u);
  EXPECT_EQ(designed.by_design_pairs, r.between_pairs);
  EXPECT_EQ(designed.deepest_m, 0.0);
}

TEST(SelfIntersection, ASphereWithItsPolePushedThroughFoldsInsideOnePiece) {
  Mesh m = sphere(0.1f);
  m.positions[0] = {0.01f, -0.15f, 0.005f};  // the north pole out through the south cap
  const IntersectionReport r = check(m);
  EXPECT_GT(r.fold_pairs, 0u);
  EXPECT_EQ(r.between_pairs, 0u);
  ASSERT_FALSE(r.by_parts.empty());
  EXPECT_EQ(r.by_parts[0].a, "ball");
  EXPECT_EQ(r.by_parts[0].b, "ball");
  EXPECT_GT(r.sharpest_crease_deg, 90.0);
}

TEST(SelfIntersection, NeighboursThatOnlyShareAVertexOrAnEdgeDoNotCount) {
  // Two triangles on one edge folded nearly flat back (179 deg crease), and a third on a shared
  // vertex only, touching it there.
  Mesh m;
  const float a = glm::radians(1.0f);  // the second triangle 1 deg from the first
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0.5f, 1, 0}, {0.5f, std::cos(a), std::sin(a)}, {-1, 0.2f, 0}, {-1, -0.2f, 0}};
  m.indices = {0, 1, 2, 1, 0, 3, 0, 5, 4};
  m.parts = {{"sheet", 0, 3}};
  IntersectionReport r = check(m);
  EXPECT_EQ(r.fold_pairs, 0u);
  EXPECT_NEAR(r.sharpest_crease_deg, 179.0, 0.01);
  // Folded exactly flat back, the two overlap beyond their edge: that counts.
  m.positions[3] = {0.5f, 1, 0};
  EXPECT_EQ(check(m).fold_pairs, 1u);
}

TEST(SelfIntersection, RefusesNonManifoldTopology) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, -1, 0}};
  m.indices = {0, 1, 2, 0, 1, 3, 0, 1, 4};  // one edge, three triangles, two running it one way
  EXPECT_FALSE(SelfIntersectionChecker::create(m));
  m.indices = {0, 1, 9};
  EXPECT_FALSE(SelfIntersectionChecker::create(m));
}

// The default body's realtime skin: what the checker finds must hang together (every pair is
// counted once and in one class, a depth comes with a pair of the two parts, only rigid parts and
// the pieces they attach to are by design), the authored posture is clean, and a hand pushed into
// the chest is found with its depth.
class BodySelfIntersection : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto b = RealtimeBody::create(default_body_model());
    ASSERT_TRUE(b) << b.error().what();
    body_ = new std::shared_ptr<const RealtimeBody>(*b);
  }
  static void TearDownTestSuite() { delete body_; }
  static const RealtimeBody& body() { return **body_; }
  static std::shared_ptr<const RealtimeBody> shared() { return *body_; }
  static void expect_consistent(const IntersectionReport& r, const std::string& what) {
    size_t folds = 0, between = 0, designed = 0;
    bool depth_has_pair = r.deepest_m == 0;
    for (const PartPairCount& p : r.by_parts) {
      (p.a == p.b ? folds : p.by_design ? designed : between) += p.pairs;
      if (p.by_design) {
        const bool rigid_a = p.a == "head" || p.a.ends_with("_hand") || p.a.ends_with("_foot");
        const std::string& rigid = rigid_a ? p.a : p.b;
        const std::string& piece = rigid_a ? p.b : p.a;
        EXPECT_TRUE(rigid == "head" ? piece == "neck" : piece.ends_with("_lower_arm") || piece.ends_with("_lower_leg"))
            << what << ": " << p.a << "/" << p.b;
      }
      depth_has_pair |= !p.by_design && ((p.a == r.deepest_part && p.b == r.deepest_inside) ||
                                         (p.b == r.deepest_part && p.a == r.deepest_inside));
    }
    EXPECT_EQ(folds, r.fold_pairs) << what;
    EXPECT_EQ(between, r.between_pairs) << what;
    EXPECT_EQ(designed, r.by_design_pairs) << what;
    EXPECT_TRUE(depth_has_pair) << what << ": " << r.deepest_part << " in " << r.deepest_inside;
    EXPECT_LT(r.deepest_m, 0.1) << what;
    EXPECT_LE(r.sharpest_crease_deg, 180.0) << what;
  }
  static inline std::shared_ptr<const RealtimeBody>* body_ = nullptr;
};

TEST_F(BodySelfIntersection, TheAuthoredPostureIsCleanAndTheRigidPartsSinkByDesign) {
  auto checker = SelfIntersectionChecker::create(body().rest_mesh());
  ASSERT_TRUE(checker) << checker.error().what();
  EXPECT_EQ(checker->part_count(), 16u);  // eleven skin pieces, head, hands and feet
  const IntersectionReport r = checker->check(body().rest_mesh().positions);
  expect_consistent(r, "zero posture");
  EXPECT_EQ(r.fold_pairs, 0u);
  EXPECT_EQ(r.between_pairs, 0u);
  EXPECT_EQ(r.deepest_m, 0.0);
  EXPECT_GT(r.by_design_pairs, 100u);  // head, hands and feet sink into their pieces
  EXPECT_EQ(r.triangles, body().rest_mesh().triangle_count());
}

TEST_F(BodySelfIntersection, AHandPushedIntoTheChestIsFoundWithItsDepth) {
  auto checker = SelfIntersectionChecker::create(body().rest_mesh());
  ASSERT_TRUE(checker) << checker.error().what();
  Mesh m = body().rest_mesh();
  const auto part =
      std::find_if(m.parts.begin(), m.parts.end(), [](const MeshPart& p) { return p.name == "left_hand"; });
  ASSERT_NE(part, m.parts.end());
  std::vector<uint32_t> hand(m.indices.begin() + 3 * part->first_triangle,
                             m.indices.begin() + 3 * (part->first_triangle + part->triangle_count));
  std::sort(hand.begin(), hand.end());
  hand.erase(std::unique(hand.begin(), hand.end()), hand.end());
  // The chest's front: the upper torso's vertex furthest along +Z (the body faces +Z).
  glm::vec3 chest(0, 0, -1e9f), centre(0);
  const auto torso =
      std::find_if(m.parts.begin(), m.parts.end(), [](const MeshPart& p) { return p.name == "upper_torso"; });
  for (uint32_t t = torso->first_triangle; t < torso->first_triangle + torso->triangle_count; ++t)
    for (int k = 0; k < 3; ++k)
      if (m.positions[m.indices[3 * t + k]].z > chest.z) chest = m.positions[m.indices[3 * t + k]];
  for (uint32_t v : hand) centre += m.positions[v] / float(hand.size());
  float reach = 0;  // the hand's farthest point from its centre along -Z, so it straddles the skin
  for (uint32_t v : hand) reach = std::max(reach, centre.z - m.positions[v].z);
  const glm::vec3 shift = chest - centre + glm::vec3(0, 0, -0.5f * reach);
  for (uint32_t v : hand) m.positions[v] += shift;
  const IntersectionReport r = checker->check(m.positions);
  expect_consistent(r, "hand in the chest");
  const auto pair = std::find_if(r.by_parts.begin(), r.by_parts.end(),
                                 [](const PartPairCount& p) { return p.a == "upper_torso" && p.b == "left_hand"; });
  ASSERT_NE(pair, r.by_parts.end());
  EXPECT_GT(pair->pairs, 0u);
  EXPECT_FALSE(pair->by_design);
  EXPECT_EQ(r.between_pairs, pair->pairs);
  EXPECT_EQ(r.deepest_part, "left_hand");
  EXPECT_EQ(r.deepest_inside, "upper_torso");
  // The hand reaches 1.5 reach behind the chest's front: from there a ray along +Z leaves the
  // torso within that (no torso point is further forward), so no hand vertex is deeper.
  EXPECT_GT(r.deepest_m, 0.5 * reach);
  EXPECT_LT(r.deepest_m, 1.5 * reach + 1e-4);
}

// Two frames of the built-in walk with both methods (the same mesh at subdivision 0): what is
// found hangs together, and the rigid parts sink into their pieces in every frame.
TEST_F(BodySelfIntersection, TwoFramesOfTheWalk) {
  auto checker = SelfIntersectionChecker::create(body().rest_mesh());
  ASSERT_TRUE(checker) << checker.error().what();
  RealtimeSkin skin(shared());
  SkinOptions so;
  so.subdivision = 0;
  so.normals = false;
  auto full = ImplicitSkin::create(default_body_model(), so);
  ASSERT_TRUE(full) << full.error().what();
  ASSERT_EQ(full->mesh().indices, body().rest_mesh().indices);
  auto walk = rig::make_builtin_motion("walk", body().skeleton());
  ASSERT_TRUE(walk) << walk.error().what();
  Mesh m = body().rest_mesh();
  rig::Pose pose = body().skeleton().zero_pose();
  for (double t_s : {0.0, 0.5}) {
    (*walk)->sample(t_s, pose);
    skin.evaluate(pose, m.positions);
    full->evaluate(pose);
    const std::vector<glm::vec3>* both[] = {&m.positions, &full->mesh().positions};
    for (const std::vector<glm::vec3>* positions : both) {
      const IntersectionReport r = checker->check(*positions);
      const std::string what =
          std::string(positions == &m.positions ? "realtime" : "full") + ", walk at " + std::to_string(t_s) + " s";
      expect_consistent(r, what);
      std::printf("%s: folds %zu, between %zu, by design %zu, deepest %.1f mm (%s in %s), crease %.1f deg\n",
                  what.c_str(), r.fold_pairs, r.between_pairs, r.by_design_pairs, 1000 * r.deepest_m,
                  r.deepest_part.c_str(), r.deepest_inside.c_str(), r.sharpest_crease_deg);
      EXPECT_GT(r.by_design_pairs, 100u) << what;
    }
  }
}

// Every shared clip, sampled (the full sweep is `mimic intersect`, docs/skin.md): the T-pose each
// CMU clip opens with is clean, and what two frames a clip show hangs together.
TEST_F(BodySelfIntersection, EverySharedClipSampled) {
  auto checker = SelfIntersectionChecker::create(body().rest_mesh());
  ASSERT_TRUE(checker) << checker.error().what();
  RealtimeSkin skin(shared());
  Mesh m = body().rest_mesh();
  size_t folds = 0, between = 0, frames = 0;
  for (const char* id : ::mimic::test::kShared_clips) {
    auto clip = rig::load_bvh(::mimic::test::clip_path(id));
    ASSERT_TRUE(clip) << clip.error().what();
    auto r = rig::retarget_bvh(*clip);
    ASSERT_TRUE(r) << r.error().what();
    const size_t n = r->poses.size();
    for (size_t f : {size_t(0), n / 3, 2 * n / 3}) {
      skin.evaluate(rig::transfer_pose(r->skeleton, r->poses[f], body().skeleton()), m.positions);
      const IntersectionReport report = checker->check(m.positions);
      const std::string what = std::string(id) + " frame " + std::to_string(f);
      expect_consistent(report, what);
      if (f == 0) {
        EXPECT_EQ(report.fold_pairs, 0u) << what;
        EXPECT_EQ(report.between_pairs, 0u) << what;
      } else {
        folds += report.fold_pairs, between += report.between_pairs, ++frames;
      }
    }
  }
  std::printf("shared clips, %zu frames: %.1f folds and %.1f pairs between pieces a frame\n", frames,
              double(folds) / double(frames), double(between) / double(frames));
}

}  // namespace
}  // namespace mimic::avatar::self_intersection_test
