#include "mimic/render/renderer.h"

#include <GL/gl.h>
#include <GL/glext.h>

#include <algorithm>
#include <cstddef>
#include <string>

#include "contact_shadow.h"
#include "depth_prepass.h"
#include "gl_program.h"

namespace mimic::render {
namespace {

using detail::buffer_offset;
using detail::link_program;

// What a mesh without colours of its own (a reference scan, a loaded OBJ) is drawn in.
constexpr glm::vec3 kPlainGrey{0.70f, 0.70f, 0.72f};

constexpr const char* kMeshVs = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec3 a_albedo;
uniform mat4 u_clip_from_world;
uniform mat4 u_view_from_world;
uniform mat4 u_world_from_mesh;
out vec3 v_normal_view;
out vec3 v_position_view;
out vec3 v_albedo;
void main() {
  vec4 world = u_world_from_mesh * vec4(a_position, 1.0);
  v_position_view = (u_view_from_world * world).xyz;
  v_normal_view = mat3(u_view_from_world) * mat3(u_world_from_mesh) * a_normal;
  v_albedo = a_albedo;
  gl_Position = u_clip_from_world * world;
}
)";

// A photographer's three lights, fixed to the camera so every view is modelled alike: a warm key
// above and a little to the left of the lens, a cool fill from the right and lower (half the
// key, so the shadow side keeps its form and the two halves of a front view weigh about the
// same), and a rim from behind that outlines the silhouette against the background; under them
// a hemisphere ambient (sky above, a darker floor bounce below, by the world's up).
constexpr const char* kMeshFs = R"(#version 330 core
in vec3 v_normal_view;
in vec3 v_position_view;
in vec3 v_albedo;
uniform vec3 u_up_view;
uniform float u_alpha;
uniform int u_unlit;
uniform int u_has_normals;
uniform sampler2D u_depth;
uniform int u_ao;
uniform vec2 u_frame_px;
uniform vec4 u_proj;  // the projection's [0][0], [1][1], [2][2], [3][2]
out vec4 out_color;
// A view-space point from the half-resolution depth of the frame (depth_prepass.h).
vec3 view_point(vec2 uv) {
  float z_ndc = texture(u_depth, uv).r * 2.0 - 1.0;
  float distance_m = u_proj.w / (z_ndc + u_proj.z);
  return vec3((uv * 2.0 - 1.0) / u_proj.xy * distance_m, -distance_m);
}
// Screen-space ambient occlusion: how much of the hemisphere over the surface other surfaces
// within 25 cm fill, from 12 samples over a disc of 12 cm (turned per pixel).
float ambient_occlusion(vec3 n) {
  if (u_ao == 0) return 1.0;
  vec2 uv = gl_FragCoord.xy / u_frame_px;
  float distance_m = -v_position_view.z;
  vec2 radius_uv = 0.12 * u_proj.xy / (2.0 * distance_m);
  float turn = 6.2831853 * fract(52.9829189 * fract(dot(gl_FragCoord.xy, vec2(0.06711056, 0.00583715))));
  float hidden = 0.0;
  for (int i = 0; i < 12; ++i) {
    float a = 2.3999632 * float(i) + turn;
    vec2 offset = sqrt((float(i) + 0.5) / 12.0) * radius_uv * vec2(cos(a), sin(a));
    vec3 s = view_point(uv + offset) - v_position_view;
    float len = length(s);
    hidden += max(dot(n, s) / max(len, 1e-4) - 0.15, 0.0) * (1.0 - smoothstep(0.12, 0.25, len));
  }
  return clamp(1.0 - 1.6 * hidden / 12.0, 0.0, 1.0);
}
void main() {
  vec3 n = u_has_normals != 0 ? normalize(v_normal_view)
                              : normalize(cross(dFdx(v_position_view), dFdy(v_position_view)));
  vec3 v = normalize(-v_position_view);
  if (dot(n, v) < 0.0) n = -n;
  vec3 key_dir = normalize(vec3(-0.35, 0.55, 0.75));
  vec3 fill_dir = normalize(vec3(0.7, 0.0, 0.7));
  vec3 rim_dir = normalize(vec3(0.0, 0.45, -0.9));
  float up = dot(n, u_up_view);
  vec3 ambient = mix(vec3(0.25, 0.24, 0.24), vec3(0.42, 0.44, 0.48), 0.5 + 0.5 * up);
  float key = max(dot(n, key_dir), 0.0);
  float fill = max(dot(n, fill_dir), 0.0);
  float ndv = max(dot(n, v), 0.0);
  float rim = pow(1.0 - ndv, 2.5) * clamp(dot(n, rim_dir) + 0.35, 0.0, 1.0);
  float specular = pow(max(dot(n, normalize(key_dir + v)), 0.0), 36.0) * 0.07;
  // Occlusion darkens what light comes from all round (ambient, fill) fully, the key half.
  float ao = ambient_occlusion(n);
  vec3 light = ambient * ao + vec3(1.0, 0.96, 0.90) * 0.66 * key * (0.5 + 0.5 * ao) +
               vec3(0.86, 0.92, 1.0) * 0.32 * fill * ao;
  vec3 c = v_albedo * light + vec3(specular) + vec3(0.95, 0.97, 1.0) * 0.30 * rim;
  out_color = vec4(u_unlit != 0 ? v_albedo : c, u_alpha);
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

}  // namespace

struct Renderer::Impl {
  struct Part {
    uint32_t first_index = 0, index_count = 0;
  };
  struct GpuMesh {
    GLuint vao = 0, positions = 0, normals = 0, albedo = 0, indices = 0;
    size_t vertex_count = 0, triangle_count = 0;
    bool has_normals = false;
    std::vector<Part> parts;
    glm::vec3 lo{0.0f}, hi{0.0f};  // bounds of the latest positions (mesh frame, metres)
  };

