// Every tracker source that yields sensor samples, opened by its spec, for the commands that read
// samples rather than poses (record, calibrate) and for the solver feeds:
//   sim:, bvh:, replay:, flock:           sim/open_source.h
//   vrpn:DEVICE@HOST[:PORT]               a VRPN tracker (vrpn_source.h)
//   osc-trackers:[HOST:]PORT              VRChat-style OSC trackers (osc_tracker_source.h)
//   vmc:[HOST:]PORT?map=SERIAL:SEGMENT    a VMC sender's 6-DOF devices
// (`vmc:` without map= carries bones, a pose rather than samples: it has no sensor source.)
#pragma once

#include <memory>

#include "mimic/core/clock.h"
#include "mimic/core/result.h"
#include "mimic/devices/serial.h"
#include "mimic/devices/source.h"
#include "mimic/rig/skeleton.h"
#include "mimic/sim/log.h"
#include "mimic/solver/sensor_layout.h"

namespace mimic::service {

// The sources that speak a network protocol and say where their sensors are worn in the spec
// (layout= or map=) rather than in a simulated rig or a log.
bool is_network_tracker(const devices::SourceSpec& spec);

// `tap` sees a serial device's raw bytes (Flock); `performer` is the body a simulation rides on.
// Fails with the spec's problem, or for `vmc:` bones ("a pose source") and the 6-DOF input devices.
Result<std::unique_ptr<devices::SensorSource>> open_tracker_source(const devices::SourceSpec& spec,
                                                                   std::shared_ptr<const Clock> clock = nullptr,
                                                                   std::shared_ptr<devices::ByteTap> tap = nullptr,
                                                                   const rig::Skeleton* performer = nullptr);

// Where a network tracker's sensors are worn on `skeleton` (its layout= or map=), as calibration
// and the solver take them.
Result<solver::SensorLayout> network_tracker_layout(const devices::SourceSpec& spec, const rig::Skeleton& skeleton);

// What a log recorded from `source` says in its header: sim::log_header_for, and for a network
// tracker its sensors where the spec puts them (so a replay solves them where they were worn).
sim::LogHeader tracker_log_header(const devices::SourceSpec& spec, const devices::SensorSource& source,
                                  const rig::Skeleton& skeleton);

}  // namespace mimic::service
