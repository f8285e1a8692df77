// Topology and geometry checks of a triangle mesh: is the skin a closed, consistently oriented,
// manifold surface (what a watertight body must be), and its volume and area.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mimic/avatar/mesh.h"

namespace mimic::avatar {

struct MeshTopology {
  size_t vertex_count = 0;  // positions referenced by at least one triangle
  size_t unreferenced_vertices = 0;
  size_t edge_count = 0;               // distinct undirected edges
  size_t face_count = 0;               // triangles
  size_t boundary_edges = 0;           // used by one triangle
  size_t boundary_loops = 0;           // connected groups of boundary edges (holes)
  size_t non_manifold_edges = 0;       // used by three or more triangles
  size_t inconsistent_edges = 0;       // used by two triangles running it the same way (a flipped face)
  size_t non_manifold_vertices = 0;    // incident triangles form more than one fan (a bow tie)
  size_t components = 0;               // edge-connected pieces
  size_t degenerate_triangles = 0;     // a repeated index or zero area
  long long euler_characteristic = 0;  // V − E + F
  // Sum over components of the genus, from χ = 2C − 2g − B; −1 unless the surface is an
  // oriented manifold (possibly with boundary).
  int genus = -1;
  double signed_volume = 0;  // cubic units of the positions; positive when faces wind outward
  double surface_area = 0;   // square units of the positions
};

// Counts everything above. Triangles with a repeated index count as faces and as degenerate
// but add no edges, and any of them leaves genus at −1. O(F log F).
MeshTopology analyze_topology(const Mesh& mesh);

// No boundary, no non-manifold edge or vertex, consistent orientation, at least one face.
bool is_closed_oriented_manifold(const MeshTopology& topology);

// Merges vertices closer than tolerance (same units as the positions) into the first of them,
// e.g. seam vertices duplicated for UVs. Triangles that collapse (repeated index) are dropped
// and part ranges shrink to match; normals of merged vertices are averaged.
Mesh weld_by_position(const Mesh& mesh, float tolerance);

// Rows of contour points (vertex indices) of one skin piece, in order along it.
struct ContourRows {
  std::string piece;
  std::vector<std::vector<uint32_t>> rows;
};

// Adjacent contours of a piece must not cross inside the skin: neither may pass through the
// disc the other spans (a fan of triangles from its centroid to its edges: flat for a planar
// contour, and through the contour's own points where a loop's follow bends it). A pair crosses
// when an edge of one pierces the other's disc more than `tolerance_m` from its edge; a contour
// may still pass beside the other outside the skin (the outer side of a bend).
struct ContourOrder {
  size_t pairs = 0;         // adjacent row pairs checked
  size_t crossing = 0;      // pairs that cross
  float worst_m = 0;        // deepest piercing, from the pierced polygon's edge
  std::string worst_piece;  // where (piece name and row index)
};
ContourOrder check_contour_order(std::span<const glm::vec3> positions, std::span<const ContourRows> pieces,
                                 float tolerance_m = 0.001f);

}  // namespace mimic::avatar
