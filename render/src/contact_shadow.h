// The soft shadow the avatars cast on the floor where they stand on it (ambient occlusion of the
// floor by the body, the contact cue that puts the feet on the ground). Each frame the bodies'
// lower part is drawn from under the floor, looking up, into a small depth texture: a height
// field of the body above each floor point. The floor is then darkened by how much body lies
// low above it, gathered over rings of growing radius, so the shadow is dark and tight where a
// sole touches and wide and faint under the knees and hips. One extra depth-only pass of the
// meshes and one quad; no light direction, so it reads the same from every camera.
#pragma once

#include <GL/gl.h>
#include <GL/glext.h>

#include <glm/glm.hpp>

#include "mimic/core/result.h"

namespace mimic::render::detail {

class ContactShadow {
 public:
  ContactShadow() = default;
  ContactShadow(const ContactShadow&) = delete;
  ContactShadow& operator=(const ContactShadow&) = delete;
  ~ContactShadow();
  Status create();

  // The height pass over the floor area lo..hi (world, metres; y ignored): binds its target and
  // program. Draw each mesh after set_model() with its positions at attribute 0, then end().
  void begin(const glm::vec3& lo, const glm::vec3& hi);
  void set_model(const glm::mat4& world_from_mesh);
  // Back to the framebuffer and viewport the frame draws into.
  void end(GLint framebuffer, const GLint viewport[4]);
  // Darkens the floor (y = 0) under the bodies, blended over what the frame holds.
  void draw_floor(const glm::mat4& clip_from_world);

 private:
  GLuint fbo_ = 0, depth_ = 0;
  GLuint height_program_ = 0, floor_program_ = 0, floor_vao_ = 0;
  GLint height_clip_ = -1, height_model_ = -1;
  GLint floor_clip_ = -1, floor_region_ = -1, floor_heights_ = -1;
  glm::vec4 region_{0.0f};  // x0, z0, x1, z1 of the height field
  glm::mat4 clip_from_world_{1.0f};
};

}  // namespace mimic::render::detail
