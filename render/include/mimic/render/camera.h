// The viewer's camera: an orbit camera around a target point (yaw about +Y, pitch, distance),
// with pan and zoom for the mouse, named presets for screenshots, and a first-person mode that
// looks from a given eye along a given direction. Pure math, no GL: tests project with it.
//
// World frame: metres, +Y up, avatars face +Z, their left is +X. yaw_rad = 0 puts the eye on
// +Z looking towards −Z, i.e. at the avatar's front.
#pragma once

#include <optional>
#include <string_view>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace mimic::render {

// Named relative to the body: front looks at its face, left at its left side, and so on.
enum class CameraPreset { kFront, kLeft, kBack, kThreeQuarter, kRight, kTop, kSide = kLeft };

// "front", "back", "left" (or "side"), "right", "three-quarter", "top"; nullopt otherwise.
std::optional<CameraPreset> parse_camera_preset(std::string_view name);

struct Camera {
  glm::vec3 target{0.0f, 0.9f, 0.0f};  // world point the orbit turns around (metres)
  float yaw_rad = 0.0f;                // about +Y; 0: eye on +Z
  float pitch_rad = 0.1f;              // up from the horizontal plane, clamped to ±1.5
  float distance_m = 3.5f;
  float fov_y_rad = 0.6f;
  float near_m = 0.05f, far_m = 100.0f;

  // First person: when set, the eye sits here looking along `first_person_forward`, its
  // `first_person_up` the top of the image (an avatar's head: render/first_person.h), turned
  // further by the user's look (a drag: left/up positive) as a headset wearer turns the head.
  std::optional<glm::vec3> first_person_eye;
  glm::vec3 first_person_forward{0.0f, 0.0f, 1.0f};
  glm::vec3 first_person_up{0.0f, 1.0f, 0.0f};
  float look_yaw_rad = 0.0f, look_pitch_rad = 0.0f;  // about the world's up, then the view's right
  // As wide as a headset's (about 90° high, 106° wide in a 4:3 window): the own hands show when
  // they come in front of the face and the own body when looking down.
  float first_person_fov_y_rad = 1.5708f;
  float first_person_near_m = 0.02f;  // the own hands may come close to the eyes

  glm::vec3 eye() const;
  glm::mat4 view_from_world() const;
  glm::mat4 clip_from_view(float aspect) const;
  glm::mat4 clip_from_world(float aspect) const { return clip_from_view(aspect) * view_from_world(); }

  // Mouse gestures. Angles in radians, pan in fractions of the view height, zoom as a factor
  // (< 1 comes closer).
  void orbit(float dyaw_rad, float dpitch_rad);
  void pan(float dx_view, float dy_view);
  void zoom(float factor);
  // A drag in first person: the look turned left by `dyaw_rad` and up by `dpitch_rad` (pitch
  // clamped to ±1.5 rad).
  void look(float dyaw_rad, float dpitch_rad);
};

// Keeps an orbit camera's target on a moving point of the floor (the avatars' centre): a glide
// with time constant `follow_s`, aimed ahead by the point's smoothed velocity times that constant,
// so a steady walker stays in the middle of the view instead of trailing behind. Height, angles
// and distance stay the user's. reset() forgets the point's history (after a pause or a jump).
class CameraFollow {
 public:
  explicit CameraFollow(float follow_s = 0.4f, float velocity_s = 0.5f)
      : follow_s_(follow_s), velocity_s_(velocity_s) {}
  void update(Camera& camera, const glm::vec3& centre, float dt_s);
  void reset() {
    primed_ = false;
    velocity_ = glm::vec3(0.0f);
  }

 private:
  float follow_s_, velocity_s_;
  bool primed_ = false;
  glm::vec3 last_centre_{0.0f};
  glm::vec3 velocity_{0.0f};  // m/s
};

// Where a body faces, as a yaw about +Y (0: +Z, the zero posture's facing; π/2: +X), from its
// root orientation; pitch and roll are ignored.
float facing_yaw_rad(const glm::quat& world_from_root);

// The orbit pitch of a preset: a little above the horizontal, more for three-quarter, nearly
// straight down for top.
float preset_pitch_rad(CameraPreset preset);

// The orbit yaw of a preset for a body facing `facing_yaw_rad`: front looks at its face, left at
// its left, right at its right, back at its back, three-quarter between its front and its left,
// top down on it with its face towards the bottom of the image.
float preset_yaw_rad(CameraPreset preset, float facing_yaw_rad);

// A camera that frames a standing body of `height_m` whose feet are at `floor_center` from the
// preset's direction relative to where the body faces, with some margin, for an image of the
// given aspect.
Camera preset_camera(CameraPreset preset, const glm::vec3& floor_center, float height_m, float aspect,
                     float facing_yaw_rad = 0.0f);

// Fits the orbit camera's target and distance (its angles kept) so that the box lo..hi
// (world, metres) shows whole inside the horizontal band [free_x0, free_x1] of the image
// (fractions of its width, 0 left .. 1 right: the part not covered by a panel), with a margin.
void fit_box(Camera& camera, const glm::vec3& lo, const glm::vec3& hi, float aspect, float free_x0 = 0.0f,
             float free_x1 = 1.0f);

}  // namespace mimic::render
