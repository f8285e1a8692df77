#include "mimic/avatar/mesh_check.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <unordered_map>

#include "mimic/avatar/mesh.h"

namespace mimic::avatar {

namespace {

class UnionFind {
 public:
  explicit UnionFind(size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), uint32_t{0}); }
  uint32_t find(uint32_t x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }
  void unite(uint32_t a, uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

 private:
  std::vector<uint32_t> parent_;
};

struct HalfEdge {
  uint32_t lo, hi;  // undirected key
  uint32_t tri;
  bool forward;  // the triangle runs lo -> hi
};

size_t distinct_roots(UnionFind& uf, const std::vector<uint32_t>& members) {
  std::vector<uint32_t> roots;
  roots.reserve(members.size());
  for (uint32_t m : members) roots.push_back(uf.find(m));
  std::sort(roots.begin(), roots.end());
  return static_cast<size_t>(std::unique(roots.begin(), roots.end()) - roots.begin());
}

// Vertices whose corners fall into more than one fan (non-manifold vertices), from the corners
// joined across shared edges.
size_t count_split_fans(const Mesh& mesh, UnionFind& corners) {
  const size_t nv = mesh.positions.size(), nt = mesh.triangle_count();
  const auto& ix = mesh.indices;
  size_t split = 0;
  // Per vertex, the fans its corners fall into.
  std::vector<uint32_t> first(nv + 1, 0);
  for (size_t f = 0; f < nt; ++f)
    for (int k = 0; k < 3; ++k) ++first[ix[3 * f + k] + 1];
  std::partial_sum(first.begin(), first.end(), first.begin());
  std::vector<uint32_t> corner_list(3 * nt), fill(first.begin(), first.end() - 1);
  for (size_t f = 0; f < nt; ++f) {
    const uint32_t v[3] = {ix[3 * f], ix[3 * f + 1], ix[3 * f + 2]};
    if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) continue;
    for (uint32_t k = 0; k < 3; ++k) corner_list[fill[v[k]]++] = static_cast<uint32_t>(3 * f + k);
  }
  std::vector<uint32_t> roots;
  for (size_t v = 0; v < nv; ++v) {
    roots.clear();
    for (uint32_t c = first[v]; c < fill[v]; ++c) roots.push_back(corners.find(corner_list[c]));
    std::sort(roots.begin(), roots.end());
    if (std::unique(roots.begin(), roots.end()) - roots.begin() > 1) ++split;
  }

  return split;
}

}  // namespace

