#include "mimic/render/window.h"

#include <GLFW/glfw3.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

#include <algorithm>
#include <cmath>

namespace mimic::render {

namespace {

// What the GLFW callbacks collect between frames.
struct InputQueue {
  std::vector<int> keys;
  double scroll = 0;
};

void on_key(GLFWwindow* w, int key, int, int action, int) {
  auto* input = static_cast<InputQueue*>(glfwGetWindowUserPointer(w));
  if (input && action == GLFW_PRESS) input->keys.push_back(key);
}

void on_scroll(GLFWwindow* w, double, double dy) {
  auto* input = static_cast<InputQueue*>(glfwGetWindowUserPointer(w));
  if (input) input->scroll += dy;
}

}  // namespace

struct Window::Impl {
  GLFWwindow* window = nullptr;
  InputQueue input;
  ImGuiContext* imgui = nullptr;
  bool imgui_glfw = false, imgui_gl = false;
  double last_x = 0, last_y = 0;
  bool have_last = false;

  ~Impl() {
    if (imgui) {
      ImGui::SetCurrentContext(imgui);
      if (imgui_gl) ImGui_ImplOpenGL3_Shutdown();
      if (imgui_glfw) ImGui_ImplGlfw_Shutdown();
      ImGui::DestroyContext(imgui);
    }
    if (window) glfwDestroyWindow(window);
    // No glfwTerminate(): it unloads the GL driver (Mesa's GLX), whose allocations then read as
    // leaks from an unknown module under LeakSanitizer. GLFW and the driver stay loaded until
    // the process exits (a later Window::open finds GLFW initialised), as the offscreen context
    // keeps its EGL display.
  }
};

Result<Window> Window::open(const std::string& title, int width, int height, bool vsync) {
  if (!glfwInit()) {
    const char* description = nullptr;
    glfwGetError(&description);
    return fail(Errc::unsupported, std::string("no display for a window (GLFW: ") +
                                       (description ? description : "init failed") +
                                       "); use --screenshot for offscreen images");
  }
  auto impl = std::make_unique<Impl>();
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_SAMPLES, 4);
  impl->window = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
  if (!impl->window) {
    const char* description = nullptr;
    glfwGetError(&description);
    return fail(Errc::unsupported,
                std::string("cannot open an OpenGL 3.3 window: ") + (description ? description : "?"));
  }
  glfwMakeContextCurrent(impl->window);
  glfwSwapInterval(vsync ? 1 : 0);
  glfwSetWindowUserPointer(impl->window, &impl->input);
  // Ours first: ImGui's backend chains to callbacks installed before it.
  glfwSetKeyCallback(impl->window, on_key);
  glfwSetScrollCallback(impl->window, on_scroll);
  IMGUI_CHECKVERSION();
  impl->imgui = ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini beside the user's files
  ImGui::StyleColorsDark();
  impl->imgui_glfw = ImGui_ImplGlfw_InitForOpenGL(impl->window, true);
  impl->imgui_gl = ImGui_ImplOpenGL3_Init("#version 330");
  if (!impl->imgui_glfw || !impl->imgui_gl) return fail(Errc::unsupported, "Dear ImGui backends failed to start");
  return Window(std::move(impl));
}

Window::Window(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Window::Window(Window&&) noexcept = default;
Window& Window::operator=(Window&&) noexcept = default;
Window::~Window() = default;

bool Window::should_close() const { return glfwWindowShouldClose(impl_->window); }
void Window::request_close() { glfwSetWindowShouldClose(impl_->window, GLFW_TRUE); }
double Window::time_s() const { return glfwGetTime(); }

std::vector<int> Window::begin_frame(Camera& camera) {
  Impl& w = *impl_;
  w.input.keys.clear();
  w.input.scroll = 0;
  glfwPollEvents();
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
  const ImGuiIO& io = ImGui::GetIO();
  double x = 0, y = 0;
  glfwGetCursorPos(w.window, &x, &y);
  int width = 1, height = 1;
  glfwGetWindowSize(w.window, &width, &height);
  if (w.have_last && !io.WantCaptureMouse) {
    const float dx = static_cast<float>(x - w.last_x), dy = static_cast<float>(y - w.last_y);
    if (glfwGetMouseButton(w.window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS && camera.first_person_eye) {
      camera.look(-dx * 0.005f, -dy * 0.005f);  // turn the head: drag right looks right
    } else if (glfwGetMouseButton(w.window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS) {
      camera.orbit(-dx * 0.008f, dy * 0.008f);
    } else if (glfwGetMouseButton(w.window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS ||
               glfwGetMouseButton(w.window, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS) {
      camera.pan(dx / static_cast<float>(std::max(height, 1)), dy / static_cast<float>(std::max(height, 1)));
    }
    if (w.input.scroll != 0) camera.zoom(std::pow(0.9f, static_cast<float>(w.input.scroll)));
  }
  w.last_x = x;
  w.last_y = y;
  w.have_last = true;
  if (io.WantCaptureKeyboard) return {};
  return w.input.keys;
}

int Window::framebuffer_width() const {
  int w = 0, h = 0;
  glfwGetFramebufferSize(impl_->window, &w, &h);
  return w;
}

int Window::framebuffer_height() const {
  int w = 0, h = 0;
  glfwGetFramebufferSize(impl_->window, &w, &h);
  return h;
}

void Window::render_ui() {
  ImGui::Render();
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
}

Image Window::read() const {
  Image image;
  image.width = framebuffer_width();
  image.height = framebuffer_height();
  std::vector<uint8_t> flipped(static_cast<size_t>(image.width) * image.height * 4);
  glReadBuffer(GL_BACK);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, image.width, image.height, GL_RGBA, GL_UNSIGNED_BYTE, flipped.data());
  image.rgba.resize(flipped.size());
  const size_t row = static_cast<size_t>(image.width) * 4;
  for (int y = 0; y < image.height; ++y)
    std::copy_n(flipped.data() + static_cast<size_t>(image.height - 1 - y) * row, row,
                image.rgba.data() + static_cast<size_t>(y) * row);
  return image;
}

void Window::swap() { glfwSwapBuffers(impl_->window); }

}  // namespace mimic::render
