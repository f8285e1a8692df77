#include "mimic/render/offscreen.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

namespace mimic::render {

struct OffscreenContext::Impl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  GLuint fbo = 0, color = 0, depth = 0;       // the (multisampled) frame drawn into
  GLuint resolve_fbo = 0, resolve_color = 0;  // single-sampled copy that is read back
  int width = 0, height = 0, samples = 0;
  std::string description;

  ~Impl() {
    if (context != EGL_NO_CONTEXT) {
      eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context);
      glDeleteFramebuffers(1, &fbo);
      glDeleteFramebuffers(1, &resolve_fbo);
      glDeleteRenderbuffers(1, &color);
      glDeleteRenderbuffers(1, &depth);
      glDeleteRenderbuffers(1, &resolve_color);
      eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      eglDestroyContext(display, context);
    }
    // The display is not terminated: EGL displays are per process, a later context reuses it,
    // and terminating unloads Mesa's driver with allocations of its own still held (which
    // then show as leaks from an unknown module under LeakSanitizer).
  }
};

namespace {

std::string egl_error(const char* what) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%s failed (EGL error 0x%04x)", what, static_cast<unsigned>(eglGetError()));
  return buf;
}

EGLDisplay open_display() {
  // Surfaceless first: it needs neither X nor a DRM device, only Mesa.
  const char* client_ext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (client_ext && std::string(client_ext).find("EGL_MESA_platform_surfaceless") != std::string::npos) {
    auto get_platform_display =
        reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (get_platform_display) {
      EGLDisplay d = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
      if (d != EGL_NO_DISPLAY && eglInitialize(d, nullptr, nullptr)) return d;
    }
  }
  EGLDisplay d = eglGetDisplay(EGL_DEFAULT_DISPLAY);
  if (d != EGL_NO_DISPLAY && eglInitialize(d, nullptr, nullptr)) return d;
  return EGL_NO_DISPLAY;
}

}  // namespace

Result<OffscreenContext> OffscreenContext::create(int width, int height, int samples) {
  if (width < 1 || height < 1 || width > 8192 || height > 8192)
    return fail(Errc::out_of_range, "offscreen size must be 1..8192 pixels each way");
  auto impl = std::make_unique<Impl>();
  impl->width = width;
  impl->height = height;
  impl->samples = samples > 1 ? samples : 0;
  impl->display = open_display();
  if (impl->display == EGL_NO_DISPLAY)
    return fail(Errc::unsupported, egl_error("EGL display (surfaceless or default)"));
  if (!eglBindAPI(EGL_OPENGL_API)) return fail(Errc::unsupported, egl_error("eglBindAPI(OpenGL)"));
  const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint configs = 0;
  eglChooseConfig(impl->display, config_attribs, &config, 1, &configs);
  const EGLint context_attribs[] = {
      EGL_CONTEXT_MAJOR_VERSION,           3,       EGL_CONTEXT_MINOR_VERSION, 3, EGL_CONTEXT_OPENGL_PROFILE_MASK,
      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  // With no config (surfaceless), EGL_KHR_no_config_context lets the context exist anyway.
  impl->context = eglCreateContext(impl->display, configs > 0 ? config : EGLConfig{}, EGL_NO_CONTEXT, context_attribs);
  if (impl->context == EGL_NO_CONTEXT) return fail(Errc::unsupported, egl_error("eglCreateContext(OpenGL 3.3 core)"));
  if (!eglMakeCurrent(impl->display, EGL_NO_SURFACE, EGL_NO_SURFACE, impl->context))
    return fail(Errc::unsupported, egl_error("eglMakeCurrent without a surface"));

  GLint max_samples = 0;
  glGetIntegerv(GL_MAX_SAMPLES, &max_samples);
  if (impl->samples > max_samples) impl->samples = max_samples > 1 ? max_samples : 0;
  auto storage = [&](GLenum format) {
    if (impl->samples > 0)
      glRenderbufferStorageMultisample(GL_RENDERBUFFER, impl->samples, format, width, height);
    else
      glRenderbufferStorage(GL_RENDERBUFFER, format, width, height);
  };
  glGenFramebuffers(1, &impl->fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, impl->fbo);
  glGenRenderbuffers(1, &impl->color);
  glBindRenderbuffer(GL_RENDERBUFFER, impl->color);
  storage(GL_RGBA8);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, impl->color);
  glGenRenderbuffers(1, &impl->depth);
  glBindRenderbuffer(GL_RENDERBUFFER, impl->depth);
  storage(GL_DEPTH24_STENCIL8);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, impl->depth);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    return fail(Errc::unsupported, "offscreen framebuffer incomplete");

  glGenFramebuffers(1, &impl->resolve_fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, impl->resolve_fbo);
  glGenRenderbuffers(1, &impl->resolve_color);
  glBindRenderbuffer(GL_RENDERBUFFER, impl->resolve_color);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, impl->resolve_color);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    return fail(Errc::unsupported, "offscreen resolve framebuffer incomplete");

  glBindFramebuffer(GL_FRAMEBUFFER, impl->fbo);
  glViewport(0, 0, width, height);
  impl->description = std::string(reinterpret_cast<const char*>(glGetString(GL_VERSION))) + " / " +
                      reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  return OffscreenContext(std::move(impl));
}

