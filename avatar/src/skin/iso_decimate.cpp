// Edge-collapse simplification and relaxation of a closed iso-surface mesh (iso_mesh.h).
#include <algorithm>
#include <array>
#include <cmath>
#include <queue>
#include <tuple>

#include "iso_mesh.h"

namespace mimic::avatar::skin_detail {

namespace {

// Symmetric 4×4 quadric of planes n·p + d = 0: Σ (n·p + d)².
struct Quadric {
  std::array<double, 10> q{};
  void add_plane(const glm::dvec3& n, double d, double w) {
    const double a = n.x, b = n.y, c = n.z;
    const std::array<double, 10> t{a * a, a * b, a * c, a * d, b * b, b * c, b * d, c * c, c * d, d * d};
    for (size_t i = 0; i < 10; ++i) q[i] += w * t[i];
  }
  void add(const Quadric& o) {
    for (size_t i = 0; i < 10; ++i) q[i] += o.q[i];
  }
  double error(const glm::dvec3& p) const {
    const double x = p.x, y = p.y, z = p.z;
    return q[0] * x * x + 2 * q[1] * x * y + 2 * q[2] * x * z + 2 * q[3] * x + q[4] * y * y + 2 * q[5] * y * z +
           2 * q[6] * y + q[7] * z * z + 2 * q[8] * z + q[9];
  }
};

using Tri = std::array<uint32_t, 3>;

constexpr double kLengthCost = 0.02;
constexpr float kMinQuality = 0.03f;
constexpr float kOnSurface = 1e-3f;  // |field − iso| of a merged vertex
constexpr float kMinTurnCos = 0.5f;  // a triangle turns by less than 60° in a collapse
// Below this many vertices a collapse is also refused when a triangle around the merged vertex
// would cross another of the mesh: coarse triangles span gaps (between fingers, under the ear)
// that fine ones do not, and a test of every triangle costs little at these sizes.
constexpr size_t kCrossingCheckBelow = 1500;

glm::vec3 normal_of(const std::vector<glm::vec3>& p, const Tri& t) {
  return glm::cross(p[t[1]] - p[t[0]], p[t[2]] - p[t[0]]);
}

// 1 for an equilateral triangle, 0 for a degenerate one.
float quality(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  const float area2 = glm::length(glm::cross(b - a, c - a));
  const float e = glm::dot(b - a, b - a) + glm::dot(c - b, c - b) + glm::dot(a - c, a - c);
  return e > 0.0f ? 2.0f * std::sqrt(3.0f) * area2 / e : 0.0f;
}

// Whether segment pq passes through triangle abc (Möller–Trumbore; touching counts).
bool segment_hits(const glm::vec3& p, const glm::vec3& q, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  const glm::vec3 d = q - p, e1 = b - a, e2 = c - a, h = glm::cross(d, e2);
  const float det = glm::dot(e1, h);
  if (std::abs(det) < 1e-20f) return false;  // parallel: the other triangle's edges decide
  const float inv = 1.0f / det;
  const glm::vec3 s = p - a;
  const float u = inv * glm::dot(s, h);
  if (u < 0.0f || u > 1.0f) return false;
  const glm::vec3 qv = glm::cross(s, e1);
  const float v = inv * glm::dot(d, qv);
  if (v < 0.0f || u + v > 1.0f) return false;
  const float t = inv * glm::dot(e2, qv);
  return t >= 0.0f && t <= 1.0f;
}

// Two triangles with no common vertex cross when an edge of one passes through the other.
bool triangles_cross(const std::array<glm::vec3, 3>& x, const std::array<glm::vec3, 3>& y) {
  const glm::vec3 xlo = glm::min(x[0], glm::min(x[1], x[2])), xhi = glm::max(x[0], glm::max(x[1], x[2]));
  const glm::vec3 ylo = glm::min(y[0], glm::min(y[1], y[2])), yhi = glm::max(y[0], glm::max(y[1], y[2]));
  if (glm::any(glm::lessThan(xhi, ylo)) || glm::any(glm::lessThan(yhi, xlo))) return false;
  for (int i = 0; i < 3; ++i) {
    if (segment_hits(x[i], x[(i + 1) % 3], y[0], y[1], y[2])) return true;
    if (segment_hits(y[i], y[(i + 1) % 3], x[0], x[1], x[2])) return true;
  }
  return false;
}

// Whether two triangles cross beyond the vertices they share: with none shared, any crossing;
// with one, an edge opposite it passing through the other; two (an edge) are left to the turn
// limits.
bool cross_beyond_shared(const Tri& f, const std::array<glm::vec3, 3>& p, const Tri& g,
                         const std::array<glm::vec3, 3>& q) {
  int shared = 0, fi = 0, gi = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (f[i] == g[j]) ++shared, fi = i, gi = j;
  if (shared == 0) return triangles_cross(p, q);
  if (shared > 1) return false;
  return segment_hits(p[(fi + 1) % 3], p[(fi + 2) % 3], q[0], q[1], q[2]) ||
         segment_hits(q[(gi + 1) % 3], q[(gi + 2) % 3], p[0], p[1], p[2]);
}

// Triangles around a moved vertex as they would be.
struct RingTriangle {
  Tri f;
  std::array<glm::vec3, 3> p;
};

// Whether a ring triangle would cross a live triangle of the mesh that is not around the moved
// vertex (`around(o)`), in a box test a triangle for most of the mesh.
template <class Around>
bool ring_crosses(const std::vector<RingTriangle>& ring, const std::vector<Tri>& faces,
                  const std::vector<glm::vec3>& pos, const std::vector<uint8_t>* alive, Around around) {
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const RingTriangle& r : ring)
    for (const glm::vec3& x : r.p) lo = glm::min(lo, x), hi = glm::max(hi, x);
  for (size_t o = 0; o < faces.size(); ++o) {
    if ((alive && !(*alive)[o]) || around(faces[o])) continue;
    const Tri& g = faces[o];
    const std::array<glm::vec3, 3> q{pos[g[0]], pos[g[1]], pos[g[2]]};
    const glm::vec3 qlo = glm::min(q[0], glm::min(q[1], q[2])), qhi = glm::max(q[0], glm::max(q[1], q[2]));
    if (glm::any(glm::lessThan(qhi, lo)) || glm::any(glm::lessThan(hi, qlo))) continue;
    for (const RingTriangle& r : ring)
      if (cross_beyond_shared(r.f, r.p, g, q)) return true;
  }
  return false;
}

class Decimator {
 public:
  Decimator(IsoMesh& m, const IsoField& f) : m_(m), f_(f) {
    const size_t nv = m.positions.size();
    faces_.resize(m.triangles.size() / 3);
    vfaces_.resize(nv);
    quadric_.resize(nv);
    stamp_.assign(nv, 0);
    alive_v_.assign(nv, 1);
    alive_f_.assign(faces_.size(), 1);
    for (size_t t = 0; t < faces_.size(); ++t) {
      faces_[t] = {m.triangles[3 * t], m.triangles[3 * t + 1], m.triangles[3 * t + 2]};
      for (uint32_t v : faces_[t]) vfaces_[v].push_back(static_cast<uint32_t>(t));
      const glm::dvec3 n2(normal_of(m.positions, faces_[t]));
      const double len = glm::length(n2);
      if (len <= 0) continue;
      const glm::dvec3 n = n2 / len;
      const double d = -glm::dot(n, glm::dvec3(m.positions[faces_[t][0]]));
      for (uint32_t v : faces_[t]) quadric_[v].add_plane(n, d, 0.5 * len);
    }
    alive_count_ = nv;
  }

