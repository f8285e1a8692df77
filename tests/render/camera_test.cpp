// The camera's conventions, which every screenshot test relies on: a front camera sees the
// body's left (+X) on the image's right, a back camera on its left; presets frame the body.
#include <gtest/gtest.h>

#include "mimic/render/avatar_lods.h"
#include "mimic/render/camera.h"

namespace camera_test {

namespace {

using mimic::render::Camera;
using mimic::render::CameraPreset;

glm::vec2 project(const Camera& c, const glm::vec3& p, float aspect) {
  const glm::vec4 clip = c.clip_from_world(aspect) * glm::vec4(p, 1.0f);
  return glm::vec2(clip) / clip.w;  // NDC: x right, y up
}

TEST(Camera, FrontSeesTheLeftOnTheRightAndBackTheOpposite) {
  const glm::vec3 left_hand(0.8f, 1.4f, 0.0f), right_hand(-0.8f, 1.4f, 0.0f);
  const Camera front = mimic::render::preset_camera(CameraPreset::kFront, {0, 0, 0}, 1.7f, 1.0f);
  EXPECT_GT(project(front, left_hand, 1).x, 0.2f);
  EXPECT_LT(project(front, right_hand, 1).x, -0.2f);
  const Camera back = mimic::render::preset_camera(CameraPreset::kBack, {0, 0, 0}, 1.7f, 1.0f);
  EXPECT_LT(project(back, left_hand, 1).x, -0.2f);
  EXPECT_GT(project(back, right_hand, 1).x, 0.2f);
  // The side camera looks at the body's left side: its front (+Z) is on the image's left.
  const Camera side = mimic::render::preset_camera(CameraPreset::kSide, {0, 0, 0}, 1.7f, 1.0f);
  EXPECT_LT(project(side, {0, 1, 0.3f}, 1).x, -0.01f);
}

TEST(Camera, PresetsAreRelativeToWhereTheBodyFaces) {
  // A body turned a quarter turn to face +X: its face is on +X, its left hand on −Z.
  const glm::quat turned = glm::angleAxis(1.5707964f, glm::vec3(0, 1, 0));
  const float facing = mimic::render::facing_yaw_rad(turned);
  EXPECT_NEAR(facing, 1.5707964f, 1e-5f);
  const Camera front = mimic::render::preset_camera(CameraPreset::kFront, {0, 0, 0}, 1.7f, 1.0f, facing);
  EXPECT_GT(front.eye().x, 2.0f);  // in front of the face
  EXPECT_NEAR(front.eye().z, 0.0f, 1e-3f);
  const glm::vec3 left_hand = turned * glm::vec3(0.8f, 1.4f, 0.0f), right_hand = turned * glm::vec3(-0.8f, 1.4f, 0.0f);
  EXPECT_GT(project(front, left_hand, 1).x, 0.2f);  // as for an unturned body: its left on the right
  EXPECT_LT(project(front, right_hand, 1).x, -0.2f);
  const Camera side = mimic::render::preset_camera(CameraPreset::kSide, {0, 0, 0}, 1.7f, 1.0f, facing);
  EXPECT_LT(side.eye().z, -2.0f);  // at its left
  const Camera back = mimic::render::preset_camera(CameraPreset::kBack, {0, 0, 0}, 1.7f, 1.0f, facing);
  EXPECT_LT(back.eye().x, -2.0f);
  const Camera right = mimic::render::preset_camera(CameraPreset::kRight, {0, 0, 0}, 1.7f, 1.0f, facing);
  EXPECT_GT(right.eye().z, 2.0f);                                         // at its right (its left hand is on −Z)
  EXPECT_GT(project(right, turned * glm::vec3(0, 1, 0.3f), 1).x, 0.01f);  // its front on the image's right
  // From the top, nearly straight down, a little to the front: the face towards the image's bottom.
  const Camera top = mimic::render::preset_camera(CameraPreset::kTop, {0, 0, 0}, 1.7f, 1.0f, facing);
  EXPECT_GT(top.eye().y, 2.0f);
  EXPECT_NEAR(top.eye().z, 0.0f, 1e-3f);
  EXPECT_LT(project(top, turned * glm::vec3(0, 1.5f, 0.3f), 1).y,
            project(top, turned * glm::vec3(0, 1.5f, -0.3f), 1).y);
  // Pitch and roll of the root do not move the heading; facing straight down has none.
  EXPECT_NEAR(mimic::render::facing_yaw_rad(turned * glm::angleAxis(0.4f, glm::vec3(1, 0, 0))), facing, 1e-5f);
  EXPECT_EQ(mimic::render::facing_yaw_rad(glm::angleAxis(1.5707964f, glm::vec3(1, 0, 0))), 0.0f);
}

TEST(Camera, FitBoxKeepsTheSceneInTheBandAPanelLeavesFree) {
  // Two avatars side by side (the viewer's local layout), the panel over the left 35 %.
  const glm::vec3 lo(-1.6f, 0.0f, -0.4f), hi(1.6f, 1.8f, 0.4f);
  for (float aspect : {0.75f, 1.33f, 2.0f})
    for (float yaw : {0.0f, 0.7f, 3.1f}) {
      Camera c;
      c.yaw_rad = yaw;
      c.pitch_rad = 0.3f;
      mimic::render::fit_box(c, lo, hi, aspect, 0.35f, 1.0f);
      float x_min = 1e9f, x_max = -1e9f;
      for (int k = 0; k < 8; ++k) {
        const glm::vec3 p((k & 1) ? hi.x : lo.x, (k & 2) ? hi.y : lo.y, (k & 4) ? hi.z : lo.z);
        const glm::vec2 ndc = project(c, p, aspect);
        x_min = std::min(x_min, ndc.x);
        x_max = std::max(x_max, ndc.x);
        EXPECT_LT(std::abs(ndc.y), 1.0f) << aspect << " " << yaw;
      }
      EXPECT_GT(x_min, 2 * 0.35f - 1) << "under the panel at aspect " << aspect << ", yaw " << yaw;
      EXPECT_LT(x_max, 1.0f) << aspect << " " << yaw;
      EXPECT_GT(x_max - x_min, 0.8f) << "and not lost in the distance";
    }
}

TEST(Camera, PresetsFrameTheWholeBodyAtAnyAspect) {
  for (float aspect : {0.5f, 0.9f, 1.0f, 1.78f})
    for (auto preset : {CameraPreset::kFront, CameraPreset::kSide, CameraPreset::kBack, CameraPreset::kThreeQuarter}) {
      const Camera c = mimic::render::preset_camera(preset, {1.0f, 0, -2.0f}, 1.7f, aspect);
      for (const glm::vec3 p : {glm::vec3(1.0f, 0, -2.0f), glm::vec3(1.0f, 1.7f, -2.0f), glm::vec3(1.8f, 1.4f, -2.0f),
                                glm::vec3(0.2f, 1.4f, -2.0f)}) {
        const glm::vec2 ndc = project(c, p, aspect);
        EXPECT_LT(std::abs(ndc.x), 1.0f) << aspect;
        EXPECT_LT(std::abs(ndc.y), 1.0f) << aspect;
      }
      // ... and fill a good part of the height (NDC spans 2).
      EXPECT_GT(project(c, {1.0f, 1.7f, -2.0f}, aspect).y - project(c, {1.0f, 0, -2.0f}, aspect).y, 0.7f);
    }
}

TEST(Camera, OrbitClampsPitchZoomClampsDistancePanMovesTheTarget) {
  Camera c;
  c.orbit(0.0f, 10.0f);
  EXPECT_FLOAT_EQ(c.pitch_rad, 1.5f);
  c.zoom(1e-6f);
  EXPECT_FLOAT_EQ(c.distance_m, 0.2f);
  Camera d;
  const glm::vec3 before = d.target;
  d.pan(0.5f, 0.0f);  // half a view height to the right: the target moves along −X (yaw 0)
  EXPECT_LT(d.target.x, before.x - 0.1f);
  EXPECT_NEAR(d.target.y, before.y, 1e-5f);
}

TEST(Camera, FirstPersonLooksAlongItsForward) {
  Camera c;
  c.first_person_eye = glm::vec3(0, 1.6f, 0);
  c.first_person_forward = {0, 0, 1};
  const glm::vec4 ahead = c.clip_from_world(1.0f) * glm::vec4(0, 1.6f, 3.0f, 1.0f);
  EXPECT_GT(ahead.w, 0.0f);  // in front of the eye
  EXPECT_NEAR(ahead.x / ahead.w, 0.0f, 1e-4f);
  const glm::vec4 behind = c.clip_from_world(1.0f) * glm::vec4(0, 1.6f, -3.0f, 1.0f);
  EXPECT_LT(behind.w, 0.0f);
}

TEST(CameraFollow, KeepsASteadyWalkerInTheMiddleWithoutSwayingWithItsSteps) {
  // A walker at 1.3 m/s along a diagonal whose hips sway ±4 cm sideways twice a second, seen at
  // 60 Hz for 10 s: after the first seconds the target stays on the walker's path, not behind.
  Camera camera = mimic::render::preset_camera(CameraPreset::kFront, {0, 0, 0}, 1.7f, 1.0f);
  const float height = camera.target.y;
  mimic::render::CameraFollow follow;
  const glm::vec3 dir = glm::normalize(glm::vec3(1, 0, -0.5f));
  const glm::vec3 side(-dir.z, 0, dir.x);
  float worst_after_3s = 0, worst_sway = 0;
  for (int k = 1; k <= 600; ++k) {
    const float t = static_cast<float>(k) / 60.0f;
    const glm::vec3 path = 1.3f * t * dir;
    const glm::vec3 hips = path + 0.04f * std::sin(2.0f * 3.14159265f * 2.0f * t) * side;
    follow.update(camera, hips, 1.0f / 60.0f);
    if (t > 3.0f) {
      worst_after_3s =
          std::max(worst_after_3s, glm::length(glm::vec2(camera.target.x - path.x, camera.target.z - path.z)));
      worst_sway = std::max(worst_sway, std::abs(glm::dot(camera.target - path, side)));
    }
  }
  EXPECT_LT(worst_after_3s, 0.05f);  // without the aim ahead it trails by 0.52 m
  EXPECT_LT(worst_sway, 0.02f);      // half the hips' sway or less
  EXPECT_EQ(camera.target.y, height);
  // A standing avatar: the target settles on it.
  for (int k = 0; k < 600; ++k) follow.update(camera, {2, 0, 3}, 1.0f / 60.0f);
  EXPECT_NEAR(camera.target.x, 2.0f, 1e-3f);
  EXPECT_NEAR(camera.target.z, 3.0f, 1e-3f);
  // No time step, no move.
  const glm::vec3 before = camera.target;
  follow.update(camera, {9, 0, 9}, 0.0f);
  EXPECT_EQ(camera.target, before);
}

TEST(Camera, ParsesPresetNames) {
  EXPECT_EQ(mimic::render::parse_camera_preset("three-quarter"), CameraPreset::kThreeQuarter);
  EXPECT_EQ(mimic::render::parse_camera_preset("left"), CameraPreset::kLeft);
  EXPECT_EQ(mimic::render::parse_camera_preset("side"), CameraPreset::kLeft);
  EXPECT_EQ(mimic::render::parse_camera_preset("right"), CameraPreset::kRight);
  EXPECT_EQ(mimic::render::parse_camera_preset("top"), CameraPreset::kTop);
  EXPECT_FALSE(mimic::render::parse_camera_preset("above"));
}

TEST(Lod, FinerAsTheBodyComesCloser) {
  int previous = -1;
  for (float d = 60.0f; d > 0.5f; d *= 0.8f) {
    const int lod = mimic::render::choose_lod(d, 1.7f, 0.6f, 720, previous);
    if (previous >= 0) {
      EXPECT_LE(lod, previous) << d;
    }
    previous = lod;
  }
  EXPECT_EQ(previous, 0);
  EXPECT_EQ(mimic::render::choose_lod(1.0f, 1.7f, 0.6f, 720), 0);
  EXPECT_EQ(mimic::render::choose_lod(50.0f, 1.7f, 0.6f, 720), mimic::render::kLodCount - 1);
  // Hysteresis: just past a threshold, the level in use is kept.
  int lod = -1;
  float switch_d = 0;
  for (float d = 1.0f; d < 60.0f && lod <= 0; d *= 1.01f) {
    lod = mimic::render::choose_lod(d, 1.7f, 0.6f, 720, 0);
    switch_d = d;
  }
  EXPECT_EQ(mimic::render::choose_lod(switch_d * 0.97f, 1.7f, 0.6f, 720, lod), lod);
}

}  // namespace

}  // namespace camera_test
