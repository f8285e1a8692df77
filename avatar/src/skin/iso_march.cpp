// Marching tetrahedra (iso_mesh.h): the rigid parts' first, fine surface.
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "iso_mesh.h"

namespace mimic::avatar::skin_detail {

glm::vec3 IsoField::gradient(const glm::vec3& p, float step) const {
  const glm::vec3 dx(step, 0, 0), dy(0, step, 0), dz(0, 0, step);
  return glm::vec3(value(p + dx) - value(p - dx), value(p + dy) - value(p - dy), value(p + dz) - value(p - dz)) /
         (2.0f * step);
}

glm::vec3 project_to_iso(const IsoField& f, glm::vec3 p, float max_step) {
  const float h = std::max(1e-5f, 0.02f * max_step);
  for (int it = 0; it < 8; ++it) {
    const float v = f.value(p) - f.iso;
    if (std::abs(v) < 1e-5f) break;
    const glm::vec3 g = f.gradient(p, h);
    const float g2 = glm::dot(g, g);
    if (!(g2 > 1e-12f)) break;
    glm::vec3 step = -v * g / g2;
    const float len = glm::length(step);
    if (len > max_step) step *= max_step / len;
    p += step;
  }
  return p;
}

namespace {

struct Grid {
  int nx = 0, ny = 0, nz = 0;
  glm::vec3 lo{0};
  float cell = 0;
  std::vector<float> value;  // minus iso; ≥ 0 inside
  size_t index(int x, int y, int z) const {
    return (static_cast<size_t>(z) * static_cast<size_t>(ny) + static_cast<size_t>(y)) * static_cast<size_t>(nx) +
           static_cast<size_t>(x);
  }
  glm::vec3 at(size_t i) const {
    const size_t x = i % static_cast<size_t>(nx), y = (i / static_cast<size_t>(nx)) % static_cast<size_t>(ny),
                 z = i / (static_cast<size_t>(nx) * static_cast<size_t>(ny));
    return lo + cell * glm::vec3(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
  }
};

Grid sample(const IsoField& f, glm::vec3 lo, glm::vec3 hi, float cell) {
  Grid g;
  g.cell = cell;
  g.lo = lo;
  g.nx = std::max(3, static_cast<int>(std::ceil((hi.x - lo.x) / cell)) + 1);
  g.ny = std::max(3, static_cast<int>(std::ceil((hi.y - lo.y) / cell)) + 1);
  g.nz = std::max(3, static_cast<int>(std::ceil((hi.z - lo.z) / cell)) + 1);
  g.value.resize(static_cast<size_t>(g.nx) * static_cast<size_t>(g.ny) * static_cast<size_t>(g.nz));
  for (int z = 0; z < g.nz; ++z)
    for (int y = 0; y < g.ny; ++y)
      for (int x = 0; x < g.nx; ++x) {
        const size_t i = g.index(x, y, z);
        const bool border = x == 0 || y == 0 || z == 0 || x == g.nx - 1 || y == g.ny - 1 || z == g.nz - 1;
        g.value[i] = border ? -1.0f : f.value(g.at(i)) - f.iso;
      }
  return g;
}

class Marcher {
 public:
  Marcher(const Grid& g, const IsoField& f) : g_(g), f_(f) {}

  // One tetrahedron of grid nodes: 0, 1 or 2 triangles where its edges cross the surface.
  void tetrahedron(const std::array<size_t, 4>& n) {
    std::array<size_t, 4> in{}, out{};
    int ni = 0, no = 0;
    for (size_t k : n) (g_.value[k] >= 0.0f ? in[static_cast<size_t>(ni++)] : out[static_cast<size_t>(no++)]) = k;
    if (ni == 0 || no == 0) return;
    glm::vec3 outward(0);
    for (int k = 0; k < no; ++k) outward += g_.at(out[static_cast<size_t>(k)]) / static_cast<float>(no);
    for (int k = 0; k < ni; ++k) outward -= g_.at(in[static_cast<size_t>(k)]) / static_cast<float>(ni);
    if (ni == 1) {
      triangle({in[0], out[0]}, {in[0], out[1]}, {in[0], out[2]}, outward);
    } else if (no == 1) {
      triangle({in[0], out[0]}, {in[1], out[0]}, {in[2], out[0]}, outward);
    } else {
      // The quad in-a·out-c, a·d, b·d, b·c, split along a·c – b·d.
      triangle({in[0], out[0]}, {in[0], out[1]}, {in[1], out[1]}, outward);
      triangle({in[0], out[0]}, {in[1], out[1]}, {in[1], out[0]}, outward);
    }
  }

  IsoMesh take() { return std::move(mesh_); }

 private:
  using Edge = std::array<size_t, 2>;  // inside node, outside node