MeshTopology analyze_topology(const Mesh& mesh) {
  MeshTopology t;
  const size_t nv = mesh.positions.size(), nt = mesh.triangle_count();
  const auto& ix = mesh.indices;
  t.face_count = nt;

  std::vector<char> used(nv, 0);
  for (uint32_t i : ix) used[i] = 1;
  t.vertex_count = static_cast<size_t>(std::count(used.begin(), used.end(), 1));
  t.unreferenced_vertices = nv - t.vertex_count;

  // Geometry, about the bounding-box centre to keep the volume sum well conditioned.
  glm::dvec3 lo(0), hi(0);
  if (nv) {
    lo = hi = glm::dvec3(mesh.positions[0]);
    for (const auto& p : mesh.positions) {
      lo = glm::min(lo, glm::dvec3(p));
      hi = glm::max(hi, glm::dvec3(p));
    }
  }
  const glm::dvec3 centre = 0.5 * (lo + hi);
  size_t index_degenerate = 0;
  std::vector<HalfEdge> half_edges;
  half_edges.reserve(3 * nt);
  for (size_t f = 0; f < nt; ++f) {
    const uint32_t v[3] = {ix[3 * f], ix[3 * f + 1], ix[3 * f + 2]};
    const glm::dvec3 a = glm::dvec3(mesh.positions[v[0]]) - centre, b = glm::dvec3(mesh.positions[v[1]]) - centre,
                     c = glm::dvec3(mesh.positions[v[2]]) - centre;
    const glm::dvec3 cr = glm::cross(b - a, c - a);
    const double twice_area = glm::length(cr);
    t.surface_area += 0.5 * twice_area;
    t.signed_volume += glm::dot(a, glm::cross(b, c)) / 6.0;
    const double longest2 = std::max({glm::dot(b - a, b - a), glm::dot(c - b, c - b), glm::dot(a - c, a - c)});
    const bool repeated = v[0] == v[1] || v[1] == v[2] || v[2] == v[0];
    if (repeated) {
      ++index_degenerate;
      ++t.degenerate_triangles;
      continue;
    }
    if (!(twice_area > 1e-10 * longest2)) ++t.degenerate_triangles;
    for (int k = 0; k < 3; ++k) {
      const uint32_t p = v[k], q = v[(k + 1) % 3];
      half_edges.push_back({std::min(p, q), std::max(p, q), static_cast<uint32_t>(f), p < q});
    }
  }
  std::sort(half_edges.begin(), half_edges.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.lo != y.lo ? x.lo < y.lo : x.hi != y.hi ? x.hi < y.hi : x.tri < y.tri;
  });

  // Corners (3 f + k) around a vertex are joined across each edge they share; a manifold
  // vertex ends with all its corners in one fan.
  UnionFind corners(3 * nt);
  UnionFind pieces(nv);
  UnionFind boundary(nv);
  std::vector<uint32_t> boundary_vertices;
  auto corner_of = [&](uint32_t f, uint32_t v) {
    for (uint32_t k = 0; k < 3; ++k)
      if (ix[3 * f + k] == v) return 3 * f + k;
    return 3 * f;  // unreachable for a triangle that uses v
  };
  for (size_t i = 0; i < half_edges.size();) {
    size_t j = i;
    while (j < half_edges.size() && half_edges[j].lo == half_edges[i].lo && half_edges[j].hi == half_edges[i].hi) ++j;
    const size_t uses = j - i;
    const HalfEdge& e = half_edges[i];
    ++t.edge_count;
    pieces.unite(e.lo, e.hi);
    if (uses == 1) {
      ++t.boundary_edges;
      boundary.unite(e.lo, e.hi);
      boundary_vertices.push_back(e.lo);
      boundary_vertices.push_back(e.hi);
    } else if (uses >= 3) {
      ++t.non_manifold_edges;
    } else if (half_edges[i].forward == half_edges[i + 1].forward) {
      ++t.inconsistent_edges;
    }
    for (size_t k = i + 1; k < j; ++k)
      for (uint32_t v : {e.lo, e.hi}) corners.unite(corner_of(half_edges[i].tri, v), corner_of(half_edges[k].tri, v));
    i = j;
  }

  t.non_manifold_vertices = count_split_fans(mesh, corners);

  std::vector<uint32_t> used_vertices;
  for (size_t f = 0; f < nt; ++f) {
    pieces.unite(ix[3 * f], ix[3 * f + 1]);
    pieces.unite(ix[3 * f], ix[3 * f + 2]);
  }
  for (size_t v = 0; v < nv; ++v)
    if (used[v]) used_vertices.push_back(static_cast<uint32_t>(v));
  t.components = distinct_roots(pieces, used_vertices);
  t.boundary_loops = distinct_roots(boundary, boundary_vertices);

  t.euler_characteristic = static_cast<long long>(t.vertex_count) - static_cast<long long>(t.edge_count) +
                           static_cast<long long>(t.face_count);
  if (t.non_manifold_edges == 0 && t.non_manifold_vertices == 0 && t.inconsistent_edges == 0 && index_degenerate == 0 &&
      t.face_count > 0) {
    const long long twice_genus =
        2 * static_cast<long long>(t.components) - t.euler_characteristic - static_cast<long long>(t.boundary_loops);
    if (twice_genus >= 0 && twice_genus % 2 == 0) t.genus = static_cast<int>(twice_genus / 2);
  }
  return t;
}

bool is_closed_oriented_manifold(const MeshTopology& t) {
  return t.face_count > 0 && t.boundary_edges == 0 && t.non_manifold_edges == 0 && t.non_manifold_vertices == 0 &&
         t.inconsistent_edges == 0;
}