  void run(size_t max_vertices) {
    for (uint32_t v = 0; v < stamp_.size(); ++v) push_edges(v);  // each edge twice: harmless
    while (alive_count_ > max_vertices && !heap_.empty()) {
      const Entry e = heap_.top();
      heap_.pop();
      const uint32_t a = std::get<1>(e), b = std::get<2>(e);
      if (!alive_v_[a] || !alive_v_[b] || stamp_[a] != std::get<3>(e) || stamp_[b] != std::get<4>(e)) continue;
      glm::vec3 target;
      if (!collapsible(a, b, target)) continue;
      collapse(a, b, target);
    }
    compact();
  }

 private:
  // cost, a, b, stamp a, stamp b; the smallest cost first, then the smallest indices.
  using Entry = std::tuple<double, uint32_t, uint32_t, uint32_t, uint32_t>;

  std::vector<uint32_t> neighbours(uint32_t v) const {
    std::vector<uint32_t> out;
    for (uint32_t t : vfaces_[v])
      for (uint32_t w : faces_[t])
        if (w != v) out.push_back(w);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }

  glm::vec3 target_of(uint32_t a, uint32_t b) const {
    const glm::vec3 mid = 0.5f * (m_.positions[a] + m_.positions[b]);
    return project_to_iso(f_, mid, 0.5f * glm::distance(m_.positions[a], m_.positions[b]));
  }

