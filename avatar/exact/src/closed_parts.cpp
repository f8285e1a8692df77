#include "closed_parts.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <utility>

namespace mimic::avatar::exact_detail {

namespace {

uint32_t find_root(std::map<uint32_t, uint32_t>& parent, uint32_t v) {
  while (parent[v] != v) v = parent[v] = parent[parent[v]];
  return v;
}

glm::dvec3 to_d(const glm::vec3& p) { return {p.x, p.y, p.z}; }

}  // namespace

ClosedPart close_part(std::span<const uint32_t> indices, size_t vertex_count, uint32_t first, uint32_t count) {
  ClosedPart part;
  std::map<std::pair<uint32_t, uint32_t>, int> directed;  // edge → times used in that direction
  for (uint32_t t = first; t < first + count; ++t) {
    const std::array<uint32_t, 3> tri{indices[3 * t], indices[3 * t + 1], indices[3 * t + 2]};
    part.triangles.push_back(tri);
    for (int k = 0; k < 3; ++k) {
      part.vertices.push_back(tri[k]);
      ++directed[{tri[k], tri[(k + 1) % 3]}];
    }
  }
  std::sort(part.vertices.begin(), part.vertices.end());
  part.vertices.erase(std::unique(part.vertices.begin(), part.vertices.end()), part.vertices.end());

  // Boundary edges: used one way only. Loops are their connected groups (a pinch, two loops
  // through one vertex, makes one group; its fan still closes both).
  std::vector<std::pair<uint32_t, uint32_t>> boundary;
  for (const auto& [e, n] : directed)
    if (!directed.contains({e.second, e.first})) boundary.push_back(e);
  std::map<uint32_t, uint32_t> parent;
  for (const auto& [a, b] : boundary) parent.emplace(a, a), parent.emplace(b, b);
  for (const auto& [a, b] : boundary) parent[find_root(parent, a)] = find_root(parent, b);
  std::map<uint32_t, uint32_t> loop_of_root;
  for (auto& [v, p] : parent) {
    const uint32_t root = find_root(parent, v);
    auto [it, added] = loop_of_root.emplace(root, static_cast<uint32_t>(part.loops.size()));
    if (added) part.loops.emplace_back();
    part.loops[it->second].push_back(v);
  }
  // The fan runs each boundary edge backwards, as the neighbouring piece would.
  for (const auto& [a, b] : boundary) {
    const uint32_t loop = loop_of_root.at(find_root(parent, a));
    part.triangles.push_back({static_cast<uint32_t>(vertex_count) + loop, b, a});
  }
  return part;
}

std::vector<std::array<uint32_t, 2>> shared_edges(std::span<const uint32_t> indices, std::span<const uint8_t> keep) {
  std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> users;
  for (uint32_t t = 0; t < keep.size(); ++t) {
    if (!keep[t]) continue;
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = indices[3 * t + k], b = indices[3 * t + (k + 1) % 3];
      users[{std::min(a, b), std::max(a, b)}].push_back(t);
    }
  }
  std::vector<std::array<uint32_t, 2>> edges;
  for (const auto& [e, ts] : users)
    if (ts.size() == 2) edges.push_back({ts[0], ts[1]});
  return edges;
}

double sharpest_crease(std::span<const glm::vec3> positions, std::span<const uint32_t> indices,
                       std::span<const std::array<uint32_t, 2>> edges, double min_area_m2, size_t& worst) {
  auto normal = [&](uint32_t t, double& area) {
    const glm::dvec3 a = to_d(positions[indices[3 * t]]), b = to_d(positions[indices[3 * t + 1]]),
                     c = to_d(positions[indices[3 * t + 2]]);
    const glm::dvec3 n = glm::cross(b - a, c - a);
    area = 0.5 * glm::length(n);
    return area > 0 ? n / (2 * area) : n;
  };
  double best = 0;
  for (size_t e = 0; e < edges.size(); ++e) {
    double area_a = 0, area_b = 0;
    const glm::dvec3 na = normal(edges[e][0], area_a), nb = normal(edges[e][1], area_b);
    if (area_a < min_area_m2 || area_b < min_area_m2) continue;
    const double angle = std::acos(std::clamp(glm::dot(na, nb), -1.0, 1.0));
    if (angle > best) best = angle, worst = e;
  }
  return best;
}

}  // namespace mimic::avatar::exact_detail