Mesh weld_by_position(const Mesh& mesh, float tolerance) {
  const size_t nv = mesh.positions.size();
  glm::vec3 lo(0), hi(0);
  if (nv) {
    lo = hi = mesh.positions[0];
    for (const auto& p : mesh.positions) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
  }
  const float extent = glm::length(hi - lo);
  const double cell = std::max({static_cast<double>(tolerance), 1e-7 * extent, 1e-30});
  struct Key {
    long long x, y, z;
    bool operator==(const Key&) const = default;
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      return static_cast<size_t>(k.x * 73856093LL ^ k.y * 19349663LL ^ k.z * 83492791LL);
    }
  };
  auto key_of = [&](const glm::vec3& p) {
    return Key{static_cast<long long>(std::floor((p.x - lo.x) / cell)),
               static_cast<long long>(std::floor((p.y - lo.y) / cell)),
               static_cast<long long>(std::floor((p.z - lo.z) / cell))};
  };
  std::unordered_map<Key, std::vector<uint32_t>, KeyHash> grid;
  std::vector<uint32_t> new_index(nv);
  Mesh out;
  std::vector<glm::vec3> normal_sum;
  const bool normals = mesh.normals.size() == nv && nv > 0;
  const float tol2 = tolerance * tolerance;
  for (size_t i = 0; i < nv; ++i) {
    const glm::vec3 p = mesh.positions[i];
    const Key k = key_of(p);
    int64_t found = -1;
    for (long long dx = -1; dx <= 1 && found < 0; ++dx)
      for (long long dy = -1; dy <= 1 && found < 0; ++dy)
        for (long long dz = -1; dz <= 1 && found < 0; ++dz) {
          auto it = grid.find(Key{k.x + dx, k.y + dy, k.z + dz});
          if (it == grid.end()) continue;
          for (uint32_t r : it->second) {
            const glm::vec3 d = out.positions[r] - p;
            if (glm::dot(d, d) <= tol2) {
              found = r;
              break;
            }
          }
        }
    if (found < 0) {
      found = static_cast<int64_t>(out.positions.size());
      out.positions.push_back(p);
      normal_sum.push_back(glm::vec3(0));
      grid[k].push_back(static_cast<uint32_t>(found));
    }
    new_index[i] = static_cast<uint32_t>(found);
    if (normals) normal_sum[static_cast<size_t>(found)] += mesh.normals[i];
  }
  if (normals)
    for (auto& n : normal_sum) {
      const float len = glm::length(n);
      out.normals.push_back(len > 0 ? n / len : glm::vec3(0, 1, 0));
    }
  // Rebuild triangles and parts, dropping collapsed ones.
  for (const auto& part : covering_parts(mesh)) {
    MeshPart np{part.name, static_cast<uint32_t>(out.triangle_count()), 0};
    for (uint32_t f = part.first_triangle; f < part.first_triangle + part.triangle_count; ++f) {
      const uint32_t a = new_index[mesh.indices[3 * f]], b = new_index[mesh.indices[3 * f + 1]],
                     c = new_index[mesh.indices[3 * f + 2]];
      if (a == b || b == c || c == a) continue;
      out.indices.insert(out.indices.end(), {a, b, c});
      ++np.triangle_count;
    }
    out.parts.push_back(np);
  }
  if (mesh.parts.empty()) out.parts.clear();
  return out;
}

}  // namespace mimic::avatar

