#include "mimic/avatar/contour_layout.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "mimic/rig/motion.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin.h"
#include "mimic/avatar/skin_lod.h"
#include "mimic/avatar/skin_weights.h"
#include "mimic/avatar/texture_layout.h"

namespace mimic::avatar::contour_layout_test {
namespace {

ContourLayout build_layout(const BodyModel& model, int subdivision, bool rigid = true) {
  auto sk = rig::Skeleton::build(model.skeleton);
  EXPECT_TRUE(sk);
  auto layout = ContourLayout::build(model, *sk, {subdivision, rigid});
  EXPECT_TRUE(layout) << layout.error().what();
  return std::move(*layout);
}

// Poses the planes are checked in: the zero posture and a walk (bent elbows and knees).
std::vector<rig::Pose> poses(const rig::Skeleton& sk) {
  std::vector<rig::Pose> out{sk.zero_pose()};
  auto walk = rig::make_builtin_motion("walk", sk);
  EXPECT_TRUE(walk);
  for (double t : {0.2, 0.45, 0.8}) {
    rig::Pose p = sk.zero_pose();
    (*walk)->sample(t, p);
    out.push_back(p);
  }
  return out;
}

TEST(ContourLayout, StarPlaneDirectionsAreUnitAndInThePlane) {
  for (int lod = 0; lod < kSkinLodCount; ++lod) {
    const ContourLayout layout = build_layout(with_skin_lod(default_body_model(), lod), 1);
    for (const rig::Pose& pose : poses(layout.skeleton())) {
      const std::vector<ContourPlane> planes = layout.star_planes(pose);
      ASSERT_FALSE(planes.empty());
      for (const ContourPlane& p : planes) {
        EXPECT_NEAR(glm::length(p.normal), 1.0f, 1e-5f) << p.name;
        ASSERT_GE(p.directions.size(), 3u) << p.name;
        for (const glm::vec3& d : p.directions) {
          EXPECT_NEAR(glm::length(d), 1.0f, 1e-5f) << p.name << " LOD " << lod;
          EXPECT_NEAR(glm::dot(d, p.normal), 0.0f, 1e-5f) << p.name << " LOD " << lod;
        }
        // The rays go once round the ring, counter-clockwise about the normal: consecutive
        // directions turn the same way and no two coincide.
        for (size_t j = 0; j < p.directions.size(); ++j) {
          const glm::vec3 a = p.directions[j], b = p.directions[(j + 1) % p.directions.size()];
          EXPECT_GT(glm::dot(glm::cross(a, b), p.normal), 0.0f) << p.name << " ray " << j;
        }
      }
    }
  }
}

TEST(ContourLayout, TheMeshUsesEveryVertexAndItsPartsCoverTheTriangles) {
  const ContourLayout layout = build_layout(default_body_model(), 0);
  // At subdivision 0 the control points are the first vertices; caps and rigid parts follow.
  EXPECT_GT(layout.vertex_count(), layout.control_point_count());
  ASSERT_EQ(layout.indices().size() % 3, 0u);
  std::vector<int> used(layout.vertex_count(), 0);
  for (uint32_t i : layout.indices()) {
    ASSERT_LT(i, layout.vertex_count());
    used[i] = 1;
  }
  EXPECT_EQ(std::count(used.begin(), used.end(), 0), 0) << "every vertex is a corner of some triangle";
  // Parts cover the triangles in order, without overlap.
  uint32_t next = 0;
  for (const MeshPart& p : layout.parts()) {
    EXPECT_EQ(p.first_triangle, next) << p.name;
    next += p.triangle_count;
  }
  EXPECT_EQ(next, layout.indices().size() / 3);
  EXPECT_EQ(layout.parts().size(), 16u);  // eleven pieces, head, two hands, two feet
}

TEST(ContourLayout, ImplicitAndRealtimeSkinsOfOneLayoutShareTheirTopology) {
  const BodyModel model = with_skin_lod(default_body_model(), 1);
  const ContourLayout layout = build_layout(model, 0);
  auto implicit = ImplicitSkin::create(model, layout);
  ASSERT_TRUE(implicit) << implicit.error().what();
  auto realtime = RealtimeBody::create(model, layout, {});
  ASSERT_TRUE(realtime) << realtime.error().what();
  const Mesh& a = implicit->mesh();
  const Mesh& b = (*realtime)->rest_mesh();
  EXPECT_EQ(a.positions.size(), layout.vertex_count());
  EXPECT_EQ(b.positions.size(), layout.vertex_count());
  EXPECT_EQ(a.indices, b.indices);
  ASSERT_EQ(a.parts.size(), b.parts.size());
  for (size_t i = 0; i < a.parts.size(); ++i) {
    EXPECT_EQ(a.parts[i].name, b.parts[i].name);
    EXPECT_EQ(a.parts[i].first_triangle, b.parts[i].first_triangle);
    EXPECT_EQ(a.parts[i].triangle_count, b.parts[i].triangle_count);
  }
  // The realtime body's initial pose is the implicit skin's zero posture, vertex for vertex.
  EXPECT_EQ(a.positions, b.positions);
  // Weights and UVs read the same layout.
  auto weights = contour_skin_weights(layout);
  ASSERT_TRUE(weights);
  EXPECT_EQ(weights->size(), layout.vertex_count());
  EXPECT_EQ(texture_layout(layout).indices.size(), layout.indices().size());
}

TEST(ContourLayout, SubdivisionRefinesTheSamePiecesAndRigidPartsAreOptional) {
  const ContourLayout coarse = build_layout(default_body_model(), 0);
  const ContourLayout fine = build_layout(default_body_model(), 2);
  EXPECT_EQ(coarse.ring_count(), fine.ring_count());
  EXPECT_EQ(coarse.control_point_count(), fine.control_point_count());
  EXPECT_GT(fine.vertex_count(), coarse.vertex_count());
  ASSERT_EQ(coarse.parts().size(), fine.parts().size());
  for (size_t i = 0; i < coarse.parts().size(); ++i) EXPECT_EQ(coarse.parts()[i].name, fine.parts()[i].name);
  const ContourLayout bare = build_layout(default_body_model(), 0, false);
  EXPECT_EQ(bare.parts().size(), 11u);
}

TEST(ContourLayout, RejectsABadSubdivisionAndARealtimeBodyOfSmoothedRows) {
  const BodyModel model = default_body_model();
  auto sk = rig::Skeleton::build(model.skeleton);
  ASSERT_TRUE(sk);
  EXPECT_FALSE(ContourLayout::build(model, *sk, {17, true}));
  EXPECT_FALSE(ContourLayout::build(model, *sk, {-1, true}));
  auto realtime = RealtimeBody::create(model, build_layout(model, 1), {});
  EXPECT_FALSE(realtime) << "a realtime body needs the control points as vertices";
}

}  // namespace
}  // namespace mimic::avatar::contour_layout_test
