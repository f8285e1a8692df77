// Naming where a network tracker is worn (VRPN, OSC trackers): a segment name of the standard
// layouts ("head", "pelvis", "chest", "l_hand", "l_foot", "l_upper_arm", "l_thigh", the r_ ones)
// or any joint of the skeleton, resolved to a solver mount at the layout's instructed placement.
#pragma once

#include <string>
#include <vector>

#include "mimic/core/result.h"
#include "mimic/rig/skeleton.h"
#include "mimic/solver/body_solver.h"

namespace mimic::service {

// The mount of sensor `sensor` worn on `segment_name`; fails (not_found, listing the names) for a
// name neither a layout binding nor a joint.
Result<solver::SensorMount> mount_on(const std::string& segment_name, uint16_t sensor, const rig::Skeleton& skeleton);

// "a,b,,c" → {"a", "b", "c"}.
std::vector<std::string> split_list(const std::string& text);

}  // namespace mimic::service
