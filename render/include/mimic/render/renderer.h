// Draws avatars, a floor grid and line overlays with OpenGL 3.3 core, in the shape of
// sokol_gfx: every GPU resource (shaders, buffers, vertex arrays) is created once, at setup or
// when a mesh is added; a frame only uploads new vertex positions and line vertices and draws.
// Each draw binds everything it uses and the frame restores the state it changed, so nothing
// leaks from one draw to the next or into code that draws after it (the ImGui overlay).
//
// Avatar meshes are shaded smoothly (per-vertex normals) in a colour per vertex (the avatar's
// clothing_albedo(), avatar/appearance.h; plain grey for a mesh without), lit by a key, a fill
// and a rim light over a hemisphere ambient, and stand in a soft contact shadow on the floor.
// Needs a current GL 3.3 core context on the calling thread for its whole life.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/avatar/mesh.h"
#include "mimic/core/result.h"
#include "mimic/render/camera.h"

namespace mimic::render {

struct LineVertex {
  glm::vec3 position;  // world, metres
  glm::vec4 color;     // linear RGBA 0..1
};

// Line segments: vertices in pairs.
struct Lines {
  std::vector<LineVertex> vertices;
  void clear() { vertices.clear(); }
  void add(const glm::vec3& a, const glm::vec3& b, const glm::vec4& color) {
    vertices.push_back({a, color});
    vertices.push_back({b, color});
  }
};

struct MeshId {
  uint32_t index = UINT32_MAX;
  bool valid() const { return index != UINT32_MAX; }
};

struct MeshDraw {
  MeshId mesh;
  glm::mat4 world_from_mesh{1.0f};
  float alpha = 1.0f;  // < 1: see-through, for overlays inside the body
  // Parts left out, bit i for the mesh's part i (the first 64): a wearer's own head, seen
  // from the eyes inside it (render/first_person.h).
  uint64_t hidden_parts = 0;
};

struct FrameDesc {
  int width_px = 0, height_px = 0;
  Camera camera;
  glm::vec3 background{0.93f, 0.94f, 0.96f};
  bool grid = true;               // 10 m × 10 m floor, a line every 0.5 m
  bool ground = false;            // the floor shaded out to the horizon (first person), under the grid
  bool contact_shadow = true;     // the meshes' soft shadow on the floor (with the grid or the ground)
  bool unlit = false;             // the meshes' colours without light (to see the materials alone)
  bool ambient_occlusion = true;  // screen-space, from a half-resolution depth pre-pass of the opaque meshes
  std::span<const MeshDraw> meshes;
  std::span<const LineVertex> lines;       // depth-tested, in pairs
  std::span<const LineVertex> xray_lines;  // drawn over everything (skeleton, rays)
};

class Renderer {
 public:
  static Result<Renderer> create();
  Renderer(Renderer&&) noexcept;
  Renderer& operator=(Renderer&&) noexcept;
  ~Renderer();

  // Uploads a mesh (topology, parts and first positions) with a colour per vertex (display RGB,
  // 0..1; any other count than the mesh's vertices: plain grey).
  MeshId add_mesh(const avatar::Mesh& mesh, std::span<const glm::vec3> albedo = {});
  // New positions (and normals, when the mesh has them) for a mesh of the same topology.
  void update_mesh(MeshId id, const avatar::Mesh& mesh);
  size_t triangle_count(MeshId id) const;

  // Clears the bound framebuffer's viewport and draws the frame.
  void render(const FrameDesc& frame);

 private:
  struct Impl;
  explicit Renderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::render
