// Helpers shared by the mesh format readers and writers (not part of the public API).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "mimic/avatar/mesh.h"
#include "mimic/core/result.h"

namespace mimic::avatar::detail {

// Parts covering every triangle in order: the mesh's own parts, with any gap filled by a part
// named "mesh". Assumes validate_mesh passed.
std::vector<MeshPart> covering_parts(const Mesh& mesh);

// Collects triangles tagged with a group number into contiguous parts, groups in order of
// first appearance; `tri_group` holds one group per triangle, `names` one name per group.
// Reorders mesh.indices accordingly and fills mesh.parts (groups without triangles dropped).
void gather_parts(Mesh& mesh, const std::vector<uint32_t>& tri_group,
                  const std::vector<std::string>& names);

// Part names go into line-based headers: no control characters, never empty.
std::string clean_name(std::string_view name);

// Unit normal, or +Y when the vector is zero or not finite (formats want unit normals).
glm::vec3 unit_or_up(glm::vec3 n);

std::string lower_extension(const std::string& path);

// A size_px × size_px checker of `squares` × `squares` cells in colours a and b, as PNG bytes.
std::string checker_png(int size_px, int squares, glm::u8vec3 a, glm::u8vec3 b);

}  // namespace mimic::avatar::detail
