// Contact in the realtime skin (realtime_contact.h; docs/skin.md, "Contact").
#include "realtime_contact.h"

#include <algorithm>
#include <cmath>
#include <string_view>

#include <glm/gtx/euler_angles.hpp>

#include "contact_field.h"
#include "mimic/avatar/simd.h"

namespace mimic::avatar::realtime_detail {

namespace {

// A skin piece's volume: the metaballs of its groups (`field`), less those in the `own` groups
// of the piece pushed out of it: a primitive the two share (the hip's for a thigh, an arm's
// shoulder primitives that are in its group) is where they join, not a side to push against.
// `band`: the piece's boundary-driven band is pushed too (the arms: their bands under the
// armpits pass into the chest; the thighs' bands, pushed, crossed the belly no less).
struct Piece {
  std::string_view name;
  GroupMask field, own;
  bool band = false;
};
using G = Group;
const Piece kPieces[] = {
    {"torso", group_bits({G::upper_torso, G::lower_torso, G::hip}),
     group_bits({G::upper_torso, G::lower_torso, G::hip})},
    {"left_upper_arm", group_bits({G::left_upper_arm}), group_bits({G::left_upper_arm}), true},
    {"right_upper_arm", group_bits({G::right_upper_arm}), group_bits({G::right_upper_arm}), true},
    {"left_lower_arm", group_bits({G::left_lower_arm}), group_bits({G::left_lower_arm})},
    {"right_lower_arm", group_bits({G::right_lower_arm}), group_bits({G::right_lower_arm})},
    {"left_upper_leg", group_bits({G::left_upper_leg}), group_bits({G::left_upper_leg, G::hip})},
    {"right_upper_leg", group_bits({G::right_upper_leg}), group_bits({G::right_upper_leg, G::hip})},
    {"left_lower_leg", group_bits({G::left_lower_leg}), group_bits({G::left_lower_leg, G::left_ankle})},
    {"right_lower_leg", group_bits({G::right_lower_leg}), group_bits({G::right_lower_leg, G::right_ankle})},
};

// (pushed, against): the pushed piece's skin gives way. One side of each pair only, so the two
// never swap places; between the legs the right one gives way to the left. Left out, measured
// (docs/skin.md, "Contact"): the forearm against its upper arm and the calf against its thigh
// (the elbow's and knee's crease is the joint band's, which keeps the zone's volume; pushed, the
// contours crossed at full flexion), and the forearm against the thighs (a forearm 60 mm in a
// thigh in a crouch only folds).
const std::pair<std::string_view, std::string_view> kPairs[] = {
    {"left_upper_arm", "torso"},           {"right_upper_arm", "torso"},          {"left_lower_arm", "torso"},
    {"right_lower_arm", "torso"},          {"left_upper_leg", "torso"},           {"right_upper_leg", "torso"},
    {"right_upper_leg", "left_upper_leg"}, {"right_lower_leg", "left_lower_leg"}, {"left_lower_leg", "right_upper_leg"},
    {"right_lower_leg", "left_upper_leg"},
};

const Piece* piece(std::string_view name) {
  for (const Piece& p : kPieces)
    if (p.name == name) return &p;
  return nullptr;
}

// Newton's steps towards the surface, each bounded to this distance from the vertex.
constexpr float kMaxPush_m = 0.06f;
// A push fades out between these lengths: a vertex that deep in another piece is where the
// motion itself puts a limb through the body (the arm raised through the head, a crouch), and
// pushing it that far folds the piece and crosses its contours.
constexpr float kFullPush_m = 0.015f, kNoPush_m = 0.03f;
constexpr int kNewtonSteps = 3;
// A band's vertex takes one: the smoothing after the pushes (relax_band) evens out what one
// step leaves (every 20th frame of the clips at LOD 0: 14.6 folds and 75.0 pairs between pieces a
// frame against 16.0 and 76.7 with three, at a third of the field evaluations).
constexpr int kBandNewtonSteps = 1;
constexpr uint32_t kCullBlock = 8;

// The active balls as eight-lane rows (ContactState::lanes); returns the padded count.
inline uint32_t fill_lanes(const ContactTables& t, ContactState& st, uint32_t n) {
  const uint32_t padded = (n + 7) / 8 * 8;
  float* rows = st.lanes.data();
  const size_t w = st.lane_stride;
  for (uint32_t k = 0; k < padded; ++k) {
    if (k >= n) {
      for (int r = 0; r < ContactState::kLaneRows; ++r) rows[r * w + k] = 0.0f;
      continue;
    }
    const uint16_t i = st.active[k];
    const glm::mat3& m = st.unit_from_world[i];
    rows[0 * w + k] = st.centre[i].x, rows[1 * w + k] = st.centre[i].y, rows[2 * w + k] = st.centre[i].z;
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) rows[(3 + 3 * r + c) * w + k] = m[c][r];  // row r of the matrix
    rows[12 * w + k] = t.balls[i].inv_r2;
    rows[13 * w + k] = t.balls[i].weight_norm;
    rows[14 * w + k] = t.balls[i].inv_min_axis;
  }
  return padded;
}

#ifdef MIMIC_SIMD_AVX2
// A point's offset from eight balls' centres in their unit spaces (lane rows 0–11), and the sum
// of eight lanes.
struct LaneOffset {
  __m256 x, y, z;
};
inline LaneOffset unit_offset(const float* rows, size_t w, uint32_t k, __m256 px, __m256 py, __m256 pz) {
  auto row = [&](int r) { return _mm256_loadu_ps(rows + static_cast<size_t>(r) * w + k); };
  const __m256 dx = _mm256_sub_ps(px, row(0)), dy = _mm256_sub_ps(py, row(1)), dz = _mm256_sub_ps(pz, row(2));
  return {_mm256_fmadd_ps(row(5), dz, _mm256_fmadd_ps(row(4), dy, _mm256_mul_ps(row(3), dx))),
          _mm256_fmadd_ps(row(8), dz, _mm256_fmadd_ps(row(7), dy, _mm256_mul_ps(row(6), dx))),
          _mm256_fmadd_ps(row(11), dz, _mm256_fmadd_ps(row(10), dy, _mm256_mul_ps(row(9), dx)))};
}
inline __m256 length2(const LaneOffset& q) {
  return _mm256_fmadd_ps(q.z, q.z, _mm256_fmadd_ps(q.y, q.y, _mm256_mul_ps(q.x, q.x)));
}
inline float lane_sum(__m256 v) {
  const __m128 h = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
  const __m128 h2 = _mm_add_ps(h, _mm_movehl_ps(h, h));
  return _mm_cvtss_f32(_mm_add_ss(h2, _mm_shuffle_ps(h2, h2, 1)));
}

// field_value over the lanes, eight balls a step.
inline float field_value_lanes(const ContactState& st, uint32_t padded, const glm::vec3& p) {
  const float* rows = st.lanes.data();
  const size_t w = st.lane_stride;
  const __m256 px = _mm256_set1_ps(p.x), py = _mm256_set1_ps(p.y), pz = _mm256_set1_ps(p.z);
  const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
  __m256 sum = zero;
  for (uint32_t k = 0; k < padded; k += 8) {
    const __m256 s = length2(unit_offset(rows, w, k, px, py, pz));
    const __m256 u = _mm256_max_ps(_mm256_fnmadd_ps(s, _mm256_loadu_ps(rows + 12 * w + k), one), zero);
    sum = _mm256_fmadd_ps(_mm256_mul_ps(_mm256_mul_ps(u, u), u), _mm256_loadu_ps(rows + 13 * w + k), sum);
  }
  return lane_sum(sum);
}

// The most the field can be anywhere within `radius` of `centre`: each ball's term at the
// nearest a point there can be to its centre in the ball's unit space (a metre moves a point at
// most inv_min_axis there), eight balls a step.
inline float field_bound_lanes(const ContactState& st, uint32_t padded, const glm::vec3& centre, float radius) {
  const float* rows = st.lanes.data();
  const size_t w = st.lane_stride;
  const __m256 px = _mm256_set1_ps(centre.x), py = _mm256_set1_ps(centre.y), pz = _mm256_set1_ps(centre.z);
  const __m256 r = _mm256_set1_ps(radius);
  const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
  __m256 sum = zero;
  for (uint32_t k = 0; k < padded; k += 8) {
    const __m256 q = _mm256_sqrt_ps(length2(unit_offset(rows, w, k, px, py, pz)));
    const __m256 d = _mm256_max_ps(_mm256_fnmadd_ps(r, _mm256_loadu_ps(rows + 14 * w + k), q), zero);
    const __m256 u =
        _mm256_max_ps(_mm256_fnmadd_ps(_mm256_mul_ps(d, d), _mm256_loadu_ps(rows + 12 * w + k), one), zero);
    sum = _mm256_fmadd_ps(_mm256_mul_ps(_mm256_mul_ps(u, u), u), _mm256_loadu_ps(rows + 13 * w + k), sum);
  }
  return lane_sum(sum);
}

// field_at over the lanes: the value and its gradient, eight balls a step.
inline FieldAt field_at_lanes(const ContactState& st, uint32_t padded, const glm::vec3& p) {
  const float* rows = st.lanes.data();
  const size_t w = st.lane_stride;
  const __m256 px = _mm256_set1_ps(p.x), py = _mm256_set1_ps(p.y), pz = _mm256_set1_ps(p.z);
  const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps(), six = _mm256_set1_ps(6.0f);
  __m256 sum = zero, gx = zero, gy = zero, gz = zero;
  for (uint32_t k = 0; k < padded; k += 8) {
    auto row = [&](int r) { return _mm256_loadu_ps(rows + r * w + k); };
    const LaneOffset q = unit_offset(rows, w, k, px, py, pz);
    const __m256 u = _mm256_max_ps(_mm256_fnmadd_ps(length2(q), row(12), one), zero);
    const __m256 wu2 = _mm256_mul_ps(row(13), _mm256_mul_ps(u, u));
    sum = _mm256_fmadd_ps(wu2, u, sum);
    // d/dp of w·u³ = −6 w u² / R² · Mᵀ q (zero where u is: outside the ball)
    const __m256 c = _mm256_mul_ps(_mm256_mul_ps(six, wu2), row(12));
    gx =
        _mm256_fnmadd_ps(c, _mm256_fmadd_ps(row(9), q.z, _mm256_fmadd_ps(row(6), q.y, _mm256_mul_ps(row(3), q.x))), gx);
    gy = _mm256_fnmadd_ps(c, _mm256_fmadd_ps(row(10), q.z, _mm256_fmadd_ps(row(7), q.y, _mm256_mul_ps(row(4), q.x))),
                          gy);
    gz = _mm256_fnmadd_ps(c, _mm256_fmadd_ps(row(11), q.z, _mm256_fmadd_ps(row(8), q.y, _mm256_mul_ps(row(5), q.x))),
                          gz);
  }
  return {lane_sum(sum), glm::vec3(lane_sum(gx), lane_sum(gy), lane_sum(gz))};
}
#endif

}  // namespace

