// Internals of the skin shared by its files (not a public header): the contour layout (chains,
// rings, surfaces, bridges, rigid parts) and BodySkin::Impl, which holds one body's layout and its
// per-frame state. The full method casts rays (ray_contours.cpp), the layout is built once
// (layout.cpp, topology.cpp), the realtime method moves the rest contours (realtime.cpp).
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include <glm/gtx/norm.hpp>

#include "mimic/avatar/bspline.h"
#include "mimic/avatar/skin.h"

namespace mimic::avatar {

namespace skin_detail {

using Clock = std::chrono::steady_clock;
inline constexpr float kPi = std::numbers::pi_v<float>;
inline constexpr float kTwoPi = 2.0f * kPi;
inline constexpr int kMaxCandidates = 256;
inline constexpr float kMissRadius_m = 0.01f;

inline double micros_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
}

inline glm::vec3 safe_normalize(const glm::vec3& v, const glm::vec3& fallback) {
  const float l2 = glm::length2(v);
  return l2 > 1e-20f ? v / std::sqrt(l2) : fallback;
}

// A polyline of skeleton points along which contour planes are placed: joint-angle driven
// configuration (bisector normals at joints, interpolated along links).
struct Chain {
  struct Node {
    int joint = -1;
    glm::vec3 offset{0.0f};  // in the joint frame
  };
  std::vector<Node> nodes;
  // Normal at the first node: the joint's +Y axis (torso bottom) or the first link direction.
  bool start_normal_from_y = false;
  // A point beyond the last node whose link direction makes the last node a bisector plane
  // (the next link, e.g. the hand); joint −1 means the last node ends the chain.
  Node beyond;
  // Per frame.
  std::vector<glm::vec3> point, normal, ref;

  void update(std::span<const RigidTransform> w) {
    const size_t n = nodes.size();
    for (size_t i = 0; i < n; ++i) point[i] = w[nodes[i].joint].apply(nodes[i].offset);
    for (size_t i = 0; i < n; ++i) {
      const glm::vec3 fallback = w[nodes[i].joint].apply_vector({0, 1, 0});
      glm::vec3 in = i > 0 ? safe_normalize(point[i] - point[i - 1], fallback) : glm::vec3(0);
      glm::vec3 out(0);
      if (i + 1 < n) out = safe_normalize(point[i + 1] - point[i], fallback);
      else if (beyond.joint >= 0) out = safe_normalize(w[beyond.joint].apply(beyond.offset) - point[i], in);
      if (i == 0) normal[i] = start_normal_from_y ? fallback : out;
      else normal[i] = safe_normalize(in + out, in);
      // The angular reference: each joint frame's +Z (the body's front in the zero posture),
      // averaged with the previous node's at interior nodes so twist spreads along links.
      const glm::vec3 z = w[nodes[i].joint].apply_vector({0, 0, 1});
      ref[i] = (i > 0 && i + 1 < n) ? safe_normalize(z + w[nodes[i - 1].joint].apply_vector({0, 0, 1}), z) : z;
    }
  }
  void resize() {
    point.resize(nodes.size());
    normal.resize(nodes.size());
    ref.resize(nodes.size());
  }
};

struct Plane {
  glm::vec3 origin, normal, front, left;
};

inline Plane ring_plane(const Chain& c, int segment, float u) {
  const int a = segment, b = std::min<int>(segment + 1, static_cast<int>(c.point.size()) - 1);
  Plane p;
  p.origin = glm::mix(c.point[a], c.point[b], u);
  p.normal = safe_normalize(glm::mix(c.normal[a], c.normal[b], u), c.normal[a]);
  const glm::vec3 ref = glm::mix(c.ref[a], c.ref[b], u);
  glm::vec3 front = ref - glm::dot(ref, p.normal) * p.normal;
  if (glm::length2(front) < 1e-10f) {
    // Reference along the normal (a degenerate posture): any perpendicular keeps the ring valid.
    front = glm::cross(p.normal, std::abs(p.normal.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0));
  }
  p.front = glm::normalize(front);
  p.left = glm::cross(p.normal, p.front);
  return p;
}

enum class RingKind : uint8_t { star, driven, arc };

struct Ring {
  std::string name;
  RingKind kind = RingKind::star;
  GroupMask mask = 0;
  std::vector<uint32_t> slots;  // control points; for arcs only the interior points
  // star
  int chain = -1, segment = 0;
  float u = 0;
  int angles = -1;  // direction table (stars and arcs)
  // driven: P = S + alpha (G − S), ray from P's projection on the chain's first link
  int s_ring = -1;
  std::vector<uint32_t> goal;  // G's slots (a loop made of other rings' points)
  float alpha = 0;
  // arc (bridge): interior points on a half circle from `from` through `up` to `to`
  uint32_t from = 0, to = 0;
  int up_ring = -1;    // ring whose normal gives "up" (arc bulges towards −normal if flip_up)
  bool flip_up = false;
};

struct Surface {
  std::string name;
  std::vector<int> rows;               // ring ids, control rows
  std::vector<uint32_t> first_row;     // control slots of row 0 when it is a loop of others' points
  bool loop_start = false;
  bool cap = false;
  std::vector<std::pair<std::string, int>> parts;  // part name, first control row
  // Output.
  std::vector<std::vector<uint32_t>> out_rows;
  uint32_t cap_vertex = 0;
  std::vector<BsplineTap> around, along;
  std::vector<int> out_row_of_control;  // output row index where each control row lands
};

struct Bridge {
  int ring = -1;                 // the arc ring (interior control points)
  uint32_t out_from = 0, out_to = 0;  // output vertices of the end points (on the torso)
  std::vector<uint32_t> out_interior;
  std::vector<BsplineTap> taps;  // over [from, interior…, to]
};

struct RigidMesh {
  RigidPart part = RigidPart::none;
  int joint = -1;
  std::vector<glm::vec3> local;  // vertices in the joint frame
  uint32_t first_vertex = 0;
};

}  // namespace skin_detail