  // Orientation from the edges' midpoints (never a degenerate triangle in a tetrahedron), so
  // it does not depend on where the vertices land along their edges.
  void triangle(Edge a, Edge b, Edge c, const glm::vec3& outward) {
    auto mid = [&](const Edge& e) { return 0.5f * (g_.at(e[0]) + g_.at(e[1])); };
    const glm::vec3 n = glm::cross(mid(b) - mid(a), mid(c) - mid(a));
    const uint32_t va = vertex(a), vb = vertex(b), vc = vertex(c);
    if (glm::dot(n, outward) >= 0.0f)
      mesh_.triangles.insert(mesh_.triangles.end(), {va, vb, vc});
    else
      mesh_.triangles.insert(mesh_.triangles.end(), {va, vc, vb});
  }

  uint32_t vertex(const Edge& e) {
    const uint64_t key = static_cast<uint64_t>(std::min(e[0], e[1])) * g_.value.size() + std::max(e[0], e[1]);
    auto [it, added] = edges_.emplace(key, static_cast<uint32_t>(mesh_.positions.size()));
    if (added) {
      // The crossing on the edge by bisection (the ends' signs differ; where the field is flat
      // outside every support a gradient step would not move), kept off the nodes so that no two
      // vertices coincide, then onto the surface along the gradient.
      const glm::vec3 a = g_.at(e[0]), b = g_.at(e[1]);
      float in = 0, out = 1;
      for (int step = 0; step < 16; ++step) {
        const float mid = 0.5f * (in + out);
        (f_.value(a + mid * (b - a)) >= f_.iso ? in : out) = mid;
      }
      const float t = std::clamp(0.5f * (in + out), 0.02f, 0.98f);
      mesh_.positions.push_back(project_to_iso(f_, a + t * (b - a), 0.5f * g_.cell));
    }
    return it->second;
  }

  const Grid& g_;
  const IsoField& f_;
  IsoMesh mesh_;
  std::unordered_map<uint64_t, uint32_t> edges_;
};

uint32_t root(std::vector<uint32_t>& parent, uint32_t i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

// The component with the most triangles (the first such), its vertices renumbered in order.
void keep_largest_component(IsoMesh& m) {
  std::vector<uint32_t> parent(m.positions.size());
  std::iota(parent.begin(), parent.end(), 0u);
  for (size_t t = 0; t < m.triangles.size(); t += 3)
    for (int k = 1; k < 3; ++k) {
      const uint32_t a = root(parent, m.triangles[t]), b = root(parent, m.triangles[t + static_cast<size_t>(k)]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<size_t> size(m.positions.size(), 0);
  for (size_t t = 0; t < m.triangles.size(); t += 3) ++size[root(parent, m.triangles[t])];
  const uint32_t best = static_cast<uint32_t>(std::max_element(size.begin(), size.end()) - size.begin());
  std::vector<uint32_t> renumber(m.positions.size(), UINT32_MAX);
  IsoMesh out;
  for (size_t t = 0; t < m.triangles.size(); t += 3) {
    if (root(parent, m.triangles[t]) != best) continue;
    for (int k = 0; k < 3; ++k) {
      uint32_t& r = renumber[m.triangles[t + static_cast<size_t>(k)]];
      if (r == UINT32_MAX) {
        r = static_cast<uint32_t>(out.positions.size());
        out.positions.push_back(m.positions[m.triangles[t + static_cast<size_t>(k)]]);
      }
      out.triangles.push_back(r);
    }
  }
  m = std::move(out);
}

}  // namespace

IsoMesh march_tetrahedra(const IsoField& f, glm::vec3 lo, glm::vec3 hi, float cell) {
  const Grid g = sample(f, lo, hi, cell);
  Marcher march(g, f);
  // Kuhn's six tetrahedra of a cube: from corner 000 to 111 along the axes in each order.
  static constexpr std::array<std::array<int, 3>, 6> kOrders{
      {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};
  for (int z = 0; z + 1 < g.nz; ++z)
    for (int y = 0; y + 1 < g.ny; ++y)
      for (int x = 0; x + 1 < g.nx; ++x) {
        bool any_in = false, any_out = false;
        for (int c = 0; c < 8; ++c) {
          const float v = g.value[g.index(x + (c & 1), y + ((c >> 1) & 1), z + ((c >> 2) & 1))];
          (v >= 0.0f ? any_in : any_out) = true;
        }
        if (!any_in || !any_out) continue;
        for (const auto& order : kOrders) {
          std::array<int, 3> p{x, y, z};
          std::array<size_t, 4> n{};
          n[0] = g.index(p[0], p[1], p[2]);
          for (int k = 0; k < 3; ++k) {
            ++p[static_cast<size_t>(order[static_cast<size_t>(k)])];
            n[static_cast<size_t>(k + 1)] = g.index(p[0], p[1], p[2]);
          }
          march.tetrahedron(n);
        }
      }
  IsoMesh m = march.take();
  if (!m.triangles.empty()) keep_largest_component(m);
  return m;
}

}  // namespace mimic::avatar::skin_detail
