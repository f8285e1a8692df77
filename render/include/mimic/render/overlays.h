// Line overlays that show the method at work, built from a skin's last evaluated frame (all
// world space, metres): the skeleton, the primitives as ellipsoids (deformable ones — muscles —
// coloured by their current f(t), blue at rest to red at full deformation), the contour rings,
// the rays cast for one ring, and tracker sensors with their axes and a stale marker.
// Appending to a Lines object reuses its capacity, so a frame allocates nothing once warm.
#pragma once

#include <span>

#include <glm/gtc/quaternion.hpp>

#include "mimic/avatar/body_model.h"
#include "mimic/rig/skeleton.h"
#include "mimic/avatar/skin.h"
#include "mimic/render/renderer.h"

namespace mimic::render {

enum Overlay : unsigned {
  kOverlaySkeleton = 1u << 0,
  kOverlayPrimitives = 1u << 1,
  kOverlayContours = 1u << 2,
  kOverlayRays = 1u << 3,
  kOverlaySensors = 1u << 4,
};
// "skeleton,primitives,contours,rays,sensors" (any subset, comma-separated; "all"; "none");
// false on an unknown name.
bool parse_overlays(std::string_view list, unsigned& mask);

// Bones from each joint to its parent and a small cross at each joint.
void append_skeleton(const rig::Skeleton& skeleton, const rig::Pose& pose, const glm::mat4& world_from_body,
                     Lines& out);
// Three principal ellipses per primitive of the field. Muscles (primitives of `model` with a
// deformation) take the colour of f(t) for `pose`; soft metaballs are amber, hard ellipsoids grey.
void append_primitives(const avatar::ImplicitSkin& skin, const avatar::BodyModel& model, const rig::Pose& pose,
                       const glm::mat4& world_from_body, Lines& out);
// Every contour ring of the last frame as a closed polyline.
void append_contours(const avatar::ImplicitSkin& skin, const glm::mat4& world_from_body, Lines& out);
// The rays of ring `ring` (clamped to the rings there are): origin → hit, hits marked.
void append_rays(const avatar::ImplicitSkin& skin, int ring, const glm::mat4& world_from_body, Lines& out);

struct SensorMark {
  glm::vec3 position_m;   // world
  glm::quat orientation;  // world_from_sensor
  bool stale = false;
};
// Axes (x red, y green, z blue) of each sensor; a stale one gets a magenta box around it.
void append_sensors(std::span<const SensorMark> sensors, Lines& out);

// f(t) of a muscle's deformation at DOF value theta_rad (0 at θ0, 1 at a limit).
float deformation_amount(const avatar::Deformation& d, const rig::Dof& dof, float theta_rad);

}  // namespace mimic::render
