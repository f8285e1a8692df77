// Naming where a network tracker is worn (VRPN, OSC trackers): a segment name of the standard
// layouts ("head", "pelvis", "chest", "l_hand", "l_foot", "l_upper_arm", "l_thigh", the r_ ones)
// or any joint of the skeleton, resolved to a solver mount at the layout's instructed placement.
#pragma once

#include <string>
#include <vector>

#include "mimic/core/result.h"
#include "mimic/rig/skeleton.h"
#include "mimic/solver/body_solver.h"
#include "mimic/solver/sensor_layout.h"

namespace mimic::service {

// Sensor `sensor` worn on `segment_name`: the standard layouts' binding of that name (its
// instructed placement) or, for any other joint of the skeleton, a sensor at the joint; fails
// (not_found, listing the names) for a name that is neither.
Result<solver::SensorBinding> binding_on(const std::string& segment_name, uint16_t sensor,
                                         const rig::Skeleton& skeleton);

// The solver's mounts of a layout's sensors: each at its binding's instructed placement.
std::vector<solver::SensorMount> mounts_of(const solver::SensorLayout& layout);

// "a,b,,c" → {"a", "b", "c"}.
std::vector<std::string> split_list(const std::string& text);

}  // namespace mimic::service
