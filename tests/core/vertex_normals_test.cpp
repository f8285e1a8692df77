#include "mimic/core/vertex_normals.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <random>
#include <vector>

namespace mimic::vertex_normals_test {
namespace {

// A closed octahedron, outward winding: each vertex's normal is its own direction.
struct Octahedron {
  std::vector<glm::vec3> p{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  std::vector<uint32_t> idx{0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
};

TEST(VertexNormals, AClosedConvexMeshGetsItsOutwardUnitNormals) {
  Octahedron o;
  std::vector<glm::vec3> n(o.p.size());
  vertex_normals(o.p, o.idx, n);
  for (size_t v = 0; v < o.p.size(); ++v) {
    EXPECT_NEAR(glm::length(n[v]), 1.0f, 1e-6f);
    EXPECT_NEAR(glm::dot(n[v], o.p[v]), 1.0f, 1e-6f) << v;
  }
}

// Against the same sum done in double with glm's cross, on a random mesh: area weighting kept.
TEST(VertexNormals, MatchesTheAreaWeightedSumOnARandomMesh) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<glm::vec3> p(200);
  for (auto& q : p) q = {u(rng), u(rng), u(rng)};
  std::vector<uint32_t> idx;
  std::uniform_int_distribution<uint32_t> pick(0, 199);
  for (int t = 0; t < 600; ++t)
    for (int k = 0; k < 3; ++k) idx.push_back(pick(rng));
  std::vector<glm::dvec3> sum(p.size(), glm::dvec3(0));
  for (size_t t = 0; t < idx.size(); t += 3) {
    const glm::dvec3 a(p[idx[t]]), b(p[idx[t + 1]]), c(p[idx[t + 2]]);
    const glm::dvec3 cr = glm::cross(b - a, c - a);
    for (int k = 0; k < 3; ++k) sum[idx[t + k]] += cr;
  }
  std::vector<glm::vec3> n(p.size());
  vertex_normals(p, idx, n);
  for (size_t v = 0; v < p.size(); ++v) {
    if (glm::length(sum[v]) < 1e-3) continue;  // nearly cancelled: direction ill-conditioned
    const glm::dvec3 want = glm::normalize(sum[v]);
    EXPECT_NEAR(glm::dot(glm::dvec3(n[v]), want), 1.0, 1e-5) << v;
  }
}

TEST(VertexNormals, LoneAndOutOfRangeVerticesGetTheFallbackAndNothingIsWrittenPastTheMesh) {
  Octahedron o;
  o.p.push_back({5, 5, 5});                                 // no triangle touches it
  o.idx.insert(o.idx.end(), {0, 2, 99, 0, 0, 0, 1, 1, 1});  // out of range; degenerate ones
  std::vector<glm::vec3> n(o.p.size() + 1, glm::vec3(7));   // one slot past the mesh
  vertex_normals(o.p, o.idx, n, {0, 0, 1});
  EXPECT_EQ(n[6], glm::vec3(0, 0, 1));
  EXPECT_EQ(n[7], glm::vec3(7));
  EXPECT_NEAR(glm::dot(n[0], o.p[0]), 1.0f, 1e-6f);
  const std::vector<glm::vec3> nan_p(3, glm::vec3(NAN));
  std::vector<glm::vec3> m(3);
  vertex_normals(nan_p, std::vector<uint32_t>{0, 1, 2}, m);
  for (const auto& q : m) EXPECT_EQ(q, glm::vec3(0, 1, 0));
}

}  // namespace
}  // namespace mimic::vertex_normals_test
