// The contour layout of a body (contour_layout.h), built once, piece by piece: chains along the
// skeleton, torso rings, bridges, the loops where limbs meet the torso, each limb's rings (star and
// boundary-driven) and the rigid parts sampled in the zero posture. topology.cpp adds the output
// mesh's rows and triangles.
#include <array>
#include <cassert>
#include <limits>

#include "rigid_part_mesh.h"
#include "skin_impl.h"

namespace mimic::avatar {

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

// Angles of a limb's first ring. Even (`face_loop` off): n equal steps round the limb, the first
// facing the loop's first point. Facing the loop: point j faces the loop's point j, so the
// columns run straight from the junction down the limb, with every gap at least a third of an
// even one — a narrow gap after point 0 pushes the points after it on, a narrow closing gap (before
// point 0, going round) pushes the points before it back, the same rule for a loop and for its
// mirror image, which is traversed the other way round. Measured in the rest posture.
std::vector<float> ring_angles(const Plane& p, std::span<const glm::vec3> loop, bool face_loop) {
  const size_t n = loop.size();
  std::vector<float> a(n);
  auto even = [&] {
    for (size_t j = 1; j < n; ++j) a[j] = a[0] + kTwoPi * static_cast<float>(j) / static_cast<float>(n);
  };
  for (size_t j = 0; j < (face_loop ? n : 1); ++j) {
    const glm::vec3 v = loop[j] - p.origin;
    a[j] = std::atan2(glm::dot(v, p.left), glm::dot(v, p.front));
  }
  if (!face_loop || n < 3) {
    even();
    return a;
  }
  bool ok = true;
  for (size_t j = 1; j < n; ++j) {
    while (a[j] <= a[j - 1]) a[j] += kTwoPi;
    if (a[j] - a[j - 1] > kPi) ok = false;
  }
  if (!ok || a[n - 1] - a[0] >= kTwoPi) even();
  const float min_gap = kTwoPi / static_cast<float>(n) / 3.0f;
  if (a[n - 1] > a[0] + kTwoPi - min_gap) {
    a[n - 1] = a[0] + kTwoPi - min_gap;
    for (size_t j = n - 1; j-- > 1;) a[j] = std::min(a[j], a[j + 1] - min_gap);
  }
  for (size_t j = 1; j < n; ++j) a[j] = std::max(a[j], a[j - 1] + min_gap);
  if (a[n - 1] - a[0] > kTwoPi - min_gap) even();
  return a;
}

// The angles of a ring of m points spread as `a` (n increasing angles within one turn) spreads
// its n: point i at a's fractional index i·n/m. A limb's own rings keep the columns of its first
// ring at their normalised index, which is how the zipper between them pairs points.
std::vector<float> resampled_angles(std::span<const float> a, int m) {
  const size_t n = a.size();
  std::vector<float> out(static_cast<size_t>(m));
  for (int i = 0; i < m; ++i) {
    const float t = static_cast<float>(i) * static_cast<float>(n) / static_cast<float>(m);
    const size_t j = std::min(static_cast<size_t>(t), n - 1);
    const float next = j + 1 < n ? a[j + 1] : a[0] + kTwoPi;
    out[static_cast<size_t>(i)] = a[j] + (t - static_cast<float>(j)) * (next - a[j]);
  }
  return out;
}

// The forefoot of a rigid part whose joint has a child joint that moves (a foot and its toes):
// each vertex's weight for the child, by how far ahead of the child's joint centre it lies
// along the child's link, in the rest posture the part was sampled in.
void bind_toes(RigidMesh& rm, const rig::Skeleton& skeleton, std::span<const rig::RigidTransform> world_from_joint) {
  int child = -1;
  for (int j = 0; j < skeleton.joint_count() && child < 0; ++j)
    if (skeleton.parent(j) == rm.joint && skeleton.dof_end(j) > skeleton.dof_begin(j)) child = j;
  if (child < 0 || glm::length(skeleton.tip_m(child)) < 1e-4f) return;
  const rig::RigidTransform& part = world_from_joint[rm.joint];
  const rig::RigidTransform& toes = world_from_joint[child];
  const glm::vec3 ahead = glm::normalize(toes.apply_vector(skeleton.tip_m(child)));
  const rig::RigidTransform toes_from_world = toes.inverse();
  for (size_t i = 0; i < rm.local.size(); ++i) {
    const glm::vec3 p = part.apply(rm.local[i]);
    const float s = glm::dot(p - toes.translation, ahead);
    const float u = std::clamp((s + kToeBlendBack_m) / (kToeBlendBack_m + kToeBlendFront_m), 0.0f, 1.0f);
    if (u <= 0.0f) continue;
    rm.toe_vertex.push_back(static_cast<uint32_t>(i));
    rm.toe_weight.push_back(u * u * (3.0f - 2.0f * u));
    rm.toe_local.push_back(toes_from_world.apply(p));
  }
  if (!rm.toe_vertex.empty()) rm.toe_joint = child;
}

// ---------------------------------------------------------------------------------------------
// Pieces

using Data = ContourLayout::Data;

int add_directions(Data& d, std::span<const float> angles_rad) {
  Directions dir;
  for (float a : angles_rad) dir.cos.push_back(std::cos(a)), dir.sin.push_back(std::sin(a));
  d.direction_tables.push_back(std::move(dir));
  return static_cast<int>(d.direction_tables.size()) - 1;
}

// A ring of `count` new control points, after every ring so far.
int add_ring(Data& d, Ring r, int count) {
  for (int i = 0; i < count; ++i) r.slots.push_back(d.control_points + static_cast<uint32_t>(i));
  d.control_points += static_cast<uint32_t>(count);
  d.rings.push_back(std::move(r));
  return static_cast<int>(d.rings.size()) - 1;
}

constexpr const char* kSkinJoints[] = {"pelvis",     "spine_lower", "spine_mid",  "spine_upper", "neck",
                                       "neck_upper", "head",        "l_shoulder", "l_elbow",     "l_wrist",
                                       "r_shoulder", "r_elbow",     "r_wrist",    "l_hip",       "l_knee",
                                       "l_ankle",    "r_hip",       "r_knee",     "r_ankle"};

Chain torso_chain(const rig::Skeleton& sk, const SkinLayout& L) {
  Chain torso;
  const int pelvis = sk.find_joint("pelvis"), su = sk.find_joint("spine_upper");
  torso.nodes = {
      {pelvis, {0, -L.crotch_drop_m, 0}},      {pelvis, {0, 0, 0}}, {sk.find_joint("spine_lower"), {0, 0, 0}},
      {sk.find_joint("spine_mid"), {0, 0, 0}}, {su, {0, 0, 0}},     {su, L.chest_ring * sk.tip_m(su)}};
  torso.start_normal_from_y = true;
  torso.beyond = {sk.find_joint("neck"), {0, 0, 0}};
  torso.resize();
  return torso;
}

// Three joints in a row, the last link continuing to the end joint's tip (neck, arm, leg).
Chain three_joint_chain(const rig::Skeleton& sk, const std::string& a, const std::string& b, const std::string& c) {
  Chain chain;
  const int end = sk.find_joint(c);
  chain.nodes = {{sk.find_joint(a), {0, 0, 0}}, {sk.find_joint(b), {0, 0, 0}}, {end, {0, 0, 0}}};
  chain.beyond = {end, sk.tip_m(end)};
  chain.resize();
  return chain;
}

// Chains: 0 torso, 1 neck, 2/3 arms, 4/5 legs.
std::vector<Chain> make_chains(const rig::Skeleton& sk, const SkinLayout& L) {
  std::vector<Chain> chains{torso_chain(sk, L), three_joint_chain(sk, "neck", "neck_upper", "head")};
  for (const std::string side : {"l_", "r_"})
    chains.push_back(three_joint_chain(sk, side + "shoulder", side + "elbow", side + "wrist"));
  for (const std::string side : {"l_", "r_"})
    chains.push_back(three_joint_chain(sk, side + "hip", side + "knee", side + "ankle"));
  return chains;
}

// The torso ring's points where its arcs meet (torso_angles): the front of the left armpit
// (fl), its back (kl), the back (kr) and front (fr) of the right one, and the back-centre (half).
struct TorsoMarks {
  int fl = 0, kl = 0, kr = 0, fr = 0, half = 0;
};
TorsoMarks torso_marks(const SkinLayout& L) {
  TorsoMarks t;
  t.fl = L.chest_front_arc / 2;
  t.kl = t.fl + L.chest_side_arc;
  t.kr = t.kl + L.chest_front_arc;
  t.fr = t.kr + L.chest_side_arc;
  t.half = L.torso_points / 2;
  return t;
}

// Torso rings: crotch → waist (lower_torso), waist → chest (upper_torso), spaced by arc length
// along the torso chain in the zero posture.
std::vector<int> add_torso_rings(Data& d) {
  const SkinLayout& L = d.counts;
  const int torso_directions = add_directions(d, torso_angles(L));
  const Chain& tc = d.chains[0];
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
  std::vector<int> ids;
  for (int i = 0; i < lower_n + upper_n - 1; ++i) {
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
    r.mask = i < 2              ? group_bit(Group::hip)
             : i < lower_n - 1  ? group_bit(Group::lower_torso)
             : i == lower_n - 1 ? GroupMask(group_bit(Group::lower_torso) | group_bit(Group::upper_torso))
                                : group_bit(Group::upper_torso);
    ids.push_back(add_ring(d, std::move(r), L.torso_points));
  }
  Surface s;
  s.name = "torso";
  s.rows = ids;
  s.parts = {{"lower_torso", 0}, {"upper_torso", lower_n - 1}};
  d.surfaces.push_back(std::move(s));
  return ids;
}

// A bridge: a half star from the chord's middle between two torso points, bulging away from the
// ring it leaves (its normal, or −normal when `flip`), its interior points at k·π/segs.
int add_arc(Data& d, const std::string& name, GroupMask mask, uint32_t from, uint32_t to, int segs, int up_ring,
            bool flip) {
  Ring r;
  r.name = name;
  r.kind = RingKind::arc;
  r.mask = mask;
  r.from = from;
  r.to = to;
  r.up_ring = up_ring;
  r.flip_up = flip;
  std::vector<float> arc_angles(static_cast<size_t>(std::max(segs - 1, 0)));
  for (int k = 1; k < segs; ++k)
    arc_angles[static_cast<size_t>(k - 1)] = kPi * static_cast<float>(k) / static_cast<float>(segs);
  r.angles = add_directions(d, arc_angles);
  const int id = add_ring(d, std::move(r), segs - 1);
  d.bridges.push_back(Bridge{id, 0, 0, {}, {}});
  return id;
}

// Bridges: under the crotch (front → back), over each shoulder (front armpit → back armpit).
void add_bridges(Data& d, int crotch_ring, int chest_ring) {
  const SkinLayout& L = d.counts;
  const TorsoMarks t = torso_marks(L);
  const std::vector<uint32_t> crotch = d.rings[crotch_ring].slots, chest = d.rings[chest_ring].slots;
  add_arc(d, "crotch_bridge", group_bit(Group::hip), crotch[0], crotch[t.half], L.crotch_bridge, crotch_ring, true);
  add_arc(d, "l_shoulder_bridge", group_bit(Group::left_shoulder), chest[t.fl], chest[t.kl], L.shoulder_bridge,
          chest_ring, false);
  add_arc(d, "r_shoulder_bridge", group_bit(Group::right_shoulder), chest[t.fr], chest[t.kr], L.shoulder_bridge,
          chest_ring, false);
}

// The loops where the limbs leave the torso, each ordered counter-clockwise about its limb's
// direction (outward-facing quads), as control slots.
struct Loops {
  std::vector<uint32_t> neck, l_arm, r_arm, l_leg, r_leg;
};

void leg_loops(const std::vector<uint32_t>& crotch, const std::vector<uint32_t>& cb, int half, Loops& loops) {
  const int m = static_cast<int>(crotch.size());
  loops.l_leg.push_back(crotch[0]);
  for (uint32_t s : cb) loops.l_leg.push_back(s);
  loops.l_leg.push_back(crotch[half]);
  for (int j = half - 1; j >= 1; --j) loops.l_leg.push_back(crotch[j]);
  loops.r_leg.push_back(crotch[0]);
  for (int j = m - 1; j > half; --j) loops.r_leg.push_back(crotch[j]);
  loops.r_leg.push_back(crotch[half]);
  for (auto it = cb.rbegin(); it != cb.rend(); ++it) loops.r_leg.push_back(*it);
}

void arm_loops(const std::vector<uint32_t>& chest, const std::vector<uint32_t>& lb, const std::vector<uint32_t>& rb,
               const TorsoMarks& t, Loops& loops) {
  for (int j = t.fl; j <= t.kl; ++j) loops.l_arm.push_back(chest[j]);
  for (auto it = lb.rbegin(); it != lb.rend(); ++it) loops.l_arm.push_back(*it);
  loops.r_arm.push_back(chest[t.fr]);
  for (uint32_t s : rb) loops.r_arm.push_back(s);
  for (int j = t.kr; j < t.fr; ++j) loops.r_arm.push_back(chest[j]);
}

// The neck's loop, cut short of the armpits (neck_corner): from `a` chest points before each
// armpit point straight to the bridge's point `c`, so that seen along the neck's link it goes
// round the link without climbing; the four corners left are flat patches of the neck.
void neck_loop(Data& d, const std::vector<uint32_t>& chest, const std::vector<uint32_t>& lb,
               const std::vector<uint32_t>& rb, const TorsoMarks& t, Loops& loops) {
  const int m = static_cast<int>(chest.size());
  std::vector<uint32_t> full;
  for (int j = 0; j <= t.fl; ++j) full.push_back(chest[j]);
  for (uint32_t s : lb) full.push_back(s);
  for (int j = t.kl; j <= t.kr; ++j) full.push_back(chest[j]);
  for (auto it = rb.rbegin(); it != rb.rend(); ++it) full.push_back(*it);
  for (int j = t.fr; j < m; ++j) full.push_back(chest[j]);
  const NeckCorner cut = neck_corner(d.counts);
  if (cut.chest > 0) {
    const int a = cut.chest, c = cut.bridge, nb = static_cast<int>(lb.size());
    const int lb0 = t.fl + 1, back_l = lb0 + nb, rb0 = back_l + (t.kr - t.kl + 1), front_r = rb0 + nb;
    d.neck_cuts = {{t.fl - a, lb0 + c, false},
                   {lb0 + nb - 1 - c, back_l + a, true},
                   {back_l + (t.kr - t.kl) - a, rb0 + c, false},
                   {rb0 + nb - 1 - c, front_r + a, true}};
  }
  cut_neck_loop(full, d.neck_cuts, 1, loops.neck, d.corners);
}

Loops make_loops(Data& d, int crotch_ring, int chest_ring) {
  const TorsoMarks t = torso_marks(d.counts);
  const std::vector<uint32_t>& crotch = d.rings[crotch_ring].slots;
  const std::vector<uint32_t>& chest = d.rings[chest_ring].slots;
  const std::vector<uint32_t>& cb = d.rings[d.bridges[0].ring].slots;
  const std::vector<uint32_t>& lb = d.rings[d.bridges[1].ring].slots;
  const std::vector<uint32_t>& rb = d.rings[d.bridges[2].ring].slots;
  Loops loops;
  leg_loops(crotch, cb, t.half, loops);
  arm_loops(chest, lb, rb, t, loops);
  neck_loop(d, chest, lb, rb, t, loops);
  return loops;
}

// A limb (or the neck): its loop, k boundary-driven rings, then star rings along its chain.
struct LimbSpec {
  const char* name;
  int chain;
  const std::vector<uint32_t>* loop;
  GroupMask upper, lower;
  GroupMask junction;          // the groups the loop was sampled in, also seen by the driven rings
  int upper_rows, lower_rows;  // lower_rows 0: a single-piece surface (the neck)
  // S ring position along the first link. Arms: 0.4. Nearer the shoulder (0.3 before) the band
  // between the loop and S is short and, with the arm hanging, nearly flat under the armpit,
  // and its rings cross (exact check over every 40th frame of the shared clips, realtime LOD 0:
  // 47.4 folds a frame with S at 0.3, 38.5 at 0.4). Legs keep 0.25: at 0.4 the groin's band
  // folds less (34.6) but a deep crouch loses 16% of the body's volume in the full method.
  float start_u;
  const char* upper_part;
  const char* lower_part;
  int points;  // of the rings after S; 0: the loop's
  // The columns face the loop's points (the legs) or go round in even steps (the arms, the neck).
  // Even steps fold less where the loop bunches its points (exact check, every 10th frame of the
  // shared clips, realtime LOD 0: 9.4 → 6.6 folds a frame, the upper arms' own 2.3 and 0.9 → 0.2
  // each; the full method 26.6 → 17.4); the legs' even columns fold the right thigh into the
  // belly in the built-in walk at LODs 0 and 1 (0.3 and 0.5 folds a frame), facing ones nowhere.
  bool columns_face_loop;
};

std::array<LimbSpec, 5> limb_specs(const SkinLayout& L, const Loops& loops) {
  auto bit = [](Group g) { return group_bit(g); };
  return {{
      {"neck", 1, &loops.neck, bit(Group::upper_torso), 0, bit(Group::upper_torso), L.neck_contours, 0, L.neck_start,
       "neck", nullptr, L.neck_points, false},
      {"l_arm", 2, &loops.l_arm, bit(Group::left_upper_arm), bit(Group::left_lower_arm), bit(Group::left_shoulder),
       L.upper_arm_contours, L.lower_arm_contours, 0.4f, "left_upper_arm", "left_lower_arm", L.arm_points, false},
      {"r_arm", 3, &loops.r_arm, bit(Group::right_upper_arm), bit(Group::right_lower_arm), bit(Group::right_shoulder),
       L.upper_arm_contours, L.lower_arm_contours, 0.4f, "right_upper_arm", "right_lower_arm", L.arm_points, false},
      {"l_leg", 4, &loops.l_leg, bit(Group::left_upper_leg), bit(Group::left_lower_leg), bit(Group::hip),
       L.upper_leg_contours, L.lower_leg_contours, 0.25f, "left_upper_leg", "left_lower_leg", L.leg_points, true},
      {"r_leg", 5, &loops.r_leg, bit(Group::right_upper_leg), bit(Group::right_lower_leg), bit(Group::hip),
       L.upper_leg_contours, L.lower_leg_contours, 0.25f, "right_upper_leg", "right_lower_leg", L.leg_points, true},
  }};
}

// Where a limb's star rings sit, (segment, u): S at start_u of the first link to the chain's end
// (the neck: spread over both links by length).
std::vector<std::pair<int, float>> limb_ring_positions(const LimbSpec& spec, const Chain& c, int star_upper) {
  std::vector<std::pair<int, float>> positions;
  if (spec.lower_rows == 0) {
    const float l0 = glm::length(c.point[1] - c.point[0]), l1 = glm::length(c.point[2] - c.point[1]);
    const float s0 = spec.start_u * l0, total = l0 + l1;
    for (int i = 0; i < star_upper; ++i) {
      const float s = s0 + (total - s0) * static_cast<float>(i) / static_cast<float>(star_upper - 1);
      positions.push_back(s <= l0 && l0 > 0 ? std::pair{0, s / l0}
                                            : std::pair{1, l1 > 0 ? std::min(1.0f, (s - l0) / l1) : 1.0f});
    }
    return positions;
  }
  for (int i = 0; i < star_upper; ++i)
    positions.push_back(
        {0, spec.start_u + (1.0f - spec.start_u) * static_cast<float>(i) / static_cast<float>(star_upper - 1)});
  for (int i = 1; i < spec.lower_rows; ++i)
    positions.push_back({1, static_cast<float>(i) / static_cast<float>(spec.lower_rows - 1)});
  return positions;
}

// The limb's star rings, S first. S keeps the loop's count of points (the driven rings blend S
// with the loop point for point); the rings after it take the limb's own (its LOD).
std::vector<int> add_limb_stars(Data& d, const LimbSpec& spec, std::span<const glm::vec3> ctrl) {
  const std::vector<uint32_t>& loop = *spec.loop;
  const int n = static_cast<int>(loop.size());
  const int own = spec.points > 0 ? spec.points : n;
  const Chain& c = d.chains[static_cast<size_t>(spec.chain)];
  const bool single = spec.lower_rows == 0;
  const int star_upper = spec.upper_rows - 1 - d.counts.boundary_contours;  // including S and the joint ring
  const std::vector<std::pair<int, float>> positions = limb_ring_positions(spec, c, star_upper);
  // The first ring's angles, measured on the S plane in the zero posture (ring_angles).
  const Plane s_plane = ring_plane(c, positions[0].first, positions[0].second);
  std::vector<glm::vec3> loop_points;
  for (uint32_t s : loop) loop_points.push_back(ctrl[s]);
  const std::vector<float> first = ring_angles(s_plane, loop_points, spec.columns_face_loop);
  const int angles = add_directions(d, first);
  const int own_angles = own == n ? angles : add_directions(d, resampled_angles(first, own));
  std::vector<int> ids;
  for (size_t i = 0; i < positions.size(); ++i) {
    Ring r;
    r.name = std::string(spec.name) + "_" + std::to_string(i);
    r.kind = RingKind::star;
    r.chain = spec.chain;
    r.segment = positions[i].first;
    r.u = positions[i].second;
    r.angles = i == 0 ? angles : own_angles;
    // The joint ring (elbow, knee) is shared by both pieces: it sees both groups.
    const int ii = static_cast<int>(i);
    r.mask = (single || ii < star_upper - 1) ? spec.upper
             : ii == star_upper - 1          ? GroupMask(spec.upper | spec.lower)
                                             : spec.lower;
    ids.push_back(add_ring(d, std::move(r), i == 0 ? n : own));
  }
  return ids;
}

// The k boundary-driven rings between the loop (α → 1) and S (α → 0), nearest the loop first.
std::vector<int> add_limb_driven(Data& d, const LimbSpec& spec, int s_ring) {
  const int k = d.counts.boundary_contours;
  std::vector<int> ids;
  for (int i = 1; i <= k; ++i) {
    Ring r;
    r.name = std::string(spec.name) + "_driven_" + std::to_string(i);
    r.kind = RingKind::driven;
    // The ring nearest the loop sees the loop's own groups too, so the shapes flow into
    // each other and an extreme posture cannot leave its rays with nothing to hit.
    r.mask = i == 1 ? GroupMask(spec.upper | spec.junction) : spec.upper;
    r.s_ring = s_ring;
    r.goal = *spec.loop;
    r.alpha = 1.0f - static_cast<float>(i) / static_cast<float>(k + 1);
    r.alpha_step = 1.0f / static_cast<float>(k + 1);
    ids.push_back(add_ring(d, std::move(r), static_cast<int>(spec.loop->size())));
  }
  return ids;
}

void add_limb(Data& d, const LimbSpec& spec, std::span<const glm::vec3> ctrl) {
  const std::vector<int> stars = add_limb_stars(d, spec, ctrl);
  const std::vector<int> driven = add_limb_driven(d, spec, stars[0]);
  Surface s;
  s.name = spec.name;
  s.loop_start = true;
  s.first_row = *spec.loop;
  s.rows.push_back(-1);  // row 0: the loop
  s.rows.insert(s.rows.end(), driven.begin(), driven.end());
  s.rows.insert(s.rows.end(), stars.begin(), stars.end());
  s.cap = true;
  s.parts.push_back({spec.upper_part, 0});
  if (spec.lower_rows != 0) s.parts.push_back({spec.lower_part, spec.upper_rows - 1});
  d.surfaces.push_back(std::move(s));
}

// A limb's last ring cuts its field on the plane between the limb and the rigid part it ends
// in. At the ankle the calf is up to 2.3 cm wider there than the foot's ankle: the leg's capped
// end stood out of the foot as a cuff in every frame. Its rays now end no further out than the
// part's own surface (measured along each ray in the zero posture, a few millimetres inside it),
// so the limb tapers into the part over its last link and the cap stays hidden inside.
void add_end_reach(Data& d, const BodyField& field, int chain, RigidPart part) {
  constexpr float kInside_m = 0.003f;
  std::vector<uint16_t> cand(kMaxCandidates);
  cand.resize(static_cast<size_t>(field.candidates_of_part(part, cand)));
  Ring* last = nullptr;
  for (Ring& r : d.rings)
    if (r.kind == RingKind::star && r.chain == chain) last = &r;
  if (cand.empty() || !last) return;
  const Plane p = ring_plane(d.chains[static_cast<size_t>(chain)], last->segment, last->u);
  if (field.field_of_part(p.origin, part) < 1.0f) return;  // a part that does not reach the joint bounds nothing
  const Directions& dir = d.direction_tables[static_cast<size_t>(last->angles)];
  std::vector<RayHit> hits(dir.cos.size());
  field.cast_star(p.origin, p.front, p.left, dir.cos, dir.sin, cand, hits);
  last->reach_m.assign(hits.size(), std::numeric_limits<float>::max());
  for (size_t j = 0; j < hits.size(); ++j)
    if (hits[j].hit()) last->reach_m[j] = std::max(hits[j].t - kInside_m, kInside_m);
}

// A rigid part meshed once in the zero posture from its primitives' field (iso_mesh.h), kept in
// its joint's frame: marching tetrahedra on a grid fine enough for its thinnest primitive (a
// finger, an ear), simplified to the part's vertex budget.
void add_rigid_part(Data& d, RigidPart part, const BodyModel& model, const BodyField& field,
                    std::span<const rig::RigidTransform> world_from_joint) {
  const rig::Skeleton& skeleton = d.skeleton;
  std::vector<uint16_t> cand(kMaxCandidates);
  const int n = field.candidates_of_part(part, cand);
  if (n == 0) return;
  cand.resize(n);
  int jnt = -1;
  for (const Primitive& p : model.primitives)
    if (p.part == part) jnt = skeleton.find_joint(p.joint);
  IsoMesh m = mesh_rigid_part(part, model, field, cand, world_from_joint[jnt], d.counts);
  RigidMesh rm;
  rm.part = part;
  rm.joint = jnt;
  rm.local = std::move(m.positions);
  rm.triangles = std::move(m.triangles);
  bind_toes(rm, skeleton, world_from_joint);
  d.rigid.push_back(std::move(rm));
}

Status check_inputs(const BodyModel& model, const ContourLayoutOptions& options) {
  if (auto st = validate(model); !st) return st;
  if (options.subdivision < 0 || options.subdivision > 16)
    return fail(Errc::invalid_argument, "subdivision must be in [0, 16]");
  return {};
}

Status check_joints(const rig::Skeleton& skeleton) {
  for (const char* name : kSkinJoints)
    if (skeleton.find_joint(name) < 0)
      return fail(Errc::invalid_argument, std::string("skin needs joint '") + name + "'");
  return {};
}

}  // namespace

