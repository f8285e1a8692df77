// Internals of the realtime skin shared by its build (realtime.cpp) and its per-frame deformation
// (realtime_deform.cpp): the body's immutable tables (RealtimeBody::Data), each avatar's state and
// the ring frames. Not a public header.
#pragma once

#include <span>
#include <vector>

#include "contour_layout_data.h"
#include "loop_follow.h"
#include "mimic/avatar/body_field.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin.h"
#include "realtime_contact.h"

namespace mimic::avatar {

namespace realtime_detail {

using skin_detail::kTorsoChain;

// The frame a ring's points are measured in this frame: the ring plane's orthonormal axes
// (front, left, normal) and, for star rings, the link the ring cuts.
struct Frame {
  glm::vec3 origin{0.0f}, x{1, 0, 0}, y{0, 1, 0}, z{0, 0, 1};
  float x_scale = 1.0f;  // bridges: the half chord, so the arc stretches with its ends
  // Star rings: a point is kept as its projection along the link onto the plane across the link
  // (px, py) and its height along the link, put back on the ring's plane along the link.
  glm::vec3 axis{0, 0, 1}, px{1, 0, 0}, py{0, 1, 0};
  float along_per_normal = 1.0f;  // 1 / cos(link, normal), bounded

  glm::vec3 to_world(const glm::vec3& l) const { return origin + (l.x * x_scale) * x + l.y * y + l.z * z; }
  glm::vec3 to_local(const glm::vec3& p) const {
    const glm::vec3 d = p - origin;
    return {glm::dot(d, x) / x_scale, glm::dot(d, y), glm::dot(d, z)};
  }
  // (px, py, height) ↔ point: p = o + q + (height − q·n)·along_per_normal·axis, q = x·px + y·py.
  glm::vec3 star_to_world(const glm::vec3& l) const {
    const glm::vec3 q = l.x * px + l.y * py;
    return origin + q + ((l.z - glm::dot(q, z)) * along_per_normal) * axis;
  }
  glm::vec3 star_to_local(const glm::vec3& p) const {
    const glm::vec3 d = p - origin;
    const float h = glm::dot(d, axis);
    const glm::vec3 q = d - h * axis;
    return {glm::dot(q, px), glm::dot(q, py), h / along_per_normal + glm::dot(q, z)};
  }
  // (px·n, py·n): how far the plane rises along the link per unit across it.
  glm::vec2 rise() const { return {glm::dot(px, z), glm::dot(py, z)}; }
};

// `along_link`: limbs and neck, round their links; the torso is no cylinder round its short
// spine links, so its rings keep their section in their plane (axis = normal).
Frame star_frame(const Chain& c, int segment, float u, bool along_link);
// A bridge's frame from its end points and the normal of the ring it leaves.
Frame arc_frame(const glm::vec3& from, const glm::vec3& to, const glm::vec3& base_normal, bool flip_up);

// What a star ring's points need this frame, beyond their own coordinates (RealtimeBody::Data::
// RingOp documents the terms).
struct StarRing {
  glm::vec3 origin, px, py, axis;
  glm::vec2 rise;        // Frame::rise()
  float a = 1;           // along_per_normal
  float shear_z = 0;     // a − a_rest: the height's share of the shear
  glm::vec2 shear_q{0};  // rise·a − rise_rest·a_rest: the position's share
  glm::vec2 centre{0};   // the band scale's centre (the ring's rest centroid)
  float scale = 1;       // the band scale this frame
};

}  // namespace realtime_detail

struct RealtimeBody::Data {
  rig::Skeleton skeleton;
  int lod = 0;
  std::vector<Chain> chains;  // nodes; the per-frame members are each avatar's
  struct RingOp {
    RingKind kind = RingKind::star;
    uint32_t first = 0, count = 0;  // the ring's slots (contiguous) = its vertices
    int chain = -1, segment = 0;    // star
    float u = 0;
    int prev_star = -1;  // star: the star ring before it on its surface
    int s_ring = -1;     // driven
    float alpha = 0;
    uint32_t goal_first = 0;    // driven: offset in `goals`
    uint32_t from = 0, to = 0;  // arc
    int up_ring = -1;
    bool flip_up = false;
    // Star: the initial pose's plane against the link (Frame::rise, along_per_normal), from
    // which the shear along the link is measured.
    glm::vec2 rest_rise{0.0f};
    float rest_a = 1.0f;
    // Star rings near an elbow or knee: the band (index in `bands`) whose scale they take, with
    // this weight, about their rest centroid.
    int band = -1;
    float band_weight = 0;
    glm::vec2 centre{0.0f};
    // Star rings of the arms, legs and neck: the chain node whose tip they round
    // (round_joint_tip: 1 the elbow, knee or the neck's middle joint, 2 the wrist, ankle or
    // head), or −1.
    int tip_node = -1;
    uint32_t muscle_first = 0, muscle_count = 0;  // blocks in `muscle_blocks`
    int follow = -1;                              // driven: its loop's follow (`follows`), or −1
    bool moves_loop = false;                      // driven: the first ring of its limb moves the loop first
    // Driven: whether the band twists with its limb (BandTwist), and this ring's share of the
    // twist, (1 − α)^power.
    bool twists = false;
    float twist_share = 0;
    int sweep = -1;  // driven: the swept band (`sweeps`) it is a ring of, or −1 (band_sweep.h)
  };
  std::vector<RingOp> rings;
  std::vector<uint32_t> goals;
  // Per slot (structure of arrays): the point in its ring's frame; star rings: (across the link
  // x, y, height above the plane), see Frame::star_to_world.
  std::vector<float> lx, ly, lz;
  // Per star slot: the rest surface along the link through the point (the column), towards the
  // previous ring on the same link (lo) and the next (hi): the change of (x, y) per metre along
  // the link, and how far along the link the neighbour is (beyond it, the column runs straight).
  std::vector<float> lo_x, lo_y, hi_x, hi_y, dh_lo, dh_hi;
  // Per boundary-driven slot: 1 / |G − S|² of its column in the initial pose. The point's rest
  // offset from P shrinks with the square of its column's length this frame over that (never
  // grows): where a bend squeezes the band between the loop and S (the armpit and groin side), an
  // offset as long as the column itself would carry the point past its neighbours.
  std::vector<float> column_inv_len2;
  // Per slot of a ring with a tip node: the squared distance it keeps to from the node's centre
  // once past the node (round_joint_tip): its distance from its link in the initial pose, or
  // from the node's centre if it was past the node already.
  std::vector<float> tip_radius2;
  // The shoulders' and hips' junction loops that follow their limbs (loop_follow.h).
  std::vector<skin_detail::LoopFollow> follows;
  // Per ring (used at S rings with driven rings): the band's rest frame in S's rest frame.
  std::vector<glm::mat3> band_in_s;
  // Per ring (used at S rings of twisting bands): band_twist_rad in the initial pose.
  std::vector<float> band_twist_rest;
  // The shoulders' bands, swept as tubes (band_sweep.h): rings first_ring .. first_ring + rings
  // − 1, from the loop towards S, each with `columns` points.
  struct Sweep {
    int first_ring = -1, rings = 0;
    uint32_t columns = 0, column_first = 0;  // its columns' entries in sweep_rest_turn
    uint32_t offset_first = 0;               // its points' entries in sweep_off_*
    float sign_g = 1, sign_s = 1;            // G's and S's point order against the band's direction
    // The limb's twist (limb_twist_rad): its joint and parent, the joint's rotation in the
    // parent's frame in the initial pose (inverted) and the limb's axis there.
    int joint = -1, parent = -1;
    glm::quat rest_local_inv{1, 0, 0, 0};
    glm::vec3 rest_axis{0, -1, 0};
  };
  std::vector<Sweep> sweeps;
  // Per column of each sweep: the angle from G's point to S's in the initial pose, radians, and
  // its cosine and sine.
  std::vector<float> sweep_rest_turn, sweep_rest_cos, sweep_rest_sin;
  // Per point of each sweep: its polar offset from the blend (radius, angle, height) that gives
  // the initial pose's point back.
  std::vector<float> sweep_off_r, sweep_off_a, sweep_off_h;

