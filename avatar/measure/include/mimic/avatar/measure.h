// Body measurements of a skin mesh, for comparing Mimic's body with a reference body (e.g. the
// MakeHuman base mesh): standing height, tape-measure girths, volume and area, and a pose that
// puts Mimic's skeleton in the reference's posture so the two can be measured alike.
//
// A girth is what a tape measure reads: the perimeter of the convex hull of one planar
// cross-section loop, the loop that encloses the limb or torso axis at that place (so arms
// hanging beside the torso, or the other leg, are not wrapped in). A slice whose torso loop
// has swallowed an arm (at the armpit) is skipped.
//
// All positions in metres, +Y up, the body faces +Z, its left is +X (the mesh must be in metres:
// scale it first). Girths are taken on the left limbs.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/avatar/mesh.h"
#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"

namespace mimic::avatar {

struct LimbLandmarks {
  glm::vec3 hip_m{0}, knee_m{0}, ankle_m{0};
  glm::vec3 shoulder_m{0}, elbow_m{0}, wrist_m{0};
};

// Joint centres of a body, world positions in metres.
struct BodyLandmarks {
  float ground_y_m = 0;  // the floor under the feet
  glm::vec3 pelvis_m{0};
  std::vector<glm::vec3> spine_m;  // spine joints between pelvis and neck, bottom to top (may be empty)
  glm::vec3 neck_m{0}, head_m{0};
  glm::vec3 head_top_m{0};  // top of the skull joint chain (not the skin's top)
  LimbLandmarks left, right;
};

// MakeHuman joint CSV (rows `name,x,y,z`; `#` comments and a `name,x,y,z` header allowed):
// l-upper-leg → left.hip, l-knee, l-ankle, l-shoulder, l-elbow, l-hand → left.wrist (same
// for r-), pelvis, neck, head, head-2 → head_top, ground → ground_y, and whichever of
// spine-4 … spine-1 (bottom to top) are present. Other rows are ignored. Fails with
// parse_error naming the line, or not_found naming the missing joints.
Result<BodyLandmarks> parse_makehuman_joints(std::string_view csv, float metres_per_unit = 0.1f,
                                             std::string_view source = "joints.csv");
Result<BodyLandmarks> load_makehuman_joints(const std::string& csv_path, float metres_per_unit = 0.1f);

// The same CSV form, so any landmarks (e.g. of Mimic's posed skeleton) can be saved beside a
// mesh and measured with `mimic measure --obj … --joints …`. Up to four spine joints are kept,
// the top one named spine-1.
std::string format_landmarks_csv(const BodyLandmarks& landmarks, float units_per_metre = 1.0f);

// Rough landmarks of a standing, roughly left–right symmetric body mesh without joints, from
// average human proportions: ground at the lowest point, torso and leg axes through the
// centroids of horizontal bands of vertices (torso near the mirror plane, legs either side).
// Arms are not located (shoulder = elbow = wrist), so no upper-arm girth is taken.
BodyLandmarks estimate_landmarks(const Mesh& mesh_m);

// Landmarks of a posed Mimic skeleton: its joints (spine_lower/mid/upper as the spine), the
// head link's tip as head_top, and the ground 1.8 cm below the lowest joint or link tip (the
// sole under the toe joint, as standing_root_height_m assumes).
BodyLandmarks landmarks_from_skeleton(const rig::Skeleton& skeleton, const rig::Pose& pose);

// Measurements in metres (volume m³, area m²). A girth that could not be taken (no loop
// around the axis anywhere in its search range) is std::nullopt. The *_level_m fields give
// the height above ground of the horizontal slice each girth came from.
struct BodyMeasurements {
  float height_m = 0;  // highest skin point − ground
  std::optional<float> chest_girth_m, waist_girth_m, hip_girth_m;
  std::optional<float> thigh_girth_m, calf_girth_m, upper_arm_girth_m;  // left limbs
  float chest_level_m = 0, waist_level_m = 0, hip_level_m = 0, thigh_level_m = 0, calf_level_m = 0;
  double volume_m3 = 0, surface_area_m2 = 0;
};

// A tape around a body in one plane: the loops of that plane's cross-section that hold an
// `include` point and no `exclude` point (projected into the plane) are wrapped by their convex
// hull.
struct GirthTape {
  glm::vec3 point{0}, normal{0, 1, 0};
  std::vector<glm::vec3> include, exclude;
};
struct GirthTapes {
  std::optional<GirthTape> chest, waist, hips, thigh, calf, upper_arm;  // the limbs' on the left
};

// Search ranges (H = height):
//   chest  max torso girth for slices at 0.68–0.76 H above ground, up to the armpit (a slice
//          whose torso loop is 15% longer than the one 5 mm below has taken in an arm)
//   waist  min torso girth at 0.56–0.66 H
//   hips   max torso girth at 0.45–0.54 H (only if the torso has split below the crotch at
//          every one of those levels, the tape wraps both thighs instead)
//   thigh  max girth of horizontal slices in the upper third from hip to knee (the slices
//          still inside the torso are skipped, so this lands just below the gluteal fold)
//   calf   max girth of horizontal slices in the upper 60% from knee to ankle
//   upper arm  the slice perpendicular to shoulder→elbow at its midpoint
// Slices are 5 mm apart. Cost: about 200 slices, each linear in the triangle count.
//
// With `tapes`, where each girth was taken (its slice's tape), for fitting a body to a
// reference's girths (body_fit.h).
BodyMeasurements measure_body(const Mesh& mesh_m, const BodyLandmarks& landmarks, GirthTapes* tapes = nullptr);

// The closed loops (and open chains, where the mesh has holes) where a plane cuts the mesh.
std::vector<std::vector<glm::vec3>> cross_section(const Mesh& mesh, const glm::vec3& plane_point,
                                                  const glm::vec3& plane_normal);

// Tape girth in one plane: the convex-hull perimeter of the loops that enclose any `include`
// point, unless such a loop also encloses an `exclude` point (points are projected into the
// plane). nullopt when no loop qualifies.
std::optional<float> tape_girth(const Mesh& mesh, const glm::vec3& plane_point, const glm::vec3& plane_normal,
                                std::span<const glm::vec3> include, std::span<const glm::vec3> exclude = {});

std::optional<float> tape_girth(const Mesh& mesh, const GirthTape& tape);

// The corners of the tape's convex hull (in the plane, in order round it): where the tape
// touches the surface. Empty when no loop qualifies.
std::vector<glm::vec3> tape_hull(const Mesh& mesh, const GirthTape& tape);

// Rows for tables and JSON: name (e.g. "chest girth"), key (e.g. "chest_girth"), value in the
// unit named ("cm" for lengths, "dm3" for the volume, "m2" for the area); absent girths are
// left out.
struct MeasurementRow {
  std::string name, key, unit;
  double value = 0;
};
std::vector<MeasurementRow> measurement_rows(const BodyMeasurements& m);

// A text table (measurement, value) and a JSON object {"height_cm": …, "chest_girth_cm": …}.
std::string format_measurements(const BodyMeasurements& m);
std::string measurements_json(const BodyMeasurements& m);

// Ours against a reference: columns measurement, ours, reference, difference %, PASS/FAIL
// (|difference| ≤ tolerance, default ±10%). A measurement missing on either side FAILs.
std::string format_comparison(const BodyMeasurements& ours, const BodyMeasurements& reference, double tolerance = 0.10);
// {"tolerance": 0.1, "pass": bool, "rows": [{"key", "unit", "ours", "reference", "difference", "pass"}]}
std::string comparison_json(const BodyMeasurements& ours, const BodyMeasurements& reference, double tolerance = 0.10);
bool comparison_passes(const BodyMeasurements& ours, const BodyMeasurements& reference, double tolerance = 0.10);

// A pose of `skeleton` in the posture of the landmarks: the root at the landmarks' pelvis,
// spine and head as in the zero posture, and shoulder + elbow and hip + knee DOFs chosen (within
// their limits) so upper arm, forearm, thigh and shin point along the landmark segments
// shoulder→elbow, elbow→wrist, hip→knee and knee→ankle. Other DOFs stay at zero.
rig::Pose pose_to_match(const rig::Skeleton& skeleton, const BodyLandmarks& landmarks);

}  // namespace mimic::avatar