  // Every edge at v, with both its ends' current stamps (an edge is pushed again whenever either
  // end changes; the older entries are then stale).
  void push_edges(uint32_t v) {
    for (uint32_t w : neighbours(v)) {
      const uint32_t a = std::min(v, w), b = std::max(v, w);
      Quadric q = quadric_[a];
      q.add(quadric_[b]);
      const glm::vec3 x = 0.5f * (m_.positions[a] + m_.positions[b]);
      // The quadric error (area × distance²), and a little of the edge's length to the fourth so
      // flat regions thin out evenly.
      const double len2 = glm::dot(m_.positions[a] - m_.positions[b], m_.positions[a] - m_.positions[b]);
      const double cost = std::max(0.0, q.error(glm::dvec3(x))) + kLengthCost * len2 * len2;
      heap_.emplace(cost, a, b, stamp_[a], stamp_[b]);
    }
  }

  // The link condition (the edge's two triangles' far corners are the only common neighbours)
  // and, with the merged vertex at target, no triangle around it turned over or a sliver.
  bool collapsible(uint32_t a, uint32_t b, glm::vec3& target) const {
    const std::vector<uint32_t> na = neighbours(a), nb = neighbours(b);
    std::vector<uint32_t> common;
    std::set_intersection(na.begin(), na.end(), nb.begin(), nb.end(), std::back_inserter(common));
    if (common.size() != 2 || na.size() < 3 || nb.size() < 3 || alive_count_ <= 4) return false;
    int shared = 0;
    for (uint32_t t : vfaces_[a]) shared += std::find(faces_[t].begin(), faces_[t].end(), b) != faces_[t].end();
    if (shared != 2) return false;
    target = target_of(a, b);
    // A midpoint off the solid (across a gap between fingers) may not reach the surface.
    if (!(std::abs(f_.value(target) - f_.iso) < kOnSurface)) return false;
    for (uint32_t v : {a, b})
      for (uint32_t t : vfaces_[v]) {
        const Tri& f = faces_[t];
        if (std::find(f.begin(), f.end(), a) != f.end() && std::find(f.begin(), f.end(), b) != f.end()) continue;
        std::array<glm::vec3, 3> p{};
        for (size_t k = 0; k < 3; ++k) p[k] = f[k] == v ? target : m_.positions[f[k]];
        const glm::vec3 before = normal_of(m_.positions, f), after = glm::cross(p[1] - p[0], p[2] - p[0]);
        const float lb = glm::length(before), la = glm::length(after);
        if (!(la > 0.0f) || glm::dot(before, after) < kMinTurnCos * lb * la) return false;
        const float qa = quality(p[0], p[1], p[2]);
        if (qa < kMinQuality && qa < quality(m_.positions[f[0]], m_.positions[f[1]], m_.positions[f[2]])) return false;
      }
    return alive_count_ > kCrossingCheckBelow || !crosses_after(a, b, target);
  }

  // Whether a triangle around the merged vertex (at target) would cross a triangle of the mesh
  // that shares no vertex with it.
  bool crosses_after(uint32_t a, uint32_t b, const glm::vec3& target) const {
    std::vector<RingTriangle> ring;
    for (uint32_t v : {a, b})
      for (uint32_t t : vfaces_[v]) {
        Tri f = faces_[t];
        if (std::count(f.begin(), f.end(), a) + std::count(f.begin(), f.end(), b) == 2) continue;  // collapses away
        std::array<glm::vec3, 3> p{};
        for (size_t k = 0; k < 3; ++k) {
          if (f[k] == b) f[k] = a;
          p[k] = f[k] == a ? target : m_.positions[f[k]];
        }
        ring.push_back({f, p});
      }
    return ring_crosses(ring, faces_, m_.positions, &alive_f_, [a, b](const Tri& g) {
      return std::find(g.begin(), g.end(), a) != g.end() || std::find(g.begin(), g.end(), b) != g.end();
    });
  }

  void collapse(uint32_t a, uint32_t b, const glm::vec3& target) {
    m_.positions[a] = target;
    for (uint32_t t : vfaces_[b]) {
      Tri& f = faces_[t];
      if (std::find(f.begin(), f.end(), a) != f.end()) {
        alive_f_[t] = 0;
        for (uint32_t w : f)
          if (w != b) std::erase(vfaces_[w], t);
        continue;
      }
      for (uint32_t& w : f)
        if (w == b) w = a;
      vfaces_[a].push_back(t);
    }
    vfaces_[b].clear();
    alive_v_[b] = 0;
    --alive_count_;
    quadric_[a].add(quadric_[b]);
    std::sort(vfaces_[a].begin(), vfaces_[a].end());
    // The edges at a changed cost; the rest keep theirs (an edge refused earlier is not tried again).
    ++stamp_[a];
    push_edges(a);
  }