  struct MuscleDof {
    int dof = -1;
    float theta0 = 0, theta_min = 0, theta_max = 0;
    Falloff falloff = Falloff::linear;
  };
  std::vector<MuscleDof> muscle_dofs;
  // One block per (star ring, muscle DOF) that moves some point of the ring: for each of the
  // ring's points, local += offset + w.x·to_min + w.y·to_max (nine arrays of `count` floats at
  // `data`: offset x, y, z, to_min x, y, z, to_max x, y, z).
  struct MuscleBlock {
    uint32_t dof = 0;  // index in muscle_dofs
    uint32_t data = 0;
  };
  std::vector<MuscleBlock> muscle_blocks;
  std::vector<float> muscle_data;
  size_t muscle_points = 0, muscle_terms = 0;

  // Joint bands (elbows, knees): the radial scale of the band's rings as a function of the
  // joint's bend, measured at build time so the joint zone keeps its volume ([0] without the
  // muscle terms, [1] with them); linear between samples, 1 at the initial pose.
  struct Band {
    int chain = -1;  // the node between the chain's two links
    std::vector<float> bend_rad;
    std::vector<float> scale[2];
    float scale_at(float bend, bool muscles) const;
  };
  std::vector<Band> bands;

  // The star rings grouped by the chain segment they sit on (runs), so their frames are
  // computed eight rings at a time from the segment's two ends: the rings of run i are
  // run_rings[first .. first + count) at run_u of the same entries (padded by eight).
  struct FrameRun {
    int chain = -1, segment = 0;
    bool along_link = true;
    uint32_t first = 0, count = 0;
  };
  std::vector<FrameRun> frame_runs;
  std::vector<uint32_t> run_rings;
  std::vector<float> run_u;

