// Exact self-intersection of a posed skin mesh (CGAL, exact predicates): where the skin folds
// through itself inside one piece, where one piece passes through another, how deep, and the
// sharpest crease between neighbouring envelope triangles. A measuring tool for commands and
// tests (mimic intersect); the realtime path never links it (docs/skin.md, "Self-intersection").
//
// Parts are the mesh's MeshPart ranges (the skin pieces and the rigid head, hands and feet).
// Triangles that share a vertex or an edge and meet only there do not intersect; any other
// contact, touching included, does. A rigid part sinking into the envelope piece it is attached
// to (the head into the neck, a hand into its forearm, a foot into its calf) is by design and is
// counted apart, not as an intersection.
#pragma once

#include <cstddef>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/avatar/mesh.h"
#include "mimic/core/result.h"

namespace mimic::avatar {

struct IntersectionRules {
  // Pairs of part names whose contact is by design (either order): not counted as folds or
  // pairs between pieces, nor in the depth.
  std::vector<std::pair<std::string, std::string>> by_design;
  // Parts left out of the crease (rigid closed meshes, not envelope).
  std::vector<std::string> rigid;
  // The default body's: head–neck, hands–forearms, feet–calves; rigid head, hands and feet.
  static IntersectionRules default_body();
  // Nothing by design, nothing rigid (test meshes).
  static IntersectionRules none() { return {}; }
};

struct PartPairCount {
  std::string a, b;  // part names; a == b for folds
  size_t pairs = 0;
  bool by_design = false;  // IntersectionRules::by_design names the two
};

struct IntersectionReport {
  size_t triangles = 0;
  size_t fold_pairs = 0;       // intersecting triangle pairs inside one part
  size_t between_pairs = 0;    // between two parts, by-design pairs left out
  size_t by_design_pairs = 0;  // between parts whose contact is by design
  // Deepest interpenetration: how far a vertex of one part lies inside another part's closed
  // surface (the part's triangles with each boundary loop closed by a fan from its centroid),
  // metres; 0 when no vertex is inside another part. By-design pairs are left out.
  double deepest_m = 0;
  std::string deepest_part, deepest_inside;  // the vertex's part and the part it is inside
  // The same between envelope pieces only (no rigid part): what the skin itself can change, where
  // the deepest above may be a hand the motion puts into the body.
  double deepest_envelope_m = 0;
  std::string deepest_envelope_part, deepest_envelope_inside;
  // Sharpest crease: the largest angle between the normals of two envelope triangles sharing an
  // edge (0 flat, 180 folded flat back), degrees; rigid parts and zero-area triangles left out.
  double sharpest_crease_deg = 0;
  std::string crease_part;              // the part of the first of the two triangles
  std::vector<PartPairCount> by_parts;  // every part pair with intersections, most pairs first
  // Every intersecting pair of triangles (indices into the topology's triangles), by-design
  // pairs included: where a fold or a crossing is.
  std::vector<std::pair<uint32_t, uint32_t>> triangle_pairs;
};

// Built once per topology (indices and parts), then checks any positions of that topology.
class SelfIntersectionChecker {
 public:
  // Fails when the parts do not cover the triangles or an index is out of range.
  static Result<SelfIntersectionChecker> create(const Mesh& topology,
                                                const IntersectionRules& rules = IntersectionRules::default_body());
  SelfIntersectionChecker(SelfIntersectionChecker&&) noexcept;
  SelfIntersectionChecker& operator=(SelfIntersectionChecker&&) noexcept;
  ~SelfIntersectionChecker();

  // `positions`: one per vertex of the topology, metres (fewer: an empty report with no
  // triangles). Allocates; not for the realtime path.
  IntersectionReport check(std::span<const glm::vec3> positions) const;

  size_t part_count() const;

 private:
  struct Impl;
  explicit SelfIntersectionChecker(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::avatar
