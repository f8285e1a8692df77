#include "mimic/sim/input_pattern.h"

#include <array>
#include <cmath>
#include <memory>
#include <random>

namespace mimic::sim {

namespace {

constexpr double kTwoPi = 6.283185307179586;

// Uniform in [lo, hi) from the raw engine output (std:: distributions differ by library).
double uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>(rng() >> 11) * (1.0 / 9007199254740992.0);
}

struct Wave {
  double amp, freq_hz, phase;
};

struct Pattern {
  std::array<std::array<Wave, 2>, 6> axes;
  std::array<uint8_t, 64> buttons;  // button pressed in each 2 s slot (cycled)
};

}  // namespace

InputPattern default_input_pattern(uint64_t seed) {
  auto p = std::make_shared<Pattern>();
  std::mt19937_64 rng(seed);
  for (auto& axis : p->axes) {
    axis[0] = {uniform(rng, 0.3, 0.5), uniform(rng, 0.05, 0.25), uniform(rng, 0.0, kTwoPi)};
    axis[1] = {uniform(rng, 0.1, 0.25), uniform(rng, 0.25, 0.6), uniform(rng, 0.0, kTwoPi)};
  }
  for (auto& b : p->buttons) b = static_cast<uint8_t>(rng() % 8);
  return [p](double t) {
    devices::InputFrame f;
    float v[6];
    for (size_t i = 0; i < 6; ++i) {
      double s = 0;
      for (const auto& w : p->axes[i]) s += w.amp * std::sin(kTwoPi * w.freq_hz * t + w.phase);
      v[i] = static_cast<float>(s);
    }
    f.translation = {v[0], v[1], v[2]};
    f.rotation = {v[3], v[4], v[5]};
    if (t >= 0) {
      const double slot = std::floor(t / 2.0);
      const double in_slot = t - 2.0 * slot;
      if (in_slot >= 1.0 && in_slot < 1.3) {
        f.buttons = 1u << p->buttons[static_cast<size_t>(slot) % p->buttons.size()];
      }
    }
    return f;
  };
}

InputPattern rest_pattern() {
  return [](double) { return devices::InputFrame{}; };
}

}  // namespace mimic::sim
