#include "gait_cues.h"

#include <algorithm>

namespace mimic::solver::detail {

bool track_bob(LocomotionState::Bob& b, float head_y, float dt, const LocomotionOptions& o, bool running) {
  b.clock_s += dt;
  if (!b.have) {
    b.y_m = b.extreme_y_m = head_y, b.have = true, b.descending = false;
    return false;
  }
  b.y_m += (1.0f - std::exp(-dt / o.bob_tau_s)) * (head_y - b.y_m);
  if (!b.descending) {
    if (b.y_m > b.extreme_y_m) b.extreme_y_m = b.y_m;
    if (b.y_m < b.extreme_y_m - o.bob_rise_m) b.descending = true, b.extreme_y_m = b.y_m, b.low_s = b.clock_s;
    return false;
  }
  if (b.y_m < b.extreme_y_m) b.extreme_y_m = b.y_m, b.low_s = b.clock_s;
  if (b.y_m < b.extreme_y_m + o.bob_rise_m) return false;
  const double since = b.last_low_s >= 0 ? b.low_s - b.last_low_s : 0.0;
  // A dip sooner than a step after the last low, in a gait already timed, is no step: the beat
  // goes on (taken as the end of the gait, it dropped a run out of its running steps for half a
  // second).
  if (b.last_low_s >= 0 && since < o.bob_min_period_s && b.period_s > 0) {
    b.descending = false, b.extreme_y_m = b.y_m;
    return false;
  }
  b.period_s = since >= o.bob_min_period_s && since <= o.bob_max_period_s ? static_cast<float>(since) : 0.0f;
  // The first low of a walk (or run): a step of a usual length in time, until the next low
  // measures it.
  if (b.last_low_s < 0) b.period_s = running ? o.run_first_period_s : o.bob_first_period_s;
  b.last_low_s = b.low_s;
  b.descending = false, b.extreme_y_m = b.y_m;
  return true;
}

void retime_swing(FootStepState& f, float remaining_s) {
  if ((1.0f - f.phase) * f.duration_s <= remaining_s) return;
  f.duration_s = std::max(1e-3f, remaining_s / std::max(1e-3f, 1.0f - f.phase));
}

float track_head(LocomotionState& s, const LocomotionInput& in, float dt, const LocomotionOptions& o) {
  float sway_m = 0;
  if (in.have_head) {
    if (!s.have_sway) s.sway_centre = s.last_head = xz(in.head), s.have_sway = true;
    s.sway_centre += (1.0f - std::exp(-dt / o.sway_tau_s)) * (xz(in.head) - s.sway_centre);
    // The mean path trails a walking head by its velocity times the time constant; seen from a
    // heading a few degrees off the path, that trail would read as sway of several centimetres.
    const glm::vec2 mean_now = s.sway_centre + o.sway_tau_s * s.velocity_mps;
    sway_m = glm::dot(xz(in.head) - mean_now, glm::vec2(std::cos(in.root_yaw_rad), -std::sin(in.root_yaw_rad)));
    // On a curved path the mean path cuts the corner: a steady offset, taken out.
    s.sway_bias_m += (1.0f - std::exp(-dt / o.sway_bias_tau_s)) * (sway_m - s.sway_bias_m);
    sway_m -= s.sway_bias_m;
    // Across the head's own mean path: the pelvis' heading turns with each stride, and a walk's
    // forward speed seen from a heading a few degrees off would swamp the sideways motion.
    // Over the time since the head was last seen: back after a dropout, its move over the gap is
    // not one frame's.
    const glm::vec2 head_mps = (xz(in.head) - s.last_head) / (dt + s.head_gap_s);
    s.last_head = xz(in.head);
    s.head_gap_s = 0;
    s.path_mps += (1.0f - std::exp(-dt / o.path_tau_s)) * (head_mps - s.path_mps);
    const float path_speed = glm::length(s.path_mps);
    const glm::vec2 left = path_speed > 0.2f ? glm::vec2(s.path_mps.y, -s.path_mps.x) / path_speed
                                             : glm::vec2(std::cos(in.root_yaw_rad), -std::sin(in.root_yaw_rad));
    // On a curve the mean path's heading lags the head's own: a steady sideways speed, taken out.
    const float across_mps = glm::dot(head_mps, left);
    s.sway_mps_bias += (1.0f - std::exp(-dt / o.sway_speed_bias_tau_s)) * (across_mps - s.sway_mps_bias);
    s.sway_mps += (1.0f - std::exp(-dt / o.sway_speed_tau_s)) * (across_mps - s.sway_mps_bias - s.sway_mps);
  }
  if (!in.have_head && s.have_sway) s.head_gap_s = std::min(s.head_gap_s + dt, 10.0f);
  return sway_m;
}

void track_arm_swing(LocomotionState& s, const LocomotionInput& in, float dt, const LocomotionOptions& o) {
  if (!in.have_hands) {
    s.have_arm_swing = false, s.arm_swing_mps = 0;
    return;
  }
  // Along the line of travel once walking: the heading can be 10–20° off it at a walk's start.
  const float speed = glm::length(s.velocity_mps);
  const glm::vec2 forward = speed > o.arm_beat_from_mps
                                ? s.velocity_mps / speed
                                : glm::vec2(std::sin(in.root_yaw_rad), std::cos(in.root_yaw_rad));
  const float swing_m = glm::dot(xz(in.hand[0]) - xz(in.hand[1]), forward);
  if (s.have_arm_swing)
    s.arm_swing_mps += (1.0f - std::exp(-dt / o.arm_swing_tau_s)) * ((swing_m - s.arm_swing_m) / dt - s.arm_swing_mps);
  s.arm_swing_m = swing_m, s.have_arm_swing = true;
}

void track_arm_beat(LocomotionState& s, const LocomotionOptions& o, bool walking) {
  LocomotionState::ArmBeat& a = s.arm;
  if (!o.arm_beat || !s.have_arm_swing || !walking || glm::length(s.velocity_mps) <= o.arm_beat_from_mps) {
    a = {};
    return;
  }
  const double now = s.bob.clock_s;
  const float m = s.arm_swing_m;
  if (a.sign == 0 || (a.sign > 0 ? m > a.extreme_m : m < a.extreme_m)) a.extreme_m = m, a.extreme_s = now;
  const int turned = a.sign >= 0 && s.arm_swing_mps < -o.arm_turn_mps  ? -1
                     : a.sign <= 0 && s.arm_swing_mps > o.arm_turn_mps ? 1
                                                                       : 0;
  if (turned == 0) return;
  const float period_s = a.last_turn_s >= 0 ? static_cast<float>(a.extreme_s - a.last_turn_s) : 0.0f;
  const bool beat = a.sign != 0 && a.last_turn_s >= 0 && std::abs(a.extreme_m - a.last_turn_m) >= o.arm_beat_min_m &&
                    period_s >= o.bob_min_period_s && period_s <= o.bob_max_period_s;
  // The walk's first beat: its first turn, or one too soon after a turn that was not a beat.
  const bool first = !beat && a.period_s == 0 && std::abs(a.extreme_m) > o.arm_first_m &&
                     (a.sign == 0 || std::abs(a.extreme_m - a.last_turn_m) >= o.arm_beat_min_m);
  if (beat || first) {
    a.period_s = beat ? period_s : o.bob_first_period_s;
    a.lifter = a.extreme_m > 0 ? 0 : 1;  // the left hand forward: the left foot is behind
    a.lift_from_s = a.extreme_s;
    a.active_until_s = now + 1.5 * a.period_s;
    // A foot its leg could no longer reach may have lifted just before the turn: this beat is
    // that swing's, which now lasts the beat's time (lifted again, it stepped twice).
    FootStepState& lifter = s.feet[a.lifter];
    if (lifter.driven && lifter.swinging && lifter.phase * lifter.duration_s < 0.5f * a.period_s) {
      const float left_s = o.arm_swing_fraction * a.period_s - static_cast<float>(now - a.extreme_s);
      if (left_s > (1.0f - lifter.phase) * lifter.duration_s)
        lifter.duration_s = left_s / std::max(1e-3f, 1.0f - lifter.phase);
      a.lift_from_s = -1;
    }
    // The other foot strikes the floor at the turn: a swing still going lands now.
    FootStepState& other = s.feet[1 - a.lifter];
    if (other.driven && other.swinging) retime_swing(other, 0.04f);
  }
  a.last_turn_m = a.extreme_m, a.last_turn_s = a.extreme_s;
  a.sign = turned;
  a.extreme_m = m, a.extreme_s = now;
}

void on_head_low(LocomotionState& s, float sway_m, const LocomotionOptions& o) {
  LocomotionState::Bob& b = s.bob;
  // Walking, both feet are down at the low: the swinging foot lands; the trailing one lifts soon.
  // Running, the low is the supporting foot's mid-stance, and the foot in the air lands before
  // the next low.
  const float land_in_s =
      s.running ? static_cast<float>(b.low_s + (1.0 - o.run_strike_before_low) * b.period_s - b.clock_s) : 0.0f;
  for (auto& f : s.feet)
    if (f.driven && f.swinging) retime_swing(f, std::max(0.04f, land_in_s));
  b.lift_at_s = b.low_s + (s.running ? o.run_lift_after_low : o.bob_lift_fraction) * b.period_s;
  // At a foot's strike the head is still over the other, trailing foot (its sway lags the
  // body's weight by about a quarter stride) and moving towards the striking one: the trailing
  // foot lifts next. The motion says it clearly at every strike; the side only at the first.
  b.lifter = b.beats < o.bob_sway_beats && std::abs(sway_m) > o.bob_sway_choice_m ? (sway_m > 0 ? 0 : 1) : -1;
  if (o.bob_sway_speed_mps > 0 && std::abs(s.sway_mps) > o.bob_sway_speed_mps) b.lifter = s.sway_mps > 0 ? 1 : 0;
  ++b.beats;
  b.run_catch_up = false;
  if (!s.running || !s.feet[0].driven || !s.feet[1].driven) return;
  // Running, the foot under the body lifts next: the one the arms' swing says (the head's sway is
  // too small beside a run's speed to read), else the one on the floor. If it is in the air the
  // run is on the wrong foot: it lands now, and the other lifts now to land before the next low.
  int stance = -1;
  if (s.have_arm_swing && std::abs(s.arm_swing_mps) > o.run_arm_swing_mps)
    stance = s.arm_swing_mps > 0 ? 0 : 1;
  else if (s.feet[0].swinging != s.feet[1].swinging)
    stance = s.feet[0].swinging ? 1 : 0;
  if (stance < 0) return;
  b.lifter = stance;
  if (s.feet[stance].swinging && !s.feet[1 - stance].swinging) {
    retime_swing(s.feet[stance], 0.04f);
    b.lifter = 1 - stance, b.lift_at_s = b.clock_s, b.run_catch_up = true;
  }
}

}  // namespace mimic::solver::detail
