// The contour layout's tables (ContourLayout::Data, contour_layout.h), shared by the skin's
// sources (not a public header): chains, rings, surfaces, bridges, the neck's armpit corners, the
// rigid parts and the output topology. Built once by contour_layout.cpp (per piece) and
// topology.cpp (the output rows and triangles); read by the implicit skin (ray_contours.cpp,
// smoothing.cpp, implicit_skin.cpp), the realtime body (realtime.cpp), the weights and the UVs.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <glm/gtx/norm.hpp>

#include "mimic/avatar/body_field.h"
#include "mimic/avatar/bspline.h"
#include "mimic/avatar/contour_layout.h"

namespace mimic::avatar {

namespace skin_detail {

inline constexpr float kPi = std::numbers::pi_v<float>;
inline constexpr float kTwoPi = 2.0f * kPi;
inline constexpr int kMaxCandidates = 256;
inline constexpr float kMissRadius_m = 0.01f;
inline constexpr int kTorsoChain = 0;  // contour_layout.cpp builds the torso chain first

inline glm::vec3 safe_normalize(const glm::vec3& v, const glm::vec3& fallback) {
  const float l2 = glm::length2(v);
  return l2 > 1e-20f ? v / std::sqrt(l2) : fallback;
}

// The twist of a shoulder's junction band (both methods): the angle by which the limb's first
// ring S has turned about the band's axis since the zero posture, wrapped to (−π, π] and tapered
// to none from 120° to 180°: at half a turn either way is as near, and the band must not flip from
// one helix to the other between two frames (a taper from 150° still moved the shoulder's skin
// 40 mm in a step of 1.5° of the arm).
inline float twist_in_band(float phi_rad) {
  constexpr float kTaperStart_rad = 2.0943951f;
  if (phi_rad > kPi) phi_rad -= kTwoPi;
  if (phi_rad < -kPi) phi_rad += kTwoPi;
  const float taper = std::clamp((kPi - std::abs(phi_rad)) / (kPi - kTaperStart_rad), 0.0f, 1.0f);
  return phi_rad * taper;
}

// How much of a junction's loop follow and band twist a limb's swing away from its zero-posture
// direction (radians) keeps: all of it up to 95°, none past 120° (the arm across the body, where
// a swung loop or a turned band would cut into the chest).
inline float band_follow_fade(float swing_rad) {
  constexpr float kFadeStart_rad = 1.658f, kFadeEnd_rad = 2.094f;
  return std::clamp((kFadeEnd_rad - swing_rad) / (kFadeEnd_rad - kFadeStart_rad), 0.0f, 1.0f);
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

  void update(std::span<const rig::RigidTransform> w) {
    const size_t n = nodes.size();
    for (size_t i = 0; i < n; ++i) point[i] = w[nodes[i].joint].apply(nodes[i].offset);
    for (size_t i = 0; i < n; ++i) {
      const glm::vec3 fallback = w[nodes[i].joint].apply_vector({0, 1, 0});
      glm::vec3 in = i > 0 ? safe_normalize(point[i] - point[i - 1], fallback) : glm::vec3(0);
      glm::vec3 out(0);
      if (i + 1 < n)
        out = safe_normalize(point[i + 1] - point[i], fallback);
      else if (beyond.joint >= 0)
        out = safe_normalize(w[beyond.joint].apply(beyond.offset) - point[i], in);
      if (i == 0)
        normal[i] = start_normal_from_y ? fallback : out;
      else
        normal[i] = safe_normalize(in + out, in);
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
  // star: per ray, the farthest its point may lie from the ring's origin (empty: no bound). A
  // leg's last ring ends inside the rigid foot it sinks into (add_end_reach).
  std::vector<float> reach_m;
  // driven: P = S + alpha (G − S), ray from P's projection on the chain's first link
  int s_ring = -1;
  std::vector<uint32_t> goal;  // G's slots (a loop made of other rings' points)
  float alpha = 0;
  float alpha_step = 0;  // between consecutive driven rings of the junction, 1/(k+1)
  // arc (bridge): interior points on a half circle from `from` through `up` to `to`
  uint32_t from = 0, to = 0;
  int up_ring = -1;  // ring whose normal gives "up" (arc bulges towards −normal if flip_up)
  bool flip_up = false;
};

struct Surface {
  std::string name;
  std::vector<int> rows;            // ring ids, control rows
  std::vector<uint32_t> first_row;  // control slots of row 0 when it is a loop of others' points
  bool loop_start = false;
  bool cap = false;
  std::vector<std::pair<std::string, int>> parts;  // part name, first control row
  // Output.
  std::vector<std::vector<uint32_t>> out_rows;
  uint32_t cap_vertex = 0;
  // B-spline smoothing: consecutive control rows of one point count are smoothed together
  // (clamped along, so a run ends exactly on its last row); where the count changes (a limb
  // at its own LOD) a zipper band joins the runs' end rows.
  struct Run {
    int first_row = 0, rows = 0;  // control rows
    int first_out = 0;            // output row of the first control row
    std::vector<BsplineTap> around, along;
  };
  std::vector<Run> runs;
  std::vector<int> out_row_of_control;  // output row index where each control row lands

  const std::vector<uint32_t>& control_row(const std::vector<Ring>& rings, size_t r) const {
    return this->rows[r] < 0 ? first_row : rings[static_cast<size_t>(this->rows[r])].slots;
  }
};

// The triangles of the band between two closed rows of n and m points, wound outward like every
// band of the skin (row a before row b along the piece). Each corner is (row: 0 a, 1 b; column),
// a column equal to the row's size being its point 0 again (u = 1 at the seam). Equal counts give
// quads split on the same diagonal; different counts a zipper that advances, each step, the row
// whose next point comes first in normalised index (both rows' points spread alike around the
// limb), so every point of both rows is a corner and no T-junction is left: n + m triangles.
struct BandCorner {
  uint32_t row, col;
};
template <class Emit>
void for_each_band_triangle(uint32_t n, uint32_t m, Emit&& emit) {
  if (n == m) {
    for (uint32_t j = 0; j < n; ++j) {
      emit(BandCorner{0, j}, BandCorner{0, j + 1}, BandCorner{1, j + 1});
      emit(BandCorner{0, j}, BandCorner{1, j + 1}, BandCorner{1, j});
    }
    return;
  }
  uint32_t i = 0, j = 0;
  while (i < n || j < m) {
    const bool advance_b = j < m && (i == n || uint64_t{j + 1} * n <= uint64_t{i + 1} * m);
    if (advance_b) {
      emit(BandCorner{0, i}, BandCorner{1, j + 1}, BandCorner{1, j});
      ++j;
    } else {
      emit(BandCorner{0, i}, BandCorner{0, i + 1}, BandCorner{1, j});
      ++i;
    }
  }
}

// Points of the loops a limb starts from, as ContourLayout::build makes them from the torso's chest and
// crotch rings and the bridges: what every ring of the limb has unless it takes its own count.
struct LoopPoints {
  int neck = 0, arm = 0, leg = 0;
};
// Where the neck's loop cuts each armpit's corner: from the chest ring's point `chest` points
// before the armpit point to the shoulder bridge's interior point `bridge` (0: its first),
// leaving the points between to a flat patch, the corner ({0, 0}: no cut). The uncut loop climbs
// the front and back of each armpit along the bridge, a stretch that, seen along the neck's link,
// is edge-on: the neck's boundary-driven rings ran along it and folded.
struct NeckCorner {
  int chest = 0, bridge = 0;
};
inline NeckCorner neck_corner(const SkinLayout& l) {
  // The front and back arcs keep at least one segment between their two cuts (a torso of eight
  // points, two segments across the front, is not cut).
  if (l.chest_front_arc < 3) return {};
  // A bridge is a half circle of rays from its chord's middle: from the armpit it climbs, and
  // about 60° round it turns over the shoulder. The cut ends on its last point within 60° (56° of
  // the default body's 16 segments; 60° at LOD 1, 36° at LOD 2).
  return {1, std::clamp(l.shoulder_bridge / 3 - 1, 0, l.shoulder_bridge / 2 - 1)};
}
inline LoopPoints loop_points(const SkinLayout& l) {
  const int fl = l.chest_front_arc / 2, kl = fl + l.chest_side_arc;
  const int kr = kl + l.chest_front_arc, fr = kr + l.chest_side_arc;
  const NeckCorner cut = neck_corner(l);
  LoopPoints p;
  // Each of the four cuts leaves its `chest` + `bridge` points between its ends to its corner.
  p.neck = (fl + 1) + (l.shoulder_bridge - 1) + (kr - kl + 1) + (l.shoulder_bridge - 1) + (l.torso_points - fr) -
           4 * (cut.chest + cut.bridge);
  p.arm = (kl - fl + 1) + (l.shoulder_bridge - 1);
  p.leg = l.torso_points / 2 + l.crotch_bridge;
  return p;
}

// An armpit corner the neck's loop cuts: its points in the uncut loop's order, from one end to
// the other (both ends stay in the loop), triangulated as a fan from its end on the chest ring.
struct Corner {
  std::vector<uint32_t> points;
  bool apex_last = false;  // the chest end is the last point (else the first)
  size_t apex() const { return apex_last ? points.size() - 1 : 0; }
  // Fan triangles (apex, i, i + 1) over the corner's other points, in the loop's winding.
  template <class Emit>
  void for_each_triangle(Emit&& emit) const {
    const size_t n = points.size(), a = apex();
    for (size_t i = 1; i + 1 < n; ++i) emit(a, (a + i) % n, (a + i + 1) % n);
  }
};
struct NeckCut {
  int from = 0, to = 0;  // positions in the uncut loop
  bool apex_last = false;
};

// The neck's loop without the armpit corners: `full` is the uncut loop (chest front arc, left
// bridge, back arc, right bridge), each cut's points between its ends left to its corner.
// Positions are control positions times `step` (B-spline samples per span; the loop's rows are
// sampled so).
inline void cut_neck_loop(const std::vector<uint32_t>& full, std::span<const NeckCut> cuts, int step,
                          std::vector<uint32_t>& loop, std::vector<Corner>& corners) {
  std::vector<bool> drop(full.size(), false);
  corners.clear();
  for (const NeckCut& cut : cuts) {
    Corner c;
    c.apex_last = cut.apex_last;
    for (int i = cut.from * step; i <= cut.to * step; ++i) c.points.push_back(full[static_cast<size_t>(i)]);
    for (int i = cut.from * step + 1; i < cut.to * step; ++i) drop[static_cast<size_t>(i)] = true;
    corners.push_back(std::move(c));
  }
  loop.clear();
  for (size_t i = 0; i < full.size(); ++i)
    if (!drop[i]) loop.push_back(full[i]);
}

struct Bridge {
  int ring = -1;                      // the arc ring (interior control points)
  uint32_t out_from = 0, out_to = 0;  // output vertices of the end points (on the torso)
  std::vector<uint32_t> out_interior;
  std::vector<BsplineTap> taps;  // over [from, interior…, to]
};

struct RigidMesh {
  RigidPart part = RigidPart::none;
  int joint = -1;
  std::vector<glm::vec3> local;     // vertices in the joint frame
  std::vector<uint32_t> triangles;  // into local, counter-clockwise seen from outside
  uint32_t first_vertex = 0;
  // A foot's forefoot bends with its toes: the vertices ahead of the joint's child (the toe
  // joint) blend towards it by toe_weight, from toe_local, their rest place in its frame. Else
  // the flexed toes would leave the forefoot under the floor at each heel rise.
  int toe_joint = -1;
  std::vector<uint32_t> toe_vertex;  // indices into local
  std::vector<float> toe_weight;     // 0 (the part's joint) .. 1 (the toe joint)
  std::vector<glm::vec3> toe_local;
};

// How the rigid parts are meshed (contour_layout.cpp add_rigid_part): each part's share of the
// vertex budget, in UV spheres of rigid_rings × rigid_points; the marching grid's cell, from the
// part's thinnest primitive (this many of its smallest semi-axis per cell, within the bounds),
// coarser when the part's box would hold more nodes than kRigidMaxNodes; the coarse grid that
// finds the box; the relaxation passes after simplification.
inline constexpr float kRigidShareHead = 3.5f, kRigidShareHand = 2.5f, kRigidShareFoot = 1.5f;
inline constexpr size_t kRigidMinVertices = 24;
inline constexpr float kRigidCellPerAxis = 0.4f, kRigidMinCell_m = 0.0025f, kRigidMaxCell_m = 0.005f;
inline constexpr float kRigidMaxNodes = 400000.0f;
inline constexpr float kRigidCoarseCell_m = 0.006f;
inline constexpr int kRigidRelaxPasses = 3;

// The forefoot blend of a rigid part (RigidMesh::toe_*): behind the toe joint's crease plane
// by more than this the part's own joint moves a vertex, ahead by more than the front distance
// the toe joint does, smoothly in between (metres along the toes' direction).
inline constexpr float kToeBlendBack_m = 0.012f, kToeBlendFront_m = 0.022f;

// Ray directions of star and arc rings in their planes (fixed by the layout): cos and sin of
// each ray's angle from the plane's front towards its left (an arc's "up").
struct Directions {
  std::vector<float> cos, sin;
};

}  // namespace skin_detail

using namespace skin_detail;

struct ContourLayout::Data {
  ContourLayoutOptions options;
  SkinLayout counts;  // the model's, as authored (and scaled by skin_lod.h)
  rig::Skeleton skeleton;
  // Nodes fixed; point/normal/ref hold the zero posture (whoever runs the layout copies the
  // chains and updates them each frame).
  std::vector<Chain> chains;
  std::vector<Directions> direction_tables;
  std::vector<Ring> rings;
  std::vector<Surface> surfaces;  // torso first, then neck, left/right arm, left/right leg
  std::vector<Bridge> bridges;    // crotch, left shoulder, right shoulder
  // The armpit corners the neck's loop cuts (neck_corner): where in the uncut loop, and each
  // corner's output vertices (part of the neck's piece).
  std::vector<NeckCut> neck_cuts;
  std::vector<Corner> corners;
  std::vector<RigidMesh> rigid;
  uint32_t control_points = 0;
  // Output mesh: vertices (control points first when subdivision is 0), triangles, parts.
  uint32_t vertex_count = 0;
  std::vector<uint32_t> indices;
  std::vector<MeshPart> parts;
  // The B-spline stage's scratch: points of the widest run of rows (0 when subdivision is 0).
  size_t bspline_cells = 0;
  size_t widest_ring = 0;  // control points of the widest ring
};

}  // namespace mimic::avatar
