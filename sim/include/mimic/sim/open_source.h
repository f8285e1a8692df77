// Opens any tracker source named by a source spec (devices/source.h):
//   sim:NAME    the sensor rig on a built-in motion ("walk", "run", "idle"; empty = "walk")
//   bvh:CLIP    the sensor rig on a BVH clip retargeted onto Mimic's skeleton
//   replay:FILE a recorded log (params speed, loop, from)
//   flock:PATH  a Flock of Birds on a serial port, when the driver is built in
// Rig parameters (sim and bvh):
//   sensors=3|6|11|all (6)  rate=HZ (100)  noise_mm=σ (1)  noise_deg=σ (0.5)  drift_mm=σ/√s (0)
//   drift_deg=σ/√s (0)  latency_ms=MS (0)  dropout=P (0)  burst=TICKS (1)  seed=N (1)
// bvh only: loop=1 plays the clip again and again (otherwise its last frame is held).
// Replay parameters: speed=X (1; 0 = unpaced)  loop=1  from=S (seconds after the first sample).
// Sources run on the host's steady clock unless a clock is given.
//
// Fails with a clear error on a scheme that yields 6-DOF input rather than tracker samples
// (spaceball, magellan, spacemouse), on a driver this build lacks, an unknown motion or layout,
// a missing or unreadable file, or a bad parameter value.
#pragma once

#include <memory>

#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"
#include "mimic/devices/serial.h"
#include "mimic/devices/source.h"
#include "mimic/core/clock.h"
#include "mimic/sim/log.h"
#include "mimic/sim/replay_source.h"
#include "mimic/sim/sensor_rig.h"

namespace mimic::sim {

// `tap`, when given, sees the raw bytes of a serial device (Flock); other sources ignore it.
// `performer`, when given, is the body the simulated sensors ride on (sim: motions are made on
// it, bvh: clips drive it); otherwise Mimic's default skeleton (sim:) or the clip's performer.
Result<std::unique_ptr<devices::SensorSource>> open_sensor_source(const devices::SourceSpec& spec,
                                                                  std::shared_ptr<const Clock> clock = nullptr,
                                                                  std::shared_ptr<devices::ByteTap> tap = nullptr,
                                                                  const rig::Skeleton* performer = nullptr);

// The rig parameters of a sim: or bvh: spec, with the layout resolved on `skeleton`.
Result<RigConfig> rig_config_from_spec(const devices::SourceSpec& spec, const rig::Skeleton& skeleton);
// The replay parameters of a replay: spec.
Result<ReplayOptions> replay_options_from_spec(const devices::SourceSpec& spec);

// What a log recorded from `source` (opened from `spec`) should say in its header: the spec,
// and for simulated sources the sensor layout, seed and rate; for replays, the original header;
// for a started Flock, its birds (named "bird<address>"), measurement rate and model.
LogHeader log_header_for(const devices::SourceSpec& spec, const devices::SensorSource& source);

}  // namespace mimic::sim
