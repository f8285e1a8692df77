#include "mimic/render/renderer.h"

#include <GL/gl.h>
#include <GL/glext.h>

#include <algorithm>
#include <cstddef>
#include <string>

namespace mimic::render {
namespace {

constexpr const char* kMeshVs = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
uniform mat4 u_clip_from_world;
uniform mat4 u_view_from_world;
uniform mat4 u_world_from_mesh;
out vec3 v_normal_view;
out vec3 v_position_view;
void main() {
  vec4 world = u_world_from_mesh * vec4(a_position, 1.0);
  v_position_view = (u_view_from_world * world).xyz;
  v_normal_view = mat3(u_view_from_world) * mat3(u_world_from_mesh) * a_normal;
  gl_Position = u_clip_from_world * world;
}
)";

// Lit in view space (a key light above and to the left of the camera, a hemisphere fill, a
// little specular and rim), so every camera sees the body modelled.
constexpr const char* kMeshFs = R"(#version 330 core
in vec3 v_normal_view;
in vec3 v_position_view;
uniform vec3 u_color;
uniform float u_alpha;
uniform int u_has_normals;
out vec4 out_color;
void main() {
  vec3 n = u_has_normals != 0 ? normalize(v_normal_view)
                              : normalize(cross(dFdx(v_position_view), dFdy(v_position_view)));
  vec3 v = normalize(-v_position_view);
  if (dot(n, v) < 0.0) n = -n;
  vec3 l = normalize(vec3(-0.45, 0.65, 0.6));
  float diffuse = max(dot(n, l), 0.0);
  float hemi = 0.5 + 0.5 * n.y;
  float specular = pow(max(dot(n, normalize(l + v)), 0.0), 40.0) * 0.18;
  float rim = pow(1.0 - max(dot(n, v), 0.0), 3.0) * 0.12;
  vec3 c = u_color * (0.22 + 0.22 * hemi + 0.62 * diffuse) + vec3(specular + rim);
  out_color = vec4(c, u_alpha);
}
)";

constexpr const char* kLineVs = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec4 a_color;
uniform mat4 u_clip_from_world;
out vec4 v_color;
void main() {
  v_color = a_color;
  gl_Position = u_clip_from_world * vec4(a_position, 1.0);
}
)";

constexpr const char* kLineFs = R"(#version 330 core
in vec4 v_color;
out vec4 out_color;
void main() { out_color = v_color; }
)";

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

Result<GLuint> link(const char* vs_source, const char* fs_source) {
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

const void* offset(size_t bytes) { return reinterpret_cast<const void*>(bytes); }

}  // namespace

glm::vec3 part_color(std::string_view name) {
  const bool left = name.rfind("l_", 0) == 0 || name.rfind("left", 0) == 0;
  const float shade = left ? 1.08f : 0.94f;
  auto has = [&](const char* s) { return name.find(s) != std::string_view::npos; };
  glm::vec3 c{0.7f, 0.7f, 0.7f};
  if (has("head") || has("neck") || has("hand") || has("foot"))  // the feet are bare
    c = {0.87f, 0.69f, 0.58f};
  else if (has("upper_torso"))
    c = {0.30f, 0.50f, 0.72f};
  else if (has("lower_torso"))
    c = {0.26f, 0.42f, 0.62f};
  else if (has("torso"))
    c = {0.30f, 0.48f, 0.70f};
  else if (has("upper_arm"))
    c = {0.36f, 0.57f, 0.78f};
  else if (has("lower_arm") || has("forearm"))
    c = {0.86f, 0.67f, 0.56f};
  else if (has("upper_leg") || has("thigh"))
    c = {0.34f, 0.34f, 0.40f};
  else if (has("lower_leg") || has("shin"))
    c = {0.40f, 0.40f, 0.47f};
  return glm::min(c * shade, glm::vec3(1.0f));
}

struct Renderer::Impl {
  struct Part {
    uint32_t first_index = 0, index_count = 0;
    glm::vec3 color{0.7f};
  };
  struct GpuMesh {
    GLuint vao = 0, positions = 0, normals = 0, indices = 0;
    size_t vertex_count = 0, triangle_count = 0;
    bool has_normals = false;
    std::vector<Part> parts;
  };

