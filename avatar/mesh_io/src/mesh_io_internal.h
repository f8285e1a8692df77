// Helpers shared by the mesh format readers and writers (not part of the public API).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "mimic/avatar/mesh.h"
#include "mimic/core/result.h"

namespace mimic::avatar::detail {

// Collects triangles tagged with a group number into contiguous parts, groups in order of
// first appearance; `tri_group` holds one group per triangle, `names` one name per group.
// Reorders mesh.indices accordingly and fills mesh.parts (groups without triangles dropped).
void gather_parts(Mesh& mesh, const std::vector<uint32_t>& tri_group, const std::vector<std::string>& names);

// Unit normal, or +Y when the vector is zero or not finite (formats want unit normals).
glm::vec3 unit_or_up(glm::vec3 n);

std::string lower_extension(const std::string& path);

// A GLB file: the 12-byte header, the JSON chunk (padded with spaces) and the binary chunk
// (padded with zeros), every number little-endian whatever the host. Fails when the file would
// pass the format's 4 GiB limit.
Result<std::string> glb_container(std::string json_text, std::string_view bin);

// The colour of the k-th part (golden-ratio hues, so neighbours differ), linear RGB in [0, 1].
glm::vec3 part_colour(size_t k);

// A size_px × size_px checker of `squares` × `squares` cells in colours a and b, as PNG bytes.
std::string checker_png(int size_px, int squares, glm::u8vec3 a, glm::u8vec3 b);

}  // namespace mimic::avatar::detail
