// What a simulated 6-DOF input device (Spaceball, Magellan, SpaceMouse) is being pushed with:
// a function of simulated time. The default is a smooth, deterministic pattern from one seed.
#pragma once

#include <cstdint>
#include <functional>

#include "mimic/devices/sample.h"

namespace mimic::sim {

// t_s: seconds since the device powered up. Returns axes in [-1, 1] (InputFrame frame:
// +X right, +Y up, +Z toward the user) and buttons; host_time_s is ignored.
using InputPattern = std::function<devices::InputFrame(double t_s)>;

// Each axis is a sum of two slow sines (0.05–0.6 Hz) with amplitudes below 0.8 in total, and
// every ~2 s one button is held for 0.3 s. Frequencies, phases and button choices come from
// the raw output of mt19937_64(seed), so the pattern is the same on every standard library.
InputPattern default_input_pattern(uint64_t seed);

// The device at rest: no deflection, no buttons.
InputPattern rest_pattern();

}  // namespace mimic::sim