glm::mat3 primitive_rotation(const PrimitiveState& s) {
  return glm::mat3(glm::eulerAngleZ(s.orientation_rad.z) * glm::eulerAngleY(s.orientation_rad.y) *
                   glm::eulerAngleX(s.orientation_rad.x));
}

namespace {

ContactTables::Ball ball_of(const Primitive& p, int joint) {
  ContactTables::Ball b;
  b.joint = joint;
  const PrimitiveState& s = p.state;
  glm::mat3 m = glm::transpose(primitive_rotation(s));
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) m[c][r] /= s.semi_axes_m[r];
  b.unit_from_joint = m;
  b.centre_joint = s.center_m;
  const float r2 = p.influence * p.influence;
  const float k = 1.0f - 1.0f / r2;
  b.weight_norm = p.weight / (k * k * k);
  b.inv_r2 = 1.0f / r2;
  b.bound_m = p.influence * std::max({s.semi_axes_m.x, s.semi_axes_m.y, s.semi_axes_m.z});
  b.inv_min_axis = 1.0f / std::min({s.semi_axes_m.x, s.semi_axes_m.y, s.semi_axes_m.z});
  return b;
}

// Vertices used by exactly one part's triangles, per part name.
std::vector<int> vertex_owner(const Mesh& rest) {
  std::vector<int> owner(rest.positions.size(), -1);
  for (size_t pi = 0; pi < rest.parts.size(); ++pi) {
    const MeshPart& part = rest.parts[pi];
    for (uint32_t t = part.first_triangle; t < part.first_triangle + part.triangle_count; ++t)
      for (int c = 0; c < 3; ++c) {
        int& o = owner[rest.indices[3 * t + c]];
        o = (o == -1 || o == int(pi)) ? int(pi) : -2;
      }
  }
  return owner;
}

