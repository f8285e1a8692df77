// Contact in the realtime skin (docs/skin.md, "Contact"): where one skin piece passes into
// another's volume, its vertices are pushed out onto the other piece's field surface, so the
// skin flattens against it as Implicit Skinning's contact does (Vaillant et al. 2013). The
// volumes are the pieces' own metaballs posed rigidly with their joints; the tables are built
// once per body, and a frame neither allocates nor throws. Not a public header.
#pragma once

#include <array>
#include <cstdint>
#include <initializer_list>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/mesh.h"
#include "mimic/rig/skeleton.h"
#include "mimic/rig/transform.h"

namespace mimic::avatar::realtime_detail {

// A primitive's rotation R = Rz·Ry·Rx from its state's angles (body_model.h), in its joint's frame.
glm::mat3 primitive_rotation(const PrimitiveState& s);

// The mask of several body groups.
constexpr GroupMask group_bits(std::initializer_list<Group> gs) {
  GroupMask m = 0;
  for (Group g : gs) m = static_cast<GroupMask>(m | group_bit(g));
  return m;
}

// A boundary-driven band's vertex: its neighbours along its ring (before, after) and along its
// column (towards the loop, towards S), mesh vertices.
using BandNeighbours = std::array<uint32_t, 4>;
inline constexpr BandNeighbours kNoBandNeighbours{~0u, ~0u, ~0u, ~0u};

struct ContactTables {
  // A metaball of some piece's volume, in its joint's frame (its relaxed state G0).
  struct Ball {
    int joint = -1;
    glm::mat3 unit_from_joint{1.0f};  // S⁻¹ · Rᵀ
    glm::vec3 centre_joint{0.0f};
    float weight_norm = 0, inv_r2 = 0, bound_m = 0;  // w / (1 − 1/R²)³, 1/R², R · largest semi-axis
    float inv_min_axis = 0;  // 1 / smallest semi-axis: how far a metre moves a point in the unit ball
  };
  // One piece (`pushed`) pressed against another's volume: the pushed piece's vertices that can
  // reach it and the other piece's balls that make the volume.
  struct Pair {
    uint32_t ball_first = 0, ball_count = 0;      // in `pair_balls`
    uint32_t vertex_first = 0, vertex_count = 0;  // in `vertices`
  };
  std::vector<Ball> balls;
  std::vector<uint16_t> pair_balls;
  std::vector<uint32_t> vertices;
  std::vector<Pair> pairs;
  // The field level the vertices are pushed out to: below the surface's 1, a few millimetres
  // outside it, since the other piece's mesh is not exactly its field's surface (0.7 crossed
  // 22% fewer triangle pairs than 1 on the clips, at 3.3 more folds a frame than none).
  float iso = 0.7f;
  // The vertices of some pair, numbered once (slots): slot_of per mesh vertex (−1 none),
  // slot_vertex per slot.
  std::vector<int32_t> slot_of;
  std::vector<uint32_t> slot_vertex;
  // The ring around a pushed patch: each slot (`ring_first`, one more entry than slots) lists
  // the slots of its mesh neighbours; a neighbour not pushed itself follows `ring_share` of its
  // pushed neighbours' mean push, so the patch's edge does not fold against the skin beside it.
  std::vector<uint32_t> ring_first, ring;
  float ring_share = 0.5f;
  // Per slot: a band vertex's neighbours (kNoBandNeighbours for any other). The pushes move the
  // vertices of an arm's squeezed armpit side by different amounts along the torso's gradient,
  // and neighbouring columns crossed (twice the folds); the touched band vertices' moves are then
  // smoothed across the band, in its tangent plane (what a push gained across the surface
  // stays), `band_relax_iterations` passes over-relaxed by `band_relax_rate` (relax_band).
  std::vector<BandNeighbours> slot_band;
  // … and those neighbours' slots, the slot count for a neighbour in no pair (ContactState::push
  // keeps a zero move there), so that the smoothing adds four moves without a branch.
  std::vector<std::array<uint32_t, 4>> slot_band_slots;
  std::vector<int32_t> slot_band_follow;  // per slot: a band vertex's loop follow, or −1
  int band_relax_iterations = 2;
  float band_relax_rate = 1.5f;