// Defined in topology.cpp: the output rows, vertices and triangles of a built layout.
void build_topology(ContourLayout::Data& d);

// ---------------------------------------------------------------------------------------------

ContourLayout::ContourLayout(std::shared_ptr<const Data> data) : data_(std::move(data)) {}

Result<ContourLayout> ContourLayout::build(const BodyModel& model, const rig::Skeleton& skeleton,
                                           const ContourLayoutOptions& options) {
  if (auto st = check_inputs(model, options); !st) return tl::unexpected(st.error());
  auto field = BodyField::create(model, skeleton);
  if (!field) return tl::unexpected(field.error());
  if (auto st = check_joints(skeleton); !st) return tl::unexpected(st.error());
  auto d = std::make_shared<Data>();
  d->options = options;
  d->counts = model.skin;
  d->skeleton = skeleton;
  d->chains = make_chains(skeleton, d->counts);
  // The zero posture, where the layout is measured.
  const rig::Pose zero = skeleton.zero_pose();
  std::vector<rig::RigidTransform> world_from_joint(static_cast<size_t>(skeleton.joint_count()));
  rig::forward_kinematics(skeleton, zero, world_from_joint);
  field->update(world_from_joint, zero.dof_rad);
  for (Chain& c : d->chains) c.update(world_from_joint);

  const std::vector<int> torso = add_torso_rings(*d);
  add_bridges(*d, torso.front(), torso.back());
  // What exists so far, ray-cast: the loops' geometry sets the limbs' ray angles.
  RingCaster caster;
  size_t widest = static_cast<size_t>(d->counts.torso_points);
  for (const Ring& r : d->rings) widest = std::max(widest, r.slots.size());
  caster.size_for(d->control_points, widest);
  for (const Ring& r : d->rings) caster.compute_ring(*d, *field, d->chains, r);
  const Loops loops = make_loops(*d, torso.front(), torso.back());
  assert(static_cast<int>(loops.neck.size()) == loop_points(d->counts).neck &&
         static_cast<int>(loops.l_arm.size()) == loop_points(d->counts).arm &&
         static_cast<int>(loops.r_leg.size()) == loop_points(d->counts).leg);
  for (const LimbSpec& spec : limb_specs(d->counts, loops)) add_limb(*d, spec, caster.ctrl);
  // Chains 4 and 5: the legs (make_chains). The arms' (2, 3) would end inside the hands too (14
  // of 24 points of the wrist's ring are outside them), but with them the girth-weighted fit
  // took another path (BodyFit.TheGirthsCountInTheFit: 3.3 → 4.3 % off); not yet.
  add_end_reach(*d, *field, 4, RigidPart::left_foot);
  add_end_reach(*d, *field, 5, RigidPart::right_foot);
  if (options.rigid_parts)
    for (int pi = 1; pi <= kRigidPartCount; ++pi)
      add_rigid_part(*d, static_cast<RigidPart>(pi), model, *field, world_from_joint);
  for (const Ring& r : d->rings) widest = std::max(widest, r.slots.size());
  d->widest_ring = widest;
  build_topology(*d);
  return ContourLayout(std::move(d));
}

