// Which sensor sits on which body segment. A segment is named by the skeleton joint whose frame
// carries it (the hand by "l_wrist", the thigh by "l_hip"). The standard layouts number their
// sensors in the same order as the simulator's (sim/sensor_rig.h), so a tracker wired in that
// order needs no configuration:
//   "3"   head, l_hand, r_hand
//   "6"   "3" + pelvis, l_foot, r_foot
//   "11"  "6" + l_upper_arm, r_upper_arm, l_thigh, r_thigh, chest
//   "all" one sensor per joint of the skeleton, in skeleton order, named after the joint, at the
//         middle of its link.
// Each binding also carries where the wearer is told to strap the sensor (segment frame of the
// zero posture, metres): calibration uses it only to estimate body proportions; the actual
// offset is measured.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"

namespace mimic::solver {

struct SensorBinding {
  uint16_t sensor = 0;       // SensorSample::sensor
  std::string name;          // "head", "l_hand", "chest", …
  std::string segment;       // skeleton joint name
  glm::vec3 placement_m{0};  // instructed position on the segment (segment frame, zero posture)
  float link_fraction = 0;   // > 0: strapped this far along the segment's link (0.5 = middle),
                             // which placement_m then approximates on the default body
};

struct SensorLayout {
  std::string name;
  std::vector<SensorBinding> bindings;
};

// Fails (not_found) on an unknown name or a segment the skeleton lacks.
Result<SensorLayout> standard_layout(std::string_view name, const rig::Skeleton& skeleton);
std::vector<std::string> standard_layout_names();

}  // namespace mimic::solver
