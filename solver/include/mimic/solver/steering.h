// Steering the avatar through the scene with a Spaceball or SpaceMouse: the 6-DOF cap moves and
// turns a rigid offset that is applied on top of the tracked (solved) body.
//
// Input axes are InputFrame's: +X right, +Y up, +Z toward the user, each in [-1, 1]. Pushing the
// cap away from you walks the avatar forward (the way it faces after steering), pushing right
// walks it to its right, twisting the cap to the left (counter-clockwise seen from above, +Y
// rotation) turns it left; lifting moves it up only if `vertical` is set. Each axis has a dead
// zone (deflections below it do nothing) and a response curve ((|x| − dz)/(1 − dz))^exponent
// scaled to max speed / max turn rate. Buttons act on presses (edges): one asks for
// recalibration, one resets the offset (and asks for a solver reset).
//
// The offset turns the tracked body about a pivot: the tracked root's floor position when the
// steering was last reset, so turning spins the avatar in place rather than around the tracker.
// Pure: no I/O, no allocation, deterministic in its inputs.
#pragma once

#include <cstdint>

#include "mimic/rig/skeleton.h"
#include "mimic/devices/sample.h"

namespace mimic::solver {

struct SteeringConfig {
  float dead_zone = 0.08f;       // fraction of full deflection ignored, per axis
  float exponent = 2.0f;         // response curve: 1 linear, 2 gentle near centre
  float max_speed_m_s = 1.5f;    // at full deflection
  float max_turn_deg_s = 90.0f;  // at full twist
  bool vertical = false;         // lifting/pressing the cap moves the avatar up/down
  int recalibrate_button = 1;    // 1-based button number; 0 = none
  int reset_button = 2;          // 1-based button number; 0 = none
};

struct SteeringEvents {
  bool recalibrate = false;  // the recalibrate button was pressed
  bool reset = false;        // the reset button was pressed (the offset is already cleared)
};

class Steering {
 public:
  explicit Steering(SteeringConfig config = {}) : config_(config) {}

  // One step: `input` is the newest frame (hold it between device packets), dt_s the time since
  // the previous step (clamped to [0, 0.1] s so a stall never teleports the avatar).
  SteeringEvents update(const devices::InputFrame& input, double dt_s);

  // Tracked pose → steered pose (root position and orientation only). Latches the pivot on the
  // first call after a reset.
  void apply(rig::Pose& pose);

  void reset();  // no offset, no turn; the next apply() sets the pivot
  float heading_rad() const { return heading_rad_; }
  const glm::vec3& offset_m() const { return offset_m_; }
  const SteeringConfig& config() const { return config_; }

  // One axis through dead zone and response curve, in [-1, 1].
  float shape(float deflection) const;

 private:
  SteeringConfig config_;
  float heading_rad_ = 0;
  glm::vec3 offset_m_{0.0f};
  glm::vec3 pivot_m_{0.0f};
  bool pivot_set_ = false;
  uint32_t buttons_ = 0;
};

}  // namespace mimic::solver
