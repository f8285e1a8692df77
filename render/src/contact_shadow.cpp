#include "contact_shadow.h"

#include <glm/gtc/matrix_transform.hpp>

#include "gl_program.h"

namespace mimic::render::detail {
namespace {

constexpr int kSize_px = 256;
// The height field spans the floor (less a margin for feet a little below it) to this height:
// body further up casts no contact shadow.
constexpr float kBelow_m = 0.05f, kAbove_m = 0.7f;

constexpr const char* kHeightVs = R"(#version 330 core
layout(location = 0) in vec3 a_position;
uniform mat4 u_clip_from_world;
uniform mat4 u_world_from_mesh;
void main() { gl_Position = u_clip_from_world * u_world_from_mesh * vec4(a_position, 1.0); }
)";

constexpr const char* kHeightFs = R"(#version 330 core
void main() {}
)";

// The floor quad over the height field's area; a corner per vertex id.
constexpr const char* kFloorVs = R"(#version 330 core
uniform mat4 u_clip_from_world;
uniform vec4 u_region;
out vec2 v_xz;
void main() {
  vec2 corner = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1));
  v_xz = mix(u_region.xy, u_region.zw, corner);
  gl_Position = u_clip_from_world * vec4(v_xz.x, 0.0, v_xz.y, 1.0);
}
)";

// Occlusion gathered on three rings of eight (4, 12 and 28 cm): each sample counts the body above it the
// more the lower it is, the wider rings reaching higher, as a hemisphere of sky would be hidden.
constexpr const char* kFloorFs = R"(#version 330 core
in vec2 v_xz;
uniform sampler2D u_heights;
uniform vec4 u_region;
uniform float u_below, u_span;
out vec4 out_color;
float height_at(vec2 xz) {
  vec2 uv = (xz - u_region.xy) / (u_region.zw - u_region.xy);
  return texture(u_heights, uv).r * u_span - u_below;
}
float ring(float radius, float reach, float turn) {
  float sum = 0.0;
  for (int i = 0; i < 8; ++i) {
    float a = 6.2831853 * (float(i) + turn) / 8.0;
    float h = height_at(v_xz + radius * vec2(cos(a), sin(a)));
    sum += 1.0 - smoothstep(0.0, reach, max(h, 0.0));
  }
  return sum / 8.0;
}
void main() {
  float centre = 1.0 - smoothstep(0.0, 0.08, max(height_at(v_xz), 0.0));
  // Each pixel turns the rings its own way, so the samples blur the body instead of repeating it.
  float turn = fract(52.9829189 * fract(dot(gl_FragCoord.xy, vec2(0.06711056, 0.00583715))));
  float occlusion = 0.35 * centre + 0.30 * ring(0.04, 0.15, turn) + 0.20 * ring(0.12, 0.40, turn) +
                    0.15 * ring(0.28, 0.70, turn);
  out_color = vec4(0.0, 0.0, 0.02, 0.8 * occlusion);
}
)";

}  // namespace

ContactShadow::~ContactShadow() {
  glDeleteFramebuffers(1, &fbo_);
  glDeleteTextures(1, &depth_);
  glDeleteVertexArrays(1, &floor_vao_);
  glDeleteProgram(height_program_);
  glDeleteProgram(floor_program_);
}

Status ContactShadow::create() {
  auto height = link_program(kHeightVs, kHeightFs);
  if (!height) return tl::unexpected(height.error());
  height_program_ = *height;
  auto floor = link_program(kFloorVs, kFloorFs);
  if (!floor) return tl::unexpected(floor.error());
  floor_program_ = *floor;
  height_clip_ = glGetUniformLocation(height_program_, "u_clip_from_world");
  height_model_ = glGetUniformLocation(height_program_, "u_world_from_mesh");
  floor_clip_ = glGetUniformLocation(floor_program_, "u_clip_from_world");
  floor_region_ = glGetUniformLocation(floor_program_, "u_region");
  floor_heights_ = glGetUniformLocation(floor_program_, "u_heights");
  glUseProgram(floor_program_);
  glUniform1f(glGetUniformLocation(floor_program_, "u_below"), kBelow_m);
  glUniform1f(glGetUniformLocation(floor_program_, "u_span"), kBelow_m + kAbove_m);
  glUseProgram(0);
  glGenVertexArrays(1, &floor_vao_);

  glGenTextures(1, &depth_);
  glBindTexture(GL_TEXTURE_2D, depth_);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, kSize_px, kSize_px, 0, GL_DEPTH_COMPONENT, GL_UNSIGNED_INT,
               nullptr);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_BORDER);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_BORDER);
  const float far_border[4] = {1.0f, 1.0f, 1.0f, 1.0f};  // outside the field: nothing above
  glTexParameterfv(GL_TEXTURE_2D, GL_TEXTURE_BORDER_COLOR, far_border);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_NONE);
  glBindTexture(GL_TEXTURE_2D, 0);
  GLint bound = 0;  // the caller's framebuffer (an offscreen one), bound again after
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &bound);
  glGenFramebuffers(1, &fbo_);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth_, 0);
  glDrawBuffer(GL_NONE);
  glReadBuffer(GL_NONE);
  const bool complete = glCheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
  glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(bound));
  if (!complete) return fail(Errc::unsupported, "contact shadow framebuffer incomplete");
  return {};
}

void ContactShadow::begin(const glm::vec3& lo, const glm::vec3& hi) {
  region_ = {lo.x, lo.z, hi.x, hi.z};
  const glm::vec3 centre(0.5f * (lo.x + hi.x), 0.0f, 0.5f * (lo.z + hi.z));
  // From under the floor looking up (+Y), +X to the right and +Z up the image: the nearest
  // surface is the body's lowest, and the depth is its height above the floor.
  const glm::mat4 view = glm::lookAt(centre, centre + glm::vec3(0, 1, 0), glm::vec3(0, 0, 1));
  const float half_x = 0.5f * (hi.x - lo.x), half_z = 0.5f * (hi.z - lo.z);
  clip_from_world_ = glm::ortho(-half_x, half_x, -half_z, half_z, -kBelow_m, kAbove_m) * view;
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, kSize_px, kSize_px);
  glDepthMask(GL_TRUE);
  glClearDepth(1.0);
  glClear(GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glUseProgram(height_program_);
  glUniformMatrix4fv(height_clip_, 1, GL_FALSE, &clip_from_world_[0][0]);
}

void ContactShadow::set_model(const glm::mat4& world_from_mesh) {
  glUniformMatrix4fv(height_model_, 1, GL_FALSE, &world_from_mesh[0][0]);
}

void ContactShadow::end(GLint framebuffer, const GLint viewport[4]) {
  glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(framebuffer));
  glViewport(viewport[0], viewport[1], viewport[2], viewport[3]);
  glDepthFunc(GL_LEQUAL);
}

void ContactShadow::draw_floor(const glm::mat4& clip_from_world) {
  glUseProgram(floor_program_);
  glUniformMatrix4fv(floor_clip_, 1, GL_FALSE, &clip_from_world[0][0]);
  glUniform4fv(floor_region_, 1, &region_[0]);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, depth_);
  glUniform1i(floor_heights_, 0);
  glDisable(GL_DEPTH_TEST);
  glDepthMask(GL_FALSE);
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glBindVertexArray(floor_vao_);
  glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
  glBindTexture(GL_TEXTURE_2D, 0);
  glDisable(GL_BLEND);
  glDepthMask(GL_TRUE);
  glEnable(GL_DEPTH_TEST);
}

}  // namespace mimic::render::detail
