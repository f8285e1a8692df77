// The named landmarks calibration fits the skeleton to (calibration_fit.h): each joint's mark,
// with a flag saying whether it was set, so a missing mark is an error, never a zero.
#include <stdexcept>
#include <string>

#include "calibration_fit.h"

namespace mimic::solver::detail {

using rig::Skeleton;

namespace {

constexpr const char* kLandmarkNames[kLandmarkCount] = {
    "pelvis", "spine_mid", "spine_upper", "head",    "l_shoulder", "l_elbow", "l_wrist", "l_hip",
    "l_knee", "l_ankle",   "r_shoulder",  "r_elbow", "r_wrist",    "r_hip",   "r_knee",  "r_ankle"};

}  // namespace

const char* landmark_name(Landmark l) { return kLandmarkNames[static_cast<size_t>(l)]; }

JointMarks::JointMarks(const Skeleton& skeleton)
    : pos_(static_cast<size_t>(skeleton.joint_count()), glm::vec3(0.0f)),
      present_(static_cast<size_t>(skeleton.joint_count()), 0) {
  for (int l = 0; l < kLandmarkCount; ++l) joint_of_[static_cast<size_t>(l)] = skeleton.find_joint(kLandmarkNames[l]);
}

glm::vec3 JointMarks::at(Landmark l) const {
  if (!has(l)) throw std::logic_error(std::string("calibration: no mark for ") + landmark_name(l));
  return pos_[static_cast<size_t>(joint_of_[static_cast<size_t>(l)])];
}

void JointMarks::set(Landmark l, const glm::vec3& p) {
  const int j = joint_of_[static_cast<size_t>(l)];
  if (j < 0) throw std::logic_error(std::string("calibration: the skeleton has no joint ") + landmark_name(l));
  set_joint(j, p);
}

glm::vec3 JointMarks::at_joint(int j) const {
  if (!has_joint(j)) throw std::logic_error("calibration: no mark for joint " + std::to_string(j));
  return pos_[static_cast<size_t>(j)];
}

void JointMarks::set_joint(int j, const glm::vec3& p) {
  if (j < 0 || j >= joint_count()) throw std::logic_error("calibration: no joint " + std::to_string(j) + " to mark");
  pos_[static_cast<size_t>(j)] = p;
  present_[static_cast<size_t>(j)] = 1;
}

}  // namespace mimic::solver::detail
