// An `osc-trackers:[HOST:]PORT` source: VRChat-style OSC trackers (as SlimeVR's server, phone
// trackers and other consumer full-body trackers send them to VRChat) become tracker samples for
// the solver. /tracking/trackers/{1..8}/position and /rotation (Unity's frame, Euler degrees) and
// /tracking/trackers/head/… are decoded by net/vmc_receive.h; each update of a tracker is one
// sample. Listens on loopback unless a host is given.
//   map=1:pelvis,2:chest,…  tracker number (head: 0) → segment (tracker_map.h's names); default
//                           SlimeVR's assignment: head, 1 pelvis, 2 chest, 3 l_foot, 4 r_foot,
//                           5 l_thigh, 6 r_thigh, 7 l_upper_arm, 8 r_upper_arm
//   stale_ms=MS             a source with no message for this long is stale (default 250)
#pragma once

#include <memory>
#include <vector>

#include "mimic/core/clock.h"
#include "mimic/core/result.h"
#include "mimic/devices/source.h"
#include "mimic/rig/skeleton.h"
#include "mimic/solver/sensor_layout.h"

namespace mimic::service {

// `vmc:[HOST:]PORT?map=SERIAL:SEGMENT,…`: a VMC sender's 6-DOF devices (/VMC/Ext/Tra/Pos,
// /Hmd/Pos, /Con/Pos — e.g. SteamVR trackers relayed by a VMC tool) as tracker samples for the
// solver, for senders that send devices and no bones. A device is named by its serial (its kind's
// letter first for an HMD or controller: "H:serial", "C:serial" also match); sensor i is the i-th
// map item.
Result<std::unique_ptr<devices::SensorSource>> open_vmc_device_source(const devices::SourceSpec& spec,
                                                                      std::shared_ptr<const Clock> clock = nullptr);
Result<solver::SensorLayout> vmc_device_layout(const devices::SourceSpec& spec, const rig::Skeleton& skeleton);

Result<std::unique_ptr<devices::SensorSource>> open_osc_tracker_source(const devices::SourceSpec& spec,
                                                                       std::shared_ptr<const Clock> clock = nullptr);

// Where the trackers are worn (sensor id = tracker number, head 0).
Result<solver::SensorLayout> osc_tracker_layout(const devices::SourceSpec& spec, const rig::Skeleton& skeleton);

}  // namespace mimic::service