namespace mimic::avatar {

namespace {

// The surface a contour spans: a fan of triangles from its centroid to each of its edges (a
// flat disc when the contour is planar; a contour a loop's follow bends out of its plane keeps
// a surface through its own points, where a disc in its mean plane would stand off them).
struct Disc {
  glm::vec3 centre{0.0f};
  std::vector<glm::vec3> ring;
  bool valid = false;
};

Disc disc_of(std::span<const glm::vec3> positions, const std::vector<uint32_t>& row) {
  Disc d;
  if (row.size() < 3) return d;
  for (uint32_t v : row) d.ring.push_back(positions[v]), d.centre += positions[v];
  d.centre /= static_cast<float>(row.size());
  d.valid = std::isfinite(d.centre.x + d.centre.y + d.centre.z);
  return d;
}

// Distance from x (on the disc) to the contour, the disc's edge.
float depth_inside(const Disc& d, const glm::vec3& x) {
  float nearest = std::numeric_limits<float>::max();
  for (size_t i = 0; i < d.ring.size(); ++i) {
    const glm::vec3 a = d.ring[i], ab = d.ring[(i + 1) % d.ring.size()] - a;
    const float len2 = glm::dot(ab, ab);
    const float t = len2 > 0 ? std::clamp(glm::dot(x - a, ab) / len2, 0.0f, 1.0f) : 0.0f;
    nearest = std::min(nearest, glm::length(x - (a + t * ab)));
  }
  return nearest;
}

// Where segment a–b passes through triangle (p, q, r), if it does (Möller–Trumbore), and from
// which side (the sign of the triangle's normal along a–b).
int segment_hits(const glm::vec3& a, const glm::vec3& b, const glm::vec3& p, const glm::vec3& q, const glm::vec3& r,
                 glm::vec3& x) {
  const glm::vec3 dir = b - a, e1 = q - p, e2 = r - p;
  // Through the triangle's plane, not along it: a point on it (within a micrometre) touches, as
  // the two rings of a bend meet on the line their planes share.
  const glm::vec3 n = glm::cross(e1, e2);
  const float n_len = glm::length(n);
  if (!(n_len > 0.0f)) return 0;
  const float sa = glm::dot(a - p, n) / n_len, sb = glm::dot(b - p, n) / n_len;
  constexpr float kTouch = 1e-6f;
  if (!((sa > kTouch && sb < -kTouch) || (sa < -kTouch && sb > kTouch))) return 0;
  const glm::vec3 h = glm::cross(dir, e2);
  const float det = glm::dot(e1, h);
  if (std::abs(det) < 1e-12f) return 0;
  const float inv = 1.0f / det;
  const glm::vec3 s = a - p;
  const float u = inv * glm::dot(s, h);
  if (u < 0.0f || u > 1.0f) return 0;
  const glm::vec3 qv = glm::cross(s, e1);
  const float v = inv * glm::dot(dir, qv);
  if (v < 0.0f || u + v > 1.0f) return 0;
  const float t = inv * glm::dot(e2, qv);
  if (t < 0.0f || t > 1.0f) return 0;
  x = a + t * dir;
  return det > 0.0f ? 1 : -1;
}

// How deep inside disc `d` the closed polyline `row` passes through it. An edge passes through
// where the fan's triangles it hits, counted by side, do not cancel (the winding number: a
// concave contour's fan folds over itself outside the contour, and there they cancel).
float piercing(std::span<const glm::vec3> positions, const Disc& d, const std::vector<uint32_t>& row) {
  float worst = 0.0f;
  for (size_t i = 0; i < row.size(); ++i) {
    const glm::vec3 a = positions[row[i]], b = positions[row[(i + 1) % row.size()]];
    int winding = 0;
    float depth = std::numeric_limits<float>::max();
    for (size_t k = 0; k < d.ring.size(); ++k) {
      glm::vec3 x;
      const int side = segment_hits(a, b, d.centre, d.ring[k], d.ring[(k + 1) % d.ring.size()], x);
      if (side == 0) continue;
      winding += side;
      depth = std::min(depth, depth_inside(d, x));
    }
    if (winding != 0) worst = std::max(worst, depth);
  }
  return worst;
}

}  // namespace

ContourOrder check_contour_order(std::span<const glm::vec3> positions, std::span<const ContourRows> pieces,
                                 float tolerance_m) {
  ContourOrder out;
  for (const ContourRows& piece : pieces) {
    for (size_t r = 0; r + 1 < piece.rows.size(); ++r) {
      const Disc a = disc_of(positions, piece.rows[r]), b = disc_of(positions, piece.rows[r + 1]);
      if (!a.valid || !b.valid) continue;
      const float worst = std::max(piercing(positions, a, piece.rows[r + 1]), piercing(positions, b, piece.rows[r]));
      ++out.pairs;
      if (worst > tolerance_m) ++out.crossing;
      if (worst > out.worst_m) {
        out.worst_m = worst;
        out.worst_piece = piece.piece + " row " + std::to_string(r);
      }
    }
  }
  return out;
}

}  // namespace mimic::avatar
