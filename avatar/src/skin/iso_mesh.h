// A closed triangle mesh of an implicit solid, made once at layout time for the rigid parts
// (head, hands, feet): marching tetrahedra on a grid, vertices projected onto the iso-surface,
// then edge collapses down to a vertex budget and tangential relaxation. Every step keeps the
// mesh a closed, consistently oriented (outward) 2-manifold; every step is deterministic (loops
// in index order, ties broken by index), so two builds of a layout are identical.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include <glm/glm.hpp>

namespace mimic::avatar::skin_detail {

// A scalar field whose solid is where value(p) ≥ iso.
struct IsoField {
  std::function<float(const glm::vec3&)> value;
  float iso = 1.0f;
  glm::vec3 gradient(const glm::vec3& p, float step) const;
};

struct IsoMesh {
  std::vector<glm::vec3> positions;
  std::vector<uint32_t> triangles;  // counter-clockwise seen from outside
};

// Newton steps along the gradient onto the iso-surface, no step longer than max_step; p as it
// ends where the gradient vanishes.
glm::vec3 project_to_iso(const IsoField& f, glm::vec3 p, float max_step);

// Marching tetrahedra over the box [lo, hi] with cubic cells of `cell`, each cube split into six
// tetrahedra around its main diagonal (Kuhn's triangulation: the tetrahedra of neighbouring cubes
// share their faces). A node is inside by one comparison (value ≥ iso) and nodes on the box's
// border count as outside, so the surface is the boundary of a union of closed cells' pieces:
// closed, manifold, with no ambiguous case. Vertices are projected onto the iso-surface; only
// the largest component (by triangles) is kept.
IsoMesh march_tetrahedra(const IsoField& f, glm::vec3 lo, glm::vec3 hi, float cell);

// Edge collapses in order of quadric error (Garland–Heckbert) until at most max_vertices remain,
// each collapse kept only when the mesh stays a closed oriented 2-manifold (the link condition)
// and no triangle turns over or degenerates; the merged vertex is projected onto the surface.
// Then `smoothing` passes of tangential relaxation (each move projected back and kept only when
// no triangle around it turns over).
void decimate(IsoMesh& m, const IsoField& f, size_t max_vertices, int smoothing);

}  // namespace mimic::avatar::skin_detail
