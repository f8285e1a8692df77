// Planar cross-sections of a mesh and tape-measure girths.
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "mimic/avatar/measure.h"

namespace mimic::avatar {

namespace {

struct Basis {
  glm::dvec3 origin, u, v;
};

Basis plane_basis(const glm::vec3& point, const glm::vec3& normal) {
  const glm::dvec3 n = glm::normalize(glm::dvec3(normal));
  // Pick the world axis least aligned with n to build u: horizontal planes get u = +X, v = −Z.
  const glm::dvec3 helper = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 0, 1);
  const glm::dvec3 v = glm::normalize(glm::cross(n, helper));
  const glm::dvec3 u = glm::cross(v, n);
  return {glm::dvec3(point), u, v};
}

glm::dvec2 to_plane(const Basis& b, const glm::vec3& p) {
  const glm::dvec3 d = glm::dvec3(p) - b.origin;
  return {glm::dot(d, b.u), glm::dot(d, b.v)};
}

// Even-odd rule; the polygon is closed implicitly.
bool inside(const std::vector<glm::dvec2>& poly, const glm::dvec2& q) {
  bool in = false;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const glm::dvec2 a = poly[i], b = poly[j];
    if ((a.y > q.y) != (b.y > q.y) && q.x < (b.x - a.x) * (q.y - a.y) / (b.y - a.y) + a.x) in = !in;
  }
  return in;
}

double cross2(const glm::dvec2& o, const glm::dvec2& a, const glm::dvec2& b) {
  return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

// The convex hull's corners in order (Andrew's monotone chain).
std::vector<glm::dvec2> convex_hull(std::vector<glm::dvec2> pts) {
  std::sort(pts.begin(), pts.end(),
            [](const glm::dvec2& a, const glm::dvec2& b) { return a.x != b.x ? a.x < b.x : a.y < b.y; });
  pts.erase(std::unique(pts.begin(), pts.end()), pts.end());
  if (pts.size() < 2) return pts;
  std::vector<glm::dvec2> h(2 * pts.size());
  size_t k = 0;
  for (size_t i = 0; i < pts.size(); ++i) {
    while (k >= 2 && cross2(h[k - 2], h[k - 1], pts[i]) <= 0) --k;
    h[k++] = pts[i];
  }
  for (size_t i = pts.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross2(h[k - 2], h[k - 1], pts[i]) <= 0) --k;
    h[k++] = pts[i];
  }
  h.resize(k - 1);  // the last corner repeats the first
  return h;
}

double perimeter(const std::vector<glm::dvec2>& hull) {
  double out = 0;
  for (size_t i = 0; i + 1 < hull.size(); ++i) out += glm::length(hull[i + 1] - hull[i]);
  return hull.size() > 1 ? out + glm::length(hull.front() - hull.back()) : out;
}

// The points, in the plane, of the loops the tape wraps.
std::vector<glm::dvec2> wrapped(const Mesh& mesh, const Basis& basis, const glm::vec3& plane_point,
                                const glm::vec3& plane_normal, std::span<const glm::vec3> include,
                                std::span<const glm::vec3> exclude) {
  std::vector<glm::dvec2> in2, out2;
  for (const auto& p : include) in2.push_back(to_plane(basis, p));
  for (const auto& p : exclude) out2.push_back(to_plane(basis, p));
  std::vector<glm::dvec2> chosen;
  for (const auto& loop : cross_section(mesh, plane_point, plane_normal)) {
    if (loop.size() < 3) continue;
    std::vector<glm::dvec2> poly;
    poly.reserve(loop.size());
    for (const auto& p : loop) poly.push_back(to_plane(basis, p));
    const bool wanted = std::any_of(in2.begin(), in2.end(), [&](const glm::dvec2& q) { return inside(poly, q); });
    const bool refused = std::any_of(out2.begin(), out2.end(), [&](const glm::dvec2& q) { return inside(poly, q); });
    if (wanted && !refused) chosen.insert(chosen.end(), poly.begin(), poly.end());
  }
  return chosen;
}

}  // namespace