  void compact() {
    std::vector<uint32_t> renumber(m_.positions.size(), UINT32_MAX);
    IsoMesh out;
    for (size_t t = 0; t < faces_.size(); ++t) {
      if (!alive_f_[t]) continue;
      for (uint32_t v : faces_[t]) {
        if (renumber[v] == UINT32_MAX) {
          renumber[v] = static_cast<uint32_t>(out.positions.size());
          out.positions.push_back(m_.positions[v]);
        }
        out.triangles.push_back(renumber[v]);
      }
    }
    m_ = std::move(out);
  }

  IsoMesh& m_;
  const IsoField& f_;
  std::vector<Tri> faces_;
  std::vector<std::vector<uint32_t>> vfaces_;
  std::vector<Quadric> quadric_;
  std::vector<uint32_t> stamp_;
  std::vector<uint8_t> alive_v_, alive_f_;
  size_t alive_count_ = 0;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> heap_;
};

// Moves each vertex halfway to its neighbours' centroid within the surface's tangent plane,
// projected back; a move that turns a triangle around the vertex over or makes a sliver is not
// taken.
void relax(IsoMesh& m, const IsoField& f) {
  const size_t nv = m.positions.size();
  std::vector<std::vector<uint32_t>> vfaces(nv);
  std::vector<Tri> faces(m.triangles.size() / 3);
  for (size_t t = 0; t < faces.size(); ++t)
    faces[t] = {m.triangles[3 * t], m.triangles[3 * t + 1], m.triangles[3 * t + 2]};
  for (size_t t = 0; t < m.triangles.size() / 3; ++t)
    for (int k = 0; k < 3; ++k) vfaces[m.triangles[3 * t + static_cast<size_t>(k)]].push_back(static_cast<uint32_t>(t));
  for (uint32_t v = 0; v < nv; ++v) {
    glm::vec3 c(0);
    float n = 0, edge = 0;
    for (uint32_t t : vfaces[v])
      for (int k = 0; k < 3; ++k) {
        const uint32_t w = m.triangles[3 * t + static_cast<size_t>(k)];
        if (w == v) continue;
        c += m.positions[w], n += 1;
        edge = std::max(edge, glm::distance(m.positions[w], m.positions[v]));
      }
    if (n == 0) continue;
    const glm::vec3 p = m.positions[v];
    const glm::vec3 g = f.gradient(p, std::max(1e-5f, 0.02f * edge));
    const float g2 = glm::dot(g, g);
    glm::vec3 d = c / n - p;
    if (g2 > 1e-12f) d -= g * (glm::dot(g, d) / g2);
    const glm::vec3 q = project_to_iso(f, p + 0.5f * d, 0.5f * edge);
    bool ok = true;
    for (uint32_t t : vfaces[v]) {
      std::array<glm::vec3, 3> a{}, b{};
      for (size_t k = 0; k < 3; ++k) {
        const uint32_t w = m.triangles[3 * t + k];
        a[k] = m.positions[w];
        b[k] = w == v ? q : a[k];
      }
      const glm::vec3 n0 = glm::cross(a[1] - a[0], a[2] - a[0]), n1 = glm::cross(b[1] - b[0], b[2] - b[0]);
      if (glm::dot(n0, n1) < 0.7f * glm::length(n0) * glm::length(n1) || quality(b[0], b[1], b[2]) < kMinQuality)
        ok = false;
    }
    if (ok && nv <= kCrossingCheckBelow) {
      std::vector<RingTriangle> ring;
      for (uint32_t t : vfaces[v]) {
        RingTriangle r{{m.triangles[3 * t], m.triangles[3 * t + 1], m.triangles[3 * t + 2]}, {}};
        for (size_t k = 0; k < 3; ++k) r.p[k] = r.f[k] == v ? q : m.positions[r.f[k]];
        ring.push_back(r);
      }
      ok = !ring_crosses(ring, faces, m.positions, nullptr,
                         [v](const Tri& g) { return g[0] == v || g[1] == v || g[2] == v; });
    }
    if (ok) m.positions[v] = q;
  }
}

}  // namespace

void decimate(IsoMesh& m, const IsoField& f, size_t max_vertices, int smoothing) {
  if (m.positions.size() > max_vertices) Decimator(m, f).run(max_vertices);
  for (int i = 0; i < smoothing; ++i) relax(m, f);
}

}  // namespace mimic::avatar::skin_detail
