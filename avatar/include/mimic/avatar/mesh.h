// Triangle mesh of the avatar: one index array shared by all frames at a given LOD (topology is
// fixed, so a frame is just new positions), with named part ranges (which triangles belong to
// which skin piece or rigid part). Metres, +Y up, the body faces +Z; triangles wind
// counter-clockwise seen from outside.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

namespace mimic::avatar {

struct MeshPart {
  std::string name;             // e.g. "l_upper_arm", "torso", "head"
  uint32_t first_triangle = 0;  // index into the triangle list (indices / 3)
  uint32_t triangle_count = 0;
};

struct Mesh {
  std::vector<glm::vec3> positions;  // metres
  std::vector<glm::vec3> normals;    // empty, or one unit normal per position
  std::vector<uint32_t> indices;     // 3 per triangle
  std::vector<MeshPart> parts;       // cover the triangles in order, without overlap
  std::vector<glm::vec2> uvs;        // empty, or one texture coordinate per position (texture_layout.h)

  size_t triangle_count() const { return indices.size() / 3; }
};

// Parts covering every triangle in order: the mesh's own parts (names made safe for line-based
// formats), with any gap filled by a part named "mesh". Assumes the parts do not overlap.
std::vector<MeshPart> covering_parts(const Mesh& mesh);

// A part name as line-based headers need it: control characters replaced, outer spaces trimmed,
// never empty ("mesh").
std::string clean_name(std::string_view name);

}  // namespace mimic::avatar
