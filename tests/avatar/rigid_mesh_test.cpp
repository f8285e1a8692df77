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
#include "mimic/avatar/body_presets.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/rigid_mesh_table.h"
#include "mimic/avatar/skin.h"
#include "mimic/avatar/skin_lod.h"
#include "mimic/avatar/surface_distance.h"

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

// The program ships the built-in body's rigid meshes (meshing a field takes a few hundred
// milliseconds a part). Mean distance from each vertex of `a` to the nearest vertex of `b`.
float mean_nearest_m(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b) {
  double sum = 0;
  for (const glm::vec3& p : a) {
    float best = 1e9f;
    for (const glm::vec3& q : b) best = std::min(best, glm::length(p - q));
    sum += best;
  }
  return a.empty() ? 1e9f : static_cast<float>(sum / static_cast<double>(a.size()));
}

RigidPartMesh part_mesh_of(const BodyModel& model, RigidPart part, bool field_only) {
  auto m = rigid_part_mesh(model, part, field_only);
  EXPECT_TRUE(m) << m.error().what();
  return m ? std::move(*m) : RigidPartMesh{};
}

// Mean distance from each vertex of `a` to the surface of `b` (its nearest triangle).
float mean_to_surface_m(const RigidPartMesh& a, const RigidPartMesh& b) {
  double sum = 0;
  for (const glm::vec3& p : a.positions_m) {
    float best = 1e9f;
    for (size_t t = 0; t < b.triangles.size(); t += 3) {
      const glm::vec3 q = closest_point_on_triangle(p, b.positions_m[b.triangles[t]], b.positions_m[b.triangles[t + 1]],
                                                    b.positions_m[b.triangles[t + 2]]);
      best = std::min(best, glm::length(p - q));
    }
    sum += best;
  }
  return a.positions_m.empty() ? 1e9f : static_cast<float>(sum / static_cast<double>(a.positions_m.size()));
}

MeshTopology topology_of(const RigidPartMesh& m) {
  Mesh mesh;
  mesh.positions = m.positions_m;
  mesh.indices = m.triangles;
  return analyze_topology(mesh);
}

// The shipped table is what the built-in body's field meshes to today: the same vertex count and
// the same surface (vertices within a fraction of a millimetre, whatever the compiler's rounding
// did to the collapse order). Fails after a rigid primitive changes until
// scripts/regen_rigid_meshes.sh writes the table again.
TEST(RigidMesh, TheShippedMeshesAreTheBuiltInBodysOwn) {
  const BodyModel model = default_body_model();
  for (RigidPart part : {RigidPart::head, RigidPart::left_hand, RigidPart::left_foot}) {
    const RigidPartMesh shipped = part_mesh_of(model, part, false), meshed = part_mesh_of(model, part, true);
    EXPECT_TRUE(shipped.shipped) << rigid_part_name(part) << ": run scripts/regen_rigid_meshes.sh";
    EXPECT_FALSE(meshed.shipped);
    EXPECT_EQ(shipped.positions_m.size(), meshed.positions_m.size()) << rigid_part_name(part);
    const float there = mean_nearest_m(shipped.positions_m, meshed.positions_m),
                back = mean_nearest_m(meshed.positions_m, shipped.positions_m);
    std::printf("[ figure ] %-10s shipped vs meshed now: %.3f / %.3f mm\n", rigid_part_name(part), there * 1e3,
                back * 1e3);
    EXPECT_LT(there, 0.0003f) << rigid_part_name(part) << ": run scripts/regen_rigid_meshes.sh";
    EXPECT_LT(back, 0.0003f) << rigid_part_name(part) << ": run scripts/regen_rigid_meshes.sh";
  }
}

// The right hand and foot are the left ones' mirror images, carried across.
TEST(RigidMesh, TheRightSideIsTheLeftsMirrorImage) {
  const BodyModel model = default_body_model();
  for (auto [left, right] : {std::pair{RigidPart::left_hand, RigidPart::right_hand},
                             std::pair{RigidPart::left_foot, RigidPart::right_foot}}) {
    const RigidPartMesh l = part_mesh_of(model, left, false), r = part_mesh_of(model, right, false);
    EXPECT_TRUE(r.shipped) << rigid_part_name(right);
    ASSERT_EQ(l.positions_m.size(), r.positions_m.size());
    ASSERT_EQ(l.triangles.size(), r.triangles.size());
    float worst = 0;
    for (size_t i = 0; i < l.positions_m.size(); ++i)
      worst = std::max(worst, glm::length(l.positions_m[i] * glm::vec3(-1, 1, 1) - r.positions_m[i]));
    EXPECT_LT(worst, 5e-5f) << rigid_part_name(right);
    const MeshTopology t = topology_of(r);
    EXPECT_TRUE(is_closed_oriented_manifold(t)) << rigid_part_name(right);
    EXPECT_GT(t.signed_volume, 0.0) << rigid_part_name(right) << ": faces wind outward";
  }
}

// A preset's head and hands are the built-in ones scaled and reshaped: the shipped meshes carried
// onto them lie on their own surface (within 0.2 mm, RigidMesh.VerticesLieOnTheirPartsIsoSurface's
// bound) and cover it as a mesh made from their field does (within 1 mm, both ways: two meshings of
// one surface at this vertex spacing differ by 0.2–0.4 mm; a missing region would be centimetres).
TEST(RigidMesh, PresetsCarryTheShippedMeshesOntoTheirOwnSurface) {
  for (const char* name : {"child", "heavy"}) {
    auto model = preset_body(*find_body_preset(name));
    ASSERT_TRUE(model) << model.error().what();
    for (RigidPart part : {RigidPart::head, RigidPart::right_hand}) {
      const RigidPartMesh carried = part_mesh_of(*model, part, false), meshed = part_mesh_of(*model, part, true);
      EXPECT_TRUE(carried.shipped) << name << " " << rigid_part_name(part);
      const MeshTopology t = topology_of(carried);
      EXPECT_TRUE(is_closed_oriented_manifold(t)) << name << " " << rigid_part_name(part);
      EXPECT_GT(t.signed_volume, 0.0);
      const float there = mean_to_surface_m(carried, meshed), back = mean_to_surface_m(meshed, carried);
      std::printf("[ figure ] %-6s %-10s carried vs meshed from its field: %.2f / %.2f mm\n", name,
                  rigid_part_name(part), there * 1e3, back * 1e3);
      EXPECT_LT(there, 0.001f) << name << " " << rigid_part_name(part);
      EXPECT_LT(back, 0.001f) << name << " " << rigid_part_name(part);
    }
  }
}

// A part whose primitives are no image of a shipped one's (a hand without its little finger) is
// meshed from its own field, closed and outward.
TEST(RigidMesh, APartUnlikeTheShippedOnesIsMeshedFromItsField) {
  BodyModel model = default_body_model();
  std::erase_if(model.primitives, [](const Primitive& p) { return p.name.rfind("l_little", 0) == 0; });
  const RigidPartMesh m = part_mesh_of(model, RigidPart::left_hand, false);
  EXPECT_FALSE(m.shipped);
  const MeshTopology t = topology_of(m);
  EXPECT_TRUE(is_closed_oriented_manifold(t));
  EXPECT_EQ(t.components, 1u);
  EXPECT_GT(t.signed_volume, 0.0);
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