OffscreenContext::OffscreenContext(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
OffscreenContext::OffscreenContext(OffscreenContext&&) noexcept = default;
OffscreenContext& OffscreenContext::operator=(OffscreenContext&&) noexcept = default;
OffscreenContext::~OffscreenContext() = default;

int OffscreenContext::width() const { return impl_->width; }
int OffscreenContext::height() const { return impl_->height; }
const char* OffscreenContext::describe() const { return impl_->description.c_str(); }

void OffscreenContext::bind() {
  glBindFramebuffer(GL_FRAMEBUFFER, impl_->fbo);
  glViewport(0, 0, impl_->width, impl_->height);
}

Image OffscreenContext::read() {
  const int w = impl_->width, h = impl_->height;
  glBindFramebuffer(GL_READ_FRAMEBUFFER, impl_->fbo);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, impl_->resolve_fbo);
  glBlitFramebuffer(0, 0, w, h, 0, 0, w, h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, impl_->resolve_fbo);
  Image image;
  image.width = w;
  image.height = h;
  image.rgba.resize(static_cast<size_t>(w) * h * 4);
  std::vector<uint8_t> flipped(image.rgba.size());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, flipped.data());
  // GL's row 0 is the bottom one.
  const size_t row = static_cast<size_t>(w) * 4;
  for (int y = 0; y < h; ++y)
    std::copy_n(flipped.data() + static_cast<size_t>(h - 1 - y) * row, row,
                image.rgba.data() + static_cast<size_t>(y) * row);
  bind();
  return image;
}

}  // namespace mimic::render

// Mesa and LLVM keep some allocations for the life of the process (compiled shader caches,
// driver singletons); they are not ours to free, so LeakSanitizer is told to ignore them in
// sanitizer builds. Harmless otherwise: nothing calls it.
extern "C" const char* __lsan_default_suppressions() {
  return "leak:libEGL\nleak:libEGL_mesa\nleak:libGLX\nleak:libGLX_mesa\nleak:libglapi\nleak:libgallium\n"
         "leak:swrast_dri\nleak:libLLVM\nleak:libdrm\nleak:libGLdispatch\nleak:libOpenGL\nleak:libX11\n"
         "leak:libxcb\nleak:libglfw\n";
}

// LeakSanitizer's tracking of dynamic TLS (through __tls_get_addr) misreads the blocks glibc 2.36
// gives the libraries Mesa loads (a block "at 0x1c6e-0x1800002d70"), and its tracer crashes at exit
// ("Tracer caught signal 11"), failing a run that leaked nothing. Dynamic TLS is left untracked;
// static TLS (ours, libnats') is still scanned.
extern "C" const char* __asan_default_options() { return "intercept_tls_get_addr=0"; }
