// The frame's depth at half resolution, drawn before the colour pass, for the screen-space
// ambient occlusion the mesh shader gathers from it (render/src/renderer.cpp): creases, the
// armpits, between the legs and under the chin darken where the body hides the sky from itself.
// A texture of its own rather than the frame's depth buffer, which is multisampled (MSAA) and
// cannot be sampled while it is drawn into.
#pragma once

#include <GL/gl.h>
#include <GL/glext.h>

#include <glm/glm.hpp>

#include "mimic/core/result.h"

namespace mimic::render::detail {

class DepthPrepass {
 public:
  DepthPrepass() = default;
  DepthPrepass(const DepthPrepass&) = delete;
  DepthPrepass& operator=(const DepthPrepass&) = delete;
  ~DepthPrepass();
  Status create();

  // Binds its target (sized to half the frame's, made again when that changes) cleared to far,
  // and its program with `clip_from_world`. Draw each mesh after set_model(), then end().
  void begin(int frame_width_px, int frame_height_px, const glm::mat4& clip_from_world);
  void set_model(const glm::mat4& world_from_mesh);
  void end(GLint framebuffer, const GLint viewport[4]);
  GLuint texture() const { return depth_; }

 private:
  GLuint fbo_ = 0, depth_ = 0, program_ = 0;
  GLint clip_ = -1, model_ = -1;
  int width_px_ = 0, height_px_ = 0;
};

}  // namespace mimic::render::detail
