// Procedural steps for legs nobody tracks (Final IK's VRIK locomotion, in spirit): the three
// sensors of a VR headset and its controllers, or a foot whose sensor dropped out.
//
// Each foot driven here is planted on the floor while it supports the body and does not move. A
// step starts when the foot's home (under its hip, where the pelvis is heading) has left it
// further than `step_threshold_m` (standing, when the pelvis has left the support between the
// feet), the body has turned more than `turn_threshold_rad` past the foot, or the leg cannot
// reach it; one foot swings at a time, the one left furthest behind, alternating when both are.
// Walking, the arms' swing (else the head's bob) says when and which foot lifts. The step lands
// where the hip will be half a stance after touchdown at the pelvis' velocity (round a curve), so
// walking feet land ahead of the body; its duration shortens with speed; the foot swings on an
// arc of a height in proportion to the step, never below the floor and never across the other
// foot.
//
// State lives in the caller's SolverContext; update() never allocates or throws.
#pragma once

#include <array>
#include <cmath>

#include <glm/glm.hpp>

namespace mimic::solver {

struct LocomotionOptions {
  float step_threshold_m = 0.14f;  // foot this far from its (predicted) home: step
  // Standing on both feet (not walking), a step when the pelvis is this far outside the segment
  // joining the feet, or a foot this far from its hip, rather than each hip 14 cm from its own
  // foot: people stand with a foot forward and sway over their feet without stepping (the boxer
  // of 02_05: a hip up to 26 cm from its ankle, the pelvis within 11 cm of the feet's midpoint).
  // 0: each foot by its own hip.
  float stand_support_m = 0.15f;
  float stand_foot_m = 0.30f;
  float turn_threshold_rad = 0.6f;  // body turned this far past the foot (34°): step
  float swing_s_slow = 0.35f;       // swing duration standing …
  float swing_s_fast = 0.30f;       // … and at `fast_mps`
  float swing_max_mps = 3.0f;       // walking, a swing's mean speed at most (0: any)
  float fast_mps = 2.5f;
  float stance_lead_s = 0.30f;   // a step lands where the hip is that long after touchdown
  float max_step_m = 0.85f;      // a step never reaches further than this from the hip
  float velocity_tau_s = 0.12f;  // smoothing of the pelvis velocity
  float turn_tau_s = 0.3f;       // … and of how fast its direction turns (a stride's sway evens out)
  // Walking faster than this, the feet's crossing guard measures sideways across the line of
  // travel rather than the pelvis' heading, and keeps only a swinging foot off the other.
  float travel_frame_from_mps = 0.6f;
  float reach_fraction = 1.10f;  // a planted foot further than this much of the leg (flat) is due
  bool flight = true;            // … and past this much it lifts while the other swings
  float flight_reach_fraction = 1.30f;
  float min_width_m = 0.10f;  // feet never closer side to side (ankle centres)
  // Walking, steps land `walk_width_m` apart (ankle centres) about the pelvis' midline, blending
  // in from under the hips between `narrow_from_mps` and that plus `narrow_over_mps`.
  float walk_width_m = 0.12f;
  float narrow_from_mps = 0.3f, narrow_over_mps = 0.5f;
  float arc_height_m = 0.10f;  // swing arc height for a 0.6 m step (in proportion, ≥ 2 cm)
  // Walking (faster than `sway_speed_mps`), the body rests on the foot the head sways over: a
  // foot lifts only while the head is at least `sway_gate_m` over to the other side of its
  // mean path (tau `sway_tau_s`). Negative gate: off.
  float sway_speed_mps = 0.4f;
  float sway_gate_m = 0.004f;
  float sway_tau_s = 0.5f;
  float sway_bias_tau_s = 1.5f;  // the sway's own mean (a curved path's offset) is removed over this
  float sway_override = 1.5f;    // a foot this many trigger distances behind steps regardless
  // Walking, the head is lowest when a foot strikes the floor (both feet down) and highest over
  // the supporting foot: its bob times the steps. Each low of the head (found once it has risen
  // `bob_rise_m` past it, heights smoothed over `bob_tau_s`) lands the swinging foot, and the
  // trailing foot lifts `bob_lift_fraction` of the time between lows later, to land at the next
  // low. Lows further apart than the bounds are no gait.
  bool bob_timing = true;
  float bob_rise_m = 0.004f;
  float bob_tau_s = 0.03f;
  float bob_min_period_s = 0.3f, bob_max_period_s = 0.9f;
  float bob_lift_fraction = 0.25f;
  int bob_sway_beats = 2;            // … for the first lows of a walk; then the feet alternate
  float bob_sway_choice_m = 0.015f;  // the head this far to one side at a low picks that foot; else alternate
  // At a low the head moves sideways towards the foot that strikes (its weight shifts onto it):
  // faster than this, the other foot is the one that lifts next, whatever the beat. Sideways is
  // across the head's mean path (its velocity smoothed over `path_tau_s`), the speed smoothed
  // over `sway_speed_tau_s` less its own mean over `sway_speed_bias_tau_s` (a curve's lag).
  float bob_sway_speed_mps = 0.05f;
  float sway_speed_tau_s = 0.04f;
  float path_tau_s = 0.5f;
  float sway_speed_bias_tau_s = 0.6f;
  float bob_first_period_s = 0.55f;  // before two lows have been seen (a step at 110 a minute)
  // Walking to the bob, another foot than the trailing one lifts only when its leg is this far
  // out of reach (flat; the heel lifts up to here): a reach rule that fired earlier broke the beat.
  float bob_lost_reach_fraction = 1.15f;
  // Running (pelvis faster than `run_from_mps`, the bob timing the steps), the head is lowest at
  // mid-stance, not at a strike: each foot lands `run_strike_before_low` of the time between lows
  // before the low, lifts `run_lift_after_low` of it after, and both feet are in the air between
  // (flight); the feet swing on an arc up to `run_arc_max_m` (the heel kicks up behind). Which
  // foot is under the body at a low: the arms swing against the legs, so the hands' fore-and-aft
  // difference (left less right) crosses zero at mid-stance, rising over the left foot, falling
  // over the right; it must change faster than `run_arm_swing_mps` (smoothed over
  // `arm_swing_tau_s`) to say so. 0: no running gait.
  float run_from_mps = 2.2f;
  float run_strike_before_low = 0.3f;
  float run_lift_after_low = 0.1f;
  float run_stance_fraction = 0.4f;  // a foot that lands late still stands this long
  float run_arc_max_m = 0.40f;
  // A running foot's swing pitches it toes-down, by this much at mid-swing: held flat under a
  // shin kicked up behind, the ankle's limits could not follow, the leg's swivel search turned
  // the knee out sideways for a frame, and the knees flipped (09_11: a knee 40 cm sideways and
  // back between two samples; its mean second difference 16 → 6 mm).
  float run_swing_pitch_rad = 0.6f;
  float run_first_period_s = 0.36f;  // a run's first low, before the next measures the beat (166 a minute)
  float run_arm_swing_mps = 0.5f;
  float arm_swing_tau_s = 0.03f;
  // Walking, the arms swing against the legs too, and on the beat: a hand is at its most forward
  // when the foot on its side, the furthest behind, lifts (07_01: the hands' fore-and-aft
  // difference is -0.6 times the feet's, in phase, ±0.43 m). Walking faster than
  // `arm_beat_from_mps`, the hands are read along the line of travel (the pelvis' heading starts
  // a walk 10–20° off it, and the hands' 0.5 m side to side then reads as fore and aft); each time
  // their difference turns back (its rate past `arm_turn_mps`) after going at least
  // `arm_beat_min_m` from the last turn, within a beat's time of it, the hand that was forward
  // names the foot that lifts, the other foot lands, and the swing ends `arm_swing_fraction` of
  // the time between turns after the turn. The first turn of a walk names the foot when the hand
  // was `arm_first_m` forward. Arms that do not swing (a dribble, hands on a wheel) leave the
  // steps to the head's bob.
  bool arm_beat = true;
  float arm_beat_from_mps = 0.6f;
  float arm_turn_mps = 0.3f;
  float arm_beat_min_m = 0.2f;
  float arm_first_m = 0.1f;
  float arm_swing_fraction = 0.9f;
  // A stepped foot never moves faster than this (a walking foot swings at 4–5 m/s): a landing
  // spot that moves with the body or a heel that lifts does not make it jump.
  float max_foot_speed_mps = 8.0f;
  // A stepped leg's knee faces where its foot points, but never further round from the hips'
  // heading than this (the hip turns 50° either way): a foot left behind by a pivot otherwise
  // asked for a knee the hip cannot turn to, and the clamped leg jerked.
  float knee_turn_max_rad = 0.8f;
  // … and its swivel is searched for only when the limits would cut this much off it at that
  // knee (each search moves the knee by a whole sample: searched at 0.2 rad, the legs shook).
  float search_swivel_above_rad = 0.6f;
  // Walking, the hips ride this much lower per m/s (at most `max_walk_drop_m`): strides need
  // the reach a locked-knee stance does not have.
  float walk_drop_m_per_mps = 0.025f;
  float max_walk_drop_m = 0.05f;
};

struct FootStepState {
  bool driven = false;  // this foot is placed by the stepper this frame
  bool swinging = false;
  glm::vec3 planted{0.0f};  // ankle, world, while planted (and where a swing ends)
  float planted_yaw_rad = 0;
  glm::vec3 from{0.0f};
  float from_yaw_rad = 0;
  float phase = 0, duration_s = 0.4f;
  glm::vec3 ankle{0.0f};   // output: this frame's ankle target
  float yaw_rad = 0;       // output: this frame's foot heading (about +Y, 0 = +Z)
  glm::vec3 target{0.0f};  // the ankle target given to the leg last frame (heel lift included)
  bool have_target = false;
  glm::vec3 last_target{0.0f};  // … and the frame before (a foot lifted off the floor moves from it)
  float most_move_m = 0;        // the furthest the target may move this frame
};

struct LocomotionState {
  std::array<FootStepState, 2> feet{};  // left, right
  glm::vec2 velocity_mps{0.0f};         // pelvis, horizontal (x, z), smoothed
  float travel_yaw_rad = 0;             // … its direction (about +Y, 0 = +Z) …
  float turn_rps = 0;                   // … turning this fast, smoothed
  bool have_travel = false;
  glm::vec3 last_root{0.0f};
  bool have_root = false;
  double last_time_s = -1;
  int last_stepped = -1;
  bool running = false;     // this frame's gait is a run (see LocomotionOptions::run_from_mps)
  float arm_swing_m = 0;    // the left hand ahead of the right, along the heading
  float arm_swing_mps = 0;  // … its rate, smoothed
  bool have_arm_swing = false;
  // The arms' beat (see LocomotionOptions::arm_beat).
  struct ArmBeat {
    int sign = 0;                // where the swing goes: +1 the left hand forward, 0 not yet known
    float extreme_m = 0;         // the furthest it has gone that way …
    double extreme_s = -1;       // … and when
    float last_turn_m = 0;       // the swing where it last turned back …
    double last_turn_s = -1;     // … and when
    float period_s = 0;          // between the last two turns (half a stride)
    int lifter = -1;             // the foot the last turn lifts …
    double lift_from_s = -1;     // … timed from that turn; -1: lifted
    double active_until_s = -1;  // the arms time the steps until then (a beat and a half on)
  } arm;
  glm::vec2 walk_root_goal{0.0f};  // where walking hips go under the head, smoothed (body_solver.cpp)
  bool have_walk_root_goal = false;
  float walk_follow_s = 0;       // … followed for this long
  glm::vec2 hands_across{0.0f};  // left hand minus right, horizontal, smoothed (body_solver.cpp)
  bool have_hands_across = false;
  float hands_seen_s = 0;       // … over this long
  long steps = 0;               // steps started so far
  glm::vec2 sway_centre{0.0f};  // the head's mean horizontal path
  bool have_sway = false;
  float sway_bias_m = 0;  // the sway's slow mean
  glm::vec2 last_head{0.0f};
  float head_gap_s = 0;      // time since last_head was seen (the frames the head was lost)
  glm::vec2 path_mps{0.0f};  // the head's velocity along its mean path (smoothed over a stride)
  float sway_mps = 0;        // the head's velocity across that path, towards the left, smoothed
  float sway_mps_bias = 0;   // … and its slow mean
  // The head's bob (see LocomotionOptions::bob_timing).
  struct Bob {
    double clock_s = 0;  // time since the stepper started
    float y_m = 0;       // smoothed head height
    bool have = false, descending = false;
    float extreme_y_m = 0;  // lowest since descending began, or highest since it ended
    double low_s = 0;       // when that lowest was
    double last_low_s = -1;
    float period_s = 0;         // between the last two lows (half a stride); 0: no gait
    double lift_at_s = -1;      // the trailing foot lifts then
    int beats = 0;              // lows since the walk began
    int lifter = -1;            // … which (the side the head is over at the low), -1: alternate
    bool run_catch_up = false;  // running on the wrong foot: the lifter lands before the next low
  } bob;
};

struct LocomotionInput {
  float dt_s = 1.0f / 120;
  glm::vec3 root{0.0f};                    // pelvis position, world
  float root_yaw_rad = 0;                  // pelvis heading
  std::array<glm::vec3, 2> hip{};          // hip joint centres, world
  std::array<float, 2> reach_m{};          // hip to ankle, leg straight
  std::array<float, 2> floor_ankle_y_m{};  // ankle height of a flat foot on the floor
  std::array<bool, 2> drive{};             // which feet the stepper places
  std::array<glm::vec3, 2> last_ankle{};   // solved ankles of the previous frame (take-over)
  bool have_last_ankle = false;
  glm::vec3 head{0.0f};  // head joint, world
  bool have_head = false;
  std::array<glm::vec3, 2> hand{};  // wrists (left, right), world, when both are tracked
  bool have_hands = false;
};

void update_locomotion(LocomotionState& state, const LocomotionInput& in, const LocomotionOptions& o = {});

}  // namespace mimic::solver
