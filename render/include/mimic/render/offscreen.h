// An OpenGL 3.3 core context with no window: EGL on Mesa's surfaceless platform (falling back
// to EGL's default display), rendering into a multisampled framebuffer of a fixed size that
// read() resolves into an Image. Needs no display server and no GPU (Mesa's llvmpipe renders),
// so screenshots and image tests run anywhere the setup script ran.
#pragma once

#include <memory>

#include "mimic/core/result.h"
#include "mimic/render/image.h"

namespace mimic::render {

class OffscreenContext {
 public:
  // Creates the context, makes it current on the calling thread and binds a framebuffer of
  // width × height pixels (1..8192) with `samples` MSAA samples (0 or 1: none). Fails with a
  // message naming what EGL refused.
  static Result<OffscreenContext> create(int width, int height, int samples = 4);

  OffscreenContext(OffscreenContext&&) noexcept;
  OffscreenContext& operator=(OffscreenContext&&) noexcept;
  ~OffscreenContext();

  int width() const;
  int height() const;
  // Binds the framebuffer again (after something else bound another one).
  void bind();
  // Resolves the multisampled frame and reads it back, top row first.
  Image read();
  // "4.5 (Core Profile) Mesa 22.3.6 / llvmpipe ..." for reports.
  const char* describe() const;

 private:
  struct Impl;
  explicit OffscreenContext(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::render