std::vector<std::vector<glm::vec3>> cross_section(const Mesh& mesh, const glm::vec3& plane_point,
                                                  const glm::vec3& plane_normal) {
  const glm::dvec3 n = glm::normalize(glm::dvec3(plane_normal)), o(plane_point);
  std::vector<double> d(mesh.positions.size());
  for (size_t i = 0; i < d.size(); ++i) d[i] = glm::dot(glm::dvec3(mesh.positions[i]) - o, n);
  // A vertex exactly on the plane counts as above it, so every crossing edge has one end
  // strictly below: each cut edge yields one node, shared by the two triangles beside it.
  std::unordered_map<uint64_t, uint32_t> node_of_edge;
  std::vector<glm::vec3> nodes;
  std::vector<std::vector<uint32_t>> adjacent;  // segment ids per node
  std::vector<std::pair<uint32_t, uint32_t>> segments;
  auto node = [&](uint32_t a, uint32_t b) {
    const uint64_t key = (uint64_t{std::min(a, b)} << 32) | std::max(a, b);
    auto [it, inserted] = node_of_edge.emplace(key, static_cast<uint32_t>(nodes.size()));
    if (inserted) {
      const double t = d[a] / (d[a] - d[b]);
      const glm::dvec3 pa(mesh.positions[a]), pb(mesh.positions[b]);
      nodes.emplace_back(pa + t * (pb - pa));
      adjacent.emplace_back();
    }
    return it->second;
  };
  for (size_t f = 0; f < mesh.triangle_count(); ++f) {
    const uint32_t v[3] = {mesh.indices[3 * f], mesh.indices[3 * f + 1], mesh.indices[3 * f + 2]};
    uint32_t cut[2];
    int cuts = 0;
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = v[k], b = v[(k + 1) % 3];
      if ((d[a] < 0) != (d[b] < 0) && cuts < 2) cut[cuts++] = node(a, b);
    }
    if (cuts != 2 || cut[0] == cut[1]) continue;
    const auto s = static_cast<uint32_t>(segments.size());
    segments.emplace_back(cut[0], cut[1]);
    adjacent[cut[0]].push_back(s);
    adjacent[cut[1]].push_back(s);
  }
  std::vector<char> used(segments.size(), 0);
  std::vector<std::vector<glm::vec3>> loops;
  auto walk = [&](uint32_t start) {
    std::vector<glm::vec3> loop{nodes[start]};
    uint32_t cur = start;
    for (;;) {
      uint32_t next_seg = UINT32_MAX;
      for (uint32_t s : adjacent[cur])
        if (!used[s]) {
          next_seg = s;
          break;
        }
      if (next_seg == UINT32_MAX) break;
      used[next_seg] = 1;
      cur = segments[next_seg].first == cur ? segments[next_seg].second : segments[next_seg].first;
      if (cur == start) break;
      loop.push_back(nodes[cur]);
    }
    if (loop.size() >= 2) loops.push_back(std::move(loop));
  };
  // Open chains (at holes) start from their free ends; what remains are closed loops.
  for (uint32_t i = 0; i < nodes.size(); ++i)
    if (adjacent[i].size() % 2 == 1) walk(i);
  for (uint32_t s = 0; s < segments.size(); ++s)
    if (!used[s]) walk(segments[s].first);
  return loops;
}

std::optional<float> tape_girth(const Mesh& mesh, const glm::vec3& plane_point, const glm::vec3& plane_normal,
                                std::span<const glm::vec3> include, std::span<const glm::vec3> exclude) {
  const Basis basis = plane_basis(plane_point, plane_normal);
  std::vector<glm::dvec2> chosen = wrapped(mesh, basis, plane_point, plane_normal, include, exclude);
  if (chosen.empty()) return std::nullopt;
  return static_cast<float>(perimeter(convex_hull(std::move(chosen))));
}

std::optional<float> tape_girth(const Mesh& mesh, const GirthTape& tape) {
  return tape_girth(mesh, tape.point, tape.normal, tape.include, tape.exclude);
}

std::vector<glm::vec3> tape_hull(const Mesh& mesh, const GirthTape& tape) {
  const Basis basis = plane_basis(tape.point, tape.normal);
  std::vector<glm::vec3> out;
  for (const glm::dvec2& q : convex_hull(wrapped(mesh, basis, tape.point, tape.normal, tape.include, tape.exclude)))
    out.emplace_back(basis.origin + q.x * basis.u + q.y * basis.v);
  return out;
}

}  // namespace mimic::avatar