  // The arms keep off the body (clear_arms): a rigid hand cannot flatten against a thigh, so
  // where a hand or a forearm passes into the torso's or a thigh's volume the whole arm turns
  // about its shoulder until it lies on that volume's surface. The probes are the hand's and the
  // forearm's ellipsoids (their metaballs), each tested at its centre and the ends of its axes.
  struct Probe {  // in its ProbeJoint's joint's frame
    glm::vec3 centre_joint{0.0f};
    glm::mat3 axes_joint{1.0f};  // R · S: the columns are the semi-axes, in the joint's frame
    float radius_m = 0;          // the largest semi-axis
  };
  // The probes of one joint, and a sphere round them (in the joint's frame), tested first.
  struct ProbeJoint {
    int joint = -1;
    glm::vec3 centre_joint{0.0f};
    float radius_m = 0;
    uint32_t probe_first = 0, probe_count = 0;  // in probes
  };
  struct Arm {
    int shoulder = -1;                                      // the joint the arm turns about
    uint64_t joint_mask = 0;                                // a bit per joint in arm_joints (below 64)
    uint32_t joint_first = 0, joint_count = 0;              // in arm_joints: the shoulder and every joint below it
    uint32_t probe_joint_first = 0, probe_joint_count = 0;  // in probe_joints
  };
  std::vector<Arm> arms;
  std::vector<int> arm_joints;
  std::vector<ProbeJoint> probe_joints;
  std::vector<Probe> probes;
  // The volumes the arms keep out of (the torso, each thigh): their balls in `volume_balls`, from
  // volume_first[v] to volume_first[v + 1].
  static constexpr int kArmVolumes = 3;
  std::vector<uint16_t> volume_balls;
  std::array<uint32_t, kArmVolumes + 1> volume_first{};
  // Measured on every 20th frame of the shared clips at LOD 0 (docs/skin.md, "The arms keep off
  // the body"): the level 0.5 (a few millimetres off the other surface) crossed 36.9 pairs
  // between pieces a frame against 40.3 at 0.7 and 32.3 at 0.3, where the hands moved 34% more
  // and up to 69 mm between two samples. A push fades from full at 40 mm to none at 80 mm: deeper
  // is a hand the motion puts into the body (05_02's hand in the chest), and turning the arm
  // that far pops it out. Two rounds of at most 0.2 rad each, three Newton steps per point.
  float arm_iso = 0.5f;
  float arm_full_push_m = 0.04f, arm_no_push_m = 0.08f;
  float arm_turn_max_rad = 0.2f;
  static constexpr int kArmRounds = 2;
  static constexpr int kArmNewtonSteps = 3;

  bool empty() const { return pairs.empty(); }
  size_t heap_bytes() const;
};

// Each avatar's per-frame scratch: the balls posed this frame.
struct ContactState {
  std::vector<glm::mat3> unit_from_world;
  std::vector<glm::vec3> centre;
  // The other volume's balls that reach the pushed vertices' bounds this frame (capacity: all).
  std::vector<uint16_t> active;
  // The same balls as eight-lane rows (centre x, y, z, unit_from_world's nine entries, 1/R²,
  // weight, 1 / smallest semi-axis), padded with weightless balls: kLaneRows rows of
  // `lane_stride` floats.
  static constexpr int kLaneRows = 15;
  std::vector<float> lanes;
  size_t lane_stride = 0;
  uint32_t moved = 0;  // vertices pushed in the last frame
  // Per slot: this frame's move (a pushed vertex's push; on the ring, the sum of its pushed
  // neighbours' pushes, then its share of it; zero when untouched, and in the one more entry
  // after the slots, which stands for every vertex in no pair), and 0 untouched, 1 pushed, 2 + n
  // on the ring with n pushed neighbours.
  std::vector<glm::vec3> push;
  std::vector<uint8_t> mark;
  std::vector<uint32_t> touched;              // the slots marked this frame (capacity: every slot)
  std::vector<glm::vec3> block_lo, block_hi;  // a pair's listed vertices' bounds, by blocks
  std::vector<uint32_t> band_touched;  // the touched band slots, two chains (relax_band); one entry per band slot
  void resize(const ContactTables& t);
  size_t heap_bytes() const;
};

// The tables for a body whose rest mesh (the initial pose, `world_from_joint`) is `rest`.
// Vertices already inside the other volume in the initial pose are where the pieces join by
// design and are left out, so the initial pose is kept vertex for vertex.
// `band`: per vertex, its neighbours where a piece blends into the torso (the boundary-driven
// bands), else kNoBandNeighbours, and `band_follow` the band's loop follow (−1: none). The arms'
// bands are pushed and their moves smoothed across the band; the thighs' keep to their own blend.
ContactTables build_contact(const BodyModel& model, const rig::Skeleton& skeleton, const Mesh& rest,
                            std::span<const rig::RigidTransform> world_from_joint, std::span<const BandNeighbours> band,
                            std::span<const int32_t> band_follow);

// The arms' probes and the volumes they keep out of, for build_contact: `ball_of_primitive` maps
// the model's primitives to ContactTables::balls (−1: none).
void build_arm_clearance(const BodyModel& model, const rig::Skeleton& skeleton, std::span<const int> ball_of_primitive,
                         ContactTables& t);

// Poses the contact's balls for the frame, then turns each arm about its shoulder so that no probe
// of its hand and forearm lies inside the torso's or a thigh's volume (to within the turn's cap),
// in `world_from_joint`, before the skin is deformed (and poses the turned arm's balls again).
// Never allocates.
void clear_arms(const ContactTables& t, ContactState& st, std::span<rig::RigidTransform> world_from_joint);

// Pushes the vertices of each pair that lie inside the other volume onto its surface, the balls
// as clear_arms posed them this frame. A band's
// pushes are scaled by its follow's fade this frame (`follow_fade`, per loop follow: 1 up to
// 95° of the limb's swing, none past 120°): swung that far the arm passes through the chest by
// design, and pushing its band there only folded it. Never allocates.
void apply_contact(const ContactTables& t, ContactState& st, std::span<const float> follow_fade,
                   std::span<glm::vec3> pos);

}  // namespace mimic::avatar::realtime_detail
