// The interactive side of `mimic view` (a GLFW window with Dear ImGui panels), apart from the
// screenshot path in cmd_view.cpp.
#pragma once

#include "mimic/avatar/realtime_skin.h"

#include <string>
#include <vector>

#include "command.h"
#include "mimic/render/camera.h"
#include "mimic/render/overlays.h"
#include "mimic/service/scene_builder.h"

namespace mimic::app {

struct ViewOptions {
  render::CameraPreset camera = render::CameraPreset::kFront;
  int width = 640, height = 720;
  int lod = -1;  // -1: chosen by distance
  unsigned overlays = 0;
  int ray_ring = 40;
  bool grid = true;
  bool see_through = false;
  bool ambient_occlusion = true;  // --no-ao: without the screen-space ambient occlusion
  bool unlit = false;             // --shading albedo: the materials' colours without light
  float frame_height_m = 0;       // screenshots: > 0 frames this height about the origin
  std::string focus;              // screenshots: frame this mesh part (head, left_hand, …) close up
  avatar::SkinMethod method = avatar::SkinMethod::realtime;  // how the drawn skin is made
  // The local scene (without --connect): what `mimic run` would serve (service/scene_builder.h).
  std::vector<service::SourceEntry> sources;
  service::Room room;
  // The interactive window.
  std::string connect;  // --connect HOST:PORT or nats://...: view that scene instead of a local one
  bool lean = true;     // with --connect: the lean pose stream (--no-lean: POSE frames)
  long frames = -1;     // quit after this many frames; -1: when the window closes
  std::string capture;  // save the last frame (with --frames) as this PNG
  long eyes = 0;        // start in first person at avatar K's head (from 1); 0: orbit
  // --look YAW[,PITCH]: in first person, the look turned from where the head looks (left, up).
  float look_yaw_rad = 0.0f, look_pitch_rad = 0.0f;
  bool look_given = false;  // without --look, the eyes turn to the nearest other avatar if none is in view
  bool vsync = true, help_overlay = false, panel = true;
};

int run_interactive(const ViewOptions& view);

}  // namespace mimic::app