  GLuint mesh_program = 0, line_program = 0;
  GLint mesh_clip = -1, mesh_view = -1, mesh_model = -1, mesh_color = -1, mesh_alpha = -1, mesh_has_normals = -1;
  GLint line_clip = -1;
  GLuint line_vao = 0, line_vbo = 0;
  size_t line_capacity = 0;  // vertices
  GLuint grid_vao = 0, grid_vbo = 0;
  GLsizei grid_vertices = 0;
  std::vector<GpuMesh> meshes;

  ~Impl() {
    for (GpuMesh& m : meshes) {
      glDeleteVertexArrays(1, &m.vao);
      GLuint buffers[] = {m.positions, m.normals, m.indices};
      glDeleteBuffers(3, buffers);
    }
    GLuint buffers[] = {line_vbo, grid_vbo};
    glDeleteBuffers(2, buffers);
    GLuint vaos[] = {line_vao, grid_vao};
    glDeleteVertexArrays(2, vaos);
    glDeleteProgram(mesh_program);
    glDeleteProgram(line_program);
  }

  static void line_layout() {
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(LineVertex), offset(offsetof(LineVertex, position)));
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, sizeof(LineVertex), offset(offsetof(LineVertex, color)));
  }

  void build_grid() {
    std::vector<LineVertex> v;
    const float half_m = 5.0f, step_m = 0.5f;
    for (int i = -10; i <= 10; ++i) {
      const float s = static_cast<float>(i) * step_m;
      const bool major = i % 2 == 0;
      glm::vec4 cx = major ? glm::vec4(0.62f, 0.64f, 0.68f, 1) : glm::vec4(0.78f, 0.79f, 0.82f, 1);
      glm::vec4 cz = cx;
      if (i == 0) {
        cx = {0.80f, 0.45f, 0.45f, 1};  // the X axis (the avatars' left) in red
        cz = {0.45f, 0.52f, 0.82f, 1};  // the Z axis (where they face) in blue
      }
      v.push_back({{-half_m, 0, s}, cx});  // along X, at z = s
      v.push_back({{half_m, 0, s}, cx});
      v.push_back({{s, 0, -half_m}, cz});  // along Z, at x = s
      v.push_back({{s, 0, half_m}, cz});
    }
    grid_vertices = static_cast<GLsizei>(v.size());
    // The ground beyond the grid, out to the far plane's reach: in first person the eye looks
    // across it to the horizon, and a floor that ends 5 m away reads as a void.
    const glm::vec4 ground{0.86f, 0.87f, 0.89f, 1.0f};
    const float far_m = 200.0f;
    for (const glm::vec2& c :
         {glm::vec2(-1, -1), glm::vec2(1, -1), glm::vec2(1, 1), glm::vec2(-1, -1), glm::vec2(1, 1), glm::vec2(-1, 1)})
      v.push_back({{c.x * far_m, 0.0f, c.y * far_m}, ground});
    glGenVertexArrays(1, &grid_vao);
    glBindVertexArray(grid_vao);
    glGenBuffers(1, &grid_vbo);
    glBindBuffer(GL_ARRAY_BUFFER, grid_vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(LineVertex)), v.data(), GL_STATIC_DRAW);
    line_layout();
    glBindVertexArray(0);
  }

  void upload_lines(std::span<const LineVertex> a, std::span<const LineVertex> b) {
    const size_t n = a.size() + b.size();
    glBindBuffer(GL_ARRAY_BUFFER, line_vbo);
    if (n > line_capacity) {
      line_capacity = std::max(n, 2 * line_capacity);
      glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(line_capacity * sizeof(LineVertex)), nullptr,
                   GL_STREAM_DRAW);
    }
    if (!a.empty()) glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(a.size_bytes()), a.data());
    if (!b.empty())
      glBufferSubData(GL_ARRAY_BUFFER, static_cast<GLintptr>(a.size_bytes()), static_cast<GLsizeiptr>(b.size_bytes()),
                      b.data());
  }

  void draw_meshes(const FrameDesc& frame, const glm::mat4& clip, const glm::mat4& view, bool transparent) {
    glUseProgram(mesh_program);
    glUniformMatrix4fv(mesh_clip, 1, GL_FALSE, &clip[0][0]);
    glUniformMatrix4fv(mesh_view, 1, GL_FALSE, &view[0][0]);
    for (const MeshDraw& d : frame.meshes) {
      if (!d.mesh.valid() || d.mesh.index >= meshes.size() || (d.alpha < 1.0f) != transparent) continue;
      const GpuMesh& m = meshes[d.mesh.index];
      glBindVertexArray(m.vao);
      glUniformMatrix4fv(mesh_model, 1, GL_FALSE, &d.world_from_mesh[0][0]);
      glUniform1f(mesh_alpha, d.alpha);
      glUniform1i(mesh_has_normals, m.has_normals ? 1 : 0);
      for (size_t i = 0; i < m.parts.size(); ++i) {
        const Part& p = m.parts[i];
        if (i < 64 && (d.hidden_parts >> i) & 1u) continue;
        glUniform3fv(mesh_color, 1, &p.color[0]);
        glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(p.index_count), GL_UNSIGNED_INT,
                       offset(p.first_index * sizeof(uint32_t)));
      }
    }
  }
};

