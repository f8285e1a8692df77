// `mimic bench`'s end-to-end latencies: a tracker sample entering Mimic → the avatar's frame
// leaving the server's socket, through the pipeline of `mimic run` (solver, skin, encoder,
// server, one subscriber reading).
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "mimic/core/result.h"

namespace mimic::app {

// Where the samples come from:
//   "sim"   the simulated walk inside the process (a sample's capture time → frame out)
//   "vrpn"  the same walk's six sensors sent by Mimic's VRPN server over loopback UDP to a
//           vrpn: source (the report read from its socket → frame out)
//   "vmc"   the same six sensors as VMC device messages (/VMC/Ext/Tra/Pos, one OSC bundle per
//           sensor sample) over loopback UDP to a vmc:?map= source (the bundle read → frame out)
// The loop is run's: it sleeps `slice_us` between passes; at SCHED_FIFO `rt_priority` (mimic run
// --realtime) when that is not 0 and the system allows it ({"refused": true} otherwise).
// Returns {"p50", "p99", "frames", "stages": {stage: {p50_us, p99_us}}} in microseconds.
Result<nlohmann::json> pipeline_latency(const std::string& input, double seconds, int slice_us, int rt_priority);

}  // namespace mimic::app
