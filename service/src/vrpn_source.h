// A `vrpn:DEVICE@HOST[:PORT]` (or `DEVICE@tcp://HOST[:PORT]`) source: a VRPN tracker's reports
// become tracker samples for the solver (docs/hardware.md).
//   layout=3|6|11|all   VRPN sensor i is sensor i of that standard layout (default 6); with
//                       devices=, device i (DEVICE first) is, each its sensor 0
//   devices=A,B,…       more tracker devices on the same server (OptiTrack Motive and Vicon
//                       Tracker serve one device per rigid body)
//   map=0:head,3:pelvis explicit: a sensor number of DEVICE, or a device name (its sensor 0) →
//   map=Head:head,…     a segment of the standard layouts ("head", "pelvis", "l_hand", "l_foot",
//                       "chest", "l_thigh", … or any joint); named devices are read as well
//   axes=x,-z,y         for the sender's X, Y and Z in turn, the Mimic axis it becomes (Mimic:
//                       +Y up, the body faces +Z, its left is +X); default x,y,z
//   scale=0.001         sender units → metres (default 1)
//   buttons=DEVICE      a vrpn_Button device on the same server: its presses reach the samples
//                       (the calibration trigger)
//   stale_ms=MS         a sensor with no report for this long is stale (default 250)
#pragma once

#include <memory>
#include <vector>

#include "mimic/core/clock.h"
#include "mimic/core/result.h"
#include "mimic/devices/source.h"
#include "mimic/rig/skeleton.h"
#include "mimic/solver/sensor_layout.h"

namespace mimic::service {

Result<std::unique_ptr<devices::SensorSource>> open_vrpn_source(const devices::SourceSpec& spec,
                                                                std::shared_ptr<const Clock> clock = nullptr);

// Where the spec's sensors are worn on `skeleton` (layout= or map=).
Result<solver::SensorLayout> vrpn_layout(const devices::SourceSpec& spec, const rig::Skeleton& skeleton);

// The signed axis mapping of an axes= value: column i is where the sender's axis i goes.
Result<glm::mat3> parse_axes(const std::string& text);

}  // namespace mimic::service
