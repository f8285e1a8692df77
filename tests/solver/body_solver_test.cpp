#include "mimic/solver/body_solver.h"

#include <gtest/gtest.h>

#include <cstdio>

#include <cmath>
#include <random>

#include "synthetic_sensors.h"

namespace mimic::solver::body_solver_test {
namespace {

using rig::Pose;
using rig::RigidTransform;
using rig::Skeleton;

Skeleton default_skeleton() { return *Skeleton::build(rig::default_skeleton_desc()); }

struct Fixture {
  Skeleton skeleton = default_skeleton();
  std::vector<SensorMount> mounts;
  SolverModel model;
  explicit Fixture(const char* layout, float tilt_rad = 0.4f)
      : mounts(testing::mounts_for(*standard_layout(layout, skeleton), tilt_rad, 5)),
        model(*SolverModel::create(skeleton, mounts)) {}
};

std::vector<RigidTransform> fk(const Skeleton& s, const Pose& p) {
  std::vector<RigidTransform> w(s.joint_count());
  forward_kinematics(s, p, w);
  return w;
}

void expect_inside_limits(const Skeleton& s, const Pose& p) {
  for (int d = 0; d < s.dof_count(); ++d) {
    ASSERT_TRUE(std::isfinite(p.dof_rad[d])) << s.dof(d).name;
    EXPECT_GE(p.dof_rad[d], s.dof(d).min_rad - 1e-5f) << s.dof(d).name;
    EXPECT_LE(p.dof_rad[d], s.dof(d).max_rad + 1e-5f) << s.dof(d).name;
  }
}

// One sensor per segment: FK(IK(sensors)) puts every joint where it was (within 4 mm: a nearly
// straight elbow's bend is ill-conditioned in the positions, so a tenth of a millimetre at the
// shoulder moves the elbow by a few).
TEST(BodySolver, OneSensorPerSegmentRecoversEveryJoint) {
  Fixture f("all");
  SolverContext ctx(f.model);
  std::mt19937_64 rng(1);
  std::vector<devices::SensorSample> samples;
  for (int trial = 0; trial < 100; ++trial) {
    const Pose truth = testing::random_pose(f.skeleton, rng, 0.6f);
    testing::sense(f.skeleton, truth, f.mounts, samples);
    Pose solved = f.skeleton.zero_pose();
    ctx.reset();
    for (int frame = 0; frame < 3; ++frame) {  // a still body for a few frames: warm starts settle
      SolveJob job{&f.model, samples, &ctx, &solved};
      ASSERT_TRUE(job.Run());
      EXPECT_EQ(job.sensors_used, static_cast<int>(f.mounts.size()));
    }
    const auto wt = fk(f.skeleton, truth), ws = fk(f.skeleton, solved);
    for (int j = 0; j < f.skeleton.joint_count(); ++j)
      EXPECT_LT(glm::length(wt[j].translation - ws[j].translation), 4e-3f)
          << f.skeleton.joint_name(j) << " trial " << trial;
    expect_inside_limits(f.skeleton, solved);
  }
}

// Six sensors: hands, feet and head land on their targets (within a few millimetres: the trunk is
// a least-squares fit pulled gently towards the relaxed posture); the pelvis is exact.
//
// Two claims, asserted separately. Once the solver has settled on a still body, every effector
// is on target, for every pose. How fast it settles from the zero pose varies with the pose:
// most need a few frames, a few need more, and for those the error after a fixed 10 frames is
// chaotic in rounding (3.2 to 4.6 mm on one pose here when the start moves by 1e-7..1e-5 rad; 13.7
// mm on another in a sanitizer build, whose instrumentation changes inlining and so floating-
// point contraction). So the 10-frame figure is asserted as a share of poses, not pose by pose.
TEST(BodySolver, SixSensorsReachTheEndEffectors) {
  Fixture f("6");
  SolverContext ctx(f.model);
  std::mt19937_64 rng(2);
  std::vector<devices::SensorSample> samples;
  const char* effectors[] = {"head", "l_wrist", "r_wrist", "l_ankle", "r_ankle", "pelvis"};
  int orientation_checks = 0, orientation_exact = 0, fast = 0;
  constexpr int kTrials = 100;
  auto worst_error = [&](const Pose& truth, const Pose& solved) {
    const auto wt = fk(f.skeleton, truth), ws = fk(f.skeleton, solved);
    float worst = 0;
    for (const char* e : effectors) {
      const int j = f.skeleton.find_joint(e);
      worst = std::max(worst, glm::length(wt[j].translation - ws[j].translation));
    }
    return worst;
  };
  for (int trial = 0; trial < kTrials; ++trial) {
    const Pose truth = testing::random_pose(f.skeleton, rng, 0.6f);
    testing::sense(f.skeleton, truth, f.mounts, samples);
    Pose solved = f.skeleton.zero_pose();
    ctx.reset();
    int frame = 0;
    for (; frame < 10; ++frame) {  // a still body for a moment: warm starts settle
      SolveJob job{&f.model, samples, &ctx, &solved};
      ASSERT_TRUE(job.Run());
    }
    fast += worst_error(truth, solved) < 5e-3f ? 1 : 0;
    // Then until it has settled (the pose no longer moves), at most 200 frames.
    for (; frame < 200; ++frame) {
      const Pose before = solved;
      SolveJob job{&f.model, samples, &ctx, &solved};
      ASSERT_TRUE(job.Run());
      float moved = glm::length(solved.root_position_m - before.root_position_m);
      for (size_t k = 0; k < solved.dof_rad.size(); ++k)
        moved = std::max(moved, std::abs(solved.dof_rad[k] - before.dof_rad[k]));
      if (moved < 1e-6f) break;
    }
    const auto wt = fk(f.skeleton, truth), ws = fk(f.skeleton, solved);
    for (const char* e : effectors) {
      const int j = f.skeleton.find_joint(e);
      EXPECT_LT(glm::length(wt[j].translation - ws[j].translation), 5e-3f)
          << e << " trial " << trial << " settled after " << frame << " frames";
      // The hand's orientation can need a twist the limits refuse under the solved (not the
      // true) clavicle and spine, which six sensors cannot see; mostly it is exact.
      const float dot = std::abs(glm::dot(wt[j].rotation, ws[j].rotation));
      EXPECT_GT(dot, std::cos(glm::radians(15.0f))) << e;  // half-angle of 30°
      orientation_checks += 1;
      orientation_exact += dot > std::cos(glm::radians(0.5f)) ? 1 : 0;
    }
    expect_inside_limits(f.skeleton, solved);
  }
  EXPECT_GT(orientation_exact, 0.9 * orientation_checks);
  // From the zero pose, 10 frames put every effector within 5 mm for nearly every pose.
  EXPECT_GE(fast, kTrials * 95 / 100);
}

// Three sensors: the root is estimated; hands and head still land on their targets.
TEST(BodySolver, ThreeSensorsEstimateTheRootAndReachHandsAndHead) {
  Fixture f("3");
  SolverContext ctx(f.model);
  std::mt19937_64 rng(3);
  std::vector<devices::SensorSample> samples;
  for (int trial = 0; trial < 50; ++trial) {
    Pose truth = testing::random_pose(f.skeleton, rng, 0.3f);
    testing::sense(f.skeleton, truth, f.mounts, samples);
    Pose solved = f.skeleton.zero_pose();
    ctx.reset();
    for (int frame = 0; frame < 10; ++frame) {  // a few frames of a still body settle the root
      SolveJob job{&f.model, samples, &ctx, &solved};
      ASSERT_TRUE(job.Run());
    }
    const auto wt = fk(f.skeleton, truth), ws = fk(f.skeleton, solved);
    for (const char* e : {"head", "l_wrist", "r_wrist"}) {
      const int j = f.skeleton.find_joint(e);
      EXPECT_LT(glm::length(wt[j].translation - ws[j].translation), 5e-3f) << e << " trial " << trial;
    }
    // Three sensors cannot see the pelvis; it only has to stay under the head, near the body.
    EXPECT_LT(glm::length(wt[0].translation - ws[0].translation), 0.6f) << "pelvis, trial " << trial;
    EXPECT_LT(ws[0].translation.y, ws[f.skeleton.find_joint("head")].translation.y - 0.2f);
    expect_inside_limits(f.skeleton, solved);
  }
}

// Head and hands only (layout 3, straps square), the wearer's standing root height known.
struct HeadAndHands {
  Skeleton s = default_skeleton();
  std::vector<SensorMount> mounts = testing::mounts_for(*standard_layout("3", s), 0.0f, 5);
  float standing_root_y = rig::standing_root_height_m(s);
  SolverModel model = make_model();
  SolverContext ctx{model};