using namespace skin_detail;

struct BodySkin::Impl {
  SkinOptions options;
  Skeleton skeleton;
  BodyField field;
  SkinLayout layout;

  std::vector<RigidTransform> world_from_joint;
  std::vector<Chain> chains;
  // Ray directions of star and arc rings in their planes (fixed by the layout): cos and sin of
  // each ray's angle from the plane's front towards its left (an arc's "up").
  struct Directions {
    std::vector<float> cos, sin;
  };
  std::vector<Directions> direction_tables;
  int add_directions(std::span<const float> angles_rad) {
    Directions d;
    for (float a : angles_rad) d.cos.push_back(std::cos(a)), d.sin.push_back(std::sin(a));
    direction_tables.push_back(std::move(d));
    return static_cast<int>(direction_tables.size()) - 1;
  }
  std::vector<Ring> rings;
  std::vector<Surface> surfaces;
  std::vector<Bridge> bridges;
  std::vector<RigidMesh> rigid;

  // Control points and, per point, the origin of the ray that produced it.
  std::vector<glm::vec3> ctrl, ctrl_origin;
  std::vector<uint8_t> ctrl_hit;

  Mesh mesh;
  std::vector<glm::vec3> scratch_grid, scratch_rows, scratch_poly;
  std::vector<uint16_t> candidates;
  std::vector<RayHit> star_hits;
  std::vector<glm::vec4> normal_sums;  // per vertex, while the normals are summed
  std::vector<glm::vec3> ray_origins, ray_dirs, ray_fallbacks;  // a ring's rays, cast together
  SkinTimings timings;
  SkinStats stats;

  uint32_t new_slots(int n) {
    const uint32_t first = static_cast<uint32_t>(ctrl.size());
    ctrl.resize(ctrl.size() + n);
    ctrl_origin.resize(ctrl.size());
    ctrl_hit.resize(ctrl.size());
    return first;
  }

  int add_ring(Ring r, int count) {
    const uint32_t first = new_slots(count);
    for (int i = 0; i < count; ++i) r.slots.push_back(first + i);
    rings.push_back(std::move(r));
    return static_cast<int>(rings.size()) - 1;
  }

  Status build(const BodyModel& model);
  void compute_ring(const Ring& r);
  // Per-ring scratch (hits, ray origins, directions, fallbacks) for the widest ring so
  // far: grown at build time, so compute_ring never allocates.
  void size_ring_buffers();
  void cast_into(uint32_t slot, const glm::vec3& origin, const glm::vec3& dir,
                 std::span<const uint16_t> cand, const glm::vec3& fallback);
  void store(uint32_t slot, const glm::vec3& origin, const glm::vec3& dir, RayHit hit, const glm::vec3& fallback);
  int gather(GroupMask mask);
  void build_output();
  void evaluate_bspline();
  void update_normals();
};

}  // namespace mimic::avatar
