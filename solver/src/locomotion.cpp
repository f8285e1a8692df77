#include "mimic/solver/locomotion.h"

#include <algorithm>

#include "floor_clearance.h"
#include "gait_cues.h"
#include "mimic/solver/body_solver.h"

namespace mimic::solver {

using detail::kPi;
using detail::on_head_low;
using detail::retime_swing;
using detail::track_arm_beat;
using detail::track_arm_swing;
using detail::track_bob;
using detail::track_head;
using detail::wrap_rad;
using detail::xz;

namespace {

// `w` (the world frame of the first joint's parent) carried down `joints`, each the child of the
// one before, at the angles `dof`.
rig::RigidTransform down_chain(const rig::Skeleton& s, rig::RigidTransform w, std::initializer_list<int> joints,
                               std::span<const float> dof) {
  for (int j : joints) w = rig::RigidTransform{w.rotation * s.local_rotation(j, dof), w.apply(s.offset_m(j))};
  return w;
}

float smooth01(float t) {
  t = std::clamp(t, 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

// Where a step that starts now lands: under the hip, half a stance past touchdown at the pelvis'
// velocity, no further than `max_step_m` from the hip. Walking, the feet land nearer the body's
// midline than the hips do (CMU walks: ankles 9–12 cm apart, hips 18–20 cm).
glm::vec2 landing(const LocomotionInput& in, const LocomotionState& s, const LocomotionOptions& o, int k,
                  float remaining_s) {
  // Running, mid-stance (where the hip is over the foot) comes a part of the beat after the strike.
  const float stance_lead_s = s.running ? o.run_strike_before_low * s.bob.period_s : o.stance_lead_s;
  glm::vec2 lead = s.velocity_mps * (remaining_s + stance_lead_s);
  // On a curve the hip goes round it: the chord of the arc turns by half the arc's angle (the
  // built-in walk turns at 0.9 rad/s; a straight lead put each foot 10 cm off the hips' path).
  const float half_arc_rad = std::clamp(0.5f * s.turn_rps * (remaining_s + stance_lead_s), -0.6f, 0.6f);
  const float c = std::cos(half_arc_rad), sn = std::sin(half_arc_rad);
  lead = glm::vec2(c * lead.x + sn * lead.y, c * lead.y - sn * lead.x);
  const float len = glm::length(lead);
  if (len > o.max_step_m && !s.running) lead *= o.max_step_m / len;
  const glm::vec2 left(std::cos(in.root_yaw_rad), -std::sin(in.root_yaw_rad));
  const float lateral = glm::dot(xz(in.hip[k]) - xz(in.root), left);
  const float walking = std::clamp((glm::length(s.velocity_mps) - o.narrow_from_mps) / o.narrow_over_mps, 0.0f, 1.0f);
  const float side = k == 0 ? 1.0f : -1.0f;
  const float narrowed = walking * (lateral - side * 0.5f * o.walk_width_m);
  return xz(in.hip[k]) - narrowed * left + lead;
}

// Keeps foot k on its own side of the other foot by `min_width_m` (feet never cross).
glm::vec2 beside(glm::vec2 p, const glm::vec2& other, float yaw, int k, float min_width_m) {
  const glm::vec2 left(std::cos(yaw), -std::sin(yaw));  // skeleton +X (left) turned by the heading
  const float side = k == 0 ? 1.0f : -1.0f;
  const float lateral = side * glm::dot(p - other, left);
  if (lateral < min_width_m) p += side * (min_width_m - lateral) * left;
  return p;
}

void take_over(FootStepState& f, const LocomotionInput& in, int k) {
  f.driven = true;
  f.planted_yaw_rad = f.from_yaw_rad = f.yaw_rad = in.root_yaw_rad;
  const float floor_y = in.floor_ankle_y_m[k];
  if (!in.have_last_ankle) {
    f.planted = glm::vec3(in.hip[k].x, floor_y, in.hip[k].z);
    f.swinging = false;
    return;
  }
  // Where the foot was: planted there, or lowered onto the floor below it if it was in the air.
  const glm::vec3 last = in.last_ankle[k];
  f.planted = glm::vec3(last.x, floor_y, last.z);
  f.swinging = last.y > floor_y + 0.02f;
  f.from = glm::vec3(last.x, std::max(last.y, floor_y), last.z);
  f.phase = 0;
  f.duration_s = 0.2f;
}

// A planted foot the leg cannot reach flat (the trailing foot of a stride) lifts its heel: it
// turns about the ball of the foot, which stays where it was planted, until the ankle is in reach.
void lift_heel(rig::RigidTransform& ankle_t, const glm::vec3& hip, float reach_m, const glm::vec3& ball_in_ankle) {
  const float reach = 0.999f * reach_m;
  if (glm::length(hip - ankle_t.translation) <= reach || glm::length(ball_in_ankle) < 1e-3f) return;
  const glm::vec3 ball = ankle_t.apply(ball_in_ankle);
  auto ankle_at = [&](float pitch_rad) {
    return ball - ankle_t.rotation * (glm::angleAxis(pitch_rad, glm::vec3(1, 0, 0)) * ball_in_ankle);
  };
  float lo = 0.0f, hi = 0.8f;  // up to about 70° of heel lift; beyond, on tiptoe, the leg stretches
  for (int i = 0; i < 12 && glm::length(hip - ankle_at(hi)) <= reach; ++i) {
    const float mid = 0.5f * (lo + hi);
    (glm::length(hip - ankle_at(mid)) > reach ? lo : hi) = mid;
  }
  ankle_t.translation = ankle_at(hi);
  ankle_t.rotation = ankle_t.rotation * glm::angleAxis(hi, glm::vec3(1, 0, 0));
}

// Foot k this frame: held where planted, or carried along its swing towards a landing spot that
// follows the body for the first part of the swing.
void advance_foot(LocomotionState& s, const LocomotionInput& in, const LocomotionOptions& o, int k, float dt) {
  FootStepState& f = s.feet[k];
  if (!f.driven) return;
  const float floor_y = in.floor_ankle_y_m[k];
  const FootStepState& other = s.feet[1 - k];
  const glm::vec2 other_xz = other.driven ? xz(other.swinging ? other.ankle : other.planted) : xz(in.last_ankle[1 - k]);
  const bool other_known = other.driven || in.have_last_ankle;
  // Sideways for the crossing guard: across the line of travel when walking (the pelvis' heading,
  // from the head, is 5–16° off it on a curve and at a walk's start, and a stride's front foot
  // then seemed over the other's side and was pushed out).
  const bool walking_guard = s.have_travel && glm::length(s.velocity_mps) > o.travel_frame_from_mps;
  const float guard_yaw_rad = walking_guard ? s.travel_yaw_rad : in.root_yaw_rad;
  if (!f.swinging) {
    f.ankle = glm::vec3(f.planted.x, floor_y, f.planted.z);
    f.yaw_rad = f.planted_yaw_rad;
    return;
  }
  f.phase = std::min(1.0f, f.phase + dt / f.duration_s);
  // The landing spot follows the body during the first part of the swing, then is committed.
  if (f.phase < 0.7f) {
    glm::vec2 to = landing(in, s, o, k, (1.0f - f.phase) * f.duration_s);
    // Walking, a landing spot is on its own side of the line of travel already (see landing()):
    // kept off the other foot as well, it was pushed out wherever the path curved, the other foot
    // planted half a stride back on the curve seeming over this one's side (the built-in walk's
    // feet 23 cm apart against its 16.5).
    if (other_known && !walking_guard) to = beside(to, other_xz, guard_yaw_rad, k, o.min_width_m);
    f.planted = glm::vec3(to.x, floor_y, to.y);
    f.planted_yaw_rad = in.root_yaw_rad;
  }
  const float t = smooth01(f.phase);
  glm::vec2 h = xz(f.from) + t * (xz(f.planted) - xz(f.from));
  if (other_known) h = beside(h, other_xz, guard_yaw_rad, k, o.min_width_m);
  const float step_m = glm::length(xz(f.planted) - xz(f.from));
  const float arc_m = std::max(0.02f, o.arc_height_m * step_m / 0.6f);
  const float arc_max_m = s.running ? o.run_arc_max_m : 0.15f;
  const float y = f.from.y + t * (floor_y - f.from.y) + std::min(arc_m, arc_max_m) * std::sin(kPi * f.phase);
  f.ankle = glm::vec3(h.x, std::max(floor_y, y), h.y);
  f.yaw_rad = f.from_yaw_rad + t * wrap_rad(f.planted_yaw_rad - f.from_yaw_rad);
  if (f.phase >= 1.0f) {
    f.swinging = false;
    f.planted = glm::vec3(h.x, floor_y, h.y);
  }
}

}  // namespace

namespace {

// Standing on both feet (not walking), how far the pelvis is outside the segment joining them and
// the furthest a hip is from its foot.
struct StandingSupport {
  bool standing = false;
  float pelvis_off_m = 0, most_off_m = 0;
};
StandingSupport standing_support(const LocomotionState& s, const LocomotionInput& in, const LocomotionOptions& o,
                                 bool walking) {
  StandingSupport out;
  if (walking || !(o.stand_support_m > 0)) return out;
  for (const auto& f : s.feet)
    if (!f.driven || f.swinging) return out;
  out.standing = true;
  const glm::vec2 a = xz(s.feet[0].planted), ab = xz(s.feet[1].planted) - a, p = xz(in.root);
  const float t = glm::dot(ab, ab) > 1e-8f ? std::clamp(glm::dot(p - a, ab) / glm::dot(ab, ab), 0.0f, 1.0f) : 0.0f;
  out.pelvis_off_m = glm::length(p - (a + t * ab));
  for (int k = 0; k < 2; ++k)
    out.most_off_m = std::max(out.most_off_m, glm::length(xz(in.hip[k]) - xz(s.feet[k].planted)));
  return out;
}

// Foot `best` lifts now: how long its swing lasts (to the beat that times the gait, if one does),
// and from where.
void start_swing(LocomotionState& s, const LocomotionInput& in, const LocomotionOptions& o, int best, float swing_s,
                 bool bob_walk, bool arm_walk) {
  FootStepState& f = s.feet[best];
  f.swinging = true;
  f.phase = 0;
  f.duration_s = swing_s;
  if (bob_walk && s.running) {
    // … to land a little before the low after next, when it supports the body again.
    const double lows = s.bob.run_catch_up ? 0.97 : 2 * 0.97;
    const double strike_s = s.bob.last_low_s + (lows - o.run_strike_before_low) * s.bob.period_s;
    f.duration_s = std::clamp(static_cast<float>(strike_s - s.bob.clock_s), 0.6f * swing_s, 3.0f * swing_s);
    s.bob.lift_at_s = -1;
    // Caught up: the foot just landed carries the body for a stance, then lifts.
    if (s.bob.run_catch_up)
      s.bob.lifter = 1 - best, s.bob.lift_at_s = s.bob.clock_s + o.run_stance_fraction * s.bob.period_s;
    s.bob.run_catch_up = false;
  } else if (arm_walk) {
    // … to land a part of the beat after the turn that named it.
    const bool named = best == s.arm.lifter && s.arm.lift_from_s >= 0;
    const float since_s = named ? static_cast<float>(s.bob.clock_s - s.arm.lift_from_s) : 0.0f;
    f.duration_s = std::clamp(o.arm_swing_fraction * s.arm.period_s - since_s, 0.6f * swing_s, 1.5f * swing_s);
    if (named) s.arm.lift_from_s = -1;
    s.bob.lift_at_s = -1;
  } else if (bob_walk) {
    // … to land at the next low of the head.
    const double next_low_s = s.bob.last_low_s + 0.97 * s.bob.period_s;
    f.duration_s = std::clamp(static_cast<float>(next_low_s - s.bob.clock_s), 0.6f * swing_s, 1.5f * swing_s);
    s.bob.lift_at_s = -1;
  }
  // From where the foot is: a trailing foot has lifted its heel off the planted spot.
  f.from = f.planted;
  if (in.have_last_ankle)
    f.from = glm::vec3(in.last_ankle[best].x, std::max(in.last_ankle[best].y, f.planted.y), in.last_ankle[best].z);
  f.from_yaw_rad = f.planted_yaw_rad;
  // Walking, no quicker than the foot covers its ground at swing_max_mps on average: timed to a
  // head's low that comes soon (06_04's dribble bobs the head), a 1.3 m stride was flown in 0.19 s
  // and landed short, and the same foot lifted again at once.
  if (o.swing_max_mps > 0 && !s.running)
    for (int pass = 0; pass < 2; ++pass)  // the landing spot leads by the time the swing takes
      f.duration_s =
          std::max(f.duration_s, glm::length(landing(in, s, o, best, f.duration_s) - xz(f.from)) / o.swing_max_mps);
  s.last_stepped = best;
  ++s.steps;
}

}  // namespace

void update_locomotion(LocomotionState& s, const LocomotionInput& in, const LocomotionOptions& o) {
  const float dt = std::clamp(in.dt_s, 1e-4f, 0.1f);
  if (s.have_root) {
    const glm::vec2 v = (xz(in.root) - xz(s.last_root)) / dt;
    const float a = 1.0f - std::exp(-dt / o.velocity_tau_s);
    s.velocity_mps += a * (v - s.velocity_mps);
  }
  s.last_root = in.root;
  s.have_root = true;
  const float speed = glm::length(s.velocity_mps);
  // The line of travel and how fast it turns (a stride's sway smoothed out).
  if (speed > o.narrow_from_mps) {
    const float yaw = std::atan2(s.velocity_mps.x, s.velocity_mps.y);
    if (s.have_travel) {
      s.turn_rps += (1.0f - std::exp(-dt / o.turn_tau_s)) * (wrap_rad(yaw - s.travel_yaw_rad) / dt - s.turn_rps);
    }
    s.travel_yaw_rad = yaw, s.have_travel = true;
  } else {
    s.have_travel = false, s.turn_rps = 0;
  }
  const float sway_m = track_head(s, in, dt, o);
  track_arm_swing(s, in, dt, o);
  const bool gate = in.have_head && o.sway_gate_m >= 0 && speed > o.sway_speed_mps;
  const bool run_speed = o.run_from_mps > 0 && speed > o.run_from_mps;
  const bool low = in.have_head && track_bob(s.bob, in.head.y, dt, o, run_speed);
  const bool bob_walk = gate && o.bob_timing && s.bob.period_s > 0;
  track_arm_beat(s, o, gate && !run_speed);
  // Walking with swinging arms, they time the steps; the head's bob goes on being followed.
  const bool arm_walk = gate && !run_speed && s.bob.clock_s < s.arm.active_until_s;
  if (!gate) s.bob.beats = 0;  // a new walk takes its first beats from the sway again
  s.running = bob_walk && run_speed;
  if (low && bob_walk && !arm_walk) on_head_low(s, sway_m, o);
  const float swing_s = o.swing_s_slow + (o.swing_s_fast - o.swing_s_slow) * std::clamp(speed / o.fast_mps, 0.0f, 1.0f);

  for (int k = 0; k < 2; ++k) {
    FootStepState& f = s.feet[k];
    if (!in.drive[k]) {
      f.driven = f.swinging = f.have_target = false;
      continue;
    }
    if (!f.driven) take_over(f, in, k);
  }

  // A new step when no foot swings: the foot whose support the body has left the most. A foot
  // about to be out of the leg's reach lifts whatever the other does (running has flight).
  bool any_swinging = false;
  for (const auto& f : s.feet) any_swinging = any_swinging || (f.driven && f.swinging);
  // Walking, a foot stays until it is as far behind as it landed ahead (half a stance).
  const float trigger_m = std::max(o.step_threshold_m, speed * o.stance_lead_s);
  int best = -1;
  float best_score = 1.0f;
  const StandingSupport support = standing_support(s, in, o, gate);
  for (int k = 0; k < 2; ++k) {
    const FootStepState& f = s.feet[k];
    if (!f.driven || f.swinging) continue;
    const float reach_used = glm::length(in.hip[k] - f.planted) / in.reach_m[k];
    if (any_swinging) {
      if (o.flight && reach_used > o.flight_reach_fraction) {
        best = k, best_score = 1e9f;
        continue;
      }
      if (!s.running) continue;  // running, the supporting foot lifts on the beat while the other flies
    }
    const float off_m = glm::length(xz(in.hip[k]) - xz(f.planted));
    const float turn = std::abs(wrap_rad(in.root_yaw_rad - f.planted_yaw_rad));
    // Standing, the body is carried while the pelvis is over the support between the feet, however
    // far each hip is from its own foot (a boxer's staggered stance); the foot further from its hip
    // steps first.
    const float off_score =
        support.standing
            ? std::max(support.pelvis_off_m / o.stand_support_m * off_m / std::max(support.most_off_m, 1e-3f),
                       off_m / o.stand_foot_m)
            : off_m / trigger_m;
    float score = std::max(off_score, turn / o.turn_threshold_rad);
    if (reach_used > o.reach_fraction) score = std::max(score, o.sway_override);
    if (k == s.last_stepped) score *= 0.8f;  // alternate when both feet are due
    if (arm_walk) {
      // Walking to the arms' beat: the foot the last turn named lifts once; another only when
      // its leg cannot reach it even on tiptoe (at 1.15 leg lengths, as to the bob, it lifted
      // just before its beat and then again on it: 07_01 stepped twice a stride).
      const bool lost = reach_used > o.flight_reach_fraction;
      if (!lost && (k != s.arm.lifter || s.arm.lift_from_s < 0)) continue;
      score = std::max(score, best_score + 1e-3f);
    } else if (bob_walk) {
      // Walking to the head's bob: the trailing foot lifts when its time comes; another only
      // when its leg can no longer reach it, even on tiptoe.
      const int lifter = s.bob.lifter >= 0 ? s.bob.lifter : 1 - s.last_stepped;
      const bool lost = reach_used > (s.running ? o.flight_reach_fraction : o.bob_lost_reach_fraction);
      if (!lost && (k != lifter || s.bob.lift_at_s < 0 || s.bob.clock_s < s.bob.lift_at_s)) continue;
      score = std::max(score, best_score + 1e-3f);
    }
    // Walking, the foot the body rests on (the head sways over it) does not lift, unless it has
    // been left far behind: the sway is a hint, not a clock.
    if (gate && !bob_walk && !arm_walk && (k == 0 ? 1.0f : -1.0f) * sway_m > -o.sway_gate_m && score < o.sway_override)
      continue;
    if (score > best_score) best = k, best_score = score;
  }
  if (best >= 0) start_swing(s, in, o, best, swing_s, bob_walk, arm_walk);

  for (int k = 0; k < 2; ++k) advance_foot(s, in, o, k, dt);
}

// Without stepping (SolverOptions::step off): each untracked foot under its hip, knee soft, on
// or above the floor, facing the heading — where a standing body's feet are.
void hang_untracked_feet(const SolverModel& m, SolverContext& c, const rig::Pose& p, std::array<bool, 2> legs) {
  const rig::Skeleton& s = m.skeleton();
  const SolverOptions& o = m.options();
  glm::vec3 fwd = p.root_orientation * glm::vec3(0, 0, 1);
  if (glm::length(glm::vec2(fwd.x, fwd.z)) < 1e-3f) return;
  const glm::quat facing = glm::angleAxis(std::atan2(fwd.x, fwd.z), glm::vec3(0, 1, 0));
  const float bend = std::clamp(o.relaxed_knee_bend_rad, 0.0f, 1.5f);
  for (int leg = 0; leg < 2; ++leg) {
    if (!legs[leg]) continue;
    const auto& ch = m.chains_[2 + leg];
    const glm::vec3 hip = p.root_position_m + p.root_orientation * s.offset_m(ch.upper);
    const float hang =
        std::sqrt(ch.upper_m * ch.upper_m + ch.lower_m * ch.lower_m + 2.0f * ch.upper_m * ch.lower_m * std::cos(bend));
    const float floor_y = o.standing_root_y_m - m.ankle_below_root_rest_[leg];
    c.segment_target_[ch.end] = rig::RigidTransform{facing, glm::vec3(hip.x, std::max(floor_y, hip.y - hang), hip.z)};
    c.has_target_[ch.end] = 1;
    c.guessed_end_[2 + leg] = true;
  }
}

// Feet of legs without a sensor (or whose sensor is lost): the stepper plants and swings them;
// their targets join the chains' solve as guesses.
void SolveJob::place_untracked_feet() {
  const SolverModel& m = *model;
  SolverContext& c = *context;
  const rig::Pose& p = *pose;
  const rig::Skeleton& s = m.skeleton();
  const SolverOptions& o = m.options();
  LocomotionInput in;
  bool any = false;
  for (int leg = 0; leg < 2; ++leg) {
    const auto& ch = m.chains_[2 + leg];
    in.drive[leg] = !c.has_target_[ch.upper] && !c.has_target_[ch.mid] && !c.has_target_[ch.end];
    any = any || in.drive[leg];
  }
  if (any && !o.step) {
    hang_untracked_feet(m, c, p, in.drive);
    any = false;
  }
  if (!any) {
    c.locomotion_.feet[0].driven = c.locomotion_.feet[1].driven = false;
    return;
  }
  in.dt_s = c.sample_step_s_;
  if (c.sample_time_s_ >= 0) c.last_time_s_ = c.sample_time_s_;
  glm::vec3 fwd = p.root_orientation * glm::vec3(0, 0, 1);
  in.root = p.root_position_m;
  in.root_yaw_rad = glm::length(glm::vec2(fwd.x, fwd.z)) > 1e-3f ? std::atan2(fwd.x, fwd.z) : 0.0f;
  in.have_last_ankle = c.have_previous_;
  for (int leg = 0; leg < 2; ++leg) {
    const auto& ch = m.chains_[2 + leg];
    in.hip[leg] = p.root_position_m + p.root_orientation * s.offset_m(ch.upper);
    in.reach_m[leg] = ch.upper_m + ch.lower_m;
    in.floor_ankle_y_m[leg] = o.standing_root_y_m - m.ankle_below_root_rest_[leg];
    in.last_ankle[leg] = c.world_[ch.end].translation;
  }
  if (c.has_target_[m.head_]) in.head = c.segment_target_[m.head_].translation, in.have_head = true;
  if (c.has_target_[m.chains_[0].end] && c.has_target_[m.chains_[1].end]) {
    in.hand = {c.segment_target_[m.chains_[0].end].translation, c.segment_target_[m.chains_[1].end].translation};
    in.have_hands = true;
  }
  update_locomotion(c.locomotion_, in, o.locomotion);
  for (int leg = 0; leg < 2; ++leg) {
    if (!in.drive[leg]) continue;
    const auto& f = c.locomotion_.feet[leg];
    const int e = m.chains_[2 + leg].end;
    const glm::quat yaw = glm::angleAxis(f.yaw_rad, glm::vec3(0, 1, 0));
    c.segment_target_[e] = rig::RigidTransform{yaw, f.ankle};
    // A running foot hangs toes-down through its swing (see LocomotionOptions::run_swing_pitch_rad).
    if (f.swinging && c.locomotion_.running)
      c.segment_target_[e].rotation =
          yaw * glm::angleAxis(o.locomotion.run_swing_pitch_rad * std::sin(3.14159265f * f.phase), glm::vec3(1, 0, 0));
    const glm::quat foot = c.segment_target_[e].rotation;
    if (!f.swinging) lift_heel(c.segment_target_[e], in.hip[leg], in.reach_m[leg], m.ball_in_ankle_[leg]);
    auto& fs = c.locomotion_.feet[leg];
    fs.most_move_m = o.locomotion.max_foot_speed_mps * in.dt_s;
    if (fs.have_target) {
      const glm::vec3 move = c.segment_target_[e].translation - fs.target;
      if (glm::length(move) > fs.most_move_m)
        c.segment_target_[e].translation = fs.target + move * (fs.most_move_m / glm::length(move));
    }
    fs.last_target = fs.have_target ? fs.target : c.segment_target_[e].translation;
    fs.target = c.segment_target_[e].translation, fs.have_target = true;
    // The toes stay flat on the floor under a lifted heel (and in line with a running foot).
    if (const int toes = m.toes_[leg]; toes >= 0 && !c.has_target_[toes]) {
      c.segment_target_[toes] = rig::RigidTransform{foot, c.segment_target_[e].apply(m.ball_in_ankle_[leg])};
      c.has_target_[toes] = 1;
    }
    c.has_target_[e] = 1;
    c.guessed_end_[2 + leg] = true;
  }
}

// A stepped foot whose leg the limits bend (a deep squat: the ankle at its flexion limit pitches
// the foot toes-down) would push the ball of the foot through the floor: the ankle's target rises
// until the ball is on the floor, as a heel does.
void SolveJob::LiftSteppedFootOffFloor(int ci) {
  const SolverModel& m = *model;
  SolverContext& c = *context;
  const rig::Skeleton& s = m.skeleton();
  const int leg = ci - 2;
  if (leg < 0 || !c.guessed_end_[ci] || m.toes_[leg] < 0 || !std::isfinite(m.options().standing_root_y_m)) return;
  const SolverModel::Chain& ch = m.chains_[ci];
  if (s.parent(ch.mid) != ch.upper || s.parent(ch.end) != ch.mid) return;
  FootStepState& fs = c.locomotion_.feet[leg];
  // The ball no lower than on a flat foot or the sole, whichever is lower, with a few millimetres
  // to spare: a flat foot's ball rests there, and lifting it for a noise's worth would shake it.
  const float floor_y =
      m.options().standing_root_y_m - std::max(m.ball_below_root_rest_[leg], m.toe_tip_below_root_rest_[leg]) - 0.003f;
  const rig::Pose& p = *pose;
  glm::vec3& target = c.segment_target_[ch.end].translation;
  // Each pass raises the target by what the ball is under the floor. A raise the ball does not
  // follow (a stretched leg, a foot the ankle's limits hold pitched) is taken back. The foot
  // never jumps: the lifted target stays within a frame's move of the last one, and no more than
  // `kMostLiftM` above where the stepper put it.
  constexpr float kMostLiftM = 0.15f;
  const float unlifted_y = target.y;
  float last_ball_y = 0.0f, last_raise_m = 0.0f;
  for (int pass = 0; pass < 4; ++pass) {
    const float ball_y = down_chain(s, c.world_[s.parent(ch.upper)], {ch.upper, ch.mid, ch.end}, p.dof_rad)
                             .apply(m.ball_in_ankle_[leg])
                             .y;
    if (pass > 0 && ball_y - last_ball_y < 0.1f * last_raise_m) {
      target.y -= last_raise_m;
      SolveLimb(ci);
      break;
    }
    const float below_m = floor_y - ball_y;
    if (below_m <= 0.0f || !std::isfinite(below_m)) break;
    const glm::vec3 d = target - fs.last_target;
    const float h2 = fs.most_move_m * fs.most_move_m - d.x * d.x - d.z * d.z;
    if (h2 <= 0.0f) break;
    const float top_y = std::min(fs.last_target.y + std::sqrt(h2), unlifted_y + kMostLiftM);
    const float raise_m = std::min(below_m + 0.001f, top_y - target.y);
    if (raise_m <= 1e-4f) break;
    target.y += raise_m;
    last_ball_y = ball_y, last_raise_m = raise_m;
    if (!SolveLimb(ci)) break;  // the last solution stays
  }
  fs.target = target;
  KeepBallAboveFloor(ci, floor_y);
}

// What the target's raise could not lift (a stretched leg, an ankle at its limit pitching the
// foot further than asked) the ankle's flexion does: the foot turns toes-up about the ankle
// until the ball is on the floor, as far as the joint's limits allow.
void SolveJob::KeepBallAboveFloor(int ci, float floor_y) {
  const SolverModel& m = *model;
  const rig::Skeleton& s = m.skeleton();
  const SolverModel::Chain& ch = m.chains_[ci];
  const int leg = ci - 2;
  std::span<float> dof(pose->dof_rad);
  const int d = s.dof_begin(ch.end);
  if (s.dof_end(ch.end) <= d) return;
  const rig::RigidTransform knee = down_chain(s, context->world_[s.parent(ch.upper)], {ch.upper, ch.mid}, dof);
  const glm::vec3 ankle = knee.apply(s.offset_m(ch.end));
  auto ball_y = [&](float a) {
    const float keep = dof[d];
    dof[d] = a;
    const float y = ankle.y + (knee.rotation * (s.local_rotation(ch.end, dof) * m.ball_in_ankle_[leg])).y;
    dof[d] = keep;
    return y;
  };
  const auto& f = s.dof(d);
  dof[d] = detail::turn_to_clear_floor(dof[d], f.min_rad, f.max_rad, floor_y, ball_y);
}

}  // namespace mimic::solver
