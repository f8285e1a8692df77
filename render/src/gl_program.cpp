#include "gl_program.h"

#include <string>

namespace mimic::render::detail {
namespace {

Result<GLuint> compile(GLenum type, const char* source) {
  GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[1024] = {};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    glDeleteShader(s);
    return fail(Errc::unsupported, std::string("shader compile failed: ") + log);
  }
  return s;
}

}  // namespace

Result<GLuint> link_program(const char* vs_source, const char* fs_source) {
  auto vs = compile(GL_VERTEX_SHADER, vs_source);
  if (!vs) return tl::unexpected(vs.error());
  auto fs = compile(GL_FRAGMENT_SHADER, fs_source);
  if (!fs) {
    glDeleteShader(*vs);
    return tl::unexpected(fs.error());
  }
  GLuint p = glCreateProgram();
  glAttachShader(p, *vs);
  glAttachShader(p, *fs);
  glLinkProgram(p);
  glDeleteShader(*vs);
  glDeleteShader(*fs);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[1024] = {};
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    glDeleteProgram(p);
    return fail(Errc::unsupported, std::string("shader link failed: ") + log);
  }
  return p;
}

}  // namespace mimic::render::detail
