#include "depth_prepass.h"

#include <algorithm>

#include "gl_program.h"

namespace mimic::render::detail {
namespace {

constexpr const char* kDepthVs = R"(#version 330 core
layout(location = 0) in vec3 a_position;
uniform mat4 u_clip_from_world;
uniform mat4 u_world_from_mesh;
void main() { gl_Position = u_clip_from_world * u_world_from_mesh * vec4(a_position, 1.0); }
)";

constexpr const char* kDepthFs = R"(#version 330 core
void main() {}
)";

}  // namespace

DepthPrepass::~DepthPrepass() {
  glDeleteFramebuffers(1, &fbo_);
  glDeleteTextures(1, &depth_);
  glDeleteProgram(program_);
}

Status DepthPrepass::create() {
  auto program = link_program(kDepthVs, kDepthFs);
  if (!program) return tl::unexpected(program.error());
  program_ = *program;
  clip_ = glGetUniformLocation(program_, "u_clip_from_world");
  model_ = glGetUniformLocation(program_, "u_world_from_mesh");
  glGenTextures(1, &depth_);
  glGenFramebuffers(1, &fbo_);
  return {};
}

void DepthPrepass::begin(int frame_width_px, int frame_height_px, const glm::mat4& clip_from_world) {
  const int w = std::max(frame_width_px / 2, 1), h = std::max(frame_height_px / 2, 1);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  if (w != width_px_ || h != height_px_) {
    width_px_ = w, height_px_ = h;
    glBindTexture(GL_TEXTURE_2D, depth_);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, w, h, 0, GL_DEPTH_COMPONENT, GL_UNSIGNED_INT, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_NONE);
    glBindTexture(GL_TEXTURE_2D, 0);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth_, 0);
    glDrawBuffer(GL_NONE);
    glReadBuffer(GL_NONE);
  }
  glViewport(0, 0, w, h);
  glDepthMask(GL_TRUE);
  glClearDepth(1.0);
  glClear(GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glUseProgram(program_);
  glUniformMatrix4fv(clip_, 1, GL_FALSE, &clip_from_world[0][0]);
}

void DepthPrepass::set_model(const glm::mat4& world_from_mesh) {
  glUniformMatrix4fv(model_, 1, GL_FALSE, &world_from_mesh[0][0]);
}

void DepthPrepass::end(GLint framebuffer, const GLint viewport[4]) {
  glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(framebuffer));
  glViewport(viewport[0], viewport[1], viewport[2], viewport[3]);
  glDepthFunc(GL_LEQUAL);
}

}  // namespace mimic::render::detail
