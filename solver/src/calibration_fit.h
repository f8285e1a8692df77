// Internal to calibration: the stand-still's per-sensor statistics, the joint positions the
// sensors mark, and one pass of fitting Mimic's skeleton and its calibration posture to them.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/rig/skeleton.h"
#include "mimic/solver/calibration.h"
#include "mimic/solver/sensor_layout.h"

namespace mimic::solver::detail {

struct SensorStats {
  const SensorBinding* binding = nullptr;
  int count = 0;
  glm::dvec3 sum{0.0};
  glm::dquat qsum{0, 0, 0, 0};
  glm::quat first{1, 0, 0, 0};
  glm::vec3 mean_pos{0.0f};
  glm::quat mean_rot{1, 0, 0, 0};
  float max_dist_m = 0, max_angle_deg = 0;
};

// The joints the fit reads by name. Left and right limbs are two blocks in the same order, so
// that `sided` turns a left landmark into either side's.
enum class Landmark : uint8_t {
  pelvis,
  spine_mid,
  spine_upper,
  head,
  l_shoulder,
  l_elbow,
  l_wrist,
  l_hip,
  l_knee,
  l_ankle,
  r_shoulder,
  r_elbow,
  r_wrist,
  r_hip,
  r_knee,
  r_ankle,
  count
};
constexpr int kLandmarkCount = static_cast<int>(Landmark::count);
constexpr int kSideLandmarks = static_cast<int>(Landmark::r_shoulder) - static_cast<int>(Landmark::l_shoulder);
const char* landmark_name(Landmark l);  // the skeleton joint's name, e.g. "l_wrist"
// side 0: left, 1: right; `left` one of the l_ landmarks.
constexpr Landmark sided(int side, Landmark left) {
  return static_cast<Landmark>(static_cast<int>(left) + side * kSideLandmarks);
}

// World positions (tracker frame) of the joints the sensors mark, one slot per joint of the
// skeleton being fitted, each with its presence: reading a mark nobody set is an error
// (std::logic_error), never a zero.
class JointMarks {
 public:
  explicit JointMarks(const rig::Skeleton& skeleton);

  bool has(Landmark l) const { return has_joint(joint_of_[static_cast<size_t>(l)]); }
  glm::vec3 at(Landmark l) const;
  void set(Landmark l, const glm::vec3& p);

  bool has_joint(int j) const { return j >= 0 && present_[static_cast<size_t>(j)] != 0; }
  glm::vec3 at_joint(int j) const;
  void set_joint(int j, const glm::vec3& p);
  int joint_count() const { return static_cast<int>(pos_.size()); }

 private:
  std::vector<glm::vec3> pos_;
  std::vector<uint8_t> present_;
  std::array<int, kLandmarkCount> joint_of_{};  // -1: the skeleton has no such joint
};

struct Fit {
  rig::SkeletonDesc desc;
  rig::Pose pose;
  float height_m = 0;
  float floor_y_m = 0;
};

// Per joint name, the rotation that turns a sensor's instructed placement into world space.
using SegmentRotations = std::map<std::string, glm::quat>;

// One pass of the fit: skeleton proportions and calibration posture from the marks. Sensors are
// placed with `segment_rot` where it names their segment, else with the heading.
Fit fit_body(const rig::SkeletonDesc& base, const std::vector<SensorStats>& stats, const glm::quat& heading,
             const SegmentRotations& segment_rot, const CalibrationOptions& opt);

// Joint world positions of a skeleton posed at `pose`.
std::vector<rig::RigidTransform> pose_world(const rig::Skeleton& s, const rig::Pose& pose);

float angle_deg(const glm::quat& a, const glm::quat& b);

}  // namespace mimic::solver::detail
