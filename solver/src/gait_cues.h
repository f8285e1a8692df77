// What the head and hands say of a gait nobody tracks the legs of (locomotion.cpp): the head's bob
// and sway, the arms' swing and its beat. Each follows its cue in the LocomotionState it is given
// and never allocates.
#pragma once

#include <cmath>

#include <glm/glm.hpp>

#include "mimic/solver/locomotion.h"

namespace mimic::solver::detail {

constexpr float kPi = 3.14159265f;
inline float wrap_rad(float a) { return std::remainder(a, 2.0f * kPi); }
inline glm::vec2 xz(const glm::vec3& p) { return {p.x, p.z}; }

// Follows the head's height; true on the frame a low is found (LocomotionState::Bob). `running`:
// the body moves at a run's speed (a first low takes a run's beat).
bool track_bob(LocomotionState::Bob& b, float head_y, float dt, const LocomotionOptions& o, bool running);

// The head's sideways sway about its mean path (which foot carries the body), and its speed
// along and across that path (LocomotionState::path_mps, sway_mps); returns the sway, metres.
float track_head(LocomotionState& s, const LocomotionInput& in, float dt, const LocomotionOptions& o);

// The hands' fore-and-aft difference and its rate (LocomotionState::arm_swing_m, arm_swing_mps),
// along the line of travel once walking, else along the pelvis' heading.
void track_arm_swing(LocomotionState& s, const LocomotionInput& in, float dt, const LocomotionOptions& o);

// The arms' beat (LocomotionOptions::arm_beat), walking: where the hands' fore-and-aft swing
// turns back, the foot on the side of the hand that was forward lifts and the other lands.
void track_arm_beat(LocomotionState& s, const LocomotionOptions& o, bool walking);

// A low of the head found while walking or running (the bob times the steps).
void on_head_low(LocomotionState& s, float sway_m, const LocomotionOptions& o);

// A swing hurried to end `remaining_s` from now: the phase stays (the foot does not jump) and
// runs faster.
void retime_swing(FootStepState& f, float remaining_s);

}  // namespace mimic::solver::detail
