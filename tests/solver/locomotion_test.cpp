// Procedural steps of legs nobody tracks (head and hands only, or a foot whose sensor is lost):
// properties of the solved feet, whatever the clip.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "mimic/rig/motion.h"
#include "mimic/solver/body_solver.h"
#include "synthetic_sensors.h"

namespace mimic::solver::locomotion_test {
namespace {

using rig::Pose;
using rig::RigidTransform;
using rig::Skeleton;

constexpr double kRateHz = 120.0;

// A wearer with the given layout (straps square), standing height known, as after calibration.
struct Wearer {
  Skeleton s = *Skeleton::build(rig::default_skeleton_desc());
  std::vector<SensorMount> mounts;
  float standing_root_y = rig::standing_root_height_m(s);
  SolverModel model;
  SolverContext ctx;
  Pose solved = s.zero_pose();
  std::vector<devices::SensorSample> samples;
  std::mt19937_64 rng{11};
  std::vector<RigidTransform> world = std::vector<RigidTransform>(s.joint_count());
  int frame = 0;

  explicit Wearer(const char* layout, const LocomotionOptions& stepping = {},
                  float walk_root_follow_weight = SolverOptions{}.walk_root_follow_weight,
                  float hands_heading_share = SolverOptions{}.hands_heading_share)
      : mounts(testing::mounts_for(*standard_layout(layout, s), 0.0f, 5)),
        model(make_model(stepping, walk_root_follow_weight, hands_heading_share)),
        ctx(model) {}
  SolverModel make_model(const LocomotionOptions& stepping, float walk_root_follow_weight,
                         float hands_heading_share) const {
    SolverOptions options;
    options.locomotion = stepping;
    options.walk_root_follow_weight = walk_root_follow_weight;
    options.hands_heading_share = hands_heading_share;
    options.standing_root_y_m = standing_root_y;
    return *SolverModel::create(s, mounts, options);
  }
  // One frame: sensors on the true pose (1 mm / 0.5° noise), solved, FK into `world`. Sensors
  // listed in `lost` send invalid samples.
  void step(const Pose& truth, std::initializer_list<uint16_t> lost = {}) {
    testing::sense(s, truth, mounts, samples, &rng, 0.001f, glm::radians(0.5f), frame / kRateHz);
    for (auto& smp : samples)
      for (uint16_t id : lost)
        if (smp.sensor == id) smp.flags = 0;
    SolveJob job{&model, samples, &ctx, &solved};
    ASSERT_TRUE(job.Run());
    rig::forward_kinematics(s, solved, world);
    ++frame;
  }
  glm::vec3 ankle(int leg) const { return world[s.find_joint(leg == 0 ? "l_ankle" : "r_ankle")].translation; }
  float leg_m(int leg) const {
    const int knee = s.find_joint(leg == 0 ? "l_knee" : "r_knee");
    const int ankle = s.find_joint(leg == 0 ? "l_ankle" : "r_ankle");
    return glm::length(s.offset_m(knee)) + glm::length(s.offset_m(ankle));
  }
  glm::vec3 ball(int leg) const { return world[s.find_joint(leg == 0 ? "l_toes" : "r_toes")].translation; }
  float floor_ankle_y() const {
    std::vector<RigidTransform> w(s.joint_count());
    rig::forward_kinematics(s, s.zero_pose(), w);
    return standing_root_y - (w[0].translation.y - w[s.find_joint("l_ankle")].translation.y);
  }
  // The sole of a flat foot: the lowest point (toe tip) of the standing skeleton.
  float sole_y() const {
    std::vector<RigidTransform> w(s.joint_count());
    rig::forward_kinematics(s, s.rest_pose(), w);
    float low = 1e9f;
    for (const char* side : {"l_toes", "r_toes"})
      low = std::min(low, w[s.find_joint(side)].apply(s.tip_m(s.find_joint(side))).y);
    return standing_root_y - (w[0].translation.y - low);
  }
  // Lowest point of either foot: ankle, toes, toe tip.
  float lowest_foot_point_y() const {
    float y = 1e9f;
    for (const char* side : {"l_", "r_"}) {
      const int a = s.find_joint(std::string(side) + "ankle"), t = s.find_joint(std::string(side) + "toes");
      y = std::min({y, world[a].translation.y, world[t].translation.y, world[t].apply(s.tip_m(t)).y});
    }
    return y;
  }
};

Pose standing(const Wearer& w, glm::vec3 at, float yaw_rad) {
  Pose p = w.s.zero_pose();
  p.root_position_m = {at.x, w.standing_root_y - 0.02f, at.z};
  p.root_orientation = glm::angleAxis(yaw_rad, glm::vec3(0, 1, 0));
  return p;
}

float horizontal(const glm::vec3& a, const glm::vec3& b) { return glm::length(glm::vec2(a.x - b.x, a.z - b.z)); }

TEST(Locomotion, StandingStillTakesNoSteps) {
  Wearer w("3");
  const Pose truth = standing(w, {0.4f, 0, -0.2f}, 0.5f);
  for (int k = 0; k < 30; ++k) w.step(truth);  // settle
  const long steps0 = w.ctx.locomotion().steps;
  const glm::vec3 l0 = w.ankle(0), r0 = w.ankle(1);
  for (int k = 0; k < int(4 * kRateHz); ++k) w.step(truth);
  EXPECT_EQ(w.ctx.locomotion().steps, steps0);
  EXPECT_LT(glm::length(w.ankle(0) - l0), 0.002f);
  EXPECT_LT(glm::length(w.ankle(1) - r0), 0.002f);
}

// Head and hands only, standing: the head looks 70° to the left (neck and head turned, as far as
// they go) while the hips and the outstretched hands stay. The hips, taken from the head alone,
// turn with it; read between the head and the hands' line they stay within 30° of the truth's.
// Arms crossed over the chest (the hands' line backwards) say nothing: the hips follow the head.
TEST(Locomotion, AHeadLookingAsideTurnsTheHipsOnlyPartOfTheWayWhenTheHandsStay) {
  auto hips_off_deg = [](float share, bool crossed) {
    Wearer w("3", {}, SolverOptions{}.walk_root_follow_weight, share);
    Pose truth = standing(w, {0.3f, 0, -0.4f}, 0.0f);
    if (crossed) {
      for (const char* side : {"l_", "r_"}) {
        truth.dof_rad[w.s.find_dof(std::string(side) + "shoulder_flexion")] = glm::radians(125.0f);
        truth.dof_rad[w.s.find_dof(std::string(side) + "shoulder_abduction")] = glm::radians(-20.0f);
      }
      std::vector<RigidTransform> at(w.s.joint_count());
      rig::forward_kinematics(w.s, truth, at);
      const float left_of_right =
          at[w.s.find_joint("l_wrist")].translation.x - at[w.s.find_joint("r_wrist")].translation.x;
      EXPECT_LT(left_of_right, -0.1f) << "the arms are not crossed";
    }
    for (int k = 0; k < int(2 * kRateHz); ++k) w.step(truth);  // the hands' line held for its time
    for (const char* joint : {"neck_twist", "neck_upper_twist", "head_twist"})
      truth.dof_rad[w.s.find_dof(joint)] = glm::radians(25.0f);
    for (int k = 0; k < int(1 * kRateHz); ++k) w.step(truth);
    const glm::vec3 f = w.solved.root_orientation * glm::vec3(0, 0, 1);
    return std::abs(glm::degrees(std::atan2(f.x, f.z)));
  };
  const float head_only = hips_off_deg(0.0f, false),
              with_hands = hips_off_deg(SolverOptions{}.hands_heading_share, false);
  const float crossed = hips_off_deg(SolverOptions{}.hands_heading_share, true);
  std::printf("  hips off the truth's: %.0f deg from the head alone, %.0f with the hands, %.0f arms crossed\n",
              head_only, with_hands, crossed);
  EXPECT_GT(head_only, 45.0f);
  EXPECT_LT(with_hands, 30.0f);
  EXPECT_GT(crossed, 45.0f);
}

TEST(Locomotion, TurningInPlaceSteps) {
  Wearer w("3");
  for (int k = 0; k < 30; ++k) w.step(standing(w, {0, 0, 0}, 0.0f));
  const long steps0 = w.ctx.locomotion().steps;
  // A quarter turn over two seconds, then a second to settle.
  for (int k = 0; k < int(3 * kRateHz); ++k) {
    const float yaw = 1.5708f * std::min(1.0f, static_cast<float>(k / (2 * kRateHz)));
    w.step(standing(w, {0, 0, 0}, yaw));
  }
  EXPECT_GE(w.ctx.locomotion().steps - steps0, 2);
  // Both feet end turned with the body, beside each other (left foot on the left).
  for (const auto& f : w.ctx.locomotion().feet) {
    EXPECT_FALSE(f.swinging);
    EXPECT_LT(std::abs(std::remainder(f.yaw_rad - 1.5708f, 6.2832f)), 0.6f);
  }
  const glm::vec3 left_dir = glm::angleAxis(1.5708f, glm::vec3(0, 1, 0)) * glm::vec3(1, 0, 0);
  EXPECT_GT(glm::dot(w.ankle(0) - w.ankle(1), left_dir), 0.08f);
}

// The built-in walk, seen by head and hands only: the solved feet step along, a planted foot does
// not slide (its ball: a trailing foot lifts its heel), no foot goes under the floor and the
// legs never cross.
TEST(Locomotion, WalkingFeetStepStayPlantedAndAboveTheFloor) {
  Wearer w("3");
  auto walk = rig::make_builtin_motion("walk", w.s);
  ASSERT_TRUE(walk.has_value());
  Pose truth = w.s.zero_pose();
  const float floor_y = w.floor_ankle_y();
  std::array<glm::vec3, 2> last{};
  std::array<bool, 2> was_planted{};
  float worst_slide_m = 0, dragged_m = 0, lowest_m = 1e9f, worst_cross_m = 1e9f, passing_cross_m = 1e9f;
  const int frames = int(6 * kRateHz);
  for (int k = 0; k < frames; ++k) {
    (*walk)->sample(k / kRateHz, truth);
    w.step(truth);
    const auto& loco = w.ctx.locomotion();
    for (int leg = 0; leg < 2; ++leg) {
      const bool planted = loco.feet[leg].driven && !loco.feet[leg].swinging;
      // Within the leg's reach (flat, or with the heel lifted) a planted foot holds still; a body
      // that outruns its legs drags a foot until it may lift, and that is counted apart.
      const glm::vec3 hip = w.world[w.s.find_joint(leg == 0 ? "l_hip" : "r_hip")].translation;
      const bool in_reach = glm::length(hip - loco.feet[leg].ankle) < 0.999f * w.leg_m(leg);
      if (k > 30 && planted && was_planted[leg]) {
        const float slide_m = horizontal(w.ball(leg), last[leg]);
        if (in_reach)
          worst_slide_m = std::max(worst_slide_m, slide_m);
        else
          dragged_m += slide_m;
      }
      was_planted[leg] = planted;
      last[leg] = w.ball(leg);
    }
    lowest_m = std::min(lowest_m, w.lowest_foot_point_y());
    // Across the walker's line of travel (over half a stride either side): on the walk's curve
    // the pelvis' heading, from the head, is 5–16° off it, and a stride's feet 60 cm apart would
    // seem to cross across it by 10 cm.
    Pose ahead = truth, behind = truth;
    (*walk)->sample(k / kRateHz + 0.55, ahead);
    (*walk)->sample(k / kRateHz - 0.55, behind);
    const glm::vec3 path = ahead.root_position_m - behind.root_position_m;
    const glm::vec3 left_dir = glm::normalize(glm::vec3(path.z, 0, -path.x));
    worst_cross_m = std::min(worst_cross_m, glm::dot(w.ankle(0) - w.ankle(1), left_dir));
    if (std::abs(glm::dot(w.ankle(0) - w.ankle(1), glm::normalize(path))) < 0.25f)
      passing_cross_m = std::min(passing_cross_m, glm::dot(w.ankle(0) - w.ankle(1), left_dir));
    EXPECT_GE(w.ankle(0).y, floor_y - 1e-4f);
    EXPECT_GE(w.ankle(1).y, floor_y - 1e-4f);
  }
  const auto& loco = w.ctx.locomotion();
  std::printf(
      "  walk: %ld steps in %.1f s, worst planted slide %.2f mm within reach (%.0f mm dragged out of "
      "reach in all), lowest foot point %.1f mm below the flat foot's ankle, narrowest %.1f cm (passing %.1f cm)\n",
      loco.steps, frames / kRateHz, 1000 * worst_slide_m, 1000 * dragged_m, 1000 * (floor_y - lowest_m),
      100 * worst_cross_m, 100 * passing_cross_m);
  EXPECT_GE(loco.steps, 6);  // a walk of six seconds steps, about twice a second
  // (A few millimetres: a guessed foot's chain is clamped to the hip's and ankle's limits.)
  EXPECT_LT(worst_slide_m, 0.005f);
  // The legs never cross: passing each other (within 25 cm fore and aft) the feet stay 5 cm apart
  // side to side (the guard keeps 10 across the stepper's own line of travel). Planted a stride
  // apart on the walk's tight curve (1.4 m radius) the front foot may land on the walker's line:
  // a narrow track, as people walk (CMU 06_04's ankles come 0.7 cm past it), not a crossing of
  // the legs; it stays within 5 cm of the line.
  EXPECT_GT(passing_cross_m, 0.05f);
  EXPECT_GT(worst_cross_m, -0.05f);
}

// A stepped foot moves as a foot can: it never jumps from one frame to the next (a landing spot
// that moves with the body, a heel that lifts or drops, a swing hurried to the head's bob), and
// the leg never turns over (the knee stays below the hip).
TEST(Locomotion, SteppedFeetNeverJumpAndKneesStayDown) {
  Wearer w("3");
  auto walk = rig::make_builtin_motion("walk", w.s);
  ASSERT_TRUE(walk.has_value());
  Pose truth = w.s.zero_pose();
  std::array<glm::vec3, 2> last{};
  float fastest_mps = 0, highest_knee_m = -1e9f;
  const int frames = int(8 * kRateHz);
  for (int k = 0; k < frames; ++k) {
    // Walking, with a turn of the whole body half-way (the clip turned about the origin).
    (*walk)->sample(k / kRateHz, truth);
    if (k > frames / 2) {
      const glm::quat turn = glm::angleAxis(0.8f * float(k - frames / 2) / float(frames / 2), glm::vec3(0, 1, 0));
      truth.root_orientation = turn * truth.root_orientation;
      truth.root_position_m = turn * truth.root_position_m;
    }
    w.step(truth);
    for (int leg = 0; leg < 2; ++leg) {
      if (k > 0) fastest_mps = std::max(fastest_mps, float(glm::length(w.ankle(leg) - last[leg]) * kRateHz));
      last[leg] = w.ankle(leg);
      const glm::vec3 hip = w.world[w.s.find_joint(leg == 0 ? "l_hip" : "r_hip")].translation;
      const glm::vec3 knee = w.world[w.s.find_joint(leg == 0 ? "l_knee" : "r_knee")].translation;
      highest_knee_m = std::max(highest_knee_m, knee.y - hip.y);
    }
  }
  std::printf("  walk and turn: fastest ankle %.2f m/s, highest knee %.1f cm relative to its hip\n", fastest_mps,
              100 * highest_knee_m);
  // The stepper's own limit (8 m/s), with a margin for the chain's clamping to the joint limits.
  EXPECT_LT(fastest_mps, 1.25f * LocomotionOptions{}.max_foot_speed_mps);
  EXPECT_LT(highest_knee_m, -0.1f);
}

// Head and hands pivot on the spot, a half circle and more in 0.6 s and in 1 s: the planted feet
// are left behind until they step, pointing where the body no longer does. Their knees face the
// feet only as far as the hips can turn, so the legs follow without a jerk (a knee asked to face
// the foot put the hip past its limits, and the clamped leg flung its ankle at 5.7–5.8 m/s).
TEST(Locomotion, APivotsLaggingFeetFollowWithoutAJerk) {
  for (float turn_s : {0.6f, 1.0f}) {
    Wearer w("3");
    for (int k = 0; k < 60; ++k) w.step(standing(w, {0, 0, 0}, 0.0f));
    std::array<glm::vec3, 2> last{w.ankle(0), w.ankle(1)};
    float fastest_mps = 0;
    const long steps0 = w.ctx.locomotion().steps;
    for (int k = 0; k < int(2 * kRateHz); ++k) {
      const float yaw = 3.5f * std::min(1.0f, static_cast<float>(k / (turn_s * kRateHz)));
      w.step(standing(w, {0, 0, 0}, yaw));
      for (int leg = 0; leg < 2; ++leg) {
        fastest_mps = std::max(fastest_mps, float(glm::length(w.ankle(leg) - last[leg]) * kRateHz));
        last[leg] = w.ankle(leg);
      }
    }
    std::printf("  a 3.5 rad pivot in %.1f s: fastest ankle %.2f m/s, %ld steps\n", turn_s, fastest_mps,
                w.ctx.locomotion().steps - steps0);
    EXPECT_GE(w.ctx.locomotion().steps - steps0, 2) << turn_s;
    EXPECT_LT(fastest_mps, 2.5f) << turn_s;
  }
}

// The built-in walk, its heading swaying ±0.6 rad, seen by head and hands: the stepped knees
// move as smoothly as a walk (a swivel search whenever the limits cut 0.2 rad off the guessed
// leg flipped the knee from one sample to the next: 0.58 m, mean 10.5 mm).
TEST(Locomotion, SteppedKneesDoNotFlip) {
  Wearer w("3");
  auto walk = rig::make_builtin_motion("walk", w.s);
  ASSERT_TRUE(walk.has_value());
  Pose truth = w.s.zero_pose();
  std::array<std::vector<glm::vec3>, 2> knees;
  for (int k = 0; k < int(8 * kRateHz); ++k) {
    (*walk)->sample(k / kRateHz, truth);
    const glm::quat turn = glm::angleAxis(0.6f * std::sin(static_cast<float>(k) / 200.0f), glm::vec3(0, 1, 0));
    truth.root_orientation = turn * truth.root_orientation;
    truth.root_position_m = turn * truth.root_position_m;
    w.step(truth);
    for (int leg = 0; leg < 2; ++leg)
      knees[leg].push_back(w.world[w.s.find_joint(leg == 0 ? "l_knee" : "r_knee")].translation);
  }
  double sum_m = 0, worst_m = 0;
  int n = 0;
  for (const auto& knee : knees)
    for (size_t t = 1; t + 1 < knee.size(); ++t) {
      const double jerk_m = glm::length(knee[t + 1] - 2.0f * knee[t] + knee[t - 1]);
      sum_m += jerk_m, worst_m = std::max(worst_m, jerk_m), ++n;
    }
  std::printf("  stepped knees: |k[t+1] - 2k[t] + k[t-1]| mean %.2f mm, largest %.1f mm\n", 1000 * sum_m / n,
              1000 * worst_m);
  EXPECT_LT(sum_m / n, 0.009);
  EXPECT_LT(worst_m, 0.3);
}

// The built-in walk solved from head and hands, 8 s: the true head's height and ankles, and the
// frames where the stepper lifted a foot (and which).
struct WalkedSteps {
  std::vector<float> head_y;
  std::array<std::vector<float>, 2> ankle_y;
  std::vector<int> lift_frames, lifted;
  int frames = 0;
};
WalkedSteps walk_from_head_and_hands(const LocomotionOptions& stepping) {
  Wearer w("3", stepping);
  auto walk = rig::make_builtin_motion("walk", w.s);
  WalkedSteps out;
  if (!walk.has_value()) return out;
  Pose truth = w.s.zero_pose();
  std::vector<RigidTransform> truth_world(w.s.joint_count());
  const int head = w.s.find_joint("head");
  const int ankles[2] = {w.s.find_joint("l_ankle"), w.s.find_joint("r_ankle")};
  out.frames = int(8 * kRateHz);
  for (int k = 0; k < out.frames; ++k) {
    (*walk)->sample(k / kRateHz, truth);
    rig::forward_kinematics(w.s, truth, truth_world);
    out.head_y.push_back(truth_world[head].translation.y);
    for (int leg = 0; leg < 2; ++leg) out.ankle_y[leg].push_back(truth_world[ankles[leg]].translation.y);
    const long before = w.ctx.locomotion().steps;
    w.step(truth);
    if (w.ctx.locomotion().steps > before)
      out.lift_frames.push_back(k), out.lifted.push_back(w.ctx.locomotion().last_stepped);
  }
  return out;
}

// Walking, the arms swing against the legs: a hand is most forward as the foot on its side, the
// one furthest behind, lifts. Timed by the hands, each solved foot lifts when the walker's own
// does, the feet alternating, one step for each of the walker's.
TEST(Locomotion, WalkingFeetLiftWithTheWalkersOnTheArmsBeat) {
  const WalkedSteps walked = walk_from_head_and_hands({});
  ASSERT_GT(walked.frames, 0);
  // The walker's lifts: a true ankle rising 2 cm above the lowest it has been since it last fell.
  std::array<std::vector<int>, 2> true_lifts;
  for (int leg = 0; leg < 2; ++leg) {
    const auto& y = walked.ankle_y[leg];
    float low = y[0];
    bool up = false;
    for (int k = 1; k < walked.frames; ++k) {
      if (!up && y[k] > low + 0.02f) true_lifts[leg].push_back(k), up = true;
      if (up && y[k] < y[k - 1] - 1e-4f) up = false, low = y[k];
      if (!up) low = std::min(low, y[k]);
    }
  }
  const int from = int(2 * kRateHz), near = int(0.12 * kRateHz);
  int counted = 0, with_walker = 0, repeats = 0, truth_count = 0;
  for (size_t i = 0; i < walked.lift_frames.size(); ++i) {
    if (walked.lift_frames[i] < from) continue;
    ++counted;
    if (i > 0 && walked.lifted[i] == walked.lifted[i - 1]) ++repeats;
    for (int t : true_lifts[walked.lifted[i]])
      if (std::abs(t - walked.lift_frames[i]) <= near) {
        ++with_walker;
        break;
      }
  }
  for (const auto& lifts : true_lifts)
    for (int t : lifts) truth_count += t >= from;
  std::printf(
      "  walk: %d steps after 2 s (the walker %d), %d of them within 0.12 s of the walker's own lift of that foot; "
      "%d times a foot stepped twice running\n",
      counted, truth_count, with_walker, repeats);
  ASSERT_GE(truth_count, 6);
  EXPECT_GE(with_walker, 0.8 * counted);
  EXPECT_NEAR(counted, truth_count, 0.2 * truth_count);
  EXPECT_EQ(repeats, 0);
}

// Walking with swinging arms, the hips hang under the head as a trunk leaning with half the
// head's tilt would hang them: the trunk's solve alone leans as readily as it moves the hips, and
// left them behind the walker's. On the built-in walk, after two seconds, the solved pelvis is
// nearer the walker's with the pull than without it.
TEST(Locomotion, WalkingHipsHangUnderTheHeadLeaningWithIt) {
  auto pelvis_error_m = [](float walk_root_follow_weight) {
    Wearer w("3", {}, walk_root_follow_weight);
    auto walk = rig::make_builtin_motion("walk", w.s);
    if (!walk.has_value()) return 1e9;
    Pose truth = w.s.zero_pose();
    std::vector<RigidTransform> truth_world(w.s.joint_count());
    double sum_m = 0;
    int n = 0;
    for (int k = 0; k < int(8 * kRateHz); ++k) {
      (*walk)->sample(k / kRateHz, truth);
      rig::forward_kinematics(w.s, truth, truth_world);
      w.step(truth);
      if (k < 2 * kRateHz) continue;
      sum_m += horizontal(w.world[0].translation, truth_world[0].translation), ++n;
    }
    return sum_m / n;
  };
  const double with_m = pelvis_error_m(SolverOptions{}.walk_root_follow_weight), without_m = pelvis_error_m(0.0f);
  std::printf("  walk: the pelvis %.1f cm from the walker's horizontally, %.1f cm without the pull\n", 100 * with_m,
              100 * without_m);
  EXPECT_LT(with_m, 0.8 * without_m);
}

// Arms that do not swing (off here) leave the beat to the head, lowest as a foot strikes: a foot
// lifts shortly after each low of the head, the feet alternating, rather than to a rhythm of the
// stepper's own.
TEST(Locomotion, WalkingStepsKeepTheHeadsBeat) {
  LocomotionOptions stepping;
  stepping.arm_beat = false;
  const WalkedSteps walked = walk_from_head_and_hands(stepping);
  ASSERT_GT(walked.frames, 0);
  const int frames = walked.frames;
  const auto& head_y = walked.head_y;
  const auto& lift_frames = walked.lift_frames;
  const auto& lifted = walked.lifted;
  // Lows of the true head; the beat is measured after the first two seconds.
  const int from = int(2 * kRateHz), half = int(0.15 * kRateHz);
  std::vector<int> lows;
  for (int k = half; k + half < frames; ++k) {
    bool lowest = true;
    for (int d = -half; d <= half && lowest; ++d) lowest = head_y[k + d] >= head_y[k];
    if (lowest) lows.push_back(k);
  }
  int on_beat = 0, counted = 0, repeats = 0;
  for (size_t i = 0; i < lift_frames.size(); ++i) {
    if (lift_frames[i] < from) continue;
    ++counted;
    if (i > 0 && lifted[i] == lifted[i - 1]) ++repeats;
    // Within the first 40 % of the time from the last low to the next.
    for (size_t l = 0; l + 1 < lows.size(); ++l)
      if (lift_frames[i] >= lows[l] && lift_frames[i] < lows[l] + 0.4 * (lows[l + 1] - lows[l])) ++on_beat;
  }
  std::printf(
      "  walk: %zu lows of the head, %d steps after 2 s, %d of them soon after a low; %d times a foot "
      "stepped twice running\n",
      lows.size(), counted, on_beat, repeats);
  ASSERT_GE(counted, 6);
  EXPECT_GE(on_beat, 0.7 * counted);
  EXPECT_LE(repeats, 1);
}

// The stepper's input for two legs of 0.79 m it places both feet of, at `dt` seconds a frame.
LocomotionInput two_driven_feet(double dt) {
  LocomotionInput in;
  in.dt_s = static_cast<float>(dt);
  in.reach_m = {0.79f, 0.79f};
  in.floor_ankle_y_m = {0.073f, 0.073f};
  in.drive = {true, true};
  return in;
}

// Standing in a staggered stance (a boxer's: the left foot 35 cm ahead of the right), the body
// sways 10 cm fore and aft over its feet: each hip is then up to 27 cm from its own foot, yet the
// pelvis never leaves the support between the feet, and no foot steps. Leaning out sideways until
// the pelvis is 20 cm outside it, the body steps.
TEST(Locomotion, AStaggeredStanceSwaysOverItsFeetWithoutStepping) {
  const double dt = 1.0 / 120, pi = 3.14159265358979;
  LocomotionState state;
  LocomotionInput in = two_driven_feet(dt);
  auto stand = [&](float x, float z) {
    in.root = {x, 0.82f, z};
    in.hip = {glm::vec3(x + 0.11f, 0.80f, z), glm::vec3(x - 0.11f, 0.80f, z)};
  };
  // The stepper takes the feet over where they are: left ahead, right behind.
  in.have_last_ankle = true;
  in.last_ankle = {glm::vec3(0.11f, 0.073f, 0.175f), glm::vec3(-0.11f, 0.073f, -0.175f)};
  stand(0, 0);
  update_locomotion(state, in, LocomotionOptions{});
  float farthest_m = 0;
  for (int k = 0; k < int(6.0 / dt); ++k) {
    const float z = static_cast<float>(0.10 * std::sin(2 * pi * k * dt / 1.5));
    stand(0, z);
    update_locomotion(state, in, LocomotionOptions{});
    for (int leg = 0; leg < 2; ++leg)
      farthest_m = std::max(farthest_m, horizontal(in.hip[leg], state.feet[leg].planted));
  }
  std::printf("  swaying: %ld steps, a hip up to %.0f cm from its planted foot\n", state.steps, 100 * farthest_m);
  EXPECT_EQ(state.steps, 0);
  EXPECT_GT(farthest_m, 0.2f);  // the old rule (each hip within 14 cm of its foot) would have stepped
  for (int k = 0; k < int(1.0 / dt); ++k) {
    stand(static_cast<float>(0.30 * std::min(1.0, k * dt / 0.5)), 0);
    update_locomotion(state, in, LocomotionOptions{});
  }
  std::printf("  leaning out 30 cm: %ld steps\n", state.steps);
  EXPECT_GE(state.steps, 1);
}

// The stepper alone, fed a head that walks straight on at 1.2 m/s, bobbing at each foot strike
// (lowest as a foot lands, every 0.55 s) and swaying 3 cm to either side: at a strike the head
// moves sideways towards the striking foot, as the body's weight shifts onto it. Three seconds
// in, the walker strikes with the same foot twice running (a shuffle that changes feet); from
// then on, the foot that lifts after each strike is still the other, trailing one: the stepper
// follows the head's sideways motion rather than merely alternating.
TEST(Locomotion, TheFootTheHeadMovesAwayFromLiftsAfterEachStrike) {
  const double dt = 1.0 / 120, period = 0.55, pi = 3.14159265358979;
  const int shuffle = 6;  // the strike that repeats the foot before it
  LocomotionState state;
  LocomotionInput in = two_driven_feet(dt);
  in.have_head = true;
  // Strike n is the left foot's (0) on even n until the shuffle, on odd n after it.
  auto striking = [&](int n) { return (n < shuffle ? n : n + 1) % 2; };
  int counted = 0, trailing = 0;
  for (int k = 0; k < int(8.0 / dt); ++k) {
    const double t = k * dt;
    // +X is the left walking along +Z: towards the left after a left strike.
    const double phase = t / period < shuffle ? t / period : t / period + 1;
    const float sway = static_cast<float>(0.03 * std::sin(pi * phase));
    const float z = static_cast<float>(1.2 * t);
    in.root = {sway, 0.82f, z};
    in.hip = {glm::vec3(sway + 0.11f, 0.80f, z), glm::vec3(sway - 0.11f, 0.80f, z)};
    in.head = {sway, static_cast<float>(1.60 - 0.02 * std::cos(2 * pi * t / period)), z + 0.05f};
    const long before = state.steps;
    update_locomotion(state, in, LocomotionOptions{});
    if (t < (shuffle + 0.5) * period || state.steps == before) continue;
    ++counted;
    if (state.last_stepped != striking(static_cast<int>(std::floor(t / period)))) ++trailing;
  }
  std::printf("  %d lifts after the shuffle, %d of them the foot the head moved away from\n", counted, trailing);
  ASSERT_GE(counted, 6);
  EXPECT_GE(trailing, counted - 1);
}

// The stepper alone, fed a walk at 1.5 m/s whose head bobs at a dribble's beat (every 0.3 s, half
// a stride's time): timed to the next low, a swing would fly its stride in 0.19 s. Every swing lasts
// at least as long as its ground takes at 3 m/s on average; with no such bound some fly faster.
TEST(Locomotion, ASwingTimedToAQuickHeadBeatStillTakesItsTime) {
  auto fastest_swing_mps = [](float swing_max_mps) {
    const double dt = 1.0 / 120, period = 0.3, pi = 3.14159265358979;
    LocomotionOptions o;
    o.swing_max_mps = swing_max_mps;
    LocomotionState state;
    LocomotionInput in = two_driven_feet(dt);
    in.have_head = true;
    std::array<glm::vec3, 2> from{};
    std::array<double, 2> lifted_s{};
    float fastest = 0;
    for (int k = 0; k < int(6.0 / dt); ++k) {
      const double t = k * dt;
      const float sway = static_cast<float>(0.03 * std::sin(pi * t / period));
      const float z = static_cast<float>(1.5 * t);
      in.root = {sway, 0.82f, z};
      in.hip = {glm::vec3(sway + 0.11f, 0.80f, z), glm::vec3(sway - 0.11f, 0.80f, z)};
      in.head = {sway, static_cast<float>(1.60 - 0.02 * std::cos(2 * pi * t / period)), z + 0.05f};
      const std::array<bool, 2> was = {state.feet[0].swinging, state.feet[1].swinging};
      update_locomotion(state, in, o);
      for (int leg = 0; leg < 2; ++leg) {
        const FootStepState& f = state.feet[leg];
        if (!was[leg] && f.swinging) from[leg] = f.from, lifted_s[leg] = t;
        if (was[leg] && !f.swinging && t > 1.0)  // landed, once the walk is under way
          fastest = std::max(fastest, horizontal(f.planted, from[leg]) / static_cast<float>(t - lifted_s[leg] + dt));
      }
    }
    return fastest;
  };
  const float bounded = fastest_swing_mps(LocomotionOptions{}.swing_max_mps), free = fastest_swing_mps(0.0f);
  std::printf("  the fastest swing: %.1f m/s on average, %.1f without the bound\n", bounded, free);
  EXPECT_LE(bounded, LocomotionOptions{}.swing_max_mps * 1.1f);
  EXPECT_GT(free, LocomotionOptions{}.swing_max_mps * 1.1f);
}

// The stepper alone, fed a run at 3.5 m/s: the head lowest at each mid-stance (every 0.36 s, left
// foot first), the arms swinging against the legs (the hands' fore-and-aft difference crossing
// zero at mid-stance, rising over the left foot). Once the run is under way the foot under the
// body at each low is the one on the floor, and every stride has flight: both feet in the air.
// The stepper starts with both feet planted, so its first steps may be on the wrong foot.
TEST(Locomotion, RunningFeetLandBeforeEachLowOnTheFootTheArmsSay) {
  const double dt = 1.0 / 120, period = 0.36, pi = 3.14159265358979;
  LocomotionState state;
  LocomotionInput in = two_driven_feet(dt);
  in.have_head = in.have_hands = true;
  int lows = 0, on_the_floor = 0, flight_frames = 0, frames = 0, strides_with_flight = 0;
  bool flight_this_stride = false;
  for (int k = 0; k < int(5.0 / dt); ++k) {
    const double t = k * dt;
    const float z = static_cast<float>(3.5 * t);
    in.root = {0.0f, 0.82f, z};
    in.hip = {glm::vec3(0.11f, 0.80f, z), glm::vec3(-0.11f, 0.80f, z)};
    in.head = {0.0f, static_cast<float>(1.60 - 0.04 * std::cos(2 * pi * t / period)), z + 0.05f};
    const float swing_m = static_cast<float>(0.3 * std::sin(pi * t / period));  // left hand ahead of the right
    in.hand = {glm::vec3(0.2f, 1.0f, z + 0.5f * swing_m), glm::vec3(-0.2f, 1.0f, z - 0.5f * swing_m)};
    update_locomotion(state, in, LocomotionOptions{});
    if (t < 1.5) continue;
    EXPECT_TRUE(state.running) << "at " << t << " s";
    const bool flying = state.feet[0].swinging && state.feet[1].swinging;
    ++frames, flight_frames += flying;
    flight_this_stride = flight_this_stride || flying;
    const double beats = t / period;
    if (beats - std::floor(beats) < dt / period) {                               // the frame of a low
      const int stance = static_cast<int>(std::llround(std::floor(beats))) % 2;  // left on even lows
      ++lows;
      if (!state.feet[stance].swinging && state.feet[1 - stance].swinging) ++on_the_floor;
      if (stance == 0) strides_with_flight += flight_this_stride, flight_this_stride = false;
    }
  }
  std::printf("  run: %d lows, the foot under the body on the floor at %d; both feet in the air %.0f%% of the time\n",
              lows, on_the_floor, 100.0 * flight_frames / frames);
  ASSERT_GE(lows, 9);
  EXPECT_GE(on_the_floor, lows - 1);
  EXPECT_GE(strides_with_flight, lows / 2 - 1);
  EXPECT_GT(flight_frames, frames / 10);
}

// Head and hands on the built-in run (about 3 m/s, a stride every 0.72 s, each foot down for
// 36 % of it): after the first two seconds, at the middle of each true stance the same solved
// foot is the one on the floor and the other is in the air, and the solved feet fly between the
// stances as the true ones do, their knees never flipping.
TEST(Locomotion, TheBuiltInRunSolvedFromHeadAndHandsRunsOnTheSameFeet) {
  Wearer w("3");
  auto run = rig::make_builtin_motion("run", w.s);
  ASSERT_TRUE(run.has_value());
  const double cycle_s = 0.72, mid_stance_s = 0.5 * 0.36 * cycle_s;
  const float floor_y = w.floor_ankle_y();
  auto down = [&](int leg) { return w.ankle(leg).y < floor_y + 0.03f; };
  Pose truth = w.s.zero_pose();
  int stances = 0, same_foot = 0, frames = 0, flying = 0;
  const int knees[2] = {w.s.find_joint("l_knee"), w.s.find_joint("r_knee")};
  glm::vec3 last_knee[2]{};
  float fastest_knee_m = 0;
  for (int k = 0; k < int(8 * kRateHz); ++k) {
    const double t = k / kRateHz;
    (*run)->sample(t, truth);
    w.step(truth);
    for (int leg = 0; leg < 2; ++leg) {
      const glm::vec3 knee = w.world[knees[leg]].translation;
      if (t >= 2.0) fastest_knee_m = std::max(fastest_knee_m, glm::length(knee - last_knee[leg]));
      last_knee[leg] = knee;
    }
    if (t < 2.0) continue;
    ++frames, flying += !down(0) && !down(1);
    // Left strikes at whole cycles, right half a cycle later; this frame the middle of a stance?
    for (int leg = 0; leg < 2; ++leg) {
      const double since_strike = std::fmod(t - leg * 0.5 * cycle_s - mid_stance_s + 10 * cycle_s, cycle_s);
      if (since_strike >= 1.0 / kRateHz) continue;
      ++stances;
      same_foot += down(leg) && !down(1 - leg);
    }
  }
  std::printf(
      "  run: %d true mid-stances, the same solved foot alone on the floor at %d; both solved feet in the "
      "air %.0f%% of the time; a knee moves at most %.0f mm in a sample\n",
      stances, same_foot, 100.0 * flying / frames, 1000.0 * fastest_knee_m);
  ASSERT_GE(stances, 14);
  EXPECT_GE(same_foot, stances - 2);
  EXPECT_GT(flying, frames / 10);
  // A knee that flips sideways and back moves 40 cm between samples (433 mm with the swinging
  // foot held flat under the kicked-up shin); a running one at most about a sixth of that (117 mm
  // when a dip of the run's head in flight dropped the stepper out of its running steps).
  EXPECT_LT(fastest_knee_m, 0.1f);
}

// The head lost for half a second of a walk: back, its speed along the path is still the walk's
// (the whole gap's move was taken as one frame's, 60 times the walk: the smoothed path speed
// jumped to 2.37 m/s).
TEST(Locomotion, AHeadBackFromADropoutKeepsItsWalkingSpeed) {
  const double dt = 1.0 / 120;
  LocomotionState state;
  LocomotionInput in = two_driven_feet(dt);
  float fastest_mps = 0;
  for (int k = 0; k < int(4.0 / dt); ++k) {
    const double t = k * dt;
    const float z = static_cast<float>(1.2 * t);
    in.root = {0.0f, 0.82f, z};
    in.hip = {glm::vec3(0.11f, 0.80f, z), glm::vec3(-0.11f, 0.80f, z)};
    in.head = {0.0f, 1.60f, z + 0.05f};
    in.have_head = t < 2.0 || t >= 2.5;
    update_locomotion(state, in, LocomotionOptions{});
    if (t >= 2.5) fastest_mps = std::max(fastest_mps, glm::length(state.path_mps));
  }
  std::printf("  the head's path speed after a 0.5 s dropout: at most %.2f m/s (walking 1.2)\n", double(fastest_mps));
  EXPECT_LT(fastest_mps, 1.3f);
  EXPECT_GT(fastest_mps, 1.1f);
}

// Squatting deep (the head comes down upright: the hips follow it), the knee's and ankle's limits
// pitch a stepped foot toes-down: its heel lifts rather than the ball or toes going through the
// floor.
TEST(Locomotion, SquattingFeetStayAboveTheFloor) {
  Wearer w("3");
  for (int k = 0; k < 30; ++k) w.step(standing(w, {0, 0, 0}, 0.0f));
  const float sole_y = w.sole_y();
  float lowest_m = 1e9f, lowest_root_m = 1e9f;
  for (int k = 0; k < int(3 * kRateHz); ++k) {
    // Down by 45 cm over 1.5 s, then held (only head and hands are seen: the legs are the solver's).
    Pose truth = standing(w, {0, 0, 0}, 0.0f);
    truth.root_position_m.y -= 0.45f * std::min(1.0f, static_cast<float>(k / (1.5 * kRateHz)));
    w.step(truth);
    lowest_m = std::min(lowest_m, w.lowest_foot_point_y());
    lowest_root_m = std::min(lowest_root_m, w.solved.root_position_m.y);
  }
  std::printf("  squat: hips down to %.0f cm, lowest foot point %.1f mm above the sole's floor\n", 100 * lowest_root_m,
              1000 * (lowest_m - sole_y));
  EXPECT_LT(lowest_root_m, w.standing_root_y - 0.3f);  // it did squat
  // (Without the lift: 5 cm under. A ball lifts once it is 3 mm under a flat foot's.)
  EXPECT_GE(lowest_m, sole_y - 0.005f);
}

// Walking, the feet land nearer the midline than the hips (people walk on a narrow track; the
// walk above checks that they never cross).
TEST(Locomotion, WalkingFeetLandNearerTheMidlineThanTheHips) {
  Wearer w("3");
  auto walk = rig::make_builtin_motion("walk", w.s);
  ASSERT_TRUE(walk.has_value());
  Pose truth = w.s.zero_pose();
  const float hip_width_m = glm::length(w.s.offset_m(w.s.find_joint("l_hip")) - w.s.offset_m(w.s.find_joint("r_hip")));
  double width_sum_m = 0, truth_sum_m = 0;
  int n = 0;
  for (int k = 0; k < int(6 * kRateHz); ++k) {
    (*walk)->sample(k / kRateHz, truth);
    w.step(truth);
    const auto& feet = w.ctx.locomotion().feet;
    if (k < 2 * kRateHz || feet[0].swinging || feet[1].swinging) continue;
    // Across the line of progression (the truth's over half a stride either side): the pelvis
    // turns with the leading leg, and across its own heading feet a step apart would read wider.
    Pose ahead = truth, behind = truth;
    (*walk)->sample(k / kRateHz + 0.55, ahead);
    (*walk)->sample(k / kRateHz - 0.55, behind);
    const glm::vec3 path = ahead.root_position_m - behind.root_position_m;
    const glm::vec3 left_dir = glm::normalize(glm::vec3(path.z, 0, -path.x));
    width_sum_m += glm::dot(w.ankle(0) - w.ankle(1), left_dir);
    {
      std::vector<RigidTransform> tw(w.s.joint_count());
      rig::forward_kinematics(w.s, truth, tw);
      truth_sum_m +=
          glm::dot(tw[w.s.find_joint("l_ankle")].translation - tw[w.s.find_joint("r_ankle")].translation, left_dir);
    }
    ++n;
  }
  ASSERT_GT(n, 30);
  const double width_m = width_sum_m / n;
  std::printf("  walk: planted feet %.1f cm apart side to side (hips %.1f cm, truth %.1f)\n", 100 * width_m,
              100 * hip_width_m, 100 * truth_sum_m / n);
  // Nearer the midline than the hips, and about as far apart as the walker's own feet.
  EXPECT_LT(width_m, hip_width_m);
  EXPECT_NEAR(width_m, truth_sum_m / n, 0.03);
  EXPECT_GT(width_m, 0.05);
}

// Six sensors, the left foot's sensor lost while walking: the stepper takes the foot over from
// where it was; it steps, and stays on or above the floor (within 5 mm: the hip's and ankle's
// limits may keep the chain a few millimetres off a planted target).
TEST(Locomotion, AFootWhoseSensorIsLostSteps) {
  Wearer w("6");
  auto walk = rig::make_builtin_motion("walk", w.s);
  ASSERT_TRUE(walk.has_value());
  uint16_t l_foot = 0;
  const auto layout = standard_layout("6", w.s);
  ASSERT_TRUE(layout.has_value());
  for (const auto& b : layout->bindings)
    if (b.name == "l_foot") l_foot = b.sensor;
  Pose truth = w.s.zero_pose();
  const float floor_y = w.floor_ankle_y();
  for (int k = 0; k < int(5 * kRateHz); ++k) {
    (*walk)->sample(k / kRateHz, truth);
    const bool lost = k > kRateHz;
    if (lost)
      w.step(truth, {l_foot});
    else
      w.step(truth);
    EXPECT_EQ(w.ctx.locomotion().feet[0].driven, lost);
    EXPECT_FALSE(w.ctx.locomotion().feet[1].driven);
    EXPECT_GE(w.ankle(0).y, floor_y - 0.005f);
  }
  EXPECT_GE(w.ctx.locomotion().steps, 3);
}

}  // namespace
}  // namespace mimic::solver::locomotion_test
