// Looking through an avatar's eyes, as a VR headset shows its wearer: the eye between the
// avatar's eyes (inside its head, which is therefore not drawn for that view), looking along the
// head's forward with the head's up at the top of the image, and a headset's wide field of view
// (Camera::first_person_fov_y_rad), so the avatar's own hands show when they come in front of the
// face and its body when it looks down. Pure math, no GL.
#pragma once

#include <cstdint>
#include <optional>
#include <span>

#include <glm/glm.hpp>

#include "mimic/avatar/mesh.h"
#include "mimic/render/camera.h"
#include "mimic/rig/skeleton.h"
#include "mimic/rig/transform.h"

namespace mimic::render {

struct AvatarEyes {
  glm::vec3 eye_m{0.0f};                // world, between the eyes
  glm::vec3 forward{0.0f, 0.0f, 1.0f};  // world, where the face points
  glm::vec3 up{0.0f, 1.0f, 0.0f};       // world, the top of the head
};

// The eyes of a body whose joints are `world_from_joint` (forward_kinematics of `skeleton`),
// placed in the world by `world_from_body`. The eye point scales with the head's link (the skull
// base to the crown): on the built-in body 7 cm above the skull base and 8 cm forward, about
// 2 cm behind the face. nullopt when the skeleton has no joint named "head".
std::optional<AvatarEyes> avatar_eyes(const rig::Skeleton& skeleton,
                                      std::span<const rig::RigidTransform> world_from_joint,
                                      const glm::mat4& world_from_body);

// The camera at those eyes (the user's look, Camera::look_yaw_rad / look_pitch_rad, kept).
void look_through(Camera& camera, const AvatarEyes& eyes);

// Where a wearer entering a scene turns to look, as a yaw from where its head looks (left
// positive, as Camera::look_yaw_rad): 0 when one of the others (their positions on the floor,
// world metres) is already in view, within `half_view_rad` of the gaze to either side; else
// towards the nearest one (beside it in the row, behind it in a scene); 0 with nobody else.
float yaw_towards_others(const glm::vec3& eye_m, const glm::vec3& forward, std::span<const glm::vec3> others_m,
                         float half_view_rad);

// The parts of `mesh` its wearer does not see from inside: the head (bits by part index, as
// MeshDraw::hidden_parts takes them).
uint64_t parts_hidden_from_own_eyes(const avatar::Mesh& mesh);

}  // namespace mimic::render
