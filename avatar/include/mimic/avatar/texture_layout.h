// Per-part texture coordinates (the paper's §4.2): every vertex of a skin piece gets u around its
// contour (0 → 1 from the ring's first point round to it again) and v along its piece (0 at the
// piece's first row, 1 at its last); the rigid head, hands and feet get u around their axis and
// v from pole to pole. Each part is its own texture square.
//
// The skin's mesh is one welded, closed surface; a texture needs the seams split: where u wraps
// (the first point of a ring is also u = 1), where two pieces meet (the elbow ring is v = 1 of
// the upper arm and v = 0 of the forearm) and at the caps. The layout lists, once per body, the
// textured vertices (which skin vertex each copies, and its (u, v)) and the triangles over them,
// in the mesh's order and parts; a frame is then a gather of positions.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/avatar/mesh.h"

namespace mimic::avatar {

class ContourLayout;
class ImplicitSkin;

struct TextureLayout {
  std::vector<uint32_t> source;   // per textured vertex: the skin vertex it copies
  std::vector<glm::vec2> uv;      // per textured vertex: (u around, v along), each in [0, 1]
  std::vector<uint32_t> indices;  // 3 per triangle, the skin mesh's triangles in order
};

// The texture layout of a contour layout's mesh (any subdivision; the realtime body holds its
// own), and the same for skin.layout().
TextureLayout texture_layout(const ContourLayout& layout);
TextureLayout texture_layout(const ImplicitSkin& skin);

// The mesh with its seams split: positions (and normals) gathered through layout.source, uvs
// set, the same parts. `mesh` must be the mesh the layout was made for.
Mesh textured_mesh(const Mesh& mesh, const TextureLayout& layout);

}  // namespace mimic::avatar
