#include "mimic/avatar/surface_distance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "mimic/avatar/measure.h"
#include "mimic/avatar/mesh_io.h"
#include "test_data.h"

namespace mimic::avatar::surface_distance_test {
namespace {

constexpr float kPi = 3.14159265358979f;

// UV sphere of radius r about c, outward faces; every vertex lies on the sphere.
Mesh sphere(glm::vec3 c, float r, int rings = 96, int sectors = 192) {
  Mesh m;
  m.positions.push_back(c + glm::vec3(0, r, 0));
  for (int i = 1; i < rings; ++i) {
    const float th = kPi * float(i) / float(rings);
    for (int j = 0; j < sectors; ++j) {
      const float ph = 2 * kPi * float(j) / float(sectors);
      m.positions.push_back(c + r * glm::vec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph)));
    }
  }
  m.positions.push_back(c - glm::vec3(0, r, 0));
  const auto ring = [&](int i, int j) { return uint32_t(1 + (i - 1) * sectors + (j % sectors)); };
  const auto bottom = uint32_t(m.positions.size() - 1);
  for (int j = 0; j < sectors; ++j) {
    m.indices.insert(m.indices.end(), {0u, ring(1, j + 1), ring(1, j)});
    for (int i = 1; i + 1 < rings; ++i)
      m.indices.insert(m.indices.end(), {ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i, j), ring(i + 1, j + 1),
                                         ring(i + 1, j)});
    m.indices.insert(m.indices.end(), {bottom, ring(rings - 1, j), ring(rings - 1, j + 1)});
  }
  return m;
}

TEST(SurfaceDistance, ClosestPointOnTriangleMatchesADenseSearch) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int trial = 0; trial < 300; ++trial) {
    const glm::vec3 a{u(rng), u(rng), u(rng)}, b{u(rng), u(rng), u(rng)}, c{u(rng), u(rng), u(rng)};
    const glm::vec3 p{2 * u(rng), 2 * u(rng), 2 * u(rng)};
    const glm::vec3 q = closest_point_on_triangle(p, a, b, c);
    // q lies on the triangle (barycentric weights in [0, 1]) and no point of a fine grid over
    // the triangle is nearer to p.
    float best = std::numeric_limits<float>::max();
    const int n = 200;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const glm::vec3 g = a + (float(i) / n) * (b - a) + (float(j) / n) * (c - a);
        best = std::min(best, glm::distance(p, g));
      }
    const float got = glm::distance(p, q);
    EXPECT_LE(got, best + 1e-5f) << trial;
    EXPECT_GE(got, best - 0.02f) << trial;  // the grid's spacing bounds how far it can miss
    const glm::vec3 n_tri = glm::cross(b - a, c - a);
    EXPECT_NEAR(glm::dot(q - a, n_tri), 0.0f, 1e-4f * glm::length(n_tri));
  }
}

TEST(SurfaceDistance, TreeFindsTheSameNearestPointAsBruteForce) {
  auto mesh = read_obj(test::shared_data("mesh/makehuman_base_body.obj"), 0.1f);
  ASSERT_TRUE(mesh) << mesh.error().message;
  const TriangleTree tree(*mesh);
  ASSERT_EQ(tree.triangle_count(), mesh->triangle_count());
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> ux(-0.5f, 0.5f), uy(-0.1f, 1.9f), uz(-0.3f, 0.3f);
  for (int trial = 0; trial < 40; ++trial) {
    const glm::vec3 p{ux(rng), uy(rng), uz(rng)};
    float best = std::numeric_limits<float>::max();
    for (size_t t = 0; t < mesh->triangle_count(); ++t) {
      const auto& ix = mesh->indices;
      const glm::vec3 q = closest_point_on_triangle(p, mesh->positions[ix[3 * t]], mesh->positions[ix[3 * t + 1]],
                                                    mesh->positions[ix[3 * t + 2]]);
      best = std::min(best, glm::distance(p, q));
    }
    const auto hit = tree.closest(p);
    EXPECT_NEAR(hit.distance_m, best, 1e-6f) << trial;
    EXPECT_NEAR(glm::distance(hit.point, p), hit.distance_m, 1e-6f);
  }
  EXPECT_LT(TriangleTree(Mesh{}).closest({0, 0, 0}).distance_m, 0.0f);
}

TEST(SurfaceDistance, SamplesAreSpreadInProportionToArea) {
  // Two unit-normal squares: the left one 1 × 1 in two triangles, the right one 1 × 3 in 600
  // thin triangles. Area-fair samples fall 1 : 3 whatever the triangle counts.
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2, 0, 2, 3};
  const int strips = 300;
  for (int i = 0; i <= strips; ++i) {
    const float y = 3.0f * float(i) / strips;
    m.positions.push_back({2, y, 0});
    m.positions.push_back({3, y, 0});
  }
  for (int i = 0; i < strips; ++i) {
    const auto b = uint32_t(4 + 2 * i);
    m.indices.insert(m.indices.end(), {b, b + 1, b + 3, b, b + 3, b + 2});
  }
  const auto samples = sample_surface(m, 8000);
  ASSERT_EQ(samples.size(), 8000u);
  int left = 0;
  for (const auto& s : samples) left += s.point.x < 1.5f;
  EXPECT_NEAR(double(left) / 8000.0, 0.25, 0.01);
  // Deterministic for a seed.
  EXPECT_EQ(sample_surface(m, 100)[37].point, sample_surface(m, 100)[37].point);
}

