// The rigid parts (head, hands, feet), meshed once from their primitives' field by marching
// tetrahedra and edge collapses: each a closed, outward, manifold surface at every LOD, lying on
// its iso-surface, deterministic, and shaped like a person's (five finger tips on a hand, eye
// sockets and ears on the head), which a UV sphere of rays from the part's centre cannot be.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>

#include "mimic/avatar/body_field.h"
#include "mimic/avatar/mesh_check.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin.h"
#include "mimic/avatar/skin_lod.h"

namespace mimic::avatar::rigid_mesh_test {
namespace {

constexpr const char* kRigid[] = {"head", "left_hand", "right_hand", "left_foot", "right_foot"};

ImplicitSkin zero_posture_skin(int lod) {
  SkinOptions o;
  o.subdivision = 0;
  o.normals = false;
  auto skin = ImplicitSkin::create(with_skin_lod(default_body_model(), lod), o);
  EXPECT_TRUE(skin) << skin.error().what();
  skin->evaluate(skin->skeleton().zero_pose());
  return std::move(*skin);
}

// One part of a mesh as a mesh of its own (its triangles; every position kept).
Mesh part_mesh(const Mesh& m, const std::string& name) {
  Mesh out;
  out.positions = m.positions;
  for (const MeshPart& p : m.parts)
    if (p.name == name)
      out.indices.assign(m.indices.begin() + 3 * p.first_triangle,
                         m.indices.begin() + 3 * (p.first_triangle + p.triangle_count));
  return out;
}

std::vector<uint32_t> vertices_of(const Mesh& part) {
  std::vector<uint32_t> v(part.indices.begin(), part.indices.end());
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

TEST(RigidMesh, EachPartIsClosedOutwardAndManifoldAtEveryLod) {
  for (int lod = 0; lod < kSkinLodCount; ++lod) {
    const ImplicitSkin skin = zero_posture_skin(lod);
    for (const char* name : kRigid) {
      const Mesh part = part_mesh(skin.mesh(), name);
      const MeshTopology t = analyze_topology(part);
      EXPECT_TRUE(is_closed_oriented_manifold(t)) << name << " LOD " << lod;
      EXPECT_EQ(t.components, 1u) << name << " LOD " << lod;
      EXPECT_EQ(t.degenerate_triangles, 0u) << name << " LOD " << lod;
      EXPECT_GT(t.signed_volume, 0.0) << name << " LOD " << lod << ": faces wind outward";
      if (lod == 0 || lod == kSkinLodCount - 1)
        std::printf("[ figure ] LOD %d %-10s %5zu vertices %5zu triangles, %.2f dm3\n", lod, name, t.vertex_count,
                    t.face_count, t.signed_volume * 1e3);
    }
  }
}

// Every vertex lies on its part's iso-surface: the field's level 1 within 0.2 mm (the level's
// distance estimated as |f − 1| / |∇f|).
TEST(RigidMesh, VerticesLieOnTheirPartsIsoSurface) {
  const BodyModel model = default_body_model();
  const ImplicitSkin skin = zero_posture_skin(0);
  auto field = BodyField::create(model, skin.skeleton());
  ASSERT_TRUE(field) << field.error().what();
  const RigidPart parts[] = {RigidPart::head, RigidPart::left_hand, RigidPart::right_hand, RigidPart::left_foot,
                             RigidPart::right_foot};
  for (RigidPart rp : parts) {
    const Mesh part = part_mesh(skin.mesh(), rigid_part_name(rp));
    float worst_m = 0;
    for (uint32_t v : vertices_of(part)) {
      const glm::vec3 p = skin.mesh().positions[v];
      const float h = 1e-4f;
      const glm::vec3 g(
          field->field_of_part(p + glm::vec3(h, 0, 0), rp) - field->field_of_part(p - glm::vec3(h, 0, 0), rp),
          field->field_of_part(p + glm::vec3(0, h, 0), rp) - field->field_of_part(p - glm::vec3(0, h, 0), rp),
          field->field_of_part(p + glm::vec3(0, 0, h), rp) - field->field_of_part(p - glm::vec3(0, 0, h), rp));
      const float slope = glm::length(g) / (2 * h);
      ASSERT_GT(slope, 0.0f) << rigid_part_name(rp);
      worst_m = std::max(worst_m, std::abs(field->field_of_part(p, rp) - kIsoLevel) / slope);
    }
    EXPECT_LT(worst_m, 0.0002f) << rigid_part_name(rp);
  }
}

TEST(RigidMesh, TwoLayoutsAreIdentical) {
  for (int lod : {0, 2}) {
    const ImplicitSkin a = zero_posture_skin(lod), b = zero_posture_skin(lod);
    ASSERT_EQ(a.mesh().indices, b.mesh().indices) << "LOD " << lod;
    ASSERT_EQ(a.mesh().positions.size(), b.mesh().positions.size());
    for (size_t i = 0; i < a.mesh().positions.size(); ++i)
      ASSERT_EQ(a.mesh().positions[i], b.mesh().positions[i]) << "LOD " << lod << " vertex " << i;
  }
}

glm::vec3 joint_position(const ImplicitSkin& skin, const char* joint) {
  std::vector<rig::RigidTransform> w(static_cast<size_t>(skin.skeleton().joint_count()));
  rig::forward_kinematics(skin.skeleton(), skin.skeleton().zero_pose(), w);
  return w[static_cast<size_t>(skin.skeleton().find_joint(joint))].translation;
}

// Pieces of the part's surface farther than r from a point: connected sets of vertices (by the
// part's edges) whose distance exceeds r.
size_t pieces_beyond(const Mesh& part, const glm::vec3& from, float r) {
  std::vector<uint32_t> parent(part.positions.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto root = [&](uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  auto far = [&](uint32_t v) { return glm::distance(part.positions[v], from) > r; };
  for (size_t k = 0; k < part.indices.size(); k += 3)
    for (int e = 0; e < 3; ++e) {
      const uint32_t a = part.indices[k + e], b = part.indices[k + (e + 1) % 3];
      if (far(a) && far(b)) parent[root(a)] = root(b);
    }
  size_t n = 0;
  for (uint32_t v : vertices_of(part)) n += far(v) && root(v) == v;
  return n;
}

// Cut by spheres about the wrist, a hand falls apart into five pieces beyond its palm (four
// fingers and the thumb); a mitten into at most two.
TEST(RigidMesh, AHandHasFiveFingerTips) {
  for (int lod : {0, 1}) {
    const ImplicitSkin skin = zero_posture_skin(lod);
    for (const char* side : {"left", "right"}) {
      const Mesh hand = part_mesh(skin.mesh(), std::string(side) + "_hand");
      const glm::vec3 wrist = joint_position(skin, side[0] == 'l' ? "l_wrist" : "r_wrist");
      size_t most = 0;
      for (float r = 0.05f; r < 0.2f; r += 0.0025f) most = std::max(most, pieces_beyond(hand, wrist, r));
      EXPECT_EQ(most, 5u) << side << " hand, LOD " << lod;
    }
  }
}

// The frontmost (largest) coordinate along `axis` where the line through `at` along it meets the
// part's triangles; nullopt when it misses.
std::optional<float> frontmost(const Mesh& part, glm::vec3 at, int axis) {
  std::optional<float> best;
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  for (size_t k = 0; k < part.indices.size(); k += 3) {
    const glm::vec3 a = part.positions[part.indices[k]], b = part.positions[part.indices[k + 1]],
                    c = part.positions[part.indices[k + 2]];
    // Barycentric coordinates of the line's point in the triangle's projection along the axis.
    const float d = (b[u] - a[u]) * (c[v] - a[v]) - (c[u] - a[u]) * (b[v] - a[v]);
    if (std::abs(d) < 1e-12f) continue;
    const float s = ((at[u] - a[u]) * (c[v] - a[v]) - (c[u] - a[u]) * (at[v] - a[v])) / d;
    const float t = ((b[u] - a[u]) * (at[v] - a[v]) - (at[u] - a[u]) * (b[v] - a[v])) / d;
    if (s < 0 || t < 0 || s + t > 1) continue;
    const float x = a[axis] + s * (b[axis] - a[axis]) + t * (c[axis] - a[axis]);
    if (!best || x > *best) best = x;
  }
  return best;
}

// Seen from the front, the line down through each eye dips into a socket between the brow and
// the cheek; seen from the side, each ear stands out of the head in front of and behind it. An
// egg's profile has neither.
TEST(RigidMesh, TheHeadHasEyeSocketsAndEars) {
  const ImplicitSkin skin = zero_posture_skin(0);
  const Mesh head = part_mesh(skin.mesh(), "head");
  const glm::vec3 h = joint_position(skin, "head");
  for (float side : {1.0f, -1.0f}) {
    // Front profile z(y) at the eye's x: the deepest point between 2 and 5 cm above the head
    // joint, and the highest above it (the brow) and below it (the cheek).
    float eye = 1e9f, eye_y = 0;
    for (float dy = 0.02f; dy <= 0.05f; dy += 0.001f) {
      const auto z = frontmost(head, h + glm::vec3(side * 0.031f, dy, 0), 2);
      ASSERT_TRUE(z);
      if (*z < eye) eye = *z, eye_y = dy;
    }
    float brow = -1e9f, cheek = -1e9f;
    for (float dy = eye_y; dy <= 0.08f; dy += 0.001f)
      if (auto z = frontmost(head, h + glm::vec3(side * 0.031f, dy, 0), 2)) brow = std::max(brow, *z);
    for (float dy = eye_y; dy >= -0.02f; dy -= 0.001f)
      if (auto z = frontmost(head, h + glm::vec3(side * 0.031f, dy, 0), 2)) cheek = std::max(cheek, *z);
    std::printf("[ figure ] eye socket %s: %.1f mm under the brow, %.1f mm under the cheek\n",
                side > 0 ? "left" : "right", (brow - eye) * 1e3, (cheek - eye) * 1e3);
    EXPECT_GT(brow - eye, 0.004f);
    EXPECT_GT(cheek - eye, 0.002f);
    // Side profile: how far out the head reaches at ear height, at the ear and 3.5 cm before and
    // behind it (the head mirrored onto +x for the right side).
    Mesh mirrored = head;
    for (glm::vec3& p : mirrored.positions) p.x *= side;
    float ear = -1e9f, around = -1e9f;
    for (float dy = 0.0f; dy <= 0.04f; dy += 0.002f) {
      if (auto x = frontmost(mirrored, h + glm::vec3(0, dy, 0.005f), 0)) ear = std::max(ear, *x);
      for (float dz : {-0.035f, 0.045f})
        if (auto x = frontmost(mirrored, h + glm::vec3(0, dy, dz), 0)) around = std::max(around, *x);
    }
    std::printf("[ figure ] %s ear stands %.1f mm out of the head\n", side > 0 ? "left" : "right",
                (ear - around) * 1e3);
    EXPECT_GT(ear - around, 0.004f);
  }
}

}  // namespace
}  // namespace mimic::avatar::rigid_mesh_test
