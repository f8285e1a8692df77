// Volume and cross-sections of the skin around one joint, the measures `mimic inspect` reports
// to compare skinning methods as a joint bends or twists.
//
// The joint zone of a joint J (centre c, proximal link direction u pointing from J back along the
// parent link, distal direction d along the child link, half-length L) is the part of the closed
// envelope's interior inside both half-spaces
//   u·(x − c) ≤ L   and   d·(x − c) ≤ L,
// i.e. a slab 2L thick around a straight joint that becomes a wedge as the joint bends, its two
// planes riding on the two links. Only the triangles of the given subset (the limb's skin pieces)
// count, so the planes do not cut the torso or the other limb; the subset's surface must cross
// each plane in closed loops.
//
// Volume, by the divergence theorem with the field F(x) = e (e·(x − c)), e a unit vector
// perpendicular to both u and d (div F = 1, and F is parallel to both planes, so the caps
// contribute nothing): V = Σ over the subset's triangles clipped to the zone of ∫ F·n dA. Exact
// for a closed triangulated surface; regions where the skin passes through itself count twice,
// as they would in any mesh volume.
//
// Cross-sections: the area of the zone's interior cut by a station plane — the region of the
// plane inside the skin and inside both half-spaces — by the same theorem in the plane, with
// G(x) = e (e·(x − c)) along the lines where the zone's planes cut the station plane, so only
// the skin's section curve (clipped to the zone) contributes. Where the limbs fold over each
// other the section holds both. Stations: the joint's bisector plane (through c, normal d − u)
// and planes perpendicular to each link at L/3 and 2L/3 from c.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/avatar/mesh.h"

namespace mimic::avatar {

struct JointZone {
  glm::vec3 center_m{0.0f};
  glm::vec3 proximal_dir{-1, 0, 0};  // unit, from the joint along the parent link
  glm::vec3 distal_dir{1, 0, 0};     // unit, from the joint along the child link
  float half_length_m = 0.08f;
};

// The triangles (indices into mesh.indices / 3) of the named parts; unknown names are skipped.
std::vector<uint32_t> part_triangles(const Mesh& mesh, std::span<const std::string> part_names);

// The zone's volume (m³) enclosed by `triangles` of `positions` (winding as mesh.indices).
double joint_zone_volume(std::span<const glm::vec3> positions, std::span<const uint32_t> indices,
                         std::span<const uint32_t> triangles, const JointZone& zone);

// Area (m²) of the zone's section by the plane (point, normal), whose normal lies in the plane
// of the two link directions (as every station's does).
double joint_zone_section_area(std::span<const glm::vec3> positions, std::span<const uint32_t> indices,
                               std::span<const uint32_t> triangles, const JointZone& zone, const glm::vec3& point,
                               const glm::vec3& normal);

// Area (m²) of the loop where the plane (point, normal) cuts the triangles around `point`: of the
// closed loops that contain it once projected, the largest; nullopt when none does. Not limited
// to a zone.
std::optional<double> section_area(std::span<const glm::vec3> positions, std::span<const uint32_t> indices,
                                   std::span<const uint32_t> triangles, const glm::vec3& point,
                                   const glm::vec3& normal);

// The five stations of the zone, proximal to distal: (point, normal).
std::array<std::pair<glm::vec3, glm::vec3>, 5> joint_zone_stations(const JointZone& zone);

}  // namespace mimic::avatar