  int missed_rays = 0;
  struct Cap {
    uint32_t vertex = 0, first = 0, count = 0;
  };
  std::vector<Cap> caps;
  struct Rigid {
    int joint = -1;
    uint32_t first_vertex = 0, first_local = 0, count = 0;
    int toe_joint = -1;  // the forefoot's blend (skin_impl.h RigidMesh::toe_*): toe_* [first_toe, +toe_count)
    uint32_t first_toe = 0, toe_count = 0;
  };
  std::vector<Rigid> rigid;
  std::vector<glm::vec3> rigid_local;
  std::vector<uint32_t> toe_vertex;  // mesh vertex
  std::vector<float> toe_weight;
  std::vector<glm::vec3> toe_local;
  Mesh rest_mesh;
  std::vector<JointInfluences> weights;
  TextureLayout texture;
  std::vector<ContourRows> contour_rows;
  // Where one piece presses into another (realtime_contact.h).
  realtime_detail::ContactTables contact;
};

namespace realtime_detail {

// How far a star ring's points reach from its origin this frame, for the crease's test: the
// largest distance and the largest |height above the plane|.
struct Reach {
  float radius = 0, height = 0;
};

// A swept band's columns this frame (band_sweep.h), sized for the widest band.
struct SweepScratch {
  std::vector<float> ug_x, ug_y, r_g, h_g, r_s, h_s, turn, shrink;
  std::vector<glm::vec3> g, s;    // the band's ends, column by column
  std::vector<glm::vec3> points;  // the band's rings, one after another
  void resize(size_t columns, size_t points);
  size_t heap_bytes() const;
};

// One avatar's per-frame state.
struct State {
  std::vector<rig::RigidTransform> world_from_joint;
  std::vector<Chain> chains;
  std::vector<Frame> frames;        // per ring, this frame
  std::vector<glm::vec2> muscle_w;  // per muscle DOF: (towards θmin, towards θmax)
  std::vector<float> band_scale;    // per band, this frame
  std::vector<float> follow_fade;   // per loop follow, this frame: 1 up to 95° of swing, 0 past 120°
  // Per chain, this frame: its two links' directions towards the middle node (tip_direction of
  // the first link there, and of the second; the second's reversed past the end node).
  std::vector<glm::vec3> tip_along;
  // Build time only: the bands' scales forced (the calibration); empty otherwise.
  std::vector<float> band_scale_forced;
  bool vectorised = true;    // the eight-wide kernels where the build has them
  std::vector<Reach> reach;  // per ring, this frame (star rings)
  ContactState contact;
  SweepScratch sweep;
  RealtimeTimings timings;

