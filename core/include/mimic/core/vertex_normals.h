#pragma once
// Area-weighted unit vertex normals of a triangle mesh: the one loop the realtime skin, the full
// method and the client library share.
#include <cstdint>
#include <glm/vec3.hpp>
#include <span>

namespace mimic {

// normals[v] = the unit sum of the (area-weighted) normals of the triangles around v, for every
// v < positions.size(); normals must hold at least that many. A vertex no triangle touches, or
// whose triangles cancel, gets `fallback`. Triangles naming a vertex out of range are skipped.
// Allocates nothing.
void vertex_normals(std::span<const glm::vec3> positions, std::span<const uint32_t> indices,
                    std::span<glm::vec3> normals, glm::vec3 fallback = {0, 1, 0});

}  // namespace mimic