TEST(SurfaceDistance, IdenticalMeshesAreZeroApart) {
  auto mesh = read_obj(test::shared_data("mesh/makehuman_base_body.obj"), 0.1f);
  auto lm = load_makehuman_joints(test::shared_data("mesh/makehuman_base_joints.csv"));
  ASSERT_TRUE(mesh && lm);
  const SurfaceDistance d = surface_distance(*mesh, *lm, *mesh, *lm, 5000);
  EXPECT_EQ(d.body_to_reference.samples, 5000);
  EXPECT_LT(d.body_to_reference.max_m, 1e-6);
  EXPECT_LT(d.reference_to_body.max_m, 1e-6);
  EXPECT_LT(d.worst_mean_m(), 1e-7);
}

TEST(SurfaceDistance, SphereInsideALargerSphereIsTheOffsetBothWays) {
  const float r = 0.10f, big = 0.13f;
  const Mesh a = sphere({0.2f, 1.0f, 0}, r), b = sphere({0.2f, 1.0f, 0}, big);
  const SurfaceDistance d = surface_distance(a, BodyLandmarks{}, b, BodyLandmarks{}, 20000);
  // The tessellation's chords lie at most r(1 − cos(π/96)) ≈ 0.05 mm inside the sphere.
  EXPECT_NEAR(d.body_to_reference.mean_m, big - r, 2e-4);
  EXPECT_NEAR(d.reference_to_body.mean_m, big - r, 2e-4);
  EXPECT_NEAR(d.body_to_reference.max_m, big - r, 3e-4);
  EXPECT_NEAR(d.worst_mean_m(), big - r, 2e-4);
  // Off-centre by d = 20 mm: a point c + r·n lies R − |c + r·n| from the big sphere, between 10
  // and 50 mm; averaged over the small sphere (uniform in cos θ) that is
  // R − ((r + d)³ − (r − d)³) / (6 r d) = 130 − 101.33 = 28.67 mm, not the 30 mm of the radii.
  const Mesh shifted = sphere({0.22f, 1.0f, 0}, r);
  const SurfaceDistance s = surface_distance(shifted, BodyLandmarks{}, b, BodyLandmarks{}, 20000);
  EXPECT_GT(s.body_to_reference.max_m, 0.049);
  EXPECT_LT(s.body_to_reference.max_m, 0.0502);
  const double shift = 0.02, expected = big - (std::pow(r + shift, 3) - std::pow(r - shift, 3)) / (6 * r * shift);
  EXPECT_NEAR(s.body_to_reference.mean_m, expected, 3e-4);
}

TEST(SurfaceDistance, RegionsFollowTheSkeleton) {
  auto lm = load_makehuman_joints(test::shared_data("mesh/makehuman_base_joints.csv"));
  ASSERT_TRUE(lm);
  const RegionClassifier regions(*lm);
  const auto mid = [](glm::vec3 a, glm::vec3 b) { return 0.5f * (a + b); };
  EXPECT_EQ(regions.classify(lm->head_top_m), BodyRegion::head);
  EXPECT_EQ(regions.classify(mid(lm->pelvis_m, lm->neck_m)), BodyRegion::torso);
  EXPECT_EQ(regions.classify(mid(lm->left.shoulder_m, lm->left.elbow_m)), BodyRegion::arms);
  EXPECT_EQ(regions.classify(mid(lm->right.elbow_m, lm->right.wrist_m)), BodyRegion::arms);
  const glm::vec3 hand = lm->left.wrist_m + 0.4f * (lm->left.wrist_m - lm->left.elbow_m);
  EXPECT_EQ(regions.classify(hand), BodyRegion::hands);
  EXPECT_EQ(regions.classify(mid(lm->left.hip_m, lm->left.knee_m)), BodyRegion::legs);
  const glm::vec3 toes = glm::vec3(lm->right.ankle_m.x, lm->ground_y_m + 0.02f, lm->right.ankle_m.z + 0.12f);
  EXPECT_EQ(regions.classify(toes), BodyRegion::feet);

  // On the mesh itself every region gets samples, in both directions.
  auto mesh = read_obj(test::shared_data("mesh/makehuman_base_body.obj"), 0.1f);
  ASSERT_TRUE(mesh);
  const auto d = directed_distance(*mesh, *lm, TriangleTree(*mesh), 6000);
  int total = 0;
  for (int k = 0; k < kBodyRegionCount; ++k) {
    EXPECT_GT(d.region_samples[size_t(k)], 60) << body_region_name(BodyRegion(k));
    total += d.region_samples[size_t(k)];
  }
  EXPECT_EQ(total, 6000);
}

}  // namespace
}  // namespace mimic::avatar::surface_distance_test