// ContactTables::slot_of and ring: each pair vertex's neighbours that are pair vertices too.
void build_ring(const Mesh& rest, ContactTables& t) {
  const size_t n = rest.positions.size();
  t.slot_of.assign(n, -1);
  for (uint32_t v : t.vertices)
    if (t.slot_of[v] < 0) t.slot_of[v] = static_cast<int32_t>(t.slot_vertex.size()), t.slot_vertex.push_back(v);
  const size_t slots = t.slot_vertex.size();
  std::vector<std::vector<uint32_t>> nb(slots);
  for (size_t k = 0; k + 2 < rest.indices.size(); k += 3)
    for (int c = 0; c < 3; ++c) {
      const int32_t a = t.slot_of[rest.indices[k + c]], b = t.slot_of[rest.indices[k + (c + 1) % 3]];
      if (a >= 0 && b >= 0) nb[a].push_back(uint32_t(b)), nb[b].push_back(uint32_t(a));
    }
  t.ring_first.assign(slots + 1, 0);
  for (size_t v = 0; v < slots; ++v) {
    std::sort(nb[v].begin(), nb[v].end());
    nb[v].erase(std::unique(nb[v].begin(), nb[v].end()), nb[v].end());
    t.ring_first[v] = static_cast<uint32_t>(t.ring.size());
    t.ring.insert(t.ring.end(), nb[v].begin(), nb[v].end());
  }
  t.ring_first[slots] = static_cast<uint32_t>(t.ring.size());
}

}  // namespace