  SolverModel make_model() const {
    SolverOptions options;
    options.standing_root_y_m = standing_root_y;
    return *SolverModel::create(s, mounts, options);
  }
};

// Head and hands only, standing still: the feet are planted under the hips with soft knees, on
// the floor, facing the heading — and a wearer who crouches bends the knees instead of sinking
// the feet through the floor.
TEST(BodySolver, LegsNobodyTracksHangUnderTheHipsAboveTheFloor) {
  HeadAndHands h;
  const Skeleton& s = h.s;
  const auto& mounts = h.mounts;
  const float standing_root_y = h.standing_root_y;
  auto& model = h.model;
  auto& ctx = h.ctx;
  const float floor_ankle_y = standing_root_y - (fk(s, s.zero_pose())[0].translation.y -
                                                 fk(s, s.zero_pose())[s.find_joint("l_ankle")].translation.y);
  for (const float drop_m : {0.0f, 0.25f}) {
    Pose truth = s.zero_pose();
    truth.root_orientation = glm::angleAxis(0.7f, glm::vec3(0, 1, 0));
    truth.root_position_m = {0.3f, standing_root_y - drop_m, -0.4f};
    std::vector<devices::SensorSample> samples;
    testing::sense(s, truth, mounts, samples);
    Pose solved = s.zero_pose();
    ctx.reset();
    for (int frame = 0; frame < 20; ++frame) {
      SolveJob job{&model, samples, &ctx, &solved};
      ASSERT_TRUE(job.Run());
    }
    const auto ws = fk(s, solved);
    for (const char* side : {"l_", "r_"}) {
      const glm::vec3 hip = ws[s.find_joint(std::string(side) + "hip")].translation;
      const glm::vec3 ankle = ws[s.find_joint(std::string(side) + "ankle")].translation;
      EXPECT_LT(glm::length(glm::vec2(ankle.x - hip.x, ankle.z - hip.z)), 0.06f) << side << " drop " << drop_m;
      EXPECT_GT(ankle.y, floor_ankle_y - 0.01f) << side << " drop " << drop_m;
      EXPECT_GT(solved.dof_rad[s.find_dof(std::string(side) + "knee_flexion")], glm::radians(5.0f)) << side;
      if (drop_m > 0) {  // crouching: the knees bend well beyond the soft stance
        EXPECT_GT(solved.dof_rad[s.find_dof(std::string(side) + "knee_flexion")], glm::radians(30.0f)) << side;
      }
    }
    expect_inside_limits(s, solved);
  }
}

// Three sensors and a deep squat (trunk upright, hips 40 cm down): the hips go down with the
// head rather than staying at standing height under a trunk folded to reach it.
TEST(BodySolver, UprightHeadComingDownIsASquatNotAFold) {
  HeadAndHands h;
  const Skeleton& s = h.s;
  const auto& mounts = h.mounts;
  const float standing_root_y = h.standing_root_y;
  auto& model = h.model;
  auto& ctx = h.ctx;
  Pose solved = s.zero_pose();
  Pose truth = s.zero_pose();
  std::vector<devices::SensorSample> samples;
  // Standing, then going down over half a second (90 Hz), then holding the squat.
  for (int frame = 0; frame < 120; ++frame) {
    const float down = std::clamp(static_cast<float>(frame - 20) / 45.0f, 0.0f, 1.0f);
    truth.root_position_m = {0.0f, standing_root_y - 0.40f * down, 0.0f};
    testing::sense(s, truth, mounts, samples);
    SolveJob job{&model, samples, &ctx, &solved};
    ASSERT_TRUE(job.Run());
  }
  const auto ws = fk(s, solved), wt = fk(s, truth);
  const int pelvis = s.find_joint("pelvis");
  std::printf("  squat: solved pelvis %.3f m, true %.3f m\n", ws[pelvis].translation.y, wt[pelvis].translation.y);
  EXPECT_LT(std::abs(ws[pelvis].translation.y - wt[pelvis].translation.y), 0.08f);
  // The trunk stays nearly upright (the last 10 cm of the drop are taken as a lean: a head that
  // low could be a bow); folded, it leaned 45°.
  const glm::vec3 trunk = ws[s.find_joint("spine_upper")].translation - ws[pelvis].translation;
  EXPECT_GT(glm::normalize(trunk).y, std::cos(glm::radians(25.0f)));
  for (const char* side : {"l_", "r_"})
    EXPECT_GT(solved.dof_rad[s.find_dof(std::string(side) + "knee_flexion")], glm::radians(60.0f)) << side;
  expect_inside_limits(s, solved);
}

// A hand sensor far out of reach: the arm points at it, fully stretched; nothing is NaN.
TEST(BodySolver, UnreachableHandEndsAtTheNearestReach) {
  Fixture f("6", 0.0f);
  SolverContext ctx(f.model);
  std::vector<devices::SensorSample> samples;
  const Pose truth = f.skeleton.zero_pose();
  testing::sense(f.skeleton, truth, f.mounts, samples);
  const glm::vec3 far(3.0f, 2.0f, 1.0f);
  samples[1].position_m = far;  // l_hand
  Pose solved = truth;
  SolveJob job{&f.model, samples, &ctx, &solved};
  ASSERT_TRUE(job.Run());
  expect_inside_limits(f.skeleton, solved);
  const auto w = fk(f.skeleton, solved);
  const glm::vec3 shoulder = w[f.skeleton.find_joint("l_shoulder")].translation;
  const glm::vec3 wrist = w[f.skeleton.find_joint("l_wrist")].translation;
  const glm::vec3 elbow = w[f.skeleton.find_joint("l_elbow")].translation;
  const glm::vec3 hand_target = far - f.mounts[1].segment_from_sensor.translation;  // unrotated mount
  EXPECT_GT(glm::dot(glm::normalize(wrist - shoulder), glm::normalize(hand_target - shoulder)), 0.995f);
  EXPECT_NEAR(glm::length(wrist - shoulder), glm::length(elbow - shoulder) + glm::length(wrist - elbow), 1e-3f);
}

// Garbage samples (NaN, unknown ids, invalid flag) are ignored, not propagated.
TEST(BodySolver, IgnoresInvalidSamples) {
  Fixture f("6");
  SolverContext ctx(f.model);
  std::vector<devices::SensorSample> samples;
  const Pose truth = f.skeleton.zero_pose();
  testing::sense(f.skeleton, truth, f.mounts, samples);
  samples[1].position_m.x = NAN;
  samples[2].flags = devices::kSampleStale;
  samples.push_back(devices::SensorSample{.sensor = 999});
  Pose solved = f.skeleton.zero_pose();
  SolveJob job{&f.model, samples, &ctx, &solved};
  ASSERT_TRUE(job.Run());
  EXPECT_EQ(job.sensors_used, 4);
  expect_inside_limits(f.skeleton, solved);
  EXPECT_TRUE(std::isfinite(solved.root_position_m.x));
}

// A smooth motion solved frame after frame (warm-started) stays continuous: no DOF jumps.
TEST(BodySolver, WarmStartedSequenceHasNoJumps) {
  Fixture f("6");
  SolverContext ctx(f.model);
  std::mt19937_64 rng(9);
  const Pose a = testing::random_pose(f.skeleton, rng, 0.5f);
  Pose b = testing::random_pose(f.skeleton, rng, 0.5f);
  b.root_position_m = a.root_position_m;
  b.root_orientation = a.root_orientation;
  std::vector<devices::SensorSample> samples;
  Pose solved = f.skeleton.zero_pose(), previous;
  for (int k = 0; k <= 200; ++k) {
    const float t = static_cast<float>(k) / 200.0f;
    Pose truth = a;
    for (int d = 0; d < f.skeleton.dof_count(); ++d) truth.dof_rad[d] = (1 - t) * a.dof_rad[d] + t * b.dof_rad[d];
    testing::sense(f.skeleton, truth, f.mounts, samples);
    previous = solved;
    SolveJob job{&f.model, samples, &ctx, &solved};
    ASSERT_TRUE(job.Run());
    if (k < 2) continue;
    const auto w0 = fk(f.skeleton, previous), w1 = fk(f.skeleton, solved);
    for (int j = 0; j < f.skeleton.joint_count(); ++j)
      EXPECT_LT(glm::length(w1[j].translation - w0[j].translation), 0.05f)
          << f.skeleton.joint_name(j) << " frame " << k;
  }
}

TEST(BodySolver, ModelRejectsBadMounts) {
  const Skeleton s = default_skeleton();
  EXPECT_FALSE(SolverModel::create(s, {SensorMount{0, "tail", {}}}));
  EXPECT_FALSE(SolverModel::create(s, {SensorMount{0, "head", {}}, SensorMount{0, "pelvis", {}}}));
  EXPECT_TRUE(SolverModel::create(s, {}));
}

}  // namespace
}  // namespace mimic::solver::body_solver_test
