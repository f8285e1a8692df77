#include "mimic/render/hud.h"

#include <imgui.h>

namespace mimic::render {

float draw_hud(const HudState& s) {
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_Always);
  ImGui::SetNextWindowBgAlpha(0.75f);
  ImGui::Begin("Mimic", nullptr,
               ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoSavedSettings |
                   ImGuiWindowFlags_NoFocusOnAppearing);
  ImGui::Text("frame %.2f ms (%.0f fps)", s.frame_ms, s.fps);
  ImGui::Text("LOD %s", s.lod_mode.c_str());
  ImGui::Text("camera %s", s.camera.c_str());
  ImGui::Text("overlays %s", s.overlays.empty() ? "none" : s.overlays.c_str());
  ImGui::TextUnformatted(s.connection.c_str());
  if (!s.avatars.empty()) ImGui::Separator();
  for (const HudAvatar& a : s.avatars) {
    // Two short lines per avatar: the panel stays narrow enough to leave the head of a body in
    // the middle of the window uncovered. The source on hover.
    if (a.stale)
      ImGui::TextColored(ImVec4(1.0f, 0.3f, 1.0f, 1.0f), "%s  STALE %s", a.name.c_str(), a.sensor_status.c_str());
    else
      ImGui::Text("%s  %s", a.name.c_str(), a.sensor_status.c_str());
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", a.source.c_str());
    ImGui::Text("  LOD %d, %zu tris, %.2f ms, %.1f m", a.lod, a.triangles, a.deform_ms, a.distance_m);
  }
  ImGui::Separator();
  ImGui::TextUnformatted("H or F1: help");
  const float display_w = ImGui::GetIO().DisplaySize.x;
  const float panel_right = display_w > 0 ? (ImGui::GetWindowPos().x + ImGui::GetWindowSize().x) / display_w : 0.0f;
  ImGui::End();

  if (!s.help) return panel_right;
  const ImGuiIO& io = ImGui::GetIO();
  ImGui::SetNextWindowPos(ImVec2(io.DisplaySize.x - 8, io.DisplaySize.y - 8), ImGuiCond_Always, ImVec2(1, 1));
  ImGui::SetNextWindowBgAlpha(0.85f);
  ImGui::Begin("Keys", nullptr,
               ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoSavedSettings);
  static const char* const kKeys[][2] = {
      {"H, F1", "this help"},
      {"1", "skeleton: joints and links"},
      {"2", "primitives as ellipsoids; muscles by f(t), blue rest .. red full"},
      {"3", "contours: the cross-section rings sampled this frame"},
      {"4", "rays of one ring (origin -> outermost hit); [ ] other ring"},
      {"5", "sensors: axes, magenta box when stale"},
      {"T", "translucent body (see overlays inside)"},
      {"L", "LOD: auto by distance, 0, 1, 2, 3"},
      {"G", "floor grid"},
      {"F", "first person at the next avatar's head (again: back to orbit)"},
      {"C", "follow the avatars (on at start; panning stops it)"},
      {"R", "reset the camera (and follow again)"},
      {"6-0, P", "camera: front, left, back, right, three-quarter, top (of the avatar)"},
      {"mouse", "left drag orbit, right/middle drag pan, wheel zoom"},
      {"Esc, Q", "quit"},
  };
  for (const auto& k : kKeys) {
    ImGui::TextColored(ImVec4(0.6f, 0.85f, 1.0f, 1.0f), "%-7s", k[0]);
    ImGui::SameLine();
    ImGui::TextUnformatted(k[1]);
  }
  ImGui::End();
  return panel_right;
}

}  // namespace mimic::render