size_t ContactTables::heap_bytes() const {
  return balls.capacity() * sizeof(Ball) + pair_balls.capacity() * 2 + vertices.capacity() * 4 +
         pairs.capacity() * sizeof(Pair) +
         (ring_first.capacity() + ring.capacity() + slot_of.capacity() + slot_vertex.capacity()) * 4 +
         slot_band.capacity() * sizeof(BandNeighbours) + slot_band_slots.capacity() * 16 +
         slot_band_follow.capacity() * 4 + arms.capacity() * sizeof(Arm) + arm_joints.capacity() * 4 +
         probe_joints.capacity() * sizeof(ProbeJoint) + probes.capacity() * sizeof(Probe) + volume_balls.capacity() * 2;
}

size_t ContactState::heap_bytes() const {
  return unit_from_world.capacity() * sizeof(glm::mat3) + centre.capacity() * sizeof(glm::vec3) +
         active.capacity() * 2 + lanes.capacity() * 4 + push.capacity() * sizeof(glm::vec3) + mark.capacity() +
         (touched.capacity() + band_touched.capacity()) * 4 +
         (block_lo.capacity() + block_hi.capacity()) * sizeof(glm::vec3);
}

void ContactState::resize(const ContactTables& t) {
  unit_from_world.assign(t.balls.size(), glm::mat3(1.0f));
  centre.assign(t.balls.size(), glm::vec3(0.0f));
  active.assign(t.balls.size(), 0);
  lane_stride = (t.balls.size() + 7) / 8 * 8;
  lanes.assign(kLaneRows * lane_stride, 0.0f);
  push.assign(t.slot_vertex.size() + 1, glm::vec3(0.0f));
  mark.assign(t.slot_vertex.size(), 0);
  touched.clear();
  touched.reserve(t.slot_vertex.size());
  uint32_t blocks = 0;
  for (const ContactTables::Pair& pr : t.pairs)
    blocks = std::max(blocks, (pr.vertex_count + kCullBlock - 1) / kCullBlock);
  band_touched.assign(
      static_cast<size_t>(std::count_if(t.slot_band.begin(), t.slot_band.end(),
                                        [](const BandNeighbours& b) { return b != kNoBandNeighbours; })),
      0u);
  block_lo.assign(blocks, glm::vec3(0.0f));
  block_hi.assign(blocks, glm::vec3(0.0f));
}

