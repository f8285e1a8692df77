// The body model: skeleton proportions, ellipsoidal primitives (soft metaballs and hard
// ellipsoids) attached to joints, deformable primitives (muscles) driven by a joint DOF, and
// the skin layout (the eleven pieces and their contour counts). A file of a few kilobytes: the
// compact, parameterised body that is cheap to send over a network. Format: docs/body-model.md.
//
// Primitive geometry is given in the local frame of its joint, which is parallel to the world
// frame in the zero posture (T-pose; +Y up, +Z front, +X the character's left), metres.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"

namespace mimic::avatar {

// The fifteen groups of the paper. A contour sees only the primitives of its group, so the two
// legs never blend; primitives near a joint may sit in several groups.
enum class Group : uint8_t {
  upper_torso,
  lower_torso,
  hip,
  left_shoulder,
  right_shoulder,
  left_upper_arm,
  right_upper_arm,
  left_lower_arm,
  right_lower_arm,
  left_upper_leg,
  right_upper_leg,
  left_lower_leg,
  right_lower_leg,
  left_ankle,
  right_ankle,
};
inline constexpr int kGroupCount = 15;
using GroupMask = uint16_t;
inline constexpr GroupMask group_bit(Group g) { return static_cast<GroupMask>(1u << static_cast<int>(g)); }
const char* group_name(Group g);
std::optional<Group> group_from_name(std::string_view name);

// Rigid closed parts meshed once from their primitives (they cover the capped skin ends).
enum class RigidPart : uint8_t { none, head, left_hand, right_hand, left_foot, right_foot };
inline constexpr int kRigidPartCount = 5;
const char* rigid_part_name(RigidPart p);
std::optional<RigidPart> rigid_part_from_name(std::string_view name);

enum class PrimitiveKind : uint8_t {
  metaball,   // soft: its field blends with its group's other metaballs
  ellipsoid,  // hard: a solid ellipsoid united with the blended surface, no blending
};

// The paper's nine-parameter state G = {a, b, c, centre, orientation}.
struct PrimitiveState {
  glm::vec3 semi_axes_m{0.05f};     // a, b, c along the primitive's own x, y, z
  glm::vec3 center_m{0.0f};         // in the joint frame
  glm::vec3 orientation_rad{0.0f};  // rotation R = Rz·Ry·Rx (x applied first), joint frame
};

enum class Falloff : uint8_t { linear, parabolic, hyperbolic };  // f(t) = t, t², √t
const char* falloff_name(Falloff f);
// f(t) for t in [0, 1]: how far a deformable primitive has gone from its relaxed state.
float falloff_value(Falloff f, float t);

// G = G0 + f(t)(Gmax − G0) for θ ≥ θ0 with t = (θ − θ0)/(θmax − θ0), and the mirror image
// towards Gmin for θ ≤ θ0; θ's limits and θ0 are those of the skeleton DOF.
struct Deformation {
  std::string dof;  // reference DOF, e.g. "l_elbow_flexion"
  PrimitiveState at_min;
  PrimitiveState at_max;
  Falloff falloff = Falloff::linear;
};

struct Primitive {
  std::string name;
  std::string joint;  // the proximal joint whose frame the state is given in
  PrimitiveKind kind = PrimitiveKind::metaball;
  PrimitiveState state;    // G0, at the DOF's relaxed value θ0
  float weight = 1.0f;     // field strength; 1 makes a lone primitive's surface its ellipsoid
  float influence = 1.6f;  // radius of influence, in units of the semi-axes (> 1)
  GroupMask groups = 0;
  RigidPart part = RigidPart::none;
  std::optional<Deformation> deformation;
};

// Contour counts of the skin. The envelope is branching generalised cylinders: a torso stack
// whose bottom ring splits into two leg loops joined by a crotch bridge, whose top (chest) ring
// splits into two arm loops and a neck loop joined by bridges over the shoulders.
struct SkinLayout {
  int torso_points = 36;         // points per torso ring (even; split as below)
  int chest_front_arc = 10;      // chest-ring segments across the front (between the arm loops)
  int chest_side_arc = 8;        // segments along each side under an arm (part of the arm loop)
  int shoulder_bridge = 16;      // segments of each bridge over a shoulder, front armpit to back
  int crotch_bridge = 6;         // segments of the bridge under the crotch, front to back
  int lower_torso_contours = 7;  // rings from the crotch ring up to the waist ring
  int upper_torso_contours = 7;  // rings from the waist ring up to the chest ring
  int neck_contours = 9;         // rings from the neck loop to the skull base
  int upper_arm_contours = 12;   // rings from the arm loop to the elbow
  int lower_arm_contours = 10;   // rings from the elbow to the wrist
  int upper_leg_contours = 14;   // rings from the leg loop to the knee
  int lower_leg_contours = 12;   // rings from the knee to the ankle
  int boundary_contours = 4;     // k: boundary-driven rings at each junction (part of the above)
  // Points per contour of each limb's own rings; 0: its loop's count. A limb whose count differs
  // from its loop's keeps the loop's through its boundary-driven rings and first ring (the
  // transition band, at the junction's resolution), then a zipper strip to its own count.
  int neck_points = 0;
  int arm_points = 0;
  int leg_points = 0;
  int rigid_rings = 16;   // latitude rings of the rigid head, hand and foot meshes
  int rigid_points = 24;  // longitude points of those meshes
  // Heights, as fractions along their links, of the special rings.
  float crotch_drop_m = 0.085f;  // crotch ring below the pelvis joint (pelvis frame)
  float chest_ring = 0.15f;      // chest ring position along the spine_upper link (0..1)
  float neck_start = 0.35f;      // first true neck ring along the neck link (0..1)
};

struct BodyModel {
  std::string name = "mimic-default";
  rig::SkeletonDesc skeleton;
  std::vector<Primitive> primitives;
  SkinLayout skin;
};

// The mirror image of a left-side primitive ("l_…" names, joints, DOFs; left groups and parts)
// on the right side: x negated, y and z rotations negated.
Primitive mirrored(const Primitive& left);
// (Joints mirror with rig::mirrored, mimic/rig/skeleton_json.h.)

// The built-in adult body (about 1.67 m), written for Mimic; needs no data files: the authored
// body with its fit to the MakeHuman base mesh applied (body_overrides.h).
BodyModel default_body_model();
// The body as authored in code (default_body.cpp), before the fitted overrides.
BodyModel authored_body_model();

// Structural checks: joints, DOF names, groups, positive axes, influence > 1, deformations name
// a DOF of their joint chain, the skin layout is consistent with itself. Messages name the
// offending primitive or field.
Status validate(const BodyModel& model);

// JSON form (docs/body-model.md). Parsing reports the JSON path of the first problem.
std::string to_json(const BodyModel& model, bool pretty = true);
Result<BodyModel> body_model_from_json(std::string_view text, std::string_view source_name = "body");
Result<BodyModel> load_body_model(const std::string& path);
Status save_body_model(const BodyModel& model, const std::string& path);

// The paper's five scaling operators, normalised (1 keeps the body as it is).
struct BodyScaling {
  float total_height = 1.0f;          // uniform
  float frontal_scaling = 1.0f;       // front–back depth (z)
  float high_lateral_scaling = 1.0f;  // width (x) of the body above the hips: torso, arms, head
  float low_lateral_scaling = 1.0f;   // width (x) of the hips and legs
  float spine_origin_ratio = 1.0f;    // spine origin (pelvis) height / total height, relative to
                                      // now; the total height is kept
};

// A new, editable body model. The operators act in the world frame of the standing posture
// (standing_posture: x lateral, y high, z frontal): every joint offset and link tip, and every
// primitive's centre, is scaled per world axis by the ratios of its region (legs and hips below
// the spine origin, the rest above); every principal axis of every primitive is tagged lateral,
// high or frontal by its dominant world component (scaling_tag) and its length scaled by that
// ratio; orientations kept. Fails on a non-positive or non-finite factor.
Result<BodyModel> scale_body(const BodyModel& model, const BodyScaling& scaling);

// A change of shape beyond the five operators (body_presets.h): the named primitives' centres
// (about their joints) and semi-axes scaled, and their centres moved, per world axis of the
// standing posture (x lateral, y high, z frontal; as scale_body), deformed states alike.
struct ShapeChange {
  // Space-separated primitive names; "l_NAME" also changes "r_NAME", mirrored; "part:head"
  // (hands: "part:left_hand", "part:right_hand"; feet likewise) every primitive of a rigid part.
  std::string_view primitives;
  glm::vec3 scale{1.0f};    // lateral, high, frontal
  glm::vec3 shift_m{0.0f};  // +x towards the body's left (mirrored on the right), +y up, +z front
};
// Fails on a non-positive or non-finite factor, or a name that no primitive has.
Result<BodyModel> reshape_body(const BodyModel& model, std::span<const ShapeChange> changes);

// The posture the scaling operators are defined in: the zero posture (a T-pose) with the upper
// arms lowered to the sides by a quarter turn of shoulder abduction, so arms scale in length
// with the height and in girth with the lateral and frontal ratios.
rig::Pose standing_posture(const rig::Skeleton& skeleton);

// The relaxed standing posture `--pose rest` shows: arms lowered towards the sides (not quite
// touching the hips), elbows slightly bent, every other DOF at its relaxed value θ0.
rig::Pose relaxed_posture(const rig::Skeleton& skeleton);

// 0 lateral (x), 1 high (y), 2 frontal (z): the largest |component| of a world direction.
int scaling_tag(const glm::vec3& axis_world);

}  // namespace mimic::avatar