  GLuint mesh_program = 0, line_program = 0;
  GLint mesh_clip = -1, mesh_view = -1, mesh_model = -1, mesh_up = -1, mesh_alpha = -1, mesh_has_normals = -1,
        mesh_unlit = -1, mesh_depth = -1, mesh_ao = -1, mesh_frame_px = -1, mesh_proj = -1;
  GLint line_clip = -1;
  GLuint line_vao = 0, line_vbo = 0;
  size_t line_capacity = 0;  // vertices
  GLuint grid_vao = 0, grid_vbo = 0;
  GLsizei grid_vertices = 0;
  std::vector<GpuMesh> meshes;
  detail::ContactShadow shadow;
  detail::DepthPrepass depth;

  ~Impl() {
    for (GpuMesh& m : meshes) {
      glDeleteVertexArrays(1, &m.vao);
      GLuint buffers[] = {m.positions, m.normals, m.albedo, m.indices};
      glDeleteBuffers(4, buffers);
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
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(LineVertex), buffer_offset(offsetof(LineVertex, position)));
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, sizeof(LineVertex), buffer_offset(offsetof(LineVertex, color)));
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

  void draw_meshes(const FrameDesc& frame, const glm::mat4& clip, const glm::mat4& view, const glm::mat4& projection,
                   bool ao, bool transparent) {
    glUseProgram(mesh_program);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, depth.texture());
    glActiveTexture(GL_TEXTURE0);
    glUniform1i(mesh_depth, 1);
    glUniform1i(mesh_ao, ao && !transparent && !frame.unlit ? 1 : 0);
    glUniform2f(mesh_frame_px, static_cast<float>(frame.width_px), static_cast<float>(frame.height_px));
    glUniform4f(mesh_proj, projection[0][0], projection[1][1], projection[2][2], projection[3][2]);
    glUniformMatrix4fv(mesh_clip, 1, GL_FALSE, &clip[0][0]);
    glUniformMatrix4fv(mesh_view, 1, GL_FALSE, &view[0][0]);
    const glm::vec3 up_view = glm::mat3(view) * glm::vec3(0.0f, 1.0f, 0.0f);
    glUniform3fv(mesh_up, 1, &up_view[0]);
    glUniform1i(mesh_unlit, frame.unlit ? 1 : 0);
    for (const MeshDraw& d : frame.meshes) {
      if (!d.mesh.valid() || d.mesh.index >= meshes.size() || (d.alpha < 1.0f) != transparent) continue;
      const GpuMesh& m = meshes[d.mesh.index];
      glBindVertexArray(m.vao);
      glUniformMatrix4fv(mesh_model, 1, GL_FALSE, &d.world_from_mesh[0][0]);
      glUniform1f(mesh_alpha, d.alpha);
      glUniform1i(mesh_has_normals, m.has_normals ? 1 : 0);
      draw_parts(m, d.hidden_parts);
    }
  }

