#include "mimic/avatar/joint_zone.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace mimic::avatar {

std::vector<uint32_t> part_triangles(const Mesh& mesh, std::span<const std::string> names) {
  std::vector<uint32_t> out;
  for (const MeshPart& p : mesh.parts)
    if (std::find(names.begin(), names.end(), p.name) != names.end())
      for (uint32_t t = 0; t < p.triangle_count; ++t) out.push_back(p.first_triangle + t);
  return out;
}

namespace {

// The zone's half-space normals and a unit e perpendicular to both (taken exactly antiparallel
// when the joint is straight).
struct ZoneFrame {
  glm::dvec3 c, u, d, e;
  bool straight;
};

ZoneFrame zone_frame(const JointZone& zone) {
  ZoneFrame f{glm::dvec3(zone.center_m),
              glm::normalize(glm::dvec3(zone.proximal_dir)),
              glm::normalize(glm::dvec3(zone.distal_dir)),
              {},
              false};
  const glm::dvec3 e = glm::cross(f.u, f.d);
  if (glm::length(e) > 1e-3) {
    f.e = glm::normalize(e);
  } else {
    f.straight = true;
    f.u = -f.d;
    const glm::dvec3 any = std::abs(f.d.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
    f.e = glm::normalize(glm::cross(f.d, any));
  }
  return f;
}

// A convex polygon of at most 3 + 2 vertices (a triangle clipped by two planes).
struct Polygon {
  glm::dvec3 p[8];
  int n = 0;
};

// Keeps the part with normal·(x − origin) ≤ limit (Sutherland–Hodgman).
Polygon clip(const Polygon& in, const glm::dvec3& origin, const glm::dvec3& normal, double limit) {
  Polygon out;
  for (int i = 0; i < in.n; ++i) {
    const glm::dvec3& a = in.p[i];
    const glm::dvec3& b = in.p[(i + 1) % in.n];
    const double da = glm::dot(normal, a - origin) - limit, db = glm::dot(normal, b - origin) - limit;
    if (da <= 0) out.p[out.n++] = a;
    if ((da <= 0) != (db <= 0)) out.p[out.n++] = a + (b - a) * (da / (da - db));
  }
  return out;
}

}  // namespace

double joint_zone_volume(std::span<const glm::vec3> positions, std::span<const uint32_t> indices,
                         std::span<const uint32_t> triangles, const JointZone& zone) {
  const ZoneFrame f = zone_frame(zone);
  const glm::dvec3 c = f.c, u = f.u, d = f.d, e = f.e;
  const double half = zone.half_length_m;
  double volume = 0;
  for (uint32_t t : triangles) {
    Polygon poly;
    poly.n = 3;
    for (int k = 0; k < 3; ++k) poly.p[k] = glm::dvec3(positions[indices[3 * t + k]]);
    poly = clip(clip(poly, c, u, half), c, d, half);
    for (int k = 1; k + 1 < poly.n; ++k) {
      const glm::dvec3 centroid = (poly.p[0] + poly.p[k] + poly.p[k + 1]) / 3.0;
      const glm::dvec3 area_vec = 0.5 * glm::cross(poly.p[k] - poly.p[0], poly.p[k + 1] - poly.p[0]);
      volume += glm::dot(e, centroid - c) * glm::dot(e, area_vec);
    }
  }
  return volume;
}

std::optional<double> section_area(std::span<const glm::vec3> positions, std::span<const uint32_t> indices,
                                   std::span<const uint32_t> triangles, const glm::vec3& point_f,
                                   const glm::vec3& normal_f) {
  const glm::dvec3 point(point_f), n = glm::normalize(glm::dvec3(normal_f));
  auto side = [&](uint32_t v) { return glm::dot(glm::dvec3(positions[v]) - point, n); };
  auto key = [](uint32_t a, uint32_t b) { return a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a); };
  // Each crossing triangle gives a segment between two crossed edges; edges are named by their
  // vertices, so the segments of neighbouring triangles meet exactly.
  struct Segment {
    uint64_t from, to;
  };
  std::vector<Segment> segs;
  std::unordered_map<uint64_t, glm::dvec3> crossing;
  std::unordered_map<uint64_t, std::vector<int>> at;
  for (uint32_t t : triangles) {
    const uint32_t* v = &indices[3 * t];
    uint64_t found[2];
    int k = 0;
    for (int i = 0; i < 3; ++i) {
      const uint32_t a = v[i], b = v[(i + 1) % 3];
      const double sa = side(a), sb = side(b);
      if ((sa >= 0) == (sb >= 0)) continue;
      const uint64_t id = key(a, b);
      crossing[id] =
          glm::dvec3(positions[a]) + (glm::dvec3(positions[b]) - glm::dvec3(positions[a])) * (sa / (sa - sb));
      if (k < 2) found[k++] = id;
    }
    if (k != 2) continue;
    at[found[0]].push_back(int(segs.size()));
    at[found[1]].push_back(int(segs.size()));
    segs.push_back({found[0], found[1]});
  }
  // A frame in the plane for the 2D tests.
  const glm::dvec3 any = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  const glm::dvec3 ax = glm::normalize(glm::cross(n, any)), ay = glm::cross(n, ax);
  std::vector<char> used(segs.size(), 0);
  std::optional<double> best;
  std::vector<glm::dvec2> loop;
  for (size_t s0 = 0; s0 < segs.size(); ++s0) {
    if (used[s0]) continue;
    loop.clear();
    used[s0] = 1;
    const uint64_t start = segs[s0].from;
    uint64_t cur = segs[s0].to;
    int prev = int(s0);
    bool closed = false;
    auto push = [&](uint64_t id) {
      const glm::dvec3 q = crossing[id] - point;
      loop.push_back({glm::dot(q, ax), glm::dot(q, ay)});
    };
    push(start);
    while (true) {
      push(cur);
      if (cur == start) {
        closed = true;
        break;
      }
      int next = -1;
      for (int s : at[cur])
        if (s != prev && !used[s]) next = s;
      if (next < 0) break;
      used[next] = 1;
      cur = segs[next].from == cur ? segs[next].to : segs[next].from;
      prev = next;
    }
    if (!closed) continue;
    loop.pop_back();  // the start again
    // Encloses the origin (the station point)? Even-odd rule on a ray along +x.
    bool inside = false;
    double area2 = 0;
    for (size_t i = 0; i < loop.size(); ++i) {
      const glm::dvec2 a = loop[i], b = loop[(i + 1) % loop.size()];
      area2 += a.x * b.y - a.y * b.x;
      if ((a.y > 0) != (b.y > 0) && a.x + (b.x - a.x) * (0 - a.y) / (b.y - a.y) > 0) inside = !inside;
    }
    if (inside) best = std::max(best.value_or(0.0), 0.5 * std::abs(area2));
  }
  return best;
}

