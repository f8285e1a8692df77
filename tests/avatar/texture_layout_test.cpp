#include "mimic/avatar/texture_layout.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <set>

#include "mimic/avatar/mesh_check.h"
#include "mimic/avatar/mesh_io.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin.h"

namespace mimic::avatar::texture_layout_test {
namespace {

ImplicitSkin skin_at(int subdivision) {
  SkinOptions o;
  o.subdivision = subdivision;
  auto s = ImplicitSkin::create(default_body_model(), o);
  EXPECT_TRUE(s) << s.error().what();
  return std::move(*s);
}

// The layout's triangles are the mesh's, corner for corner, with the seams split: every UV
// triangle is small in (u, v) (none spans the wrap) and lies in its part's unit square.
TEST(TextureLayout, SplitsTheSeamsAndKeepsEveryTriangle) {
  for (int sub : {0, 1}) {
    const ImplicitSkin s = skin_at(sub);
    const Mesh& m = s.mesh();
    const TextureLayout t = texture_layout(s);
    ASSERT_EQ(t.indices.size(), m.indices.size());
    ASSERT_EQ(t.source.size(), t.uv.size());
    for (size_t k = 0; k < t.indices.size(); ++k) ASSERT_EQ(t.source[t.indices[k]], m.indices[k]) << k;
    EXPECT_GT(t.source.size(), m.positions.size()) << "seams add vertices";
    // The skin pieces split along one seam each; the rigid parts' cube-map charts (texture_layout.cpp)
    // along their charts' borders, about half their vertices more.
    EXPECT_LT(t.source.size(), m.positions.size() * 3 / 2) << "only seams";
    std::set<uint32_t> used(t.source.begin(), t.source.end());
    EXPECT_EQ(used.size(), m.positions.size()) << "every vertex textured";
    for (size_t k = 0; k < t.indices.size(); k += 3) {
      glm::vec2 lo(1e9f), hi(-1e9f);
      for (int c = 0; c < 3; ++c) {
        const glm::vec2 uv = t.uv[t.indices[k + c]];
        ASSERT_TRUE(uv.x >= 0 && uv.x <= 1 && uv.y >= 0 && uv.y <= 1) << k;
        lo = glm::min(lo, uv), hi = glm::max(hi, uv);
      }
      EXPECT_LT(hi.x - lo.x, 0.5f) << "triangle " << k / 3 << " spans the wrap";
      EXPECT_LT(hi.y - lo.y, 0.5f) << "triangle " << k / 3;
    }
  }
}

// Each skin piece covers v from 0 to 1 and u from 0 to 1; the forearm's first row is the elbow
// ring, so the elbow's vertices appear twice: v = 1 of the upper arm, v = 0 of the forearm.
TEST(TextureLayout, EachPartIsItsOwnSquare) {
  const ImplicitSkin s = skin_at(0);
  const Mesh& m = s.mesh();
  const TextureLayout t = texture_layout(s);
  for (const MeshPart& p : m.parts) {
    glm::vec2 lo(1e9f), hi(-1e9f);
    for (uint32_t k = 3 * p.first_triangle; k < 3 * (p.first_triangle + p.triangle_count); ++k)
      lo = glm::min(lo, t.uv[t.indices[k]]), hi = glm::max(hi, t.uv[t.indices[k]]);
    EXPECT_FLOAT_EQ(lo.x, 0.0f) << p.name;
    EXPECT_FLOAT_EQ(hi.x, 1.0f) << p.name;
    EXPECT_FLOAT_EQ(lo.y, 0.0f) << p.name;
    EXPECT_FLOAT_EQ(hi.y, 1.0f) << p.name;
  }
}

// A textured frame of the realtime skin through each format: the UVs come back.
TEST(TextureLayout, ExportsCarryTheUvs) {
  auto body = RealtimeBody::create(default_body_model(), RealtimeOptions{2, std::nullopt, true});
  ASSERT_TRUE(body) << body.error().what();
  RealtimeSkin skin(*body);
  Mesh frame = (*body)->rest_mesh();
  skin.evaluate((*body)->skeleton().zero_pose(), frame.positions, frame.normals);
  const Mesh textured = textured_mesh(frame, (*body)->texture_layout());
  ASSERT_TRUE(validate_mesh(textured));
  EXPECT_EQ(textured.parts.size(), 16u);
  for (const char* ext : {"obj", "ply", "glb"}) {
    const std::string path = (std::filesystem::temp_directory_path() / (std::string("mimic_uv.") + ext)).string();
    ASSERT_TRUE(write_mesh(textured, path)) << ext;
    auto back = read_mesh(path);
    ASSERT_TRUE(back) << back.error().what();
    ASSERT_EQ(back->uvs.size(), textured.uvs.size()) << ext;
    ASSERT_EQ(back->parts.size(), 16u) << ext;
    for (size_t i = 0; i < textured.uvs.size(); ++i)
      ASSERT_NEAR(glm::distance(back->uvs[i], textured.uvs[i]), 0.0f, 1e-6f) << ext << " " << i;
    std::filesystem::remove(path);
  }
  // The glTF file names one material per part, each with its own PNG image.
  auto glb = encode_glb(textured);
  ASSERT_TRUE(glb);
  for (const char* key : {"\"materials\"", "\"baseColorTexture\"", "\"image/png\"", "TEXCOORD_0"})
    EXPECT_NE(glb->find(key), std::string::npos) << key;
  size_t pngs = 0;
  for (size_t at = glb->find("\x89PNG"); at != std::string::npos; at = glb->find("\x89PNG", at + 1)) ++pngs;
  EXPECT_EQ(pngs, 16u);
}

}  // namespace
}  // namespace mimic::avatar::texture_layout_test
