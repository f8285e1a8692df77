// Per-part texture coordinates (texture_layout.h): the skin's triangles walked in the order
// topology.cpp emits them, each corner given (u, v) from its column and row in its part; equal
// (vertex, u, v) corners share one textured vertex, so seams split and nothing else does.
#include "mimic/avatar/texture_layout.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <tuple>

#include "contour_layout_data.h"
#include "mimic/avatar/skin.h"

namespace mimic::avatar {

namespace {

class Builder {
 public:
  explicit Builder(TextureLayout& out) : out_(out) {}
  void corner(uint32_t vertex, float u, float v) {
    const auto key = std::make_tuple(vertex, u, v);
    auto [it, inserted] = index_.emplace(key, static_cast<uint32_t>(out_.source.size()));
    if (inserted) {
      out_.source.push_back(vertex);
      out_.uv.emplace_back(u, v);
    }
    out_.indices.push_back(it->second);
  }

 private:
  TextureLayout& out_;
  std::map<std::tuple<uint32_t, float, float>, uint32_t> index_;
};

float frac(size_t i, size_t n) { return n > 0 ? static_cast<float>(i) / static_cast<float>(n) : 0.0f; }

// Each triangle's chart (axis 2i+0 is +e_i, 2i+1 is −e_i): the axis its normal points most along.
std::vector<int> rigid_charts(const RigidMesh& rm) {
  const size_t nt = rm.triangles.size() / 3;
  std::vector<glm::vec3> normal(nt);
  std::vector<int> chart(nt);
  for (size_t t = 0; t < nt; ++t) {
    const glm::vec3 &p0 = rm.local[rm.triangles[3 * t]], &p1 = rm.local[rm.triangles[3 * t + 1]],
                    &p2 = rm.local[rm.triangles[3 * t + 2]];
    normal[t] = safe_normalize(glm::cross(p1 - p0, p2 - p0), {0, 0, 1});
    int axis = 0;
    for (int i = 1; i < 3; ++i)
      if (std::abs(normal[t][i]) > std::abs(normal[t][axis])) axis = i;
    chart[t] = 2 * axis + (normal[t][axis] < 0 ? 1 : 0);
  }
  return chart;
}

// A rigid part's UVs, a cube map: each triangle goes to the chart of the axis (±x, ±y, ±z of
// its joint's frame) its normal points most along and is projected along that axis, so no
// triangle folds over in (u, v) (its normal's component along the axis is at least 1/√3 of it)
// and vertices split only where neighbouring triangles face different axes. The six charts sit
// in a 3 × 2 grid of the part's square at one scale (the part's box's largest side), each in its
// cell with a margin, and the part then fills its unit square.
void rigid_uvs(const RigidMesh& rm, Builder& b) {
  if (rm.local.empty()) return;
  glm::vec3 box_lo(1e9f), box_hi(-1e9f);
  for (const glm::vec3& p : rm.local) box_lo = glm::min(box_lo, p), box_hi = glm::max(box_hi, p);
  const glm::vec3 box = box_hi - box_lo;
  const float extent = std::max({box.x, box.y, box.z, 1e-6f});
  // Per chart (+x, −x, +y, −y, +z, −z): the axes of u and v, with u × v along the chart's axis.
  static constexpr std::array<std::array<int, 2>, 6> kAxes{{{1, 2}, {2, 1}, {2, 0}, {0, 2}, {0, 1}, {1, 0}}};
  // Within its cell a chart takes 0.28 × 0.45 of the square (a triangle then spans at most that).
  constexpr float kMargin = 0.01f, kWidth = 0.28f, kHeight = 0.45f;
  const std::vector<int> chart_of = rigid_charts(rm);
  std::vector<glm::vec2> corners(rm.triangles.size());
  glm::vec2 lo(1e9f), hi(-1e9f);
  for (size_t k = 0; k + 2 < rm.triangles.size(); k += 3) {
    const size_t chart = static_cast<size_t>(chart_of[k / 3]);
    const glm::vec2 cell(static_cast<float>(chart % 3) / 3.0f, static_cast<float>(chart / 3) / 2.0f);
    for (size_t c = 0; c < 3; ++c) {
      const glm::vec3 q = (rm.local[rm.triangles[k + c]] - box_lo) / extent;
      const glm::vec2 uv = cell + kMargin + glm::vec2(kWidth * q[kAxes[chart][0]], kHeight * q[kAxes[chart][1]]);
      corners[k + c] = uv;
      lo = glm::min(lo, uv), hi = glm::max(hi, uv);
    }
  }
  const glm::vec2 span = glm::max(hi - lo, glm::vec2(1e-6f));
  for (size_t k = 0; k < corners.size(); ++k) {
    const glm::vec2 uv = glm::clamp((corners[k] - lo) / span, glm::vec2(0), glm::vec2(1));
    b.corner(rm.first_vertex + rm.triangles[k], uv.x, uv.y);
  }
}

}  // namespace

TextureLayout texture_layout(const ImplicitSkin& skin) { return texture_layout(skin.layout()); }

TextureLayout texture_layout(const ContourLayout& layout) {
  const ContourLayout::Data& m = layout.data();
  TextureLayout out;
  Builder b(out);
  for (const Surface& s : m.surfaces) {
    for (size_t p = 0; p < s.parts.size(); ++p) {
      const int row_from = s.out_row_of_control[s.parts[p].second];
      const int row_to = p + 1 < s.parts.size() ? s.out_row_of_control[s.parts[p + 1].second]
                                                : static_cast<int>(s.out_rows.size()) - 1;
      const bool capped = s.cap && p + 1 == s.parts.size();
      // The neck's armpit corners take the first step of its square, below its loop: their ends
      // at the loop's u, the points between spread along v = 0.
      const bool corners = &s == &m.surfaces[1] && p == 0 && !m.corners.empty();
      // Rows spread over v ∈ [0, 1]; a capped piece keeps its last step for the cap.
      const size_t steps = static_cast<size_t>(row_to - row_from) + (capped ? 1 : 0) + (corners ? 1 : 0);
      const size_t first_step = corners ? 1 : 0;
      if (corners) {
        const std::vector<uint32_t>& loop = s.out_rows[static_cast<size_t>(row_from)];
        const float v_loop = frac(1, steps);
        auto u_of = [&](uint32_t vertex) {
          return frac(static_cast<size_t>(std::find(loop.begin(), loop.end(), vertex) - loop.begin()), loop.size());
        };
        for (const Corner& c : m.corners) {
          const size_t n = c.points.size();
          const float u0 = u_of(c.points.front()), u1 = u_of(c.points.back());
          c.for_each_triangle([&](size_t i0, size_t i1, size_t i2) {
            for (size_t i : {i0, i1, i2}) {
              const bool end = i == 0 || i + 1 == n;
              b.corner(c.points[i], u0 + (u1 - u0) * frac(i, n - 1), end ? v_loop : 0.0f);
            }
          });
        }
      }
      for (int r = row_from; r < row_to; ++r) {
        const std::vector<uint32_t>* rows[2] = {&s.out_rows[r], &s.out_rows[r + 1]};
        const float v[2] = {frac(static_cast<size_t>(r - row_from) + first_step, steps),
                            frac(static_cast<size_t>(r + 1 - row_from) + first_step, steps)};
        // The mesh's own band triangles (a zipper where the rows' counts differ), each corner at
        // its column's u on its own row: column n is point 0 again at u = 1, where the ring wraps.
        auto corner = [&](BandCorner k) {
          const std::vector<uint32_t>& row = *rows[k.row];
          b.corner(row[k.col % row.size()], frac(k.col, row.size()), v[k.row]);
        };
        for_each_band_triangle(
            static_cast<uint32_t>(rows[0]->size()), static_cast<uint32_t>(rows[1]->size()),
            [&](BandCorner c0, BandCorner c1, BandCorner c2) { corner(c0), corner(c1), corner(c2); });
      }
      if (capped) {
        const auto& last = s.out_rows.back();
        const size_t n = last.size();
        const float v = frac(steps - 1, steps);
        for (size_t j = 0; j < n; ++j) {
          b.corner(last[j], frac(j, n), v), b.corner(last[(j + 1) % n], frac(j + 1, n), v);
          b.corner(s.cap_vertex, (static_cast<float>(j) + 0.5f) / static_cast<float>(n), 1.0f);
        }
      }
    }
  }
  for (const RigidMesh& rm : m.rigid) rigid_uvs(rm, b);
  return out;
}

Mesh textured_mesh(const Mesh& mesh, const TextureLayout& layout) {
  Mesh t;
  t.positions.resize(layout.source.size());
  for (size_t i = 0; i < layout.source.size(); ++i) t.positions[i] = mesh.positions[layout.source[i]];
  if (!mesh.normals.empty()) {
    t.normals.resize(layout.source.size());
    for (size_t i = 0; i < layout.source.size(); ++i) t.normals[i] = mesh.normals[layout.source[i]];
  }
  t.uvs = layout.uv;
  t.indices = layout.indices;
  t.parts = mesh.parts;
  return t;
}

}  // namespace mimic::avatar