double joint_zone_section_area(std::span<const glm::vec3> positions, std::span<const uint32_t> indices,
                               std::span<const uint32_t> triangles, const JointZone& zone, const glm::vec3& point_f,
                               const glm::vec3& normal_f) {
  ZoneFrame f = zone_frame(zone);
  const glm::dvec3 point(point_f), n = glm::normalize(glm::dvec3(normal_f));
  // The in-plane field G = e (e·(x − c)) has divergence 1 in the plane; e must run along the
  // lines where the zone's planes cut the station plane so they add no flux.
  if (f.straight) {
    const glm::dvec3 along = glm::cross(n, f.d);
    if (glm::length(along) > 1e-6) f.e = glm::normalize(along);
  }
  const double half = zone.half_length_m;
  double area = 0;
  for (uint32_t t : triangles) {
    const glm::dvec3 v[3] = {glm::dvec3(positions[indices[3 * t]]), glm::dvec3(positions[indices[3 * t + 1]]),
                             glm::dvec3(positions[indices[3 * t + 2]])};
    glm::dvec3 hit[2];
    int k = 0;
    for (int i = 0; i < 3 && k < 2; ++i) {
      const glm::dvec3 a = v[i], b = v[(i + 1) % 3];
      const double sa = glm::dot(a - point, n), sb = glm::dot(b - point, n);
      if ((sa >= 0) != (sb >= 0)) hit[k++] = a + (b - a) * (sa / (sa - sb));
    }
    if (k != 2) continue;
    // Clip the segment to the zone: u·(x − c) ≤ L and d·(x − c) ≤ L.
    double t0 = 0, t1 = 1;
    for (const glm::dvec3& h : {f.u, f.d}) {
      const double s0 = glm::dot(h, hit[0] - f.c) - half, s1 = glm::dot(h, hit[1] - f.c) - half;
      if (s0 > 0 && s1 > 0)
        t0 = 1, t1 = 0;
      else if (s0 > 0)
        t0 = std::max(t0, s0 / (s0 - s1));
      else if (s1 > 0)
        t1 = std::min(t1, s0 / (s0 - s1));
    }
    if (t1 <= t0) continue;
    const glm::dvec3 p = hit[0] + t0 * (hit[1] - hit[0]), q = hit[0] + t1 * (hit[1] - hit[0]);
    // Outward in-plane normal (length = segment length): the triangle's normal, projected.
    glm::dvec3 m = glm::cross(n, q - p);
    if (glm::dot(m, glm::cross(v[1] - v[0], v[2] - v[0])) < 0) m = -m;
    area += glm::dot(f.e, 0.5 * (p + q) - f.c) * glm::dot(f.e, m);
  }
  return area;
}

std::array<std::pair<glm::vec3, glm::vec3>, 5> joint_zone_stations(const JointZone& z) {
  const glm::vec3 u = glm::normalize(z.proximal_dir), d = glm::normalize(z.distal_dir);
  const glm::vec3 bis = glm::length(d - u) > 1e-3f ? glm::normalize(d - u) : d;
  const float l = z.half_length_m;
  return {{{z.center_m + u * (2 * l / 3), u},
           {z.center_m + u * (l / 3), u},
           {z.center_m, bis},
           {z.center_m + d * (l / 3), d},
           {z.center_m + d * (2 * l / 3), d}}};
}

}  // namespace mimic::avatar
