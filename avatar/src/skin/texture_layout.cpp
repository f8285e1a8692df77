// Per-part texture coordinates (texture_layout.h): the skin's triangles walked in the order
// topology.cpp emits them, each corner given (u, v) from its column and row in its part; equal
// (vertex, u, v) corners share one textured vertex, so seams split and nothing else does.
#include "mimic/avatar/texture_layout.h"

#include <algorithm>
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
  const size_t rings = static_cast<size_t>(m.counts.rigid_rings), pts = static_cast<size_t>(m.counts.rigid_points);
  for (const RigidMesh& rm : m.rigid) {
    const uint32_t south = rm.first_vertex, north = south + 1 + static_cast<uint32_t>(rings * pts);
    auto at = [&](size_t r, size_t j) { return south + 1 + static_cast<uint32_t>(r * pts + j % pts); };
    auto pole_u = [&](size_t j) { return (static_cast<float>(j) + 0.5f) / static_cast<float>(pts); };
    for (size_t j = 0; j < pts; ++j) {
      const float v = frac(1, rings + 1);
      b.corner(at(0, j + 1), frac(j + 1, pts), v), b.corner(at(0, j), frac(j, pts), v),
          b.corner(south, pole_u(j), 0.0f);
    }
    for (size_t r = 0; r + 1 < rings; ++r) {
      const float v0 = frac(r + 1, rings + 1), v1 = frac(r + 2, rings + 1);
      for (size_t j = 0; j < pts; ++j) {
        const float u0 = frac(j, pts), u1 = frac(j + 1, pts);
        b.corner(at(r, j), u0, v0), b.corner(at(r, j + 1), u1, v0), b.corner(at(r + 1, j + 1), u1, v1);
        b.corner(at(r, j), u0, v0), b.corner(at(r + 1, j + 1), u1, v1), b.corner(at(r + 1, j), u0, v1);
      }
    }
    for (size_t j = 0; j < pts; ++j) {
      const float v = frac(rings, rings + 1);
      b.corner(at(rings - 1, j), frac(j, pts), v), b.corner(at(rings - 1, j + 1), frac(j + 1, pts), v);
      b.corner(north, pole_u(j), 1.0f);
    }
  }
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