  static void draw_parts(const GpuMesh& m, uint64_t hidden_parts) {
    for (size_t i = 0; i < m.parts.size(); ++i) {
      const Part& p = m.parts[i];
      if (i < 64 && (hidden_parts >> i) & 1u) continue;
      glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(p.index_count), GL_UNSIGNED_INT,
                     buffer_offset(p.first_index * sizeof(uint32_t)));
    }
  }

  // The floor area under every drawn mesh (its bounds moved into the world), with room round it
  // for the shadow's spread; false when nothing is drawn.
  bool floor_area(const FrameDesc& frame, glm::vec3& lo, glm::vec3& hi) const {
    lo = glm::vec3(1e9f), hi = glm::vec3(-1e9f);
    for (const MeshDraw& d : frame.meshes) {
      if (!d.mesh.valid() || d.mesh.index >= meshes.size()) continue;
      const GpuMesh& m = meshes[d.mesh.index];
      for (int corner = 0; corner < 8; ++corner) {
        const glm::vec3 c((corner & 1) ? m.hi.x : m.lo.x, (corner & 2) ? m.hi.y : m.lo.y,
                          (corner & 4) ? m.hi.z : m.lo.z);
        const glm::vec3 w = glm::vec3(d.world_from_mesh * glm::vec4(c, 1.0f));
        lo = glm::min(lo, w);
        hi = glm::max(hi, w);
      }
    }
    if (lo.x > hi.x) return false;
    const float margin_m = 0.4f;
    lo -= glm::vec3(margin_m, 0.0f, margin_m);
    hi += glm::vec3(margin_m, 0.0f, margin_m);
    return true;
  }

  // The opaque meshes' depth for the ambient occlusion (depth_prepass.h).
  bool depth_prepass(const FrameDesc& frame, const glm::mat4& clip) {
    GLint framebuffer = 0, viewport[4] = {};
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &framebuffer);
    glGetIntegerv(GL_VIEWPORT, viewport);
    depth.begin(frame.width_px, frame.height_px, clip);
    bool any = false;
    for (const MeshDraw& d : frame.meshes) {
      if (!d.mesh.valid() || d.mesh.index >= meshes.size() || d.alpha < 1.0f) continue;
      const GpuMesh& m = meshes[d.mesh.index];
      glBindVertexArray(m.vao);
      depth.set_model(d.world_from_mesh);
      draw_parts(m, d.hidden_parts);
      any = true;
    }
    depth.end(framebuffer, viewport);
    return any;
  }

  // The bodies' heights above the floor for the contact shadow (contact_shadow.h).
  bool shadow_heights(const FrameDesc& frame) {
    glm::vec3 lo, hi;
    if (!floor_area(frame, lo, hi)) return false;
    GLint framebuffer = 0, viewport[4] = {};
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &framebuffer);
    glGetIntegerv(GL_VIEWPORT, viewport);
    shadow.begin(lo, hi);
    for (const MeshDraw& d : frame.meshes) {
      if (!d.mesh.valid() || d.mesh.index >= meshes.size()) continue;
      const GpuMesh& m = meshes[d.mesh.index];
      glBindVertexArray(m.vao);
      shadow.set_model(d.world_from_mesh);
      draw_parts(m, d.hidden_parts);
    }
    shadow.end(framebuffer, viewport);
    return true;
  }
};