  explicit State(const RealtimeBody::Data& d);
  size_t heap_bytes() const;
};

// The frame's positions (never allocates).
// `contact`: the body's contact tables are applied this frame (clear_arms here, apply_contact after).
void deform(const RealtimeBody::Data& d, State& st, const rig::Pose& pose, std::span<glm::vec3> pos, bool muscles,
            bool contact);

// A star ring's points (the muscle blocks when `muscle_w` is not null, the band scale, the
// column slide, then the plane): the scalar reference, and eight at a time where the build
// targets AVX2 and FMA (the same arithmetic in the same order, fused multiply-adds aside).
Reach star_points_scalar(const RealtimeBody::Data& d, const RealtimeBody::Data::RingOp& r, const StarRing& s,
                         const glm::vec2* muscle_w, glm::vec3* out);
Reach star_points_avx2(const RealtimeBody::Data& d, const RealtimeBody::Data::RingOp& r, const StarRing& s,
                       const glm::vec2* muscle_w, glm::vec3* out);
// Every star ring's frame into st.frames (the frame runs, eight rings at a time where the build
// has AVX2 and FMA; star_frame one by one otherwise or when `vectorised` is false).
struct State;
void star_frames(const RealtimeBody::Data& d, State& st, bool vectorised);

// A boundary-driven ring's points: P = S + α(G − S) + the rest offset turned with `f`
// (junction_frame),
// scaled by min(1, |G − S|² · column_inv_len2).
void driven_points(const RealtimeBody::Data& d, const RealtimeBody::Data::RingOp& r, const Frame& f,
                   std::span<glm::vec3> pos, bool vectorised);
// The frame a boundary-driven ring's rest offsets turn with: z from the centre of the torso's
// loop G to the centre of the limb's first ring S, x across it towards G's first point. It
// turns with the band itself (S's own frame turns with the limb alone, and carried the offsets
// under the armpit past their neighbours when the arm hangs).
// Past the follow's fade (`band`: 1 the band's frame, 0 S's frame `s` turned by band_in_s) the
// frame turns back to S's: with the arm swung across the body the band's axis runs through the
// chest.
Frame junction_frame(const RealtimeBody::Data& d, const RealtimeBody::Data::RingOp& r, std::span<const glm::vec3> pos,
                     const Frame& s, float band);
// The same from the band's own frame (band_axis_frame).
Frame junction_frame(const RealtimeBody::Data& d, const RealtimeBody::Data::RingOp& r, Frame axis, const Frame& s,
                     float band);
// The band's own frame (junction_frame before any fade): origin at the loop's centre, z towards
// S's centre (`fallback_z` where the two centres meet), x towards the loop's first point.
Frame band_axis_frame(const RealtimeBody::Data& d, const RealtimeBody::Data::RingOp& r, std::span<const glm::vec3> pos,
                      const glm::vec3& fallback_z);
// How far S's frame has turned about the band's axis from the loop's first point: the angle of
// S's x in the band's (x, y), radians. Its change from the initial pose is the limb's twist
// against the loop.
float band_twist_rad(const Frame& s, const Frame& axis);

// A twisting band: the limb's first ring S turns with the limb about the band's axis while the
// loop G stays with the torso. Joined column by column (S_k to G_k) across a turn, the band
// would pinch to a waist and fold; instead each ring blends S turned back by the twist φ with
// G, and is then turned by w·φ, w = RingOp::twist_share (all of it at S, none at the loop): the
// columns run as helices. Per ring: P = origin + to_s·S + to_g·G + shrink·offset·(lx, ly, lz)
// (the turns are about the axis through the band frame's origin; `origin` carries it).
struct BandTwist {
  glm::vec3 origin{0.0f};
  glm::mat3 to_s{1.0f}, to_g{1.0f}, offset{1.0f};
};
// The ring's BandTwist for the twist `phi_rad` about `axis`, its offsets in frame `f`;
// `untwist` turns by −phi_rad about the axis (the same for every ring of the band).
BandTwist band_twist(const RealtimeBody::Data::RingOp& r, const Frame& axis, const Frame& f, float phi_rad,
                     const glm::mat3& untwist);
// A twisting band's ring (eight at a time where the build has AVX2 and FMA and `vectorised`).
void driven_points_twisted(const RealtimeBody::Data& d, const RealtimeBody::Data::RingOp& r, const BandTwist& t,
                           std::span<glm::vec3> pos, bool vectorised);
// Rigid vertices: out[i] = rotation·local[i] + translation.
void rigid_points(const glm::mat3& rotation, const glm::vec3& translation, const glm::vec3* local, uint32_t count,
                  glm::vec3* out, bool vectorised);
inline constexpr bool kHasAvx2Kernel =
#if defined(__AVX2__) && defined(__FMA__)
    true;
#else
    false;
#endif

// The outer side of a bent elbow or knee. The two links' ring planes tilt towards the bisector
// and meet as a mitre whose outer corner reaches up to 1/cos(72.5°) = 3.3 times the limb's
// radius out along the tilted planes: a beak at 90°, a needle at full flexion. Flesh wraps round
// the joint instead, as a capsule round the bent bones does: a point the tilt carries past the
// joint (beyond the plane across its link at the joint's centre) lies no further from that centre
// than it lay from its link in the initial pose (times the ring's band scale; a point already
// past the joint there keeps to its distance from the centre); one that would slides straight
// back towards its ring's origin, to where that line leaves the capsule of that radius round its
// link and the joint's centre (through the capsule's side when the origin is far short of the
// joint). Points short of the joint keep their distance from their link (the column slide
// moves them along it), so the limb's sides run straight into a round tip. The same at the wrists
// and ankles and along the neck. In the initial pose nothing moves; points only move towards
// their ring's origin, straight, so the ring's reach and height over its plane hold.
struct TipRound {
  glm::vec3 origin{0.0f};  // the ring's
  glm::vec3 centre{0.0f};  // the tip node's point
  glm::vec3 along{0.0f};   // tip_direction there: positive past the joint
  glm::vec3 w{0.0f};       // origin − centre (along the link: the origin is on its axis)
  float w2 = 0;            // |w|²
  float origin_past = 0;   // w·along
  float scale2 = 1;        // (band scale)², with a hair's margin
};
// Along a ring's link (`segment`) at chain node `node` (1 or 2), pointing past the node.
inline glm::vec3 tip_direction(const Chain& c, int segment, int node) {
  const glm::vec3 d = segment == 0 || node == 2 ? c.point[node] - c.point[node - 1] : c.point[1] - c.point[2];
  return safe_normalize(d, {0, -1, 0});
}
// A star ring's points (`out`, the ring's slots) rounded at their tip node (eight at a time where
// the build has AVX2 and FMA and `vectorised`).
void round_joint_tip(const RealtimeBody::Data& d, const RealtimeBody::Data::RingOp& r, const TipRound& t,
                     glm::vec3* out, bool vectorised);

// The bend of a chain at its middle node (radians, 0 straight).
float chain_bend(const Chain& c);

// Build time (realtime_measure.cpp): the contours a realtime body is measured from, the layout's
// chains at the initial pose and the control points the implicit skin ray-cast there.
struct RestContours {
  const ContourLayout::Data& layout;
  const std::vector<Chain>& chains;
  std::span<const glm::vec3> ctrl;
};
// Each slot's coordinates in its ring's frame, for the contours `m.ctrl` (the inverse of what
// deform does with the columns at rest).
void measure_local(const RestContours& m, const RealtimeBody::Data& d, std::vector<glm::vec3>& local);
// The columns (Data::lo_x …): in the initial pose, each limb point's neighbours on the previous
// and next star ring of the same link, in the point's own ring frame.
void measure_columns(const RestContours& m, RealtimeBody::Data& d);
// The boundary-driven slots' rest column lengths (Data::column_inv_len2).
void measure_driven_columns(const RestContours& m, RealtimeBody::Data& d);
// The shoulders' and hips' loop follows (Data::follows), in the initial pose `base`.
void measure_loop_follows(const RestContours& m, const rig::Pose& base, RealtimeBody::Data& d);
// The rings that round a joint's tip and the distances they keep to (round_joint_tip).
void measure_joint_tips(const RestContours& m, RealtimeBody::Data& d);
// Joint bands at the elbows and knees and their scales over each joint's bend.
Status calibrate_bands(const RestContours& m, const rig::Pose& base, RealtimeBody::Data& d);
// The muscle terms: `skin` (the layout's implicit skin) ray-casts the contours with each
// deforming DOF's primitives at θ0, θmin and θmax, the posture kept at `base`.
void measure_muscles(const BodyModel& model, ImplicitSkin& skin, const RestContours& m, const rig::Pose& base,
                     RealtimeBody::Data& d);

}  // namespace realtime_detail

}  // namespace mimic::avatar
