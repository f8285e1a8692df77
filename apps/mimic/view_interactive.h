// The interactive side of `mimic view` (a GLFW window with Dear ImGui panels), apart from the
// screenshot path in cmd_view.cpp.
#pragma once

#include "mimic/avatar/realtime_skin.h"

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
  float frame_height_m = 0;                                  // screenshots: > 0 frames this height about the origin
  avatar::SkinMethod method = avatar::SkinMethod::realtime;  // how the drawn skin is made
  // The local scene (without --connect): what `mimic run` would serve (service/scene_builder.h).
  std::vector<service::SourceEntry> sources;
  service::Room room;
};

int run_interactive(Args& args, const ViewOptions& view);

}  // namespace mimic::app