// Bounds of a mesh's positions, for the floor area its shadow needs.
void bounds(const std::vector<glm::vec3>& positions, glm::vec3& lo, glm::vec3& hi) {
  lo = glm::vec3(1e9f), hi = glm::vec3(-1e9f);
  for (const glm::vec3& p : positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  if (positions.empty()) lo = hi = glm::vec3(0.0f);
}

Result<Renderer> Renderer::create() {
  auto impl = std::make_unique<Impl>();
  auto mesh = link_program(kMeshVs, kMeshFs);
  if (!mesh) return tl::unexpected(mesh.error());
  impl->mesh_program = *mesh;
  auto line = link_program(kLineVs, kLineFs);
  if (!line) return tl::unexpected(line.error());
  impl->line_program = *line;
  impl->mesh_clip = glGetUniformLocation(impl->mesh_program, "u_clip_from_world");
  impl->mesh_view = glGetUniformLocation(impl->mesh_program, "u_view_from_world");
  impl->mesh_model = glGetUniformLocation(impl->mesh_program, "u_world_from_mesh");
  impl->mesh_up = glGetUniformLocation(impl->mesh_program, "u_up_view");
  impl->mesh_unlit = glGetUniformLocation(impl->mesh_program, "u_unlit");
  impl->mesh_depth = glGetUniformLocation(impl->mesh_program, "u_depth");
  impl->mesh_ao = glGetUniformLocation(impl->mesh_program, "u_ao");
  impl->mesh_frame_px = glGetUniformLocation(impl->mesh_program, "u_frame_px");
  impl->mesh_proj = glGetUniformLocation(impl->mesh_program, "u_proj");
  impl->mesh_alpha = glGetUniformLocation(impl->mesh_program, "u_alpha");
  impl->mesh_has_normals = glGetUniformLocation(impl->mesh_program, "u_has_normals");
  impl->line_clip = glGetUniformLocation(impl->line_program, "u_clip_from_world");
  if (auto shadow = impl->shadow.create(); !shadow) return tl::unexpected(shadow.error());
  if (auto depth = impl->depth.create(); !depth) return tl::unexpected(depth.error());
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

MeshId Renderer::add_mesh(const avatar::Mesh& mesh, std::span<const glm::vec3> albedo) {
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
  // A colour per vertex: the avatar's materials blend across part boundaries with the surface.
  std::vector<glm::vec3> colours;
  if (albedo.size() != m.vertex_count) colours.assign(m.vertex_count, kPlainGrey);
  const glm::vec3* colour_data = albedo.size() == m.vertex_count ? albedo.data() : colours.data();
  glGenBuffers(1, &m.albedo);
  glBindBuffer(GL_ARRAY_BUFFER, m.albedo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(m.vertex_count * sizeof(glm::vec3)), colour_data,
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, sizeof(glm::vec3), nullptr);
  glGenBuffers(1, &m.indices);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m.indices);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh.indices.size() * sizeof(uint32_t)),
               mesh.indices.data(), GL_STATIC_DRAW);
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, 0);
  if (mesh.parts.empty()) {
    m.parts.push_back({0, static_cast<uint32_t>(mesh.indices.size())});
  } else {
    for (const avatar::MeshPart& p : mesh.parts) m.parts.push_back({p.first_triangle * 3, p.triangle_count * 3});
  }
  bounds(mesh.positions, m.lo, m.hi);
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
  bounds(mesh.positions, m.lo, m.hi);
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
  const glm::mat4 projection = frame.camera.clip_from_view(aspect);
  const glm::mat4 clip = projection * view;
  // A floor to fall on: the grid's or the ground's.
  const bool shadow = frame.contact_shadow && (frame.grid || frame.ground) && r.shadow_heights(frame);
  const bool ao = frame.ambient_occlusion && !frame.unlit && r.depth_prepass(frame, clip);

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
  if (frame.grid) {  // depth-tested: the body drawn next hides the lines behind it
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glBindVertexArray(r.grid_vao);
    glDrawArrays(GL_LINES, 0, r.grid_vertices);
    glDisable(GL_BLEND);
  }
  if (shadow) r.shadow.draw_floor(clip);

  r.draw_meshes(frame, clip, view, projection, ao, false);

  r.upload_lines(frame.lines, frame.xray_lines);
  glUseProgram(r.line_program);
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glBindVertexArray(r.line_vao);
  if (!frame.lines.empty()) glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(frame.lines.size()));

  // See-through meshes after the opaque ones, without writing depth, so lines inside show.
  glDepthMask(GL_FALSE);
  r.draw_meshes(frame, clip, view, projection, ao, true);
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
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, 0);
  glActiveTexture(GL_TEXTURE0);
  glUseProgram(0);
  glDisable(GL_BLEND);
  glDisable(GL_DEPTH_TEST);
}

}  // namespace mimic::render