Result<Renderer> Renderer::create() {
  auto impl = std::make_unique<Impl>();
  auto mesh = link(kMeshVs, kMeshFs);
  if (!mesh) return tl::unexpected(mesh.error());
  impl->mesh_program = *mesh;
  auto line = link(kLineVs, kLineFs);
  if (!line) return tl::unexpected(line.error());
  impl->line_program = *line;
  impl->mesh_clip = glGetUniformLocation(impl->mesh_program, "u_clip_from_world");
  impl->mesh_view = glGetUniformLocation(impl->mesh_program, "u_view_from_world");
  impl->mesh_model = glGetUniformLocation(impl->mesh_program, "u_world_from_mesh");
  impl->mesh_color = glGetUniformLocation(impl->mesh_program, "u_color");
  impl->mesh_alpha = glGetUniformLocation(impl->mesh_program, "u_alpha");
  impl->mesh_has_normals = glGetUniformLocation(impl->mesh_program, "u_has_normals");
  impl->line_clip = glGetUniformLocation(impl->line_program, "u_clip_from_world");
  glGenVertexArrays(1, &impl->line_vao);
  glBindVertexArray(impl->line_vao);
  glGenBuffers(1, &impl->line_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, impl->line_vbo);
  impl->line_capacity = 1 << 16;
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(impl->line_capacity * sizeof(LineVertex)), nullptr,
               GL_STREAM_DRAW);
  Impl::line_layout();
  glBindVertexArray(0);
  impl->build_grid();
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  return Renderer(std::move(impl));
}

Renderer::Renderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Renderer::Renderer(Renderer&&) noexcept = default;
Renderer& Renderer::operator=(Renderer&&) noexcept = default;
Renderer::~Renderer() = default;

MeshId Renderer::add_mesh(const avatar::Mesh& mesh) {
  Impl::GpuMesh m;
  m.vertex_count = mesh.positions.size();
  m.triangle_count = mesh.triangle_count();
  m.has_normals = mesh.normals.size() == mesh.positions.size();
  glGenVertexArrays(1, &m.vao);
  glBindVertexArray(m.vao);
  glGenBuffers(1, &m.positions);
  glBindBuffer(GL_ARRAY_BUFFER, m.positions);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(m.vertex_count * sizeof(glm::vec3)), mesh.positions.data(),
               GL_DYNAMIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(glm::vec3), nullptr);
  glGenBuffers(1, &m.normals);
  glBindBuffer(GL_ARRAY_BUFFER, m.normals);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(m.vertex_count * sizeof(glm::vec3)),
               m.has_normals ? mesh.normals.data() : nullptr, GL_DYNAMIC_DRAW);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(glm::vec3), nullptr);
  glGenBuffers(1, &m.indices);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m.indices);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh.indices.size() * sizeof(uint32_t)),
               mesh.indices.data(), GL_STATIC_DRAW);
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, 0);
  if (mesh.parts.empty()) {
    m.parts.push_back({0, static_cast<uint32_t>(mesh.indices.size()), part_color("")});
  } else {
    for (const avatar::MeshPart& p : mesh.parts)
      m.parts.push_back({p.first_triangle * 3, p.triangle_count * 3, part_color(p.name)});
  }
  impl_->meshes.push_back(std::move(m));
  return MeshId{static_cast<uint32_t>(impl_->meshes.size() - 1)};
}

