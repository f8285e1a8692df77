#include "mimic/avatar/mesh_check.h"

#include <gtest/gtest.h>

#include <cmath>

#include "mimic/avatar/mesh_io.h"
#include "test_data.h"

namespace mimic::avatar::mesh_check_test {
namespace {

// Box [0,a]x[0,b]x[0,c] with 8 shared vertices, outward counter-clockwise faces.
Mesh box(float a, float b, float c) {
  Mesh m;
  for (int i = 0; i < 8; ++i)
    m.positions.push_back({float(i & 1) * a, float((i >> 1) & 1) * b, float((i >> 2) & 1) * c});
  const uint32_t quads[6][4] = {{0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (const auto& q : quads) m.indices.insert(m.indices.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
  m.parts = {{"box", 0, 12}};
  return m;
}

// Torus around +Y, major radius R, minor radius r, n x k quads.
Mesh torus(float R, float r, int n, int k) {
  Mesh m;
  const float two_pi = 6.28318530718f;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < k; ++j) {
      const float u = two_pi * float(i) / float(n), v = two_pi * float(j) / float(k);
      m.positions.push_back(
          {(R + r * std::cos(v)) * std::cos(u), r * std::sin(v), (R + r * std::cos(v)) * std::sin(u)});
    }
  auto at = [&](int i, int j) { return static_cast<uint32_t>((i % n) * k + (j % k)); };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < k; ++j) {
      const uint32_t a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
      m.indices.insert(m.indices.end(), {a, d, c, a, c, b});
    }
  return m;
}

TEST(MeshCheck, BoxIsAClosedGenusZeroSurfaceWithExactVolumeAndArea) {
  const auto t = analyze_topology(box(2, 3, 4));
  EXPECT_TRUE(is_closed_oriented_manifold(t));
  EXPECT_EQ(t.vertex_count, 8u);
  EXPECT_EQ(t.edge_count, 18u);
  EXPECT_EQ(t.face_count, 12u);
  EXPECT_EQ(t.euler_characteristic, 2);
  EXPECT_EQ(t.genus, 0);
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.degenerate_triangles, 0u);
  EXPECT_NEAR(t.signed_volume, 24.0, 1e-9);
  EXPECT_NEAR(t.surface_area, 2 * (6 + 8 + 12), 1e-9);
}

TEST(MeshCheck, InsideOutBoxHasNegativeVolume) {
  Mesh m = box(1, 1, 1);
  for (size_t f = 0; f < m.triangle_count(); ++f) std::swap(m.indices[3 * f + 1], m.indices[3 * f + 2]);
  const auto t = analyze_topology(m);
  EXPECT_TRUE(is_closed_oriented_manifold(t));
  EXPECT_NEAR(t.signed_volume, -1.0, 1e-9);
}

TEST(MeshCheck, TorusHasGenusOne) {
  const float R = 1.0f, r = 0.25f;
  const auto t = analyze_topology(torus(R, r, 96, 48));
  EXPECT_TRUE(is_closed_oriented_manifold(t));
  EXPECT_EQ(t.euler_characteristic, 0);
  EXPECT_EQ(t.genus, 1);
  const double pi = 3.14159265358979;
  EXPECT_NEAR(t.signed_volume, 2 * pi * pi * R * r * r, 0.01 * 2 * pi * pi * R * r * r);
  EXPECT_NEAR(t.surface_area, 4 * pi * pi * R * r, 0.01 * 4 * pi * pi * R * r);
}

TEST(MeshCheck, HoleGivesBoundaryEdgesAndOneLoop) {
  Mesh m = box(1, 1, 1);
  m.indices.resize(m.indices.size() - 3);
  m.parts[0].triangle_count = 11;
  const auto t = analyze_topology(m);
  EXPECT_FALSE(is_closed_oriented_manifold(t));
  EXPECT_EQ(t.boundary_edges, 3u);
  EXPECT_EQ(t.boundary_loops, 1u);
  EXPECT_EQ(t.non_manifold_edges, 0u);
  EXPECT_EQ(t.inconsistent_edges, 0u);
  EXPECT_EQ(t.genus, 0);  // a disc is still genus 0
}

TEST(MeshCheck, FlippedTriangleGivesInconsistentEdges) {
  Mesh m = box(1, 1, 1);
  std::swap(m.indices[1], m.indices[2]);
  const auto t = analyze_topology(m);
  EXPECT_FALSE(is_closed_oriented_manifold(t));
  EXPECT_EQ(t.inconsistent_edges, 3u);
  EXPECT_EQ(t.boundary_edges, 0u);
  EXPECT_EQ(t.genus, -1);
}

TEST(MeshCheck, BowTieVertexIsNonManifold) {
  // Two closed boxes touching at one corner: every edge is fine, the shared vertex is not.
  Mesh m = box(1, 1, 1);
  Mesh other = box(1, 1, 1);
  const uint32_t base = static_cast<uint32_t>(m.positions.size());
  for (auto& p : other.positions) m.positions.push_back(p + glm::vec3(1, 1, 1));
  for (uint32_t i : other.indices) m.indices.push_back(i == 0 ? 7 : base + i);  // its corner 0 is our corner 7
  const auto t = analyze_topology(m);
  EXPECT_FALSE(is_closed_oriented_manifold(t));
  EXPECT_EQ(t.non_manifold_vertices, 1u);
  EXPECT_EQ(t.non_manifold_edges, 0u);
  EXPECT_EQ(t.boundary_edges, 0u);
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.unreferenced_vertices, 1u);
  EXPECT_EQ(t.genus, -1);
}

TEST(MeshCheck, FinOnAnEdgeIsNonManifold) {
  Mesh m = box(1, 1, 1);
  m.positions.push_back({0.5f, -1.0f, 0.5f});
  m.indices.insert(m.indices.end(), {0, 1, 8});  // a third triangle on edge 0-1
  const auto t = analyze_topology(m);
  EXPECT_FALSE(is_closed_oriented_manifold(t));
  EXPECT_EQ(t.non_manifold_edges, 1u);
  EXPECT_EQ(t.boundary_edges, 2u);
}

TEST(MeshCheck, DegenerateTrianglesAreCounted) {
  Mesh m = box(1, 1, 1);
  m.positions.push_back({0.5f, 0, 0});  // on edge 0-1: zero area
  m.indices.insert(m.indices.end(), {0, 8, 1, 2, 2, 3});
  const auto t = analyze_topology(m);
  EXPECT_EQ(t.degenerate_triangles, 2u);
  EXPECT_EQ(t.genus, -1);
}

TEST(MeshCheck, EmptyMeshIsNotClosed) {
  const auto t = analyze_topology(Mesh{});
  EXPECT_FALSE(is_closed_oriented_manifold(t));
  EXPECT_EQ(t.components, 0u);
}

TEST(MeshCheck, WeldJoinsSeamDuplicates) {
  // The same box with every triangle on its own three vertices, plus tiny noise.
  const Mesh shared = box(1, 2, 3);
  Mesh split;
  split.parts = {{"a", 0, 4}, {"b", 4, 8}};
  for (size_t i = 0; i < shared.indices.size(); ++i) {
    split.positions.push_back(shared.positions[shared.indices[i]] + glm::vec3(1e-6f * float(i % 3), 0, 0));
    split.normals.push_back({0, 1, 0});
    split.indices.push_back(static_cast<uint32_t>(i));
  }
  const auto before = analyze_topology(split);
  EXPECT_EQ(before.components, 12u);
  EXPECT_FALSE(is_closed_oriented_manifold(before));

  const Mesh welded = weld_by_position(split, 1e-4f);
  EXPECT_EQ(welded.positions.size(), 8u);
  EXPECT_EQ(welded.normals.size(), 8u);
  ASSERT_EQ(welded.parts.size(), 2u);
  EXPECT_EQ(welded.parts[1].first_triangle, 4u);
  const auto after = analyze_topology(welded);
  EXPECT_TRUE(is_closed_oriented_manifold(after));
  EXPECT_EQ(after.genus, 0);
  EXPECT_NEAR(after.signed_volume, 6.0, 1e-4);
  // A tolerance below the noise keeps them apart.
  EXPECT_GT(weld_by_position(split, 1e-9f).positions.size(), 8u);
}

TEST(MeshCheck, WeldDropsCollapsedTriangles) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1e-5f, 0, 0}};
  m.indices = {0, 1, 2, 0, 3, 2};
  const Mesh w = weld_by_position(m, 1e-3f);
  EXPECT_EQ(w.positions.size(), 3u);
  EXPECT_EQ(w.triangle_count(), 1u);
  EXPECT_TRUE(w.parts.empty());
}

TEST(MeshCheck, MakeHumanBodyIsClosedGenusZero) {
  auto m = read_obj(test::shared_data("mesh/makehuman_base_body.obj"), 0.1f);
  ASSERT_TRUE(m) << m.error().what();
  const auto t = analyze_topology(*m);
  EXPECT_TRUE(is_closed_oriented_manifold(t));
  EXPECT_EQ(t.vertex_count, 13380u);
  EXPECT_EQ(t.face_count, 26756u);
  EXPECT_EQ(t.edge_count, 26756u + 13378u);  // quad edges plus one diagonal per quad
  EXPECT_EQ(t.euler_characteristic, 2);
  EXPECT_EQ(t.genus, 0);
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.non_manifold_vertices, 0u);
  EXPECT_NEAR(t.signed_volume, 0.0549, 0.0005);  // m³
  EXPECT_NEAR(t.surface_area, 1.614, 0.005);     // m²
  // Welding a mesh without duplicates changes nothing.
  EXPECT_EQ(weld_by_position(*m, 1e-6f).positions.size(), 13380u);
}

}  // namespace
}  // namespace mimic::avatar::mesh_check_test
