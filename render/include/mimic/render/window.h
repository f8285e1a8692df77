// The interactive viewer's window: GLFW (window, OpenGL 3.3 core context, input) with Dear
// ImGui on top (its GLFW and OpenGL3 backends). The mouse drives a Camera unless ImGui wants
// it: left drag orbits (in first person: turns the look), right or middle drag pans, the wheel zooms. Keys pressed
// since the last frame are queued for the caller, again unless ImGui has the keyboard: printable keys as their
// upper-case ASCII code ('A', '1', '['), others as the constants below.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "mimic/core/result.h"
#include "mimic/render/camera.h"
#include "mimic/render/image.h"

namespace mimic::render {

inline constexpr int kKeyEscape = 256;  // GLFW's codes: printable keys are ASCII already
inline constexpr int kKeyF1 = 290;

class Window {
 public:
  // Opens a window (needs a display: X11 or Wayland, e.g. Xvfb) with vsync as asked.
  static Result<Window> open(const std::string& title, int width, int height, bool vsync = true);
  Window(Window&&) noexcept;
  Window& operator=(Window&&) noexcept;
  ~Window();

  bool should_close() const;
  void request_close();
  // Polls events, moves `camera` by the mouse, starts an ImGui frame. Returns the keys pressed.
  std::vector<int> begin_frame(Camera& camera);
  int framebuffer_width() const;
  int framebuffer_height() const;
  // Draws ImGui's frame over the scene; the back buffer is then complete (see read()).
  void render_ui();
  // The back buffer as drawn so far (top row first): a capture of what the window shows.
  Image read() const;
  void swap();
  double time_s() const;

 private:
  struct Impl;
  explicit Window(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::render