void Renderer::update_mesh(MeshId id, const avatar::Mesh& mesh) {
  if (!id.valid() || id.index >= impl_->meshes.size()) return;
  Impl::GpuMesh& m = impl_->meshes[id.index];
  if (mesh.positions.size() != m.vertex_count) return;  // another topology: add_mesh() it
  glBindBuffer(GL_ARRAY_BUFFER, m.positions);
  glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(m.vertex_count * sizeof(glm::vec3)),
                  mesh.positions.data());
  m.has_normals = mesh.normals.size() == m.vertex_count;
  if (m.has_normals) {
    glBindBuffer(GL_ARRAY_BUFFER, m.normals);
    glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(m.vertex_count * sizeof(glm::vec3)),
                    mesh.normals.data());
  }
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

size_t Renderer::triangle_count(MeshId id) const {
  return id.valid() && id.index < impl_->meshes.size() ? impl_->meshes[id.index].triangle_count : 0;
}

void Renderer::render(const FrameDesc& frame) {
  Impl& r = *impl_;
  const float aspect =
      frame.height_px > 0 ? static_cast<float>(frame.width_px) / static_cast<float>(frame.height_px) : 1.0f;
  const glm::mat4 view = frame.camera.view_from_world();
  const glm::mat4 clip = frame.camera.clip_from_view(aspect) * view;

  glViewport(0, 0, frame.width_px, frame.height_px);
  glClearColor(frame.background.x, frame.background.y, frame.background.z, 1.0f);
  glDepthMask(GL_TRUE);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDisable(GL_CULL_FACE);  // two-sided: open parts (caps under the head, hands) stay solid
  glDisable(GL_BLEND);
  glDisable(GL_SCISSOR_TEST);

  glUseProgram(r.line_program);
  glUniformMatrix4fv(r.line_clip, 1, GL_FALSE, &clip[0][0]);
  if (frame.ground) {  // behind everything: no depth, as the clear colour is
    glDisable(GL_DEPTH_TEST);
    glBindVertexArray(r.grid_vao);
    glDrawArrays(GL_TRIANGLES, r.grid_vertices, 6);
    glEnable(GL_DEPTH_TEST);
  }

  r.draw_meshes(frame, clip, view, false);

  r.upload_lines(frame.lines, frame.xray_lines);
  glUseProgram(r.line_program);
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  if (frame.grid) {
    glBindVertexArray(r.grid_vao);
    glDrawArrays(GL_LINES, 0, r.grid_vertices);
  }
  glBindVertexArray(r.line_vao);
  if (!frame.lines.empty()) glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(frame.lines.size()));

  // See-through meshes after the opaque ones, without writing depth, so lines inside show.
  glDepthMask(GL_FALSE);
  r.draw_meshes(frame, clip, view, true);
  glDepthMask(GL_TRUE);

  if (!frame.xray_lines.empty()) {
    glDisable(GL_DEPTH_TEST);
    glUseProgram(r.line_program);
    glBindVertexArray(r.line_vao);
    glDrawArrays(GL_LINES, static_cast<GLint>(frame.lines.size()), static_cast<GLsizei>(frame.xray_lines.size()));
  }

  // Leave the context as we found it for whoever draws next.
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  glUseProgram(0);
  glDisable(GL_BLEND);
  glDisable(GL_DEPTH_TEST);
}

}  // namespace mimic::render
