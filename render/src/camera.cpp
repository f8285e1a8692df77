#include "mimic/render/camera.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

namespace mimic::render {

std::optional<CameraPreset> parse_camera_preset(std::string_view name) {
  if (name == "front") return CameraPreset::kFront;
  if (name == "left" || name == "side") return CameraPreset::kLeft;
  if (name == "right") return CameraPreset::kRight;
  if (name == "top") return CameraPreset::kTop;
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
    f = glm::normalize(f);
    // The up vector made square to the gaze; a head facing straight up or down keeps the world's.
    glm::vec3 up = first_person_up - glm::dot(first_person_up, f) * f;
    if (glm::length(up) < 1e-3f) up = std::abs(f.y) < 0.99f ? glm::vec3(0, 1, 0) - f.y * f : glm::vec3(0, 0, 1);
    up = glm::normalize(up);
    // The user's look: turned about the world's vertical, then tilted about the view's right.
    const glm::quat yaw = glm::angleAxis(look_yaw_rad, glm::vec3(0, 1, 0));
    f = yaw * f;
    up = yaw * up;
    const glm::quat pitch = glm::angleAxis(look_pitch_rad, glm::normalize(glm::cross(f, up)));
    f = pitch * f;
    up = pitch * up;
    return glm::lookAt(*first_person_eye, *first_person_eye + f, up);
  }
  return glm::lookAt(eye(), target, glm::vec3(0, 1, 0));
}

glm::mat4 Camera::clip_from_view(float aspect) const {
  if (first_person_eye)
    return glm::perspective(first_person_fov_y_rad, std::max(aspect, 1e-3f), first_person_near_m, far_m);
  return glm::perspective(fov_y_rad, std::max(aspect, 1e-3f), near_m, far_m);
}

void Camera::look(float dyaw_rad, float dpitch_rad) {
  look_yaw_rad = std::remainder(look_yaw_rad + dyaw_rad, 6.2831853f);
  look_pitch_rad = std::clamp(look_pitch_rad + dpitch_rad, -1.5f, 1.5f);
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

float facing_yaw_rad(const glm::quat& world_from_root) {
  const glm::vec3 f = world_from_root * glm::vec3(0.0f, 0.0f, 1.0f);
  if (f.x * f.x + f.z * f.z < 1e-8f) return 0.0f;  // facing straight up or down: no heading
  return std::atan2(f.x, f.z);
}

float preset_yaw_rad(CameraPreset preset, float facing_yaw_rad) {
  constexpr float kPi = 3.14159265f;
  // The eye sits at yaw: on +Z for 0 (see Camera::eye), so a body facing yaw is seen from the
  // front at the same yaw, from its left (its +X) a quarter turn further.
  switch (preset) {
    case CameraPreset::kFront: return facing_yaw_rad;
    case CameraPreset::kLeft: return facing_yaw_rad + 0.5f * kPi;
    case CameraPreset::kBack: return facing_yaw_rad + kPi;
    case CameraPreset::kThreeQuarter: return facing_yaw_rad + 0.25f * kPi;
    case CameraPreset::kRight: return facing_yaw_rad - 0.5f * kPi;
    case CameraPreset::kTop: return facing_yaw_rad;
  }
  return facing_yaw_rad;
}

float preset_pitch_rad(CameraPreset preset) {
  switch (preset) {
    case CameraPreset::kThreeQuarter: return 0.2f;
    case CameraPreset::kTop: return 1.45f;
    default: return 0.08f;
  }
}

Camera preset_camera(CameraPreset preset, const glm::vec3& floor_center, float height_m, float aspect,
                     float facing_yaw_rad) {
  Camera c;
  c.target = floor_center + glm::vec3(0.0f, 0.5f * height_m, 0.0f);
  c.pitch_rad = preset_pitch_rad(preset);
  c.yaw_rad = preset_yaw_rad(preset, facing_yaw_rad);
  // Fit the body's height (plus margin, and its arm span when the image is narrow) in the view.
  const float half_fov = 0.5f * c.fov_y_rad;
  const float needed_half_height = 0.62f * height_m * std::max(1.0f, 1.0f / std::max(aspect, 1e-3f));
  c.distance_m = needed_half_height / std::tan(half_fov);
  return c;
}

void fit_box(Camera& camera, const glm::vec3& lo, const glm::vec3& hi, float aspect, float free_x0, float free_x1) {
  constexpr float kMargin = 0.9f;  // of the free band and of the height
  aspect = std::max(aspect, 1e-3f);
  free_x0 = std::clamp(free_x0, 0.0f, 0.9f);
  free_x1 = std::clamp(free_x1, free_x0 + 0.1f, 1.0f);
  camera.first_person_eye.reset();
  camera.target = 0.5f * (lo + hi);
  const float t = std::tan(0.5f * camera.fov_y_rad);
  // NDC half-extents the box may take: the free band's half width, the full height.
  const float band_half = kMargin * (free_x1 - free_x0);  // NDC spans 2 over the width
  const float band_centre = (free_x0 + free_x1) - 1.0f;   // in NDC
  const glm::vec3 corners[8] = {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {lo.x, hi.y, lo.z}, {hi.x, hi.y, lo.z},
                                {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {lo.x, hi.y, hi.z}, {hi.x, hi.y, hi.z}};
  // The smallest distance (bisection) at which every corner projects inside the band's width
  // and the image's height; the pan then moves the box's middle to the band's middle.
  auto extent = [&](float d, float& x_min, float& x_max, float& y_abs) {
    camera.distance_m = d;
    const glm::mat4 v = camera.view_from_world();
    x_min = 1e9f, x_max = -1e9f, y_abs = 0.0f;
    for (const glm::vec3& p : corners) {
      const glm::vec4 q = v * glm::vec4(p, 1.0f);
      const float depth = std::max(-q.z, 1e-3f);
      const float x = q.x / (depth * t * aspect), y = q.y / (depth * t);
      x_min = std::min(x_min, x);
      x_max = std::max(x_max, x);
      y_abs = std::max(y_abs, std::abs(y));
    }
  };
  const float radius = 0.5f * glm::length(hi - lo) + 0.1f;
  float near_d = radius, far_d = 80.0f;
  for (int i = 0; i < 40; ++i) {
    const float d = 0.5f * (near_d + far_d);
    float x_min, x_max, y_abs;
    extent(d, x_min, x_max, y_abs);
    const bool fits = x_max - x_min <= 2.0f * band_half && y_abs <= kMargin;
    (fits ? far_d : near_d) = d;
  }
  float x_min, x_max, y_abs;
  extent(far_d, x_min, x_max, y_abs);
  // Pan so the box's NDC middle lands on the band's: one NDC unit is t·aspect·d metres at the target.
  const float shift_ndc = band_centre - 0.5f * (x_min + x_max);
  const glm::mat4 v = camera.view_from_world();
  const glm::vec3 right(v[0][0], v[1][0], v[2][0]);
  camera.target -= right * (shift_ndc * t * aspect * far_d);
}

}  // namespace mimic::render
