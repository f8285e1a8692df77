// Sensor-to-segment calibration from a few seconds of the wearer standing still in a T-pose
// (arms out, palms down) or an N-pose (arms down at the sides), facing any direction.
//
// From the capture (samples of every sensor of the layout, tracker reference frame = Mimic's
// world, +Y up) it measures, per sensor, the mean pose and how much it moved; then
//   - the heading from the left–right sensor pairs (hands, feet, upper arms, thighs);
//   - body proportions: each sensor, strapped where the layout says (SensorLayout placements),
//     marks its joint; height from head and feet (or the floor), arm length from shoulder to
//     hand, leg length from hip to foot, spine length from pelvis to head, shoulder and hip
//     width from the upper-arm and thigh sensors — whatever the layout has;
//   - the calibration posture: the nominal pose, with arm elevation and leg spread as measured;
//   - each sensor's offset on its segment, rotation and translation (segment_from_sensor).
// Refuses, with the reason, a capture in which a sensor of the layout is missing (or too
// sparse) or moved more than the stated tolerance. Saved and loaded as JSON.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"
#include "mimic/devices/sample.h"
#include "mimic/solver/body_solver.h"
#include "mimic/solver/sensor_layout.h"

namespace mimic::solver {

enum class CalibrationPose { t_pose, n_pose };

struct CalibrationOptions {
  CalibrationPose pose = CalibrationPose::t_pose;
  float max_motion_m = 0.03f;   // largest distance of a sensor from its mean over the capture
  float max_motion_deg = 6.0f;  // largest angle of a sensor from its mean orientation
  int min_samples = 5;          // per sensor
  float floor_y_m = 0.0f;       // floor height when no foot sensor shows it
};

struct SensorCalibration {
  uint16_t sensor = 0;
  std::string name;     // e.g. "l_hand"
  std::string segment;  // skeleton joint
  rig::RigidTransform segment_from_sensor;
};

struct Calibration {
  rig::SkeletonDesc skeleton;  // Mimic's skeleton fitted to the wearer
  std::vector<SensorCalibration> sensors;
  CalibrationPose pose = CalibrationPose::t_pose;
  float height_m = 0;           // floor to top of the head, estimated
  float heading_deg = 0;        // which way the wearer faced (0 = +Z, turning left positive)
  float floor_y_m = 0;          // floor height in tracker coordinates, estimated
  float standing_root_y_m = 0;  // root (pelvis joint) height while standing, tracker coordinates
  // The wearer's body model (`mimic calibrate --body-out`), relative to the calibration file's
  // folder; empty: none. `mimic run --calibration` uses it unless --body says otherwise.
  std::string body;
  // Capture statistics: how still the wearer stood.
  int samples = 0;
  double duration_s = 0;
  float max_motion_mm = 0;
  float max_motion_deg = 0;
};

// Mimic's skeleton as the solver fits it: the joints no sensor marks follow the common
// motion-capture convention (BVH from MotionBuilder and the CMU database): the lower back rises
// from the root, the neck and both clavicles branch from the top of the thoracic spine, the hip
// centres sit a hand's width below the root. Same joints, DOFs and limits as `base`; the joint
// positions of the zero posture change only where those conventions differ.
rig::SkeletonDesc tracking_skeleton_desc(const rig::SkeletonDesc& base = rig::default_skeleton_desc());

// [in] base: the skeleton to fit (tracking_skeleton_desc() usually); layout: which sensor is
// where; capture: every sample received during the stand-still (any order, any mix of sensors).
Result<Calibration> calibrate(const rig::SkeletonDesc& base, const SensorLayout& layout,
                              std::span<const devices::SensorSample> capture, const CalibrationOptions& options = {});

// The fitted skeleton and sensor mounts as the solver wants them.
Result<SolverModel> make_solver_model(const Calibration& calibration, SolverOptions options = {});

std::string calibration_to_json(const Calibration& calibration);
// Clear error (parse_error naming the field) on malformed or incomplete text.
Result<Calibration> calibration_from_json(std::string_view text);
Status save_calibration(const std::string& path, const Calibration& calibration);
Result<Calibration> load_calibration(const std::string& path);
// The path of a calibration's body file (Calibration::body) as seen from here: relative paths are
// taken from the calibration file's folder. Empty when it names none.
std::string calibration_body_path(const std::string& calibration_path, const Calibration& calibration);

const char* calibration_pose_name(CalibrationPose pose);  // "tpose", "npose"
Result<CalibrationPose> parse_calibration_pose(std::string_view name);

}  // namespace mimic::solver
