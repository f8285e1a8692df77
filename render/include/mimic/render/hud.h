// The viewer's panels, drawn with Dear ImGui inside a Window frame: per avatar its LOD,
// triangle count, deform time and sensor status; the frame time; the overlays in use; and the
// help overlay listing the keys. Plain data in, so the front end needs no ImGui of its own.
#pragma once

#include <string>
#include <vector>

namespace mimic::render {

struct HudAvatar {
  std::string name;
  std::string source;         // what feeds it ("sim:walk?sensors=11", "remote #2" ...)
  std::string sensor_status;  // "streaming, 11 sensors", "stale" ...
  bool stale = false;
  int lod = 0;
  size_t triangles = 0;
  double deform_ms = 0;
  double distance_m = 0;
};

struct HudState {
  double frame_ms = 0;  // mean over the last second
  double fps = 0;
  std::string lod_mode;    // "auto (by distance)" or "fixed 1"
  std::string camera;      // "orbit" or "first person: <avatar>"
  std::string overlays;    // names in use
  std::string connection;  // "local pipeline" or "connected to HOST:PORT, N frames"
  std::vector<HudAvatar> avatars;
  bool help = false;
};

// Returns the status panel's right edge as a fraction of the display's width (the part of the
// view it covers, from the left), so a camera can frame the scene beside it.
float draw_hud(const HudState& state);

}  // namespace mimic::render
