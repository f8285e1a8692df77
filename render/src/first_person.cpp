#include "mimic/render/first_person.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace mimic::render {

std::optional<AvatarEyes> avatar_eyes(const rig::Skeleton& skeleton,
                                      std::span<const rig::RigidTransform> world_from_joint,
                                      const glm::mat4& world_from_body) {
  const int head = skeleton.find_joint("head");
  if (head < 0 || static_cast<size_t>(head) >= world_from_joint.size()) return std::nullopt;
  // The head's frame: +Y along the neck to the crown, +Z out of the face. The eyes sit about
  // half the skull-base-to-crown length above the skull base and a little more forward (an
  // adult's: 7 cm up, 8 cm forward, the face's surface 2 cm further).
  const float head_m = std::max(glm::length(skeleton.tip_m(head)), 0.05f);
  const rig::RigidTransform& h = world_from_joint[static_cast<size_t>(head)];
  AvatarEyes e;
  e.eye_m = glm::vec3(world_from_body * glm::vec4(h.apply({0.0f, 0.47f * head_m, 0.53f * head_m}), 1.0f));
  e.forward = glm::normalize(glm::vec3(world_from_body * glm::vec4(h.apply_vector({0, 0, 1}), 0.0f)));
  e.up = glm::normalize(glm::vec3(world_from_body * glm::vec4(h.apply_vector({0, 1, 0}), 0.0f)));
  return e;
}

void look_through(Camera& camera, const AvatarEyes& eyes) {
  camera.first_person_eye = eyes.eye_m;
  camera.first_person_forward = eyes.forward;
  camera.first_person_up = eyes.up;
}

float yaw_towards_others(const glm::vec3& eye_m, const glm::vec3& forward, std::span<const glm::vec3> others_m,
                         float half_view_rad) {
  const glm::vec2 f(forward.x, forward.z);
  if (glm::length(f) < 1e-3f) return 0.0f;  // looking straight up or down: no heading to turn from
  float nearest_m = 1e30f, yaw_rad = 0.0f;
  for (const glm::vec3& p : others_m) {
    const glm::vec2 d(p.x - eye_m.x, p.z - eye_m.z);
    const float distance_m = glm::length(d);
    if (distance_m < 1e-3f) continue;
    // Signed angle from the gaze to the other about the world's up (+Y): counter-clockwise seen
    // from above is a turn to the left. In the floor's (x, z), that is f × d = f.y·d.x − f.x·d.y.
    const float angle_rad = std::atan2(f.y * d.x - f.x * d.y, glm::dot(f, d));
    if (std::abs(angle_rad) <= half_view_rad) return 0.0f;
    if (distance_m < nearest_m) nearest_m = distance_m, yaw_rad = angle_rad;
  }
  return yaw_rad;
}

namespace {
// The head holds the eyes. The neck stays: its piece is the collar and upper chest, the first
// thing a look down meets, and leaving it out would open the torso to the view.
bool is_behind_the_eyes(const std::string& part) { return part.find("head") != std::string::npos; }
}  // namespace

uint64_t parts_hidden_from_own_eyes(const avatar::Mesh& mesh) {
  uint64_t hidden = 0;
  for (size_t i = 0; i < mesh.parts.size() && i < 64; ++i)
    if (is_behind_the_eyes(mesh.parts[i].name)) hidden |= uint64_t{1} << i;
  return hidden;
}

}  // namespace mimic::render