ContactTables build_contact(const BodyModel& model, const rig::Skeleton& skeleton, const Mesh& rest,
                            std::span<const rig::RigidTransform> world_from_joint, std::span<const BandNeighbours> band,
                            std::span<const int32_t> band_follow) {
  ContactTables t;
  // Every metaball of the pieces, once; a pair lists the ones of its volume (16-bit indices: the
  // body's field, built before these tables, refuses 65,535 primitives or more).
  std::vector<int> ball_of_primitive(model.primitives.size(), -1);
  for (size_t i = 0; i < model.primitives.size(); ++i) {
    const Primitive& p = model.primitives[i];
    const int joint = skeleton.find_joint(p.joint);
    if (p.kind != PrimitiveKind::metaball || p.part != RigidPart::none || joint < 0) continue;
    ball_of_primitive[i] = static_cast<int>(t.balls.size());
    t.balls.push_back(ball_of(p, joint));
  }
  const std::vector<int> owner = vertex_owner(rest);
  ContactState st;
  st.resize(t);
  pose_balls(t, st, world_from_joint);
  for (const auto& [pushed_name, against_name] : kPairs) {
    const Piece* pushed = piece(pushed_name);
    const Piece* against = piece(against_name);
    int part = -1;
    for (size_t pi = 0; pi < rest.parts.size(); ++pi)
      if (rest.parts[pi].name == pushed_name) part = int(pi);
    if (!pushed || !against || part < 0) continue;
    ContactTables::Pair pr;
    pr.ball_first = static_cast<uint32_t>(t.pair_balls.size());
    for (size_t i = 0; i < model.primitives.size(); ++i) {
      const GroupMask g = model.primitives[i].groups;
      if (ball_of_primitive[i] >= 0 && (g & against->field) && !(g & pushed->own))
        t.pair_balls.push_back(static_cast<uint16_t>(ball_of_primitive[i]));
    }
    pr.ball_count = static_cast<uint32_t>(t.pair_balls.size()) - pr.ball_first;
    const std::span<const uint16_t> volume(t.pair_balls.data() + pr.ball_first, pr.ball_count);
    pr.vertex_first = static_cast<uint32_t>(t.vertices.size());
    for (size_t v = 0; v < owner.size(); ++v)
      if (owner[v] == part && (band[v] == kNoBandNeighbours || pushed->band) &&
          field_value(t, volume, st, rest.positions[v]) < t.iso)
        t.vertices.push_back(static_cast<uint32_t>(v));
    pr.vertex_count = static_cast<uint32_t>(t.vertices.size()) - pr.vertex_first;
    if (pr.ball_count > 0 && pr.vertex_count > 0) t.pairs.push_back(pr);
  }
  build_arm_clearance(model, skeleton, ball_of_primitive, t);
  build_ring(rest, t);
  const size_t slots = t.slot_vertex.size();
  const auto none = static_cast<uint32_t>(slots);
  t.slot_band.resize(slots);
  t.slot_band_follow.resize(slots);
  t.slot_band_slots.assign(slots, {none, none, none, none});
  for (size_t k = 0; k < slots; ++k) {
    const BandNeighbours& nb = t.slot_band[k] = band[t.slot_vertex[k]];
    t.slot_band_follow[k] = band_follow[t.slot_vertex[k]];
    if (nb == kNoBandNeighbours) continue;
    for (int i = 0; i < 4; ++i)
      if (const int32_t slot = t.slot_of[nb[i]]; slot >= 0) t.slot_band_slots[k][i] = static_cast<uint32_t>(slot);
  }

  return t;
}

