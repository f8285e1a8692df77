#include "mimic/solver/body_solver.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/gtx/quaternion.hpp>

#include "axis_turn.h"
#include "floor_clearance.h"
#include "limb_chain.h"
#include "mimic/solver/swing_twist.h"
#include "sample_check.h"

namespace mimic::solver {

using rig::Pose;
using rig::RigidTransform;
using rig::Skeleton;

namespace {

using detail::finite_sample;

using detail::ChainInput;
using detail::ChainSolution;
using detail::perpendicular_part;

// Rotation about +Y that turns +Z towards the horizontal part of `forward`; false if vertical.
bool heading_of(const glm::vec3& forward, glm::quat& out) {
  const glm::vec2 h(forward.x, forward.z);
  if (glm::length(h) < 0.2f) return false;
  out = glm::angleAxis(std::atan2(h.x, h.y), glm::vec3(0, 1, 0));
  return true;
}

// `dir`'s horizontal part turned back about +Y to within `max_rad` of `reference`'s (unchanged
// when either is about vertical).
glm::vec3 within_turn_of(const glm::vec3& dir, const glm::vec3& reference, float max_rad) {
  const glm::vec2 d(dir.x, dir.z), r(reference.x, reference.z);
  if (glm::length(d) < 1e-6f || glm::length(r) < 0.3f) return dir;
  const float yaw_r = std::atan2(r.x, r.y);
  const float off = std::remainder(std::atan2(d.x, d.y) - yaw_r, 6.2831853f);
  if (std::abs(off) <= max_rad) return dir;
  const float yaw = yaw_r + std::copysign(max_rad, off);
  return glm::length(d) * glm::vec3(std::sin(yaw), 0.0f, std::cos(yaw)) + glm::vec3(0.0f, dir.y, 0.0f);
}

// Toes nothing tracks follow the foot, and a foot pitched toes-down (a sensor's foot at push-off)
// would push their tip through the floor: they bend up at the ball instead, as toes do.
void keep_toes_above_floor(const SolverModel& m, int toes, float floor_y, const RigidTransform& foot_w,
                           std::span<float> dof) {
  const Skeleton& s = m.skeleton();
  if (s.dof_end(toes) - s.dof_begin(toes) != 1) return;
  const int d = s.dof_begin(toes);
  const auto& f = s.dof(d);
  const glm::vec3 ball = foot_w.apply(s.offset_m(toes));
  auto tip_y = [&](float a) { return ball.y + (foot_w.rotation * (glm::angleAxis(a, f.axis) * s.tip_m(toes))).y; };
  dof[d] = detail::turn_to_clear_floor(dof[d], f.min_rad, f.max_rad, floor_y, tip_y);
}

}  // namespace

bool SolveJob::Validate() const {
  if (!model || !context || !pose) return false;
  const Skeleton& s = model->skeleton();
  return static_cast<int>(pose->dof_rad.size()) == s.dof_count() && context->ls_.joint_count() == s.joint_count() &&
         static_cast<int>(context->has_target_.size()) == s.joint_count();
}

// 1. Segment targets from the samples.
void SolveJob::GatherTargets() {
  const SolverModel& m = *model;
  SolverContext& c = *context;
  Pose& p = *pose;
  std::fill(c.has_target_.begin(), c.has_target_.end(), uint8_t{0});
  c.guessed_end_.fill(false);
  sensors_used = 0;
  double now_s = -1;
  for (const auto& smp : samples) {
    if (smp.flags & devices::kSampleValid) now_s = std::max(now_s, smp.device_time_s);
    if (!(smp.flags & devices::kSampleValid) || smp.sensor >= m.slot_of_sensor_.size()) continue;
    const int slot = m.slot_of_sensor_[smp.sensor];
    if (slot < 0 || !finite_sample(smp)) continue;
    const RigidTransform world_from_sensor{glm::normalize(smp.orientation), smp.position_m};
    const int j = m.mount_joint_[slot];
    c.segment_target_[j] = world_from_sensor * m.sensor_from_segment_[slot];
    c.has_target_[j] = 1;
    ++sensors_used;
  }
  // The frame's clock, read once here for every stage that smooths or times over it.
  const double last_s = c.last_time_s_;
  c.sample_time_s_ = now_s;
  c.sample_step_s_ = now_s > last_s && last_s >= 0 ? static_cast<float>(now_s - last_s) : 1.0f / 120;
  if (!std::isfinite(p.root_position_m.x + p.root_position_m.y + p.root_position_m.z) ||
      !(glm::dot(p.root_orientation, p.root_orientation) > 0.25f))
    p.root_position_m = glm::vec3(0.0f), p.root_orientation = glm::quat(1, 0, 0, 0);
}

// Where the hips of an untracked root go (world) and how hard they are pulled there: the root's
// height nobody tracks is standing, unless the head has come down while staying upright — a
// squat or a seat, where the hips go down with it. (Bending over tilts the head too, and there
// the hips stay up; a head bob of a few centimetres is no crouch.)
IkTarget SolveJob::StandingRootTarget(const glm::quat& heading) {
  const SolverModel& m = *model;
  SolverContext& c = *context;
  const Skeleton& s = m.skeleton_;
  const SolverOptions& o = m.options_;
  const Pose& p = *pose;
  float root_y = o.standing_root_y_m - o.relaxed_root_drop_m;
  glm::vec3 goal(p.root_position_m.x, root_y, p.root_position_m.z);
  float weight = o.standing_weight;
  if (c.has_target_[m.head_]) {
    const RigidTransform& head = c.segment_target_[m.head_];
    const float head_standing_y = o.standing_root_y_m + m.head_from_root_rest_.y;
    const float drop_m = head_standing_y - head.translation.y;
    const glm::vec3 up = head.rotation * glm::vec3(0, 1, 0);
    const float upright = std::clamp((up.y - 0.5f) / 0.4f, 0.0f, 1.0f);  // 1 within 26° of vertical, 0 past 60°
    goal.y -= std::max(0.0f, drop_m - o.crouch_allowance_m) * upright;
    if (o.step)
      goal.y -= std::min(o.locomotion.max_walk_drop_m,
                         o.locomotion.walk_drop_m_per_mps * glm::length(c.locomotion_.velocity_mps));
    // Horizontally the hips hang under the head as an upright trunk would, leaning with part
    // of the head's tilt (looking down is not bending over); without this pull the trunk's
    // solve leans as readily as it moves the hips, and walking it left them 10 cm behind.
    const glm::vec3 lean_up = glm::normalize(glm::vec3(0, 1, 0) + o.lean_follow * (up - glm::vec3(0, 1, 0)));
    const glm::quat lean = glm::rotation(glm::vec3(0, 1, 0), lean_up);
    const glm::vec3 under = head.translation - lean * (heading * m.head_from_root_rest_);
    if (o.root_follow_weight > 0) goal.x = under.x, goal.z = under.z, weight = o.root_follow_weight;
    FollowWalkingHead(heading, up, goal, weight);
  }
  // A planted foot must stay within the leg's reach: the hips come down between wide-apart
  // feet, as they do in a stride.
  for (int leg = 0; leg < 2; ++leg) {
    const FootStepState& f = c.locomotion_.feet[leg];
    if (!f.driven || f.swinging) continue;
    const auto& ch = m.chains_[2 + leg];
    const glm::vec3 hip_offset = heading * s.offset_m(ch.upper);
    const glm::vec2 d(goal.x + hip_offset.x - f.planted.x, goal.z + hip_offset.z - f.planted.z);
    const float reach = o.locomotion_reach * (ch.upper_m + ch.lower_m);
    const float up_m = std::sqrt(std::max(0.0f, reach * reach - glm::dot(d, d)));
    goal.y = std::min(goal.y, f.planted.y + up_m - hip_offset.y);
  }
  return IkTarget{0, goal, glm::quat(1, 0, 0, 0), weight, 0.0f};
}

// Walking with swinging arms, the hips go under the head as a trunk leaning part of the head's
// tilt hangs them (SolverOptions::walk_root_follow_weight): `goal`'s horizontal and `weight` move
// to that pull's as the walk fades in.
void SolveJob::FollowWalkingHead(const glm::quat& heading, const glm::vec3& head_up, glm::vec3& goal, float& weight) {
  const SolverModel& m = *model;
  SolverContext& c = *context;
  const SolverOptions& o = m.options_;
  LocomotionState& ls = c.locomotion_;
  const float speed_mps = glm::length(ls.velocity_mps);
  const bool gait = ls.bob.clock_s < ls.arm.active_until_s;
  const float walking = gait && o.step ? std::clamp((speed_mps - 0.8f) / 0.4f, 0.0f, 1.0f) *
                                             std::clamp((2.2f - speed_mps) / 0.4f, 0.0f, 1.0f)
                                       : 0.0f;
  if (!(walking > 0.0f) || !(o.walk_root_follow_weight > 0.0f)) {
    ls.have_walk_root_goal = false, ls.walk_follow_s = 0;
    return;
  }
  const glm::vec3 lean_up = glm::normalize(glm::vec3(0, 1, 0) + o.walk_lean_follow * (head_up - glm::vec3(0, 1, 0)));
  const glm::vec3 under = c.segment_target_[m.head_].translation -
                          glm::rotation(glm::vec3(0, 1, 0), lean_up) * (heading * m.head_from_root_rest_);
  // Smoothed (the head's orientation noise would shake the hips) and led by the pelvis' velocity
  // for the time the smoothing lags.
  const float dt_s = c.sample_step_s_;
  const glm::vec2 to(under.x, under.z);
  if (!ls.have_walk_root_goal || !(o.walk_follow_tau_s > 0.0f))
    ls.walk_root_goal = to, ls.have_walk_root_goal = true;
  else
    ls.walk_root_goal +=
        (1.0f - std::exp(-std::clamp(dt_s, 1e-4f, 0.1f) / o.walk_follow_tau_s)) * (to - ls.walk_root_goal);
  const glm::vec2 led = ls.walk_root_goal + std::max(0.0f, o.walk_follow_tau_s) * ls.velocity_mps;
  // Only once the walk has lasted 0.3 s, faded in over the next 0.3 (goal and weight alike): a
  // run's start passes through walking speeds in a few frames, and a goal moved there changed
  // 09_11's steps (its jitter 2.95 → 3.77 mm).
  ls.walk_follow_s = std::min(ls.walk_follow_s + dt_s, 1.0f);
  const float share = walking * std::clamp((ls.walk_follow_s - 0.3f) / 0.3f, 0.0f, 1.0f);
  goal.x += share * (led.x - goal.x), goal.z += share * (led.y - goal.z);
  weight = share * o.walk_root_follow_weight + (1.0f - share) * weight;
}

// The hips' heading when only the head gives one: a head that looks round while the hands stay
// in front (13_26's traffic warden looks 60–80° either way; the hips taken from the head alone
// were 32° off the truth's there, 3–7° on the walks) turns them part of the way to the hands'
// line across the body, as held over hands_heading_tau_s. Only where the two disagree by more
// than hands_heading_from_rad: walking, the swinging arms turn that line by ±30° a stride, and
// below it the head is the better guide.
glm::quat SolveJob::TurnTowardsTheHands(const glm::quat& head_heading) {
  const SolverModel& m = *model;
  SolverContext& c = *context;
  const SolverOptions& o = m.options_;
  LocomotionState& ls = c.locomotion_;
  const int left = m.chains_[0].end, right = m.chains_[1].end;
  if (!(o.hands_heading_share > 0.0f) || !c.has_target_[left] || !c.has_target_[right]) {
    ls.have_hands_across = false;
    return head_heading;
  }
  const glm::vec3 d = c.segment_target_[left].translation - c.segment_target_[right].translation;
  const glm::vec2 across(d.x, d.z);
  const float dt_s = std::clamp(c.sample_step_s_, 1e-4f, 0.1f);
  const float tau_s = std::max(o.hands_heading_tau_s, 1e-3f);
  if (!ls.have_hands_across)
    ls.hands_across = across, ls.have_hands_across = true, ls.hands_seen_s = 0;
  else
    ls.hands_across += (1.0f - std::exp(-dt_s / tau_s)) * (across - ls.hands_across);
  ls.hands_seen_s = std::min(ls.hands_seen_s + dt_s, 10.0f);
  // Read once held for its time, faded in over as long again (a walk's first steps otherwise
  // read one swing of the arms as the line: 07_01 5.98 → 6.17 cm).
  const float held = std::clamp(ls.hands_seen_s / tau_s - 1.0f, 0.0f, 1.0f);
  // Hands together (a clap, a held ball) draw no line.
  const float spread = std::clamp((glm::length(ls.hands_across) - 0.2f) / 0.3f, 0.0f, 1.0f);
  const glm::vec3 f = head_heading * glm::vec3(0, 0, 1);
  const float head_yaw = std::atan2(f.x, f.z);
  // Skeleton +X (left) turned by yaw y is (cos y, −sin y) in x, z.
  const float off = std::remainder(std::atan2(-ls.hands_across.y, ls.hands_across.x) - head_yaw, 6.2831853f);
  // The hands' line more than 110–130° from the head's (a neck turns some 80° from the chest):
  // the arms are crossed, and the line says nothing of the hips.
  const float crossed = std::clamp((2.27f - std::abs(off)) / 0.35f, 0.0f, 1.0f);
  const float share =
      o.hands_heading_share * held * spread * crossed *
      std::clamp((std::abs(off) - o.hands_heading_from_rad) / std::max(o.hands_heading_over_rad, 1e-3f), 0.0f, 1.0f);
  if (!(share > 0.0f)) return head_heading;
  return glm::angleAxis(head_yaw + share * off, glm::vec3(0, 1, 0));
}

// An observed trunk without a pelvis sensor: the root is an unknown, kept upright and facing
// where the head (or the feet) face; tracked feet place it, else it stands (StandingRootTarget).
void SolveJob::AddRootTargets() {
  const SolverModel& m = *model;
  SolverContext& c = *context;
  const SolverOptions& o = m.options_;
  Pose& p = *pose;
  glm::quat heading = p.root_orientation;
  const glm::quat head_rot = c.has_target_[m.head_] ? c.segment_target_[m.head_].rotation : glm::quat(1, 0, 0, 0);
  glm::vec3 forward(0.0f);
  for (int leg = 2; leg < 4; ++leg)
    if (c.has_target_[m.chains_[leg].end])
      forward += c.segment_target_[m.chains_[leg].end].rotation * glm::vec3(0, 0, 1);
  const bool from_head = glm::length(forward) < 0.5f && c.has_target_[m.head_];
  if (from_head) {
    forward = head_rot * glm::vec3(0, 0, 1);
    if (glm::length(glm::vec2(forward.x, forward.z)) < 0.3f) forward = head_rot * glm::vec3(0, 1, 0);
  }
  if (heading_of(forward, heading) && from_head) heading = TurnTowardsTheHands(heading);
  if (!c.have_previous_ && c.has_target_[m.head_]) {
    // First frame: start the root upright under the head rather than at the origin.
    p.root_orientation = heading;
    p.root_position_m = c.segment_target_[m.head_].translation - heading * m.head_from_root_rest_;
  }
  c.targets_.push_back(IkTarget{0, glm::vec3(0.0f), heading, 0.0f, 0.5f * o.rotation_weight});
  bool feet = false;
  for (int leg = 2; leg < 4; ++leg) {
    const int e = m.chains_[leg].end;
    if (!c.has_target_[e]) continue;
    c.targets_.push_back(IkTarget{e, c.segment_target_[e].translation, glm::quat(1, 0, 0, 0), o.position_weight, 0.0f});
    feet = true;
  }
  if (feet) c.ls_dofs_.insert(c.ls_dofs_.end(), m.leg_dofs_.begin(), m.leg_dofs_.end());
  if (!feet && std::isfinite(o.standing_root_y_m)) c.targets_.push_back(StandingRootTarget(heading));
}

// Hands: the arm DOFs (clavicle, shoulder, elbow bend) join the solve so that the trunk leaves
// the hands within reach; the analytic chains then place the arms exactly.
void SolveJob::AddArmTargets() {
  const SolverModel& m = *model;
  SolverContext& c = *context;
  const Skeleton& s = m.skeleton_;
  const SolverOptions& o = m.options_;
  for (int arm = 0; arm < 2; ++arm) {
    const int e = m.chains_[arm].end;
    if (!c.has_target_[e]) continue;
    c.targets_.push_back(IkTarget{e, c.segment_target_[e].translation, glm::quat(1, 0, 0, 0), o.position_weight, 0.0f});
    c.ls_dofs_.insert(c.ls_dofs_.end(), m.arm_dofs_[arm].begin(), m.arm_dofs_[arm].end());
    // An upper-arm sensor places the shoulder joint (through clavicle and spine) too.
    const int upper = m.chains_[arm].upper;
    if (c.has_target_[upper])
      c.targets_.push_back(IkTarget{upper, c.segment_target_[upper].translation, c.segment_target_[upper].rotation,
                                    o.position_weight, o.rotation_weight});
    const int clavicle = s.parent(upper);
    if (c.has_target_[clavicle])
      c.targets_.push_back(IkTarget{clavicle, c.segment_target_[clavicle].translation,
                                    c.segment_target_[clavicle].rotation, o.position_weight, o.rotation_weight});
  }
}

// 3. The trunk's damped least squares over the DOFs and targets gathered.
void SolveJob::SolveTrunk(bool root_known) {
  const SolverModel& m = *model;
  SolverContext& c = *context;
  const Skeleton& s = m.skeleton_;
  const SolverOptions& o = m.options_;
  std::span<float> dof(pose->dof_rad);
  LeastSquaresIkJob ls;
  ls.skeleton = &s;
  ls.dofs = c.ls_dofs_;
  ls.solve_root = !root_known;
  ls.targets = c.targets_;
  // Relaxed trunk, but no pull on the arms: their DOFs are there only to keep the hands in reach.
  std::copy(m.prior_rad_.begin(), m.prior_rad_.end(), c.prior_.begin());
  // Shoulder and elbow move freely; the clavicle (rarely moving much) keeps its pull.
  for (int arm = 0; arm < 2; ++arm)
    for (int d : m.arm_dofs_[arm])
      if (s.dof(d).joint != s.parent(m.chains_[arm].upper)) c.prior_[d] = dof[d];
  // A segment with its own sensor needs no pull: its orientation is measured.
  for (int j : m.trunk_joints_)
    if (c.has_target_[j])
      for (int d = s.dof_begin(j); d < s.dof_end(j); ++d) c.prior_[d] = dof[d];
  ls.prior_rad = c.prior_;
  ls.prior_weight = root_known ? o.prior_weight_with_pelvis : o.prior_weight;
  ls.damping = o.damping;
  ls.max_iterations = o.iterations;
  ls.model_tolerance = o.model_tolerance;
  ls.context = &c.ls_;
  ls.pose = pose;
  ls.Run();
  ls_iterations = ls.iterations;
}

// The world transform of joint j from its parent's (already placed) and its DOFs.
void SolveJob::PlaceJoint(int j) {
  const Skeleton& s = model->skeleton_;
  SolverContext& c = *context;
  const Pose& p = *pose;
  const std::span<const detail::AxisKind> kinds = c.ls_.axis_kinds();
  glm::quat local(1, 0, 0, 0);
  for (int i = s.dof_begin(j); i < s.dof_end(j); ++i)
    local = detail::turned(local, s.dof(i).axis, kinds[i], p.dof_rad[i]);
  const int par = s.parent(j);
  if (par < 0) {
    c.world_[j] = RigidTransform{p.root_orientation * local, p.root_position_m + p.root_orientation * s.offset_m(j)};
  } else {
    c.world_[j] = RigidTransform{c.world_[par].rotation * local, c.world_[par].apply(s.offset_m(j))};
  }
}

// Joint j's DOFs from its segment's measured orientation relative to its placed parent.
void SolveJob::OrientFromTarget(int j) {
  const Skeleton& s = model->skeleton_;
  const SolverContext& c = *context;
  Pose& p = *pose;
  const int par = s.parent(j);
  const glm::quat parent_rot = par < 0 ? p.root_orientation : c.world_[par].rotation;
  joint_dofs_from_rotation(s, j, glm::conjugate(parent_rot) * c.segment_target_[j].rotation, p.dof_rad);
}

// 4. The two-bone chain `ci` reaching for its end target from its placed parent: swivel from the
// middle or upper segment's sensor, else a guess; when the limits cannot follow that swivel, the
// feasible one nearest to it. False when the chain cannot be solved (the caller falls back).
bool SolveJob::SolveLimb(int ci) {
  const SolverModel& m = *model;
  SolverContext& c = *context;
  const Skeleton& s = m.skeleton_;
  const Pose& p = *pose;
  std::span<float> dof(pose->dof_rad);
  const SolverModel::Chain& ch = m.chains_[ci];
  const int j = ch.upper;
  const RigidTransform& parent_w = c.world_[s.parent(j)];
  const glm::vec3 start = parent_w.apply(s.offset_m(j));
  const RigidTransform& end_t = c.segment_target_[ch.end];
  glm::vec3 pole;
  const glm::vec3 default_pole = p.root_orientation * ch.default_pole;
  if (c.has_target_[ch.mid]) {
    // The middle segment's origin is the middle joint: its sensor's position says where (a
    // shorter lever than the lower link turned by the sensor's orientation).
    pole = c.segment_target_[ch.mid].translation - start;
  } else if (c.has_target_[ch.upper]) {
    pole = ch.upper_m * (c.segment_target_[ch.upper].rotation * ch.upper_dir);
  } else if (ci >= 2 && c.guessed_end_[ci]) {
    // A foot the stepper placed: the knee faces where the foot points (its heading; a lifted heel
    // pitches the foot, and a pole taken from the pitched foot turned the straight leg over).
    const glm::vec3 toe = end_t.rotation * glm::vec3(0, 0, 1);
    const glm::vec3 ahead = glm::length(glm::vec2(toe.x, toe.z)) > 0.2f ? glm::vec3(toe.x, 0, toe.z) : default_pole;
    pole = glm::normalize(
        within_turn_of(ahead, p.root_orientation * glm::vec3(0, 0, 1), m.options_.locomotion.knee_turn_max_rad));
  } else {
    // The hand (foot) rarely bends far from its forearm (shin): guess the middle joint
    // one lower link back along it, leaning on the natural direction when that is vague.
    const glm::vec3 guess = end_t.translation - ch.lower_m * (end_t.rotation * ch.upper_dir) - start;
    const float reach = ch.upper_m + ch.lower_m;
    pole = guess + 0.3f * reach * default_pole;
  }
  ChainInput in{&s, &ch, &parent_w, start, &end_t, dof};
  if (c.has_target_[ch.upper]) in.upper_rot = &c.segment_target_[ch.upper].rotation;
  if (c.has_target_[ch.upper])
    in.hinge_hint = c.segment_target_[ch.upper].rotation * ch.hinge;
  else if (c.has_target_[ch.mid])
    in.hinge_hint = c.segment_target_[ch.mid].rotation * ch.hinge;
  else if (c.have_previous_)
    in.last_bend = &c.last_bend_world_[ci];
  else
    in.hinge_hint = end_t.rotation * ch.hinge;
  // Swivel: the hint first; if the limits cannot follow it (shoulder twist, forearm twist,
  // wrist, hip rotation …), the feasible swivel nearest to it.
  const glm::vec3 axis_dir = end_t.translation - start;
  const float axis_len = glm::length(axis_dir);
  const glm::vec3 n = axis_len > 1e-6f ? axis_dir / axis_len : glm::vec3(0, -1, 0);
  glm::vec3 e1 = perpendicular_part(pole, n);
  if (glm::length(e1) < 1e-6f) e1 = perpendicular_part(default_pole, n);
  if (glm::length(e1) < 1e-6f) e1 = perpendicular_part(glm::vec3(0, 0, 1), n);
  if (glm::length(e1) < 1e-6f) e1 = perpendicular_part(glm::vec3(1, 0, 0), n);
  e1 = glm::normalize(e1);
  const glm::vec3 e2 = glm::cross(n, e1);
  const detail::ChainGeometry hinted = detail::chain_geometry(in, e1);
  ChainSolution best = detail::solve_chain(in, hinted);
  // A guessed foot is searched only when the limits would cut a lot off the swivel's leg
  // (LocomotionOptions::search_swivel_above_rad): clamped that far, a stretched leg turned up off
  // the floor. Its knee's direction being a guess too, a coarser grid does (8 samples, down to
  // 0.01 rad: the eight clips' figures unchanged, the search 40 % shorter).
  const float search_above = c.guessed_end_[ci] ? m.options_.locomotion.search_swivel_above_rad : 1e-4f;
  const detail::SwivelGrid grid = c.guessed_end_[ci] ? detail::SwivelGrid{8, 0.01f} : detail::SwivelGrid{};
  if (best.ok && best.violation > search_above) best = detail::search_swivel(in, hinted, e1, e2, best, grid);
  if (!best.ok) return false;
  for (int i = 0; i < ch.upper_dof_count; ++i) dof[ch.upper_dofs[i]] = best.upper[i];
  dof[ch.flex_dof] = best.bend;
  for (int i = 0; i < ch.end_dof_count; ++i) dof[ch.end_dofs[i]] = best.end[i];
  c.last_bend_world_[ci] = best.bend_world;
  return true;
}

// 4. Limbs and the rest, parents first: chains reach for their ends, other segments with a
// sensor take its orientation, joints nothing observes relax.
void SolveJob::SolveLimbsAndRest(bool trunk_observed) {
  const SolverModel& m = *model;
  SolverContext& c = *context;
  const Skeleton& s = m.skeleton_;
  const SolverOptions& o = m.options_;
  std::span<float> dof(pose->dof_rad);
  std::array<bool, 4> chain_solved{};
  auto relax = [&](int j) {
    for (int d = s.dof_begin(j); d < s.dof_end(j); ++d) dof[d] = m.prior_rad_[d];
  };
  bool is_trunk[64] = {};
  bool solved_by_ls[64] = {};
  if (trunk_observed)
    for (int d : c.ls_dofs_) solved_by_ls[s.dof(d).joint] = true;
  for (int j : m.trunk_joints_) is_trunk[j] = true;

  for (int j = 0; j < s.joint_count(); ++j) {
    const int ci = m.chain_of_joint_[j];
    if (j == 0 || is_trunk[j]) {
      if (j != 0 && !trunk_observed) {
        if (c.has_target_[j]) OrientFromTarget(j);
      }
    } else if (ci >= 0) {
      const SolverModel::Chain& ch = m.chains_[ci];
      if (j == ch.upper && c.has_target_[ch.end] && SolveLimb(ci)) {
        LiftSteppedFootOffFloor(ci);
        PlaceJoint(j);
        chain_solved[ci] = true;
        continue;
      }
      if (!chain_solved[ci]) {
        if (c.has_target_[j])
          OrientFromTarget(j);
        else
          relax(j);
      }
    } else {
      if (c.has_target_[j])
        OrientFromTarget(j);
      else if (!solved_by_ls[j])
        relax(j);
    }
    PlaceJoint(j);
    if (const int leg = j == m.toes_[0]   ? 0
                        : j == m.toes_[1] ? 1
                                          : -1;
        leg >= 0 && std::isfinite(o.standing_root_y_m)) {
      keep_toes_above_floor(m, j, o.standing_root_y_m - m.toe_tip_below_root_rest_[leg], c.world_[s.parent(j)], dof);
      PlaceJoint(j);  // the toes may have bent up
    }
  }
}

bool SolveJob::Run() {
  if (!Validate()) return false;
  const SolverModel& m = *model;
  SolverContext& c = *context;
  const Skeleton& s = m.skeleton_;
  const SolverOptions& o = m.options_;
  Pose& p = *pose;

  GatherTargets();
  // 2. Root from the pelvis, else an unknown of the trunk solve.
  const bool root_known = c.has_target_[0] != 0;
  if (root_known) {
    const RigidTransform& t = c.segment_target_[0];
    p.root_orientation = t.rotation;
    p.root_position_m = t.translation - t.rotation * s.offset_m(0);
  }

  // 3. Trunk: damped least squares.
  c.targets_.clear();
  c.ls_dofs_.clear();
  c.ls_dofs_.insert(c.ls_dofs_.end(), m.trunk_dofs_.begin(), m.trunk_dofs_.end());
  for (int j : m.trunk_joints_)
    if (c.has_target_[j])
      c.targets_.push_back(IkTarget{j, c.segment_target_[j].translation, c.segment_target_[j].rotation,
                                    o.position_weight, o.rotation_weight});
  const bool trunk_observed = !c.targets_.empty();
  if (!root_known && trunk_observed) AddRootTargets();
  if (trunk_observed) AddArmTargets();
  ls_iterations = 0;
  if (trunk_observed) SolveTrunk(root_known);

  // 3b. Legs nobody tracks step (locomotion.h); without a floor (no calibration) they are
  // left to the relaxed posture.
  if (trunk_observed && std::isfinite(o.standing_root_y_m)) place_untracked_feet();

  SolveLimbsAndRest(trunk_observed);
  c.have_previous_ = true;
  return true;
}

}  // namespace mimic::solver
