#include "mimic/render/camera.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

namespace mimic::render {

std::optional<CameraPreset> parse_camera_preset(std::string_view name) {
  if (name == "front") return CameraPreset::kFront;
  if (name == "side") return CameraPreset::kSide;
  if (name == "back") return CameraPreset::kBack;
  if (name == "three-quarter") return CameraPreset::kThreeQuarter;
  return std::nullopt;
}

glm::vec3 Camera::eye() const {
  if (first_person_eye) return *first_person_eye;
  const float c = std::cos(pitch_rad);
  return target + distance_m * glm::vec3(c * std::sin(yaw_rad), std::sin(pitch_rad), c * std::cos(yaw_rad));
}

glm::mat4 Camera::view_from_world() const {
  if (first_person_eye) {
    glm::vec3 f = first_person_forward;
    if (glm::length(f) < 1e-6f) f = {0, 0, 1};
    return glm::lookAt(*first_person_eye, *first_person_eye + glm::normalize(f), glm::vec3(0, 1, 0));
  }
  return glm::lookAt(eye(), target, glm::vec3(0, 1, 0));
}

glm::mat4 Camera::clip_from_view(float aspect) const {
  return glm::perspective(first_person_eye ? first_person_fov_y_rad : fov_y_rad, std::max(aspect, 1e-3f), near_m, far_m);
}

void Camera::orbit(float dyaw_rad, float dpitch_rad) {
  yaw_rad += dyaw_rad;
  pitch_rad = std::clamp(pitch_rad + dpitch_rad, -1.5f, 1.5f);
}

void Camera::pan(float dx_view, float dy_view) {
  // Move the target in the view plane; one unit of dy is the height of the view at the target.
  const glm::mat4 view = view_from_world();
  const glm::vec3 right(view[0][0], view[1][0], view[2][0]);
  const glm::vec3 up(view[0][1], view[1][1], view[2][1]);
  const float height_m = 2.0f * distance_m * std::tan(0.5f * fov_y_rad);
  target += (-dx_view * right + dy_view * up) * height_m;
}

void Camera::zoom(float factor) { distance_m = std::clamp(distance_m * factor, 0.2f, 80.0f); }

void CameraFollow::update(Camera& camera, const glm::vec3& centre, float dt_s) {
  if (!(dt_s > 0.0f)) return;
  if (primed_) velocity_ += (1.0f - std::exp(-dt_s / velocity_s_)) * ((centre - last_centre_) / dt_s - velocity_);
  last_centre_ = centre;
  primed_ = true;
  const glm::vec3 aim = centre + follow_s_ * velocity_;
  const float k = 1.0f - std::exp(-dt_s / follow_s_);
  camera.target.x += k * (aim.x - camera.target.x);
  camera.target.z += k * (aim.z - camera.target.z);
}

Camera preset_camera(CameraPreset preset, const glm::vec3& floor_center, float height_m, float aspect) {
  Camera c;
  c.target = floor_center + glm::vec3(0.0f, 0.5f * height_m, 0.0f);
  c.pitch_rad = 0.08f;
  switch (preset) {
    case CameraPreset::kFront: c.yaw_rad = 0.0f; break;
    case CameraPreset::kSide: c.yaw_rad = 0.5f * 3.14159265f; break;  // eye on +X: the left side
    case CameraPreset::kBack: c.yaw_rad = 3.14159265f; break;
    case CameraPreset::kThreeQuarter:
      c.yaw_rad = 0.25f * 3.14159265f;
      c.pitch_rad = 0.2f;
      break;
  }
  // Fit the body's height (plus margin, and its arm span when the image is narrow) in the view.
  const float half_fov = 0.5f * c.fov_y_rad;
  const float needed_half_height = 0.62f * height_m * std::max(1.0f, 1.0f / std::max(aspect, 1e-3f));
  c.distance_m = needed_half_height / std::tan(half_fov);
  return c;
}

}  // namespace mimic::render
