// The topology the exact checker precomputes once per mesh, without CGAL: each part closed by
// fans over its boundary loops (so "inside a part" means something for an open skin piece), and
// the edges two envelope triangles share (for the crease).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

namespace mimic::avatar::exact_detail {

// A part's own triangles plus, for each boundary loop (connected boundary edges), a fan from the
// loop's centroid wound against the boundary edges, so the whole is closed and oriented as the
// part is. Indices below the mesh's vertex count are mesh vertices; index vertex_count + k is
// the centroid of loop k.
struct ClosedPart {
  std::vector<uint32_t> vertices;  // mesh vertices its own triangles use, ascending
  std::vector<std::array<uint32_t, 3>> triangles;
  std::vector<std::vector<uint32_t>> loops;  // each loop's vertices (any order)
};

// `indices`: the mesh's triangles (3 per triangle); `first`, `count`: the part's triangle range.
ClosedPart close_part(std::span<const uint32_t> indices, size_t vertex_count, uint32_t first, uint32_t count);

// Every edge shared by exactly two triangles that both pass `keep` (per triangle), as the two
// triangle indices.
std::vector<std::array<uint32_t, 2>> shared_edges(std::span<const uint32_t> indices, std::span<const uint8_t> keep);

// The sharpest crease over the shared edges: the largest angle between the unit normals of two
// triangles (radians), triangles under `min_area_m2` left out; `worst` gets the edge's index (or
// stays unchanged when no edge counts).
double sharpest_crease(std::span<const glm::vec3> positions, std::span<const uint32_t> indices,
                       std::span<const std::array<uint32_t, 2>> edges, double min_area_m2, size_t& worst);

}  // namespace mimic::avatar::exact_detail