namespace {

// The contact's moves of the touched band vertices smoothed across the band
// (ContactTables::slot_band): each move goes towards the mean of its four neighbours' moves
// (none for a neighbour the contact left alone), within the band's tangent plane, in place.
// Only the moves are smoothed, not the band: without pushes nothing changes, and a push that
// grows from nothing smooths from nothing, so the skin moves on continuously with the pose.
// st.push holds the move each touched slot made, and keeps doing so.
void relax_band(const ContactTables& t, ContactState& st, std::span<glm::vec3> pos) {
  // Two chains: the first touched band's slots from the front of band_touched, any other band's
  // from its back, each in the order touched. An update waits on its neighbours' (the previous
  // update's, mostly); the two arms' bands share no vertex, so their updates interleaved run side
  // by side in the core and each band's sums stay those of the band alone.
  uint32_t* const chains = st.band_touched.data();
  const size_t capacity = st.band_touched.size();
  size_t front = 0, back = 0;
  int32_t first_follow = -2;
  for (const uint32_t slot : st.touched) {
    if (t.slot_band[slot] == kNoBandNeighbours) continue;
    const int32_t follow = t.slot_band_follow[slot];
    if (first_follow == -2) first_follow = follow;
    if (follow == first_follow)
      chains[front++] = slot;
    else
      chains[capacity - 1 - back++] = slot;  // front + back ≤ band slots = capacity
  }
  // Component by component: whole-vector copies of points just written went through the stack
  // and waited on store forwarding (47 ns an update against about 17). An untouched neighbour's
  // move is zero (and a neighbour in no pair reads the zero entry after the slots): the four are
  // added without a branch.
  const float w = t.band_relax_rate;
  const auto relax = [&](uint32_t slot) {
    const BandNeighbours& nb = t.slot_band[slot];
    const float* const a = &pos[nb[0]].x;
    const float* const b = &pos[nb[1]].x;
    const float* const c = &pos[nb[2]].x;
    const float* const e = &pos[nb[3]].x;
    const float ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
    const float vx = e[0] - c[0], vy = e[1] - c[1], vz = e[2] - c[2];
    const float nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
    const float n2 = nx * nx + ny * ny + nz * nz;
    if (!(n2 > 1e-16f)) return;
    float mean[3] = {0.0f, 0.0f, 0.0f};
    for (const uint32_t n : t.slot_band_slots[slot]) {
      const float* const m = &st.push[n].x;
      mean[0] += m[0], mean[1] += m[1], mean[2] += m[2];
    }
    float* const own = &st.push[slot].x;
    const float mx = 0.25f * mean[0] - own[0], my = 0.25f * mean[1] - own[1], mz = 0.25f * mean[2] - own[2];
    const float across = (mx * nx + my * ny + mz * nz) / n2;
    const float dx = w * (mx - across * nx), dy = w * (my - across * ny), dz = w * (mz - across * nz);
    float* const p = &pos[t.slot_vertex[slot]].x;
    p[0] += dx, p[1] += dy, p[2] += dz;
    own[0] += dx, own[1] += dy, own[2] += dz;
  };
  for (int pass = 0; pass < t.band_relax_iterations; ++pass)
    for (size_t i = 0; i < std::max(front, back); ++i) {
      if (i < front) relax(chains[i]);
      if (i < back) relax(chains[capacity - 1 - i]);
    }
}

// The ring around the pushed patches follows part of their push, the bands are relaxed; then the
// marks are cleared.
void spread_to_ring(const ContactTables& t, ContactState& st, std::span<glm::vec3> pos) {
  const size_t pushed = st.touched.size();
  for (size_t k = 0; k < pushed; ++k) {
    const uint32_t v = st.touched[k];
    for (uint32_t e = t.ring_first[v]; e < t.ring_first[v + 1]; ++e) {
      const uint32_t n = t.ring[e];
      if (st.mark[n] == 1) continue;
      if (st.mark[n] == 0) st.touched.push_back(n), st.mark[n] = 2;
      if (st.mark[n] < 255) ++st.mark[n];
      st.push[n] += st.push[v];
    }
  }
  for (size_t k = pushed; k < st.touched.size(); ++k) {  // from the neighbours' sum to this one's move
    const uint32_t n = st.touched[k];
    st.push[n] *= t.ring_share / static_cast<float>(st.mark[n] - 2);
    pos[t.slot_vertex[n]] += st.push[n];
  }
  relax_band(t, st, pos);
  for (uint32_t v : st.touched) st.push[v] = glm::vec3(0.0f), st.mark[v] = 0;
  st.touched.clear();
}

}  // namespace

