// The contour layout of a body, built once: chains along the skeleton, torso rings, bridges,
// the loops where limbs meet the torso, limb rings (star and boundary-driven) and the rigid parts
// sampled in the rest posture.
#include <cassert>

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
  const rig::Pose zero = skeleton.zero_pose();
  rig::forward_kinematics(skeleton, zero, world_from_joint);
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

    // The neck's loop, cut short of the armpits (neck_corner): from `a` chest points before each
    // armpit point straight to the bridge's point `c`, so that seen along the neck's link it goes
    // round the link without climbing; the four corners left are flat patches of the neck.
    std::vector<uint32_t> full;
    for (int j = 0; j <= fl; ++j) full.push_back(chest_slots[j]);
    for (uint32_t s : lb) full.push_back(s);
    for (int j = kl; j <= kr; ++j) full.push_back(chest_slots[j]);
    for (auto it = rb.rbegin(); it != rb.rend(); ++it) full.push_back(*it);
    for (int j = fr; j < M; ++j) full.push_back(chest_slots[j]);
    const NeckCorner cut = neck_corner(L);
    if (cut.chest > 0) {
      const int a = cut.chest, c = cut.bridge, nb = static_cast<int>(lb.size());
      const int lb0 = fl + 1, back_l = lb0 + nb, rb0 = back_l + (kr - kl + 1), front_r = rb0 + nb;
      neck_cuts = {{fl - a, lb0 + c, false},
                   {lb0 + nb - 1 - c, back_l + a, true},
                   {back_l + (kr - kl) - a, rb0 + c, false},
                   {rb0 + nb - 1 - c, front_r + a, true}};
    }
    cut_neck_loop(full, neck_cuts, 1, neck_loop, corners);
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
    int points;                  // of the rings after S; 0: the loop's
  };
  const LimbSpec limbs[] = {
      {"neck", 1, &neck_loop, group_bit(Group::upper_torso), 0, group_bit(Group::upper_torso), L.neck_contours, 0,
       L.neck_start, "neck", nullptr, L.neck_points},
      {"l_arm", 2, &l_arm_loop, group_bit(Group::left_upper_arm), group_bit(Group::left_lower_arm),
       group_bit(Group::left_shoulder), L.upper_arm_contours, L.lower_arm_contours, 0.3f, "left_upper_arm",
       "left_lower_arm", L.arm_points},
      {"r_arm", 3, &r_arm_loop, group_bit(Group::right_upper_arm), group_bit(Group::right_lower_arm),
       group_bit(Group::right_shoulder), L.upper_arm_contours, L.lower_arm_contours, 0.3f, "right_upper_arm",
       "right_lower_arm", L.arm_points},
      {"l_leg", 4, &l_leg_loop, group_bit(Group::left_upper_leg), group_bit(Group::left_lower_leg), group_bit(Group::hip),
       L.upper_leg_contours, L.lower_leg_contours, 0.25f, "left_upper_leg", "left_lower_leg", L.leg_points},
      {"r_leg", 5, &r_leg_loop, group_bit(Group::right_upper_leg), group_bit(Group::right_lower_leg), group_bit(Group::hip),
       L.upper_leg_contours, L.lower_leg_contours, 0.25f, "right_upper_leg", "right_lower_leg", L.leg_points},
  };
  assert(static_cast<int>(neck_loop.size()) == loop_points(L).neck && static_cast<int>(l_arm_loop.size()) == loop_points(L).arm &&
         static_cast<int>(r_leg_loop.size()) == loop_points(L).leg);
  const int k = L.boundary_contours;
  for (const LimbSpec& spec : limbs) {
    const std::vector<uint32_t>& loop = *spec.loop;
    const int n = static_cast<int>(loop.size());
    // The limb's own points per contour (its LOD): the loop, the boundary-driven rings and S
    // keep the loop's count (the driven rings blend S with the loop point for point), the rings
    // after S take the limb's own.
    const int own = spec.points > 0 ? spec.points : n;
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
    const std::vector<float> facing = angles_facing(ring_plane(c, positions[0].first, positions[0].second), goal_points);
    const int angles = add_directions(facing);
    const int own_angles = own == n ? angles : add_directions(resampled_angles(facing, own));

    std::vector<int> star_ids;
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
      star_ids.push_back(add_ring(std::move(r), i == 0 ? n : own));
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
      r.alpha_step = 1.0f / static_cast<float>(k + 1);
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
      const rig::RigidTransform& w = world_from_joint[jnt];
      const glm::vec3 axis = safe_normalize(w.apply_vector(skeleton.tip_m(jnt)), {0, 1, 0});
      const glm::vec3 front0 = std::abs(axis.z) < 0.9f ? glm::vec3(0, 0, 1) : glm::vec3(0, 1, 0);
      const glm::vec3 front = glm::normalize(front0 - glm::dot(front0, axis) * axis);
      const glm::vec3 left = glm::cross(axis, front);
      RigidMesh rm;
      rm.part = part;
      rm.joint = jnt;
      const rig::RigidTransform local_from_world = w.inverse();
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
      bind_toes(rm, skeleton, world_from_joint);
      rigid.push_back(std::move(rm));
    }
  }
  size_ring_buffers();
  build_output();
  return {};
}

}  // namespace mimic::avatar
