#include "mimic/avatar/skin.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

#include <glm/gtx/norm.hpp>

#include "mimic/avatar/bspline.h"

namespace mimic::avatar {

namespace {

using Clock = std::chrono::steady_clock;
constexpr float kPi = std::numbers::pi_v<float>;
constexpr float kTwoPi = 2.0f * kPi;
constexpr int kMaxCandidates = 256;
constexpr float kMissRadius_m = 0.01f;

double micros_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
}

glm::vec3 safe_normalize(const glm::vec3& v, const glm::vec3& fallback) {
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

Plane ring_plane(const Chain& c, int segment, float u) {
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

}  // namespace

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

// ---------------------------------------------------------------------------------------------
// Contours

int BodySkin::Impl::gather(GroupMask mask) {
  int n = 0;
  for (int i = 0; i < field.size() && n < kMaxCandidates; ++i)
    if (field.groups(i) & mask) candidates[n++] = static_cast<uint16_t>(i);
  return n;
}

void BodySkin::Impl::cast_into(uint32_t slot, const glm::vec3& origin, const glm::vec3& dir,
                               std::span<const uint16_t> cand, const glm::vec3& fallback) {
  store(slot, origin, dir, field.cast_outermost(origin, dir, cand), fallback);
}

void BodySkin::Impl::store(uint32_t slot, const glm::vec3& origin, const glm::vec3& dir, RayHit hit,
                           const glm::vec3& fallback) {
  ++stats.rays;
  ctrl_origin[slot] = origin;
  if (hit.hit()) {
    ctrl[slot] = origin + hit.t * dir;
    ctrl_hit[slot] = 1;
  } else {
    ctrl[slot] = fallback;
    ctrl_hit[slot] = 0;
    ++stats.missed_rays;
  }
}

void BodySkin::Impl::size_ring_buffers() {
  size_t widest = star_hits.size();
  for (const Ring& r : rings) widest = std::max(widest, r.slots.size());
  star_hits.resize(widest);
  ray_origins.resize(widest);
  ray_dirs.resize(widest);
  ray_fallbacks.resize(widest);
}

void BodySkin::Impl::compute_ring(const Ring& r) {
  switch (r.kind) {
    case RingKind::star: {
      const Plane p = ring_plane(chains[r.chain], r.segment, r.u);
      const int n = field.candidates_near_plane(p.origin, p.normal, r.mask, candidates);
      const std::span<const uint16_t> cand(candidates.data(), n);
      const Directions& dir = direction_tables[r.angles];
      const std::span<RayHit> hits(star_hits.data(), r.slots.size());
      field.cast_star(p.origin, p.front, p.left, dir.cos, dir.sin, cand, hits);
      for (size_t j = 0; j < r.slots.size(); ++j) {
        const glm::vec3 d = dir.cos[j] * p.front + dir.sin[j] * p.left;
        store(r.slots[j], p.origin, d, hits[j], p.origin + kMissRadius_m * d);
      }
      break;
    }
    case RingKind::driven: {
      const Ring& s = rings[r.s_ring];
      const Chain& c = chains[s.chain];
      const glm::vec3 a = c.point[0];
      const glm::vec3 axis = safe_normalize(c.point[1] - c.point[0], c.normal[0]);
      const int n = gather(r.mask);
      const std::span<const uint16_t> cand(candidates.data(), n);
      // Origins are P's projection on the link, kept between just before the joint and the
      // S ring: in extreme postures (an arm swung across the chest) the bare projection can
      // land far down the limb, from where the ray would miss the junction.
      const float s_along = glm::dot(ctrl_origin[s.slots[0]] - a, axis);
      const size_t m = r.slots.size();
      for (size_t j = 0; j < m; ++j) {
        const glm::vec3 sj = ctrl[s.slots[j]];
        const glm::vec3 pj = sj + r.alpha * (ctrl[r.goal[j]] - sj);
        const glm::vec3 o = a + std::clamp(glm::dot(pj - a, axis), -0.05f, std::max(s_along, -0.05f)) * axis;
        const glm::vec3 so = a + glm::dot(sj - a, axis) * axis;
        ray_origins[j] = o;
        ray_dirs[j] = safe_normalize(pj - o, safe_normalize(sj - so, c.normal[0]));
        ray_fallbacks[j] = pj;
      }
      // Every ray of the ring at once, eight in lock-step.
      const std::span<RayHit> hits(star_hits.data(), m);
      field.cast_rays(std::span(ray_origins.data(), m), std::span(ray_dirs.data(), m), cand, hits);
      for (size_t j = 0; j < m; ++j) store(r.slots[j], ray_origins[j], ray_dirs[j], hits[j], ray_fallbacks[j]);
      break;
    }
    case RingKind::arc: {
      const glm::vec3 from = ctrl[r.from], to = ctrl[r.to];
      const glm::vec3 o = 0.5f * (from + to);
      const glm::vec3 front = safe_normalize(from - o, {0, 0, 1});
      // "Up" is the normal of the ring the bridge leaves (the chest or crotch ring).
      const Ring& base = rings[r.up_ring];
      const Plane base_plane = ring_plane(chains[base.chain], base.segment, base.u);
      glm::vec3 up = r.flip_up ? -base_plane.normal : base_plane.normal;
      up = safe_normalize(up - glm::dot(up, front) * front, {0, 1, 0});
      const int n = gather(r.mask);
      const std::span<const uint16_t> cand(candidates.data(), n);
      // A half star from the chord's middle: one contour's worth of shared work.
      const int segs = static_cast<int>(r.slots.size()) + 1;
      const size_t m = r.slots.size();
      const Directions& dir = direction_tables[r.angles];
      const std::span<RayHit> hits(star_hits.data(), m);
      field.cast_star(o, front, up, dir.cos, dir.sin, cand, hits);
      for (int k = 1; k < segs; ++k) {
        const glm::vec3 d = dir.cos[static_cast<size_t>(k - 1)] * front + dir.sin[static_cast<size_t>(k - 1)] * up;
        const glm::vec3 chord = glm::mix(from, to, static_cast<float>(k) / static_cast<float>(segs));
        store(r.slots[k - 1], o, d, hits[static_cast<size_t>(k - 1)], chord);
      }
      break;
    }
  }
  ++stats.contours;
}

// ---------------------------------------------------------------------------------------------
// Construction

namespace {

// Angles (radians, from the ring's front towards its left) of the torso rings: arcs of equal
// segments between the front-centre, the front and back of each armpit, and the back-centre.
std::vector<float> torso_angles(const SkinLayout& s) {
  const float front_armpit = glm::radians(60.0f), back_armpit = glm::radians(120.0f);
  std::vector<float> a;
  const int half_front = s.chest_front_arc / 2;
  auto arc = [&](float from, float to, int segs) {
    for (int i = 0; i < segs; ++i) a.push_back(from + (to - from) * static_cast<float>(i) / static_cast<float>(segs));
  };
  arc(0.0f, front_armpit, half_front);
  arc(front_armpit, back_armpit, s.chest_side_arc);
  arc(back_armpit, kTwoPi - back_armpit, s.chest_front_arc);
  arc(kTwoPi - back_armpit, kTwoPi - front_armpit, s.chest_side_arc);
  arc(kTwoPi - front_armpit, kTwoPi, s.chest_front_arc - half_front);
  return a;
}

// Angles of a limb's rings chosen so ring point j faces the loop's point j (measured in the
// rest posture), keeping the columns straight from the junction down the limb.
std::vector<float> angles_facing(const Plane& p, std::span<const glm::vec3> goal) {
  const size_t n = goal.size();
  std::vector<float> a(n);
  for (size_t j = 0; j < n; ++j) {
    const glm::vec3 v = goal[j] - p.origin;
    a[j] = std::atan2(glm::dot(v, p.left), glm::dot(v, p.front));
  }
  bool ok = true;
  for (size_t j = 1; j < n; ++j) {
    while (a[j] <= a[j - 1]) a[j] += kTwoPi;
    if (a[j] - a[j - 1] > kPi) ok = false;
  }
  if (!ok || a[n - 1] - a[0] >= kTwoPi) {
    for (size_t j = 1; j < n; ++j) a[j] = a[0] + kTwoPi * static_cast<float>(j) / static_cast<float>(n);
  }
  // Keep every gap at least a third of the uniform one so no ray pair collapses.
  const float min_gap = kTwoPi / static_cast<float>(n) / 3.0f;
  for (size_t j = 1; j < n; ++j) a[j] = std::max(a[j], a[j - 1] + min_gap);
  if (a[n - 1] - a[0] > kTwoPi - min_gap) {
    for (size_t j = 1; j < n; ++j) a[j] = a[0] + kTwoPi * static_cast<float>(j) / static_cast<float>(n);
  }
  return a;
}

}  // namespace

Status BodySkin::Impl::build(const BodyModel& model) {
  layout = model.skin;
  const SkinLayout& L = layout;
  world_from_joint.resize(skeleton.joint_count());
  candidates.resize(kMaxCandidates);
  star_hits.resize(static_cast<size_t>(L.torso_points));

  auto joint = [&](const char* name) { return skeleton.find_joint(name); };
  for (const char* name : {"pelvis", "spine_lower", "spine_mid", "spine_upper", "neck", "neck_upper", "head",
                           "l_shoulder", "l_elbow", "l_wrist", "r_shoulder", "r_elbow", "r_wrist", "l_hip",
                           "l_knee", "l_ankle", "r_hip", "r_knee", "r_ankle"})
    if (joint(name) < 0) return fail(Errc::invalid_argument, std::string("skin needs joint '") + name + "'");

  // Chains: 0 torso, 1 neck, 2/3 arms, 4/5 legs.
  {
    Chain torso;
    const int pelvis = joint("pelvis"), su = joint("spine_upper");
    torso.nodes = {{pelvis, {0, -L.crotch_drop_m, 0}}, {pelvis, {0, 0, 0}}, {joint("spine_lower"), {0, 0, 0}},
                   {joint("spine_mid"), {0, 0, 0}}, {su, {0, 0, 0}}, {su, L.chest_ring * skeleton.tip_m(su)}};
    torso.start_normal_from_y = true;
    torso.beyond = {joint("neck"), {0, 0, 0}};
    torso.resize();
    chains.push_back(torso);
    Chain neck;
    neck.nodes = {{joint("neck"), {0, 0, 0}}, {joint("neck_upper"), {0, 0, 0}}, {joint("head"), {0, 0, 0}}};
    neck.beyond = {joint("head"), skeleton.tip_m(joint("head"))};
    neck.resize();
    chains.push_back(neck);
    for (const char* side : {"l_", "r_"}) {
      const std::string s(side);
      Chain arm;
      const int wrist = joint((s + "wrist").c_str());
      arm.nodes = {{joint((s + "shoulder").c_str()), {0, 0, 0}}, {joint((s + "elbow").c_str()), {0, 0, 0}}, {wrist, {0, 0, 0}}};
      arm.beyond = {wrist, skeleton.tip_m(wrist)};
      arm.resize();
      chains.push_back(arm);
    }
    for (const char* side : {"l_", "r_"}) {
      const std::string s(side);
      Chain leg;
      const int ankle = joint((s + "ankle").c_str());
      leg.nodes = {{joint((s + "hip").c_str()), {0, 0, 0}}, {joint((s + "knee").c_str()), {0, 0, 0}}, {ankle, {0, 0, 0}}};
      leg.beyond = {ankle, skeleton.tip_m(ankle)};
      leg.resize();
      chains.push_back(leg);
    }
  }

  // Rest posture for measuring the layout.
  const Pose zero = skeleton.zero_pose();
  forward_kinematics(skeleton, zero, world_from_joint);
  field.update(world_from_joint, zero.dof_rad);
  for (Chain& c : chains) c.update(world_from_joint);

  // Torso rings: crotch → waist (lower_torso), waist → chest (upper_torso), spaced by arc length.
  const int M = L.torso_points;
  const int torso_directions = add_directions(torso_angles(L));
  const Chain& tc = chains[0];
  std::vector<float> cum(tc.point.size(), 0.0f);
  for (size_t i = 1; i < cum.size(); ++i) cum[i] = cum[i - 1] + glm::length(tc.point[i] - tc.point[i - 1]);
  auto at_length = [&](float s, int& seg, float& u) {
    seg = 0;
    while (seg + 2 < static_cast<int>(cum.size()) && s > cum[seg + 1]) ++seg;
    const float len = cum[seg + 1] - cum[seg];
    u = len > 1e-9f ? std::clamp((s - cum[seg]) / len, 0.0f, 1.0f) : 0.0f;
  };
  const float waist_s = 0.5f * (cum[2] + cum[3]);
  const int lower_n = L.lower_torso_contours, upper_n = L.upper_torso_contours;
  const int torso_n = lower_n + upper_n - 1;
  std::vector<int> torso_rings;
  for (int i = 0; i < torso_n; ++i) {
    const float s = i < lower_n ? waist_s * static_cast<float>(i) / static_cast<float>(lower_n - 1)
                                : waist_s + (cum.back() - waist_s) * static_cast<float>(i - lower_n + 1) /
                                                static_cast<float>(upper_n - 1);
    Ring r;
    r.name = "torso_" + std::to_string(i);
    r.kind = RingKind::star;
    r.chain = 0;
    at_length(s, r.segment, r.u);
    r.angles = torso_directions;
    // The waist ring is shared by both torso pieces: it sees both groups.
    r.mask = i < 2             ? group_bit(Group::hip)
             : i < lower_n - 1 ? group_bit(Group::lower_torso)
             : i == lower_n - 1 ? GroupMask(group_bit(Group::lower_torso) | group_bit(Group::upper_torso))
                                : group_bit(Group::upper_torso);
    torso_rings.push_back(add_ring(std::move(r), M));
  }
  const Ring& crotch_ring = rings[torso_rings.front()];
  const int chest_id = torso_rings.back();
  std::vector<uint32_t> chest_slots = rings[chest_id].slots, crotch_slots = crotch_ring.slots;

  // Bridges: under the crotch (front → back), over each shoulder (front armpit → back armpit).
  const int half = M / 2;
  const int f_half = L.chest_front_arc / 2;
  const int fl = f_half, kl = f_half + L.chest_side_arc;
  const int kr = kl + L.chest_front_arc, fr = kr + L.chest_side_arc;
  auto add_arc = [&](const std::string& name, GroupMask mask, uint32_t from, uint32_t to, int segs, int up_ring,
                     bool flip) {
    Ring r;
    r.name = name;
    r.kind = RingKind::arc;
    r.mask = mask;
    r.from = from;
    r.to = to;
    r.up_ring = up_ring;
    r.flip_up = flip;
    // A half star from the chord's middle, the interior points at k·π/segs.
    std::vector<float> arc_angles(static_cast<size_t>(std::max(segs - 1, 0)));
    for (int k = 1; k < segs; ++k) arc_angles[static_cast<size_t>(k - 1)] = kPi * static_cast<float>(k) / static_cast<float>(segs);
    r.angles = add_directions(arc_angles);
    return add_ring(std::move(r), segs - 1);
  };
  const int crotch_bridge =
      add_arc("crotch_bridge", group_bit(Group::hip), crotch_slots[0], crotch_slots[half], L.crotch_bridge, torso_rings.front(), true);
  const int l_bridge = add_arc("l_shoulder_bridge", group_bit(Group::left_shoulder), chest_slots[fl], chest_slots[kl],
                               L.shoulder_bridge, chest_id, false);
  const int r_bridge = add_arc("r_shoulder_bridge", group_bit(Group::right_shoulder), chest_slots[fr], chest_slots[kr],
                               L.shoulder_bridge, chest_id, false);
  bridges.push_back(Bridge{crotch_bridge, 0, 0, {}, {}});
  bridges.push_back(Bridge{l_bridge, 0, 0, {}, {}});
  bridges.push_back(Bridge{r_bridge, 0, 0, {}, {}});

  // Compute what exists so far in the rest posture: the loops' geometry sets the limb angles.
  size_ring_buffers();
  for (const Ring& r : rings) compute_ring(r);

  auto slots_of = [&](int ring) -> const std::vector<uint32_t>& { return rings[ring].slots; };
  // Loops, each ordered counter-clockwise about its limb's direction (outward-facing quads).
  std::vector<uint32_t> l_leg_loop, r_leg_loop, l_arm_loop, r_arm_loop, neck_loop;
  {
    const auto& cb = slots_of(crotch_bridge);
    l_leg_loop.push_back(crotch_slots[0]);
    for (uint32_t s : cb) l_leg_loop.push_back(s);
    l_leg_loop.push_back(crotch_slots[half]);
    for (int j = half - 1; j >= 1; --j) l_leg_loop.push_back(crotch_slots[j]);
    r_leg_loop.push_back(crotch_slots[0]);
    for (int j = M - 1; j > half; --j) r_leg_loop.push_back(crotch_slots[j]);
    r_leg_loop.push_back(crotch_slots[half]);
    for (auto it = cb.rbegin(); it != cb.rend(); ++it) r_leg_loop.push_back(*it);

    const auto& lb = slots_of(l_bridge);
    const auto& rb = slots_of(r_bridge);
    for (int j = fl; j <= kl; ++j) l_arm_loop.push_back(chest_slots[j]);
    for (auto it = lb.rbegin(); it != lb.rend(); ++it) l_arm_loop.push_back(*it);
    r_arm_loop.push_back(chest_slots[fr]);
    for (uint32_t s : rb) r_arm_loop.push_back(s);
    for (int j = kr; j < fr; ++j) r_arm_loop.push_back(chest_slots[j]);

    for (int j = 0; j <= fl; ++j) neck_loop.push_back(chest_slots[j]);
    for (uint32_t s : lb) neck_loop.push_back(s);
    for (int j = kl; j <= kr; ++j) neck_loop.push_back(chest_slots[j]);
    for (auto it = rb.rbegin(); it != rb.rend(); ++it) neck_loop.push_back(*it);
    for (int j = fr; j < M; ++j) neck_loop.push_back(chest_slots[j]);
  }

  // Torso surface.
  {
    Surface s;
    s.name = "torso";
    s.rows = torso_rings;
    s.parts = {{"lower_torso", 0}, {"upper_torso", lower_n - 1}};
    surfaces.push_back(std::move(s));
  }

  // Limbs and neck: loop, k boundary-driven rings, then star rings along the chain.
  struct LimbSpec {
    const char* name;
    int chain;
    std::vector<uint32_t>* loop;
    GroupMask upper, lower;
    GroupMask junction;  // the groups the loop was sampled in, also seen by the driven rings
    int upper_rows, lower_rows;  // lower_rows 0: a single-piece surface (the neck)
    float start_u;               // S ring position along the first link
    const char* upper_part;
    const char* lower_part;
  };
  const LimbSpec limbs[] = {
      {"neck", 1, &neck_loop, group_bit(Group::upper_torso), 0, group_bit(Group::upper_torso), L.neck_contours, 0,
       L.neck_start, "neck", nullptr},
      {"l_arm", 2, &l_arm_loop, group_bit(Group::left_upper_arm), group_bit(Group::left_lower_arm),
       group_bit(Group::left_shoulder), L.upper_arm_contours, L.lower_arm_contours, 0.3f, "left_upper_arm",
       "left_lower_arm"},
      {"r_arm", 3, &r_arm_loop, group_bit(Group::right_upper_arm), group_bit(Group::right_lower_arm),
       group_bit(Group::right_shoulder), L.upper_arm_contours, L.lower_arm_contours, 0.3f, "right_upper_arm",
       "right_lower_arm"},
      {"l_leg", 4, &l_leg_loop, group_bit(Group::left_upper_leg), group_bit(Group::left_lower_leg), group_bit(Group::hip),
       L.upper_leg_contours, L.lower_leg_contours, 0.25f, "left_upper_leg", "left_lower_leg"},
      {"r_leg", 5, &r_leg_loop, group_bit(Group::right_upper_leg), group_bit(Group::right_lower_leg), group_bit(Group::hip),
       L.upper_leg_contours, L.lower_leg_contours, 0.25f, "right_upper_leg", "right_lower_leg"},
  };
  const int k = L.boundary_contours;
  for (const LimbSpec& spec : limbs) {
    const std::vector<uint32_t>& loop = *spec.loop;
    const int n = static_cast<int>(loop.size());
    const Chain& c = chains[spec.chain];
    const bool single = spec.lower_rows == 0;
    // Star rings: S at start_u of the first link, to the chain's end (neck: over both links).
    const int star_upper = spec.upper_rows - 1 - k;  // including S and the joint ring
    std::vector<std::pair<int, float>> positions;      // (segment, u)
    if (single) {
      // Neck: S … top spread over the two links by length.
      const float l0 = glm::length(c.point[1] - c.point[0]), l1 = glm::length(c.point[2] - c.point[1]);
      const float s0 = spec.start_u * l0, total = l0 + l1;
      for (int i = 0; i < star_upper; ++i) {
        const float s = s0 + (total - s0) * static_cast<float>(i) / static_cast<float>(star_upper - 1);
        positions.push_back(s <= l0 && l0 > 0 ? std::pair{0, s / l0} : std::pair{1, l1 > 0 ? std::min(1.0f, (s - l0) / l1) : 1.0f});
      }
    } else {
      for (int i = 0; i < star_upper; ++i)
        positions.push_back({0, spec.start_u + (1.0f - spec.start_u) * static_cast<float>(i) / static_cast<float>(star_upper - 1)});
      for (int i = 1; i < spec.lower_rows; ++i)
        positions.push_back({1, static_cast<float>(i) / static_cast<float>(spec.lower_rows - 1)});
    }
    // Angles facing the loop, measured on the S plane in the rest posture.
    std::vector<glm::vec3> goal_points;
    for (uint32_t s : loop) goal_points.push_back(ctrl[s]);
    const int angles = add_directions(angles_facing(ring_plane(c, positions[0].first, positions[0].second), goal_points));

    std::vector<int> star_ids;
    for (size_t i = 0; i < positions.size(); ++i) {
      Ring r;
      r.name = std::string(spec.name) + "_" + std::to_string(i);
      r.kind = RingKind::star;
      r.chain = spec.chain;
      r.segment = positions[i].first;
      r.u = positions[i].second;
      r.angles = angles;
      // The joint ring (elbow, knee) is shared by both pieces: it sees both groups.
      const int ii = static_cast<int>(i);
      r.mask = (single || ii < star_upper - 1) ? spec.upper
               : ii == star_upper - 1          ? GroupMask(spec.upper | spec.lower)
                                               : spec.lower;
      star_ids.push_back(add_ring(std::move(r), n));
    }
    std::vector<int> driven_ids;
    for (int i = 1; i <= k; ++i) {
      Ring r;
      r.name = std::string(spec.name) + "_driven_" + std::to_string(i);
      r.kind = RingKind::driven;
      // The ring nearest the loop sees the loop's own groups too, so the shapes flow into
      // each other and an extreme posture cannot leave its rays with nothing to hit.
      r.mask = i == 1 ? GroupMask(spec.upper | spec.junction) : spec.upper;
      r.s_ring = star_ids[0];
      r.goal = loop;
      r.alpha = 1.0f - static_cast<float>(i) / static_cast<float>(k + 1);
      driven_ids.push_back(add_ring(std::move(r), n));
    }
    Surface s;
    s.name = spec.name;
    s.loop_start = true;
    s.first_row = loop;
    s.rows.push_back(-1);  // row 0: the loop
    for (int id : driven_ids) s.rows.push_back(id);
    for (int id : star_ids) s.rows.push_back(id);
    s.cap = true;
    s.parts.push_back({spec.upper_part, 0});
    if (!single) s.parts.push_back({spec.lower_part, spec.upper_rows - 1});
    surfaces.push_back(std::move(s));
  }
  // Rigid parts, sampled once in the rest posture and kept in their joint's frame.
  if (options.rigid_parts) {
    for (int pi = 1; pi <= kRigidPartCount; ++pi) {
      const RigidPart part = static_cast<RigidPart>(pi);
      std::vector<uint16_t> cand(kMaxCandidates);
      const int n = field.candidates_of_part(part, cand);
      if (n == 0) continue;
      cand.resize(n);
      int jnt = -1;
      for (const Primitive& p : model.primitives)
        if (p.part == part) jnt = skeleton.find_joint(p.joint);
      glm::vec3 centre(0);
      for (uint16_t i : cand) centre += field.center(i);
      centre /= static_cast<float>(n);
      const RigidTransform& w = world_from_joint[jnt];
      const glm::vec3 axis = safe_normalize(w.apply_vector(skeleton.tip_m(jnt)), {0, 1, 0});
      const glm::vec3 front0 = std::abs(axis.z) < 0.9f ? glm::vec3(0, 0, 1) : glm::vec3(0, 1, 0);
      const glm::vec3 front = glm::normalize(front0 - glm::dot(front0, axis) * axis);
      const glm::vec3 left = glm::cross(axis, front);
      RigidMesh rm;
      rm.part = part;
      rm.joint = jnt;
      const RigidTransform local_from_world = w.inverse();
      auto sample = [&](const glm::vec3& d) {
        const RayHit h = field.cast_outermost(centre, d, cand);
        const glm::vec3 p = centre + (h.hit() ? h.t : kMissRadius_m) * d;
        rm.local.push_back(local_from_world.apply(p));
      };
      sample(-axis);
      for (int ri = 1; ri <= L.rigid_rings; ++ri) {
        const float theta = kPi * static_cast<float>(ri) / static_cast<float>(L.rigid_rings + 1);
        for (int pj = 0; pj < L.rigid_points; ++pj) {
          const float phi = kTwoPi * static_cast<float>(pj) / static_cast<float>(L.rigid_points);
          sample(-std::cos(theta) * axis + std::sin(theta) * (std::cos(phi) * front + std::sin(phi) * left));
        }
      }
      sample(axis);
      rigid.push_back(std::move(rm));
    }
  }
  size_ring_buffers();
  build_output();
  return {};
}

// ---------------------------------------------------------------------------------------------
// Output topology

namespace {

void append_band(std::vector<uint32_t>& idx, const std::vector<uint32_t>& a, const std::vector<uint32_t>& b) {
  const size_t n = a.size();
  for (size_t j = 0; j < n; ++j) {
    const size_t j1 = (j + 1) % n;
    idx.insert(idx.end(), {a[j], a[j1], b[j1]});
    idx.insert(idx.end(), {a[j], b[j1], b[j]});
  }
}

}  // namespace

void BodySkin::Impl::build_output() {
  const int sub = options.subdivision;
  std::vector<glm::vec3>& pos = mesh.positions;
  pos.clear();
  auto new_vertices = [&](size_t n) {
    const uint32_t first = static_cast<uint32_t>(pos.size());
    pos.resize(pos.size() + n);
    return first;
  };
  auto range = [](uint32_t first, size_t n) {
    std::vector<uint32_t> v(n);
    for (size_t i = 0; i < n; ++i) v[i] = first + static_cast<uint32_t>(i);
    return v;
  };

  if (sub == 0) {
    // Realtime mode: control points are the vertices.
    new_vertices(ctrl.size());
    for (Surface& s : surfaces) {
      s.out_rows.clear();
      s.out_row_of_control.clear();
      for (size_t r = 0; r < s.rows.size(); ++r) {
        s.out_rows.push_back(s.rows[r] < 0 ? s.first_row : rings[s.rows[r]].slots);
        s.out_row_of_control.push_back(static_cast<int>(r));
      }
    }
  } else {
    // Torso first (its first and last output rows carry the loops), then bridges, then limbs.
    Surface& torso = surfaces[0];
    const int m = static_cast<int>(rings[torso.rows[0]].slots.size());
    const int cols = m * sub;
    const int out_n = (static_cast<int>(torso.rows.size()) - 1) * sub + 1;
    torso.around = periodic_cubic_taps(m, sub);
    torso.along = clamped_cubic_taps(static_cast<int>(torso.rows.size()), out_n);
    for (int o = 0; o < out_n; ++o) torso.out_rows.push_back(range(new_vertices(cols), cols));
    for (size_t r = 0; r < torso.rows.size(); ++r) torso.out_row_of_control.push_back(static_cast<int>(r) * sub);
    const std::vector<uint32_t>& bottom = torso.out_rows.front();
    const std::vector<uint32_t>& top = torso.out_rows.back();
    const int half = m / 2;
    const int f_half = layout.chest_front_arc / 2;
    const int fl = f_half, kl = f_half + layout.chest_side_arc;
    const int kr = kl + layout.chest_front_arc, fr = kr + layout.chest_side_arc;
    const std::pair<uint32_t, uint32_t> ends[3] = {{bottom[0], bottom[half * sub]},
                                                   {top[fl * sub], top[kl * sub]},
                                                   {top[fr * sub], top[kr * sub]}};
    for (int b = 0; b < 3; ++b) {
      Bridge& br = bridges[b];
      const int segs = static_cast<int>(rings[br.ring].slots.size()) + 1;
      br.out_from = ends[b].first;
      br.out_to = ends[b].second;
      br.taps = clamped_cubic_taps(segs + 1, segs * sub + 1);
      br.out_interior = range(new_vertices(segs * sub - 1), segs * sub - 1);
    }
    auto bridge_out = [&](int b, bool reversed) {
      std::vector<uint32_t> v = bridges[b].out_interior;
      if (reversed) std::reverse(v.begin(), v.end());
      return v;
    };
    auto top_range = [&](int from, int to) {  // inclusive, increasing, wrapping
      std::vector<uint32_t> v;
      for (int j = from;; j = (j + 1) % cols) {
        v.push_back(top[j]);
        if (j == to) break;
      }
      return v;
    };
    std::vector<std::vector<uint32_t>> loops(5);
    {
      // Same orders as the control loops (see build()).
      auto& nl = loops[0];
      auto a = top_range(0, fl * sub);
      nl.insert(nl.end(), a.begin(), a.end());
      auto lb = bridge_out(1, false);
      nl.insert(nl.end(), lb.begin(), lb.end());
      a = top_range(kl * sub, kr * sub);
      nl.insert(nl.end(), a.begin(), a.end());
      auto rb = bridge_out(2, true);
      nl.insert(nl.end(), rb.begin(), rb.end());
      a = top_range(fr * sub, cols - 1);
      nl.insert(nl.end(), a.begin(), a.end());

      auto& la = loops[1];
      a = top_range(fl * sub, kl * sub);
      la.insert(la.end(), a.begin(), a.end());
      lb = bridge_out(1, true);
      la.insert(la.end(), lb.begin(), lb.end());

      auto& ra = loops[2];
      ra.push_back(top[fr * sub]);
      rb = bridge_out(2, false);
      ra.insert(ra.end(), rb.begin(), rb.end());
      a = top_range(kr * sub, fr * sub - 1);
      ra.insert(ra.end(), a.begin(), a.end());

      auto& ll = loops[3];
      ll.push_back(bottom[0]);
      auto cb = bridge_out(0, false);
      ll.insert(ll.end(), cb.begin(), cb.end());
      for (int j = half * sub; j >= 1; --j) ll.push_back(bottom[j]);

      auto& rl = loops[4];
      rl.push_back(bottom[0]);
      for (int j = cols - 1; j >= half * sub; --j) rl.push_back(bottom[j]);
      cb = bridge_out(0, true);
      rl.insert(rl.end(), cb.begin(), cb.end());
    }
    for (size_t si = 1; si < surfaces.size(); ++si) {
      Surface& s = surfaces[si];
      const int n = static_cast<int>(s.first_row.size());
      const int c = n * sub;
      const int rows_out = (static_cast<int>(s.rows.size()) - 1) * sub + 1;
      s.around = periodic_cubic_taps(n, sub);
      s.along = clamped_cubic_taps(static_cast<int>(s.rows.size()), rows_out);
      s.out_rows.push_back(loops[si - 1]);
      for (int o = 1; o < rows_out; ++o) s.out_rows.push_back(range(new_vertices(c), c));
      for (size_t r = 0; r < s.rows.size(); ++r) s.out_row_of_control.push_back(static_cast<int>(r) * sub);
    }
    size_t cells = 0;
    for (const Surface& s : surfaces) {
      const size_t n = s.rows[0] < 0 ? s.first_row.size() : rings[s.rows[0]].slots.size();
      cells = std::max(cells, n * s.rows.size() * sub);
    }
    scratch_rows.resize(cells);
    scratch_grid.resize(cells);
    scratch_poly.resize(1024);
  }
  for (Surface& s : surfaces)
    if (s.cap) s.cap_vertex = new_vertices(1);
  for (RigidMesh& rm : rigid) rm.first_vertex = new_vertices(rm.local.size());

  // Triangles, part by part.
  mesh.indices.clear();
  mesh.parts.clear();
  auto begin_part = [&](const std::string& name) {
    MeshPart p;
    p.name = name;
    p.first_triangle = static_cast<uint32_t>(mesh.indices.size() / 3);
    mesh.parts.push_back(p);
  };
  auto end_part = [&]() {
    MeshPart& p = mesh.parts.back();
    p.triangle_count = static_cast<uint32_t>(mesh.indices.size() / 3) - p.first_triangle;
  };
  // Parts in the paper's order: torso pieces, neck, arms, legs, then rigid parts.
  for (Surface& s : surfaces) {
    for (size_t p = 0; p < s.parts.size(); ++p) {
      const int row_from = s.out_row_of_control[s.parts[p].second];
      const int row_to = p + 1 < s.parts.size() ? s.out_row_of_control[s.parts[p + 1].second]
                                                : static_cast<int>(s.out_rows.size()) - 1;
      begin_part(s.parts[p].first);
      for (int r = row_from; r < row_to; ++r) append_band(mesh.indices, s.out_rows[r], s.out_rows[r + 1]);
      if (s.cap && p + 1 == s.parts.size()) {
        const auto& last = s.out_rows.back();
        for (size_t j = 0; j < last.size(); ++j)
          mesh.indices.insert(mesh.indices.end(), {last[j], last[(j + 1) % last.size()], s.cap_vertex});
      }
      end_part();
    }
  }
  for (const RigidMesh& rm : rigid) {
    begin_part(rigid_part_name(rm.part));
    const uint32_t south = rm.first_vertex;
    const uint32_t rings_n = static_cast<uint32_t>(layout.rigid_rings), pts = static_cast<uint32_t>(layout.rigid_points);
    const uint32_t north = south + 1 + rings_n * pts;
    auto ring = [&](uint32_t r) {
      std::vector<uint32_t> v(pts);
      for (uint32_t j = 0; j < pts; ++j) v[j] = south + 1 + r * pts + j;
      return v;
    };
    const auto first = ring(0);
    for (uint32_t j = 0; j < pts; ++j) mesh.indices.insert(mesh.indices.end(), {first[(j + 1) % pts], first[j], south});
    for (uint32_t r = 0; r + 1 < rings_n; ++r) append_band(mesh.indices, ring(r), ring(r + 1));
    const auto last = ring(rings_n - 1);
    for (uint32_t j = 0; j < pts; ++j) mesh.indices.insert(mesh.indices.end(), {last[j], last[(j + 1) % pts], north});
    end_part();
  }
  if (options.normals) {
    mesh.normals.assign(pos.size(), glm::vec3(0, 1, 0));
    normal_sums.assign(pos.size(), glm::vec4(0));
  }
}

// ---------------------------------------------------------------------------------------------
// Per frame

void BodySkin::Impl::evaluate_bspline() {
  std::vector<glm::vec3>& pos = mesh.positions;
  if (options.subdivision == 0) {
    std::copy(ctrl.begin(), ctrl.end(), pos.begin());
    return;
  }
  const int sub = options.subdivision;
  for (size_t si = 0; si < surfaces.size(); ++si) {
    const Surface& s = surfaces[si];
    const size_t rows = s.rows.size();
    const std::vector<uint32_t>& row0 = s.rows[0] < 0 ? s.first_row : rings[s.rows[0]].slots;
    const size_t n = row0.size();
    const size_t cols = n * sub;
    // Around: each control row → cols samples (closed curve).
    for (size_t r = 0; r < rows; ++r) {
      const std::vector<uint32_t>& slots = s.rows[r] < 0 ? s.first_row : rings[s.rows[r]].slots;
      glm::vec3* dst = &scratch_rows[r * cols];
      for (size_t c = 0; c < cols; ++c) {
        const BsplineTap& t = s.around[c];
        dst[c] = t.weight[0] * ctrl[slots[t.index[0]]] + t.weight[1] * ctrl[slots[t.index[1]]] +
                 t.weight[2] * ctrl[slots[t.index[2]]] + t.weight[3] * ctrl[slots[t.index[3]]];
      }
    }
    // Along: clamped; limbs keep their first row from the torso/bridges (shared vertices).
    const size_t first_out = s.loop_start ? 1 : 0;
    for (size_t o = first_out; o < s.out_rows.size(); ++o) {
      const BsplineTap& t = s.along[o];
      const glm::vec3* r0 = &scratch_rows[t.index[0] * cols];
      const glm::vec3* r1 = &scratch_rows[t.index[1] * cols];
      const glm::vec3* r2 = &scratch_rows[t.index[2] * cols];
      const glm::vec3* r3 = &scratch_rows[t.index[3] * cols];
      const std::vector<uint32_t>& out = s.out_rows[o];
      for (size_t c = 0; c < cols; ++c)
        pos[out[c]] = t.weight[0] * r0[c] + t.weight[1] * r1[c] + t.weight[2] * r2[c] + t.weight[3] * r3[c];
    }
    if (si == 0) {
      // Bridges hang between torso vertices: polygon [end, interior…, end], clamped.
      for (const Bridge& b : bridges) {
        const std::vector<uint32_t>& interior = rings[b.ring].slots;
        const size_t np = interior.size() + 2;
        scratch_poly[0] = pos[b.out_from];
        for (size_t i = 0; i < interior.size(); ++i) scratch_poly[i + 1] = ctrl[interior[i]];
        scratch_poly[np - 1] = pos[b.out_to];
        for (size_t i = 0; i < b.out_interior.size(); ++i)
          pos[b.out_interior[i]] = apply_tap(b.taps[i + 1], scratch_poly);
      }
    }
  }
}

void BodySkin::Impl::update_normals() {
  // Summed in 16-byte slots: neighbouring triangles share vertices, and a 12-byte vec3 read
  // back right after its two-part store cannot be forwarded (half the frame went there).
  std::vector<glm::vec4>& acc = normal_sums;
  std::fill(acc.begin(), acc.end(), glm::vec4(0));
  const auto& pos = mesh.positions;
  const auto& idx = mesh.indices;
  for (size_t t = 0; t + 2 < idx.size(); t += 3) {
    const glm::vec3 a = pos[idx[t]], b = pos[idx[t + 1]], c = pos[idx[t + 2]];
    const glm::vec4 n(glm::cross(b - a, c - a), 0.0f);  // length = twice the area: area weighting
    acc[idx[t]] += n;
    acc[idx[t + 1]] += n;
    acc[idx[t + 2]] += n;
  }
  std::vector<glm::vec3>& nrm = mesh.normals;
  for (size_t v = 0; v < nrm.size(); ++v) nrm[v] = safe_normalize(glm::vec3(acc[v]), {0, 1, 0});
}

// ---------------------------------------------------------------------------------------------

BodySkin::BodySkin(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
BodySkin::BodySkin(BodySkin&&) noexcept = default;
BodySkin& BodySkin::operator=(BodySkin&&) noexcept = default;
BodySkin::~BodySkin() = default;

Result<BodySkin> BodySkin::create(const BodyModel& model, const SkinOptions& options) {
  auto skeleton = Skeleton::build(model.skeleton);
  if (!skeleton) return tl::unexpected(skeleton.error());
  return create(model, *skeleton, options);
}

Result<BodySkin> BodySkin::create(const BodyModel& model, const Skeleton& skeleton, const SkinOptions& options) {
  if (auto st = validate(model); !st) return tl::unexpected(st.error());
  if (options.subdivision < 0 || options.subdivision > 16)
    return fail(Errc::invalid_argument, "subdivision must be in [0, 16]");
  auto field = BodyField::create(model, skeleton);
  if (!field) return tl::unexpected(field.error());
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->skeleton = skeleton;
  impl->field = std::move(*field);
  if (auto st = impl->build(model); !st) return tl::unexpected(st.error());
  BodySkin skin(std::move(impl));
  skin.evaluate(skin.impl_->skeleton.zero_pose());
  return skin;
}

void BodySkin::stage_fk(const Pose& pose) {
  const auto t0 = Clock::now();
  forward_kinematics(impl_->skeleton, pose, impl_->world_from_joint);
  impl_->timings.fk_us = micros_since(t0);
}

void BodySkin::stage_deform(const Pose& pose) {
  const auto t0 = Clock::now();
  impl_->field.update(impl_->world_from_joint, pose.dof_rad);
  for (Chain& c : impl_->chains) c.update(impl_->world_from_joint);
  impl_->timings.deform_us = micros_since(t0);
}

void BodySkin::stage_contours() {
  const auto t0 = Clock::now();
  Impl& m = *impl_;
  m.stats = {};
  for (const Ring& r : m.rings) m.compute_ring(r);
  m.timings.contours_us = micros_since(t0);
}

void BodySkin::stage_bspline() {
  const auto t0 = Clock::now();
  impl_->evaluate_bspline();
  impl_->timings.bspline_us = micros_since(t0);
}

void BodySkin::stage_stitch() {
  const auto t0 = Clock::now();
  Impl& m = *impl_;
  auto& pos = m.mesh.positions;
  for (const Surface& s : m.surfaces) {
    if (!s.cap) continue;
    glm::vec3 c(0);
    for (uint32_t v : s.out_rows.back()) c += pos[v];
    pos[s.cap_vertex] = c / static_cast<float>(s.out_rows.back().size());
  }
  for (const RigidMesh& rm : m.rigid) {
    const RigidTransform& w = m.world_from_joint[rm.joint];
    for (size_t i = 0; i < rm.local.size(); ++i) pos[rm.first_vertex + i] = w.apply(rm.local[i]);
  }
  m.timings.stitch_us = micros_since(t0);
  if (m.options.normals) {
    const auto t1 = Clock::now();
    m.update_normals();
    m.timings.normals_us = micros_since(t1);
  }
}

void BodySkin::evaluate(const Pose& pose) {
  stage_fk(pose);
  stage_deform(pose);
  stage_contours();
  stage_bspline();
  stage_stitch();
}

const Mesh& BodySkin::mesh() const { return impl_->mesh; }
const Skeleton& BodySkin::skeleton() const { return impl_->skeleton; }
const BodyField& BodySkin::field() const { return impl_->field; }
const SkinTimings& BodySkin::timings() const { return impl_->timings; }
const SkinStats& BodySkin::stats() const { return impl_->stats; }

std::vector<BodySkin::ContourView> BodySkin::contours() const {
  std::vector<ContourView> out;
  for (const Ring& r : impl_->rings) {
    ContourView v;
    v.name = r.name;
    v.mask = r.mask;
    for (uint32_t s : r.slots) {
      v.points.push_back(impl_->ctrl[s]);
      v.ray_origins.push_back(impl_->ctrl_origin[s]);
      v.from_ray.push_back(impl_->ctrl_hit[s]);
    }
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace mimic::avatar