void apply_contact(const ContactTables& t, ContactState& st, std::span<const float> follow_fade,
                   std::span<glm::vec3> pos) {
  st.moved = 0;
  for (const ContactTables::Pair& pr : t.pairs) {
    // The pushed vertices' bounds this frame, the other volume's balls that reach them, and
    // those balls' bounds: no vertex outside them can be inside the volume.
    // … gathered by blocks of kCullBlock listed vertices (neighbours on a ring, mostly), whose
    // own bounds cull them below.
    glm::vec3 vlo(1e30f), vhi(-1e30f);
    for (uint32_t k = 0, b = 0; k < pr.vertex_count; k += kCullBlock, ++b) {
      glm::vec3 blo(1e30f), bhi(-1e30f);
      for (uint32_t j = k; j < std::min(pr.vertex_count, k + kCullBlock); ++j) {
        const glm::vec3& p = pos[t.vertices[pr.vertex_first + j]];
        blo = glm::min(blo, p), bhi = glm::max(bhi, p);
      }
      st.block_lo[b] = blo, st.block_hi[b] = bhi;
      vlo = glm::min(vlo, blo), vhi = glm::max(vhi, bhi);
    }
    uint32_t n = 0;
    glm::vec3 lo(1e30f), hi(-1e30f);
    for (uint32_t k = 0; k < pr.ball_count; ++k) {
      const uint16_t i = t.pair_balls[pr.ball_first + k];
      const glm::vec3 c = st.centre[i];
      const glm::vec3 d = c - glm::clamp(c, vlo, vhi);
      const float r = t.balls[i].bound_m;
      if (glm::dot(d, d) >= r * r) continue;
      st.active[n++] = i;
      lo = glm::min(lo, c - r);
      hi = glm::max(hi, c + r);
    }
    if (n == 0) continue;
    lo = glm::max(lo, vlo), hi = glm::min(hi, vhi);
    const std::span<const uint16_t> balls(st.active.data(), n);
#ifdef MIMIC_SIMD_AVX2
    const uint32_t padded = fill_lanes(t, st, n);
#endif
    for (uint32_t k = 0; k < pr.vertex_count; ++k) {
      glm::vec3& p = pos[t.vertices[pr.vertex_first + k]];
      // A block outside the balls' bounds, or where the field cannot reach the level anywhere
      // in its bounding sphere: none of its vertices is tested alone.
      if (k % kCullBlock == 0) {
        const glm::vec3 blo = st.block_lo[k / kCullBlock], bhi = st.block_hi[k / kCullBlock];
        bool culled = glm::any(glm::lessThan(bhi, lo)) || glm::any(glm::greaterThan(blo, hi));
#ifdef MIMIC_SIMD_AVX2
        culled = culled || field_bound_lanes(st, padded, 0.5f * (blo + bhi), 0.5f * glm::distance(blo, bhi)) <= t.iso;
#endif
        if (culled) {
          k = std::min(pr.vertex_count, k + kCullBlock) - 1;
          continue;
        }
      }
      if (p.x < lo.x || p.y < lo.y || p.z < lo.z || p.x > hi.x || p.y > hi.y || p.z > hi.z) continue;
#ifdef MIMIC_SIMD_AVX2
      if (field_value_lanes(st, padded, p) <= t.iso) continue;
#else
      if (field_value(t, balls, st, p) <= t.iso) continue;
#endif
#ifdef MIMIC_SIMD_AVX2
      const auto field = [&](const glm::vec3& x) { return field_at_lanes(st, padded, x); };
#else
      const auto field = [&](const glm::vec3& x) { return field_at(t, balls, st, x); };
#endif
      const uint32_t slot = static_cast<uint32_t>(t.slot_of[t.vertices[pr.vertex_first + k]]);
      const int32_t follow = t.slot_band_follow[slot];
      const float fade = follow >= 0 && static_cast<size_t>(follow) < follow_fade.size()
                             ? follow_fade[static_cast<size_t>(follow)]
                             : 1.0f;
      if (!(fade > 0.0f)) continue;
      FieldAt f = field(p);
      const glm::vec3 start = p;
      glm::vec3 q = p;
      const int steps = t.slot_band[slot] != kNoBandNeighbours ? kBandNewtonSteps : kNewtonSteps;
      for (int step = 0; step < steps && f.value > t.iso; ++step) {
        const float g2 = glm::dot(f.gradient, f.gradient);
        if (!(g2 > 1e-12f)) break;
        glm::vec3 next = q - ((f.value - t.iso) / g2) * f.gradient;
        const glm::vec3 moved = next - start;
        const float moved_m = glm::length(moved);
        if (moved_m > kMaxPush_m) next = start + moved * (kMaxPush_m / moved_m);
        q = next;
        if (step + 1 < steps) f = field(q);  // the last step's field is not needed
      }
      const float push_m = glm::length(q - start);
      if (push_m >= kNoPush_m) continue;
      if (push_m > kFullPush_m) q = start + (q - start) * ((kNoPush_m - push_m) / (kNoPush_m - kFullPush_m));
      q = start + fade * (q - start);
      p = q;
      ++st.moved;
      if (st.mark[slot] == 0) st.touched.push_back(slot);  // within capacity: each slot once
      st.mark[slot] = 1;
      st.push[slot] += q - start;
    }
  }
  spread_to_ring(t, st, pos);
}

}  // namespace mimic::avatar::realtime_detail