const rig::Skeleton& ContourLayout::skeleton() const { return data_->skeleton; }
const ContourLayoutOptions& ContourLayout::options() const { return data_->options; }
size_t ContourLayout::ring_count() const { return data_->rings.size(); }
size_t ContourLayout::control_point_count() const { return data_->control_points; }
size_t ContourLayout::vertex_count() const { return data_->vertex_count; }
std::span<const uint32_t> ContourLayout::indices() const { return data_->indices; }
std::span<const MeshPart> ContourLayout::parts() const { return data_->parts; }

std::vector<ContourPlane> ContourLayout::star_planes(const rig::Pose& pose) const {
  const Data& d = *data_;
  std::vector<rig::RigidTransform> world_from_joint(static_cast<size_t>(d.skeleton.joint_count()));
  rig::forward_kinematics(d.skeleton, pose, world_from_joint);
  std::vector<Chain> chains = d.chains;
  for (Chain& c : chains) c.update(world_from_joint);
  std::vector<ContourPlane> out;
  for (const Ring& r : d.rings) {
    if (r.kind != RingKind::star) continue;
    const Plane p = ring_plane(chains[static_cast<size_t>(r.chain)], r.segment, r.u);
    const Directions& dir = d.direction_tables[static_cast<size_t>(r.angles)];
    ContourPlane cp{r.name, p.origin, p.normal, {}};
    for (size_t j = 0; j < dir.cos.size(); ++j) cp.directions.push_back(dir.cos[j] * p.front + dir.sin[j] * p.left);
    out.push_back(std::move(cp));
  }
  return out;
}

}  // namespace mimic::avatar
