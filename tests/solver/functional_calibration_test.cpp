// Functional calibration: limb lengths and joint centres found from motion, on a wearer whose
// true skeleton differs from what the stand-still calibration assumed.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mimic/solver/joint_centres.h"
#include "mimic/solver/limb_refinement.h"
#include "mimic/solver/model_refiner.h"
#include "synthetic_sensors.h"

namespace mimic::solver::functional_calibration_test {
namespace {

using rig::Pose;
using rig::Skeleton;

// The default skeleton with its limbs re-proportioned: long thighs and forearms, short shins and
// upper arms, the way no stand-still can tell.
Skeleton wearer_skeleton() {
  auto desc = rig::default_skeleton_desc();
  for (auto& j : desc.joints) {
    const float k = j.name == "l_knee" || j.name == "r_knee"     ? 1.12f
                    : j.name == "l_ankle" || j.name == "r_ankle" ? 0.88f
                    : j.name == "l_elbow" || j.name == "r_elbow" ? 0.90f
                    : j.name == "l_wrist" || j.name == "r_wrist" ? 1.12f
                                                                 : 1.0f;
    j.offset_m *= k;
  }
  return *Skeleton::build(desc);
}

// Moving about: every DOF swept within 60 % of its range around relaxed.
std::vector<Pose> moving(const Skeleton& s, int n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<Pose> out;
  for (int i = 0; i < n; ++i) out.push_back(testing::random_pose(s, rng, 0.6f));
  return out;
}

float length_of(const Skeleton& s, const char* joint) { return glm::length(s.offset_m(s.find_joint(joint))); }

TEST(LimbRefinement, FindsTheElbowAndKneeTheStandStillCouldNotSee) {
  const Skeleton truth = wearer_skeleton();
  const auto layout = *standard_layout("11", truth);
  const auto mounts = testing::mounts_for(layout, glm::radians(20.0f), 3);
  // The model the stand-still gave: right hands and feet, default split of each limb.
  auto model = *SolverModel::create(*Skeleton::build(rig::default_skeleton_desc()), mounts);
  LimbLengthEstimator est(model);
  EXPECT_EQ(est.observable_count(), 4);
  std::mt19937_64 noise(9);
  std::vector<devices::SensorSample> tick;
  for (const Pose& p : moving(truth, 600, 5)) {
    testing::sense(truth, p, mounts, tick, &noise, 0.001f, glm::radians(0.5f));
    est.add(tick, model);
  }
  const char* mids[4] = {"l_elbow", "r_elbow", "l_knee", "r_knee"};
  const char* ends[4] = {"l_wrist", "r_wrist", "l_ankle", "r_ankle"};
  for (int c = 0; c < 4; ++c) {
    const LimbFit f = est.fit(c, model);
    ASSERT_TRUE(f.valid) << c << " spread " << f.arc_spread_m << " off-plane " << f.off_plane_m;
    EXPECT_NEAR(f.upper_m, length_of(truth, mids[c]), 0.005f) << mids[c];
    EXPECT_NEAR(f.lower_m, length_of(truth, ends[c]), 0.005f) << ends[c];
  }
  EXPECT_EQ(est.refine(model), 4);
  for (int c = 0; c < 4; ++c) {
    EXPECT_NEAR(length_of(model.skeleton(), mids[c]), length_of(truth, mids[c]), 0.005f);
    EXPECT_NEAR(length_of(model.skeleton(), ends[c]), length_of(truth, ends[c]), 0.005f);
  }
}

TEST(LimbRefinement, KeepsTheCalibrationWhenTheLimbsNeverBend) {
  const Skeleton truth = wearer_skeleton();
  const auto layout = *standard_layout("11", truth);
  const auto mounts = testing::mounts_for(layout, 0.0f, 3);
  auto model = *SolverModel::create(*Skeleton::build(rig::default_skeleton_desc()), mounts);
  const float before = length_of(model.skeleton(), "l_knee");
  LimbLengthEstimator est(model);
  std::mt19937_64 noise(1);
  std::vector<devices::SensorSample> tick;
  Pose p = truth.zero_pose();
  for (int i = 0; i < 500; ++i) {  // walking about with straight limbs: the arc never opens
    p.root_position_m = {0.002f * static_cast<float>(i), 0.95f, 0.0f};
    testing::sense(truth, p, mounts, tick, &noise, 0.001f, glm::radians(0.5f));
    est.add(tick, model);
  }
  for (int c = 0; c < 4; ++c) EXPECT_FALSE(est.fit(c, model).valid) << c;
  EXPECT_EQ(est.refine(model), 0);
  EXPECT_EQ(length_of(model.skeleton(), "l_knee"), before);
}

TEST(LimbRefinement, IgnoresInvalidAndNonFiniteSamples) {
  const Skeleton truth = wearer_skeleton();
  const auto mounts = testing::mounts_for(*standard_layout("11", truth), 0.0f, 3);
  auto model = *SolverModel::create(truth, mounts);
  LimbLengthEstimator est(model);
  std::vector<devices::SensorSample> tick;
  testing::sense(truth, truth.zero_pose(), mounts, tick);
  for (auto& s : tick) s.position_m.x = std::nanf("");
  for (int i = 0; i < 100; ++i) est.add(tick, model);
  for (auto& s : tick) s.flags = 0;
  for (int i = 0; i < 100; ++i) est.add(tick, model);
  for (int c = 0; c < 4; ++c) EXPECT_EQ(est.fit(c, model).samples, 0);
  EXPECT_EQ(est.refine(model), 0);
}

// One sensor per segment: every joint centre is seen from both sides.
TEST(JointCentres, RecoverEveryJointFromOneSensorPerSegment) {
  const Skeleton truth = wearer_skeleton();
  const auto layout = *standard_layout("all", truth);
  const auto mounts = testing::mounts_for(layout, glm::radians(20.0f), 4);
  // A calibration that put every joint somewhere else: the default skeleton, mounts 3 cm off.
  Calibration cal;
  cal.skeleton = rig::default_skeleton_desc();
  for (const auto& m : mounts) {
    SensorCalibration sc{m.sensor, m.segment, m.segment, m.segment_from_sensor};
    sc.segment_from_sensor.translation += glm::vec3(0.03f, -0.02f, 0.01f);
    cal.sensors.push_back(sc);
  }
  JointCentreEstimator est(cal);
  EXPECT_EQ(est.pair_count(), truth.joint_count() - 1);
  std::mt19937_64 noise(2);
  std::vector<devices::SensorSample> tick;
  const auto poses = moving(truth, 800, 6);
  for (const Pose& p : poses) {
    testing::sense(truth, p, mounts, tick, &noise, 0.001f, glm::radians(0.5f));
    est.add(tick);
  }
  // Where each joint really is, in the child sensor's frame: the inverse mount's origin.
  int checked = 0;
  for (const auto& f : est.fits()) {
    const auto& m = mounts[static_cast<size_t>(layout.bindings[static_cast<size_t>(f.joint)].sensor)];
    const glm::vec3 want = m.segment_from_sensor.inverse().translation;
    if (f.min_excitation < 0.02f) continue;  // a hinge: its axis direction stays with the prior
    EXPECT_LT(glm::length(f.in_child_sensor - want), 0.004f) << truth.joint_name(f.joint);
    EXPECT_LT(f.rms_m, 0.004f) << truth.joint_name(f.joint);
    ++checked;
  }
  EXPECT_GE(checked, 12);

  // Solving with the refined calibration: the joints land where they are.
  auto refined = est.refine(cal);
  ASSERT_TRUE(refined) << refined.error().what();
  auto model = make_solver_model(*refined);
  ASSERT_TRUE(model) << model.error().what();
  auto before = *make_solver_model(cal);
  auto mean_error = [&](const SolverModel& sm) {
    SolverContext ctx(sm);
    Pose pose = sm.skeleton().zero_pose();
    std::vector<rig::RigidTransform> wt(truth.joint_count()), ws(sm.skeleton().joint_count());
    double sum = 0;
    int n = 0;
    for (size_t i = 0; i < 200; ++i) {
      testing::sense(truth, poses[i], mounts, tick);
      for (int it = 0; it < 5; ++it) {  // converge from the previous pose
        SolveJob job{&sm, tick, &ctx, &pose};
        EXPECT_TRUE(job.Run());
      }
      rig::forward_kinematics(truth, poses[i], wt);
      rig::forward_kinematics(sm.skeleton(), pose, ws);
      for (int j = 0; j < truth.joint_count(); ++j) sum += glm::length(wt[j].translation - ws[j].translation), ++n;
    }
    return sum / n;
  };
  const double e_before = mean_error(before), e_after = mean_error(*model);
  EXPECT_LT(e_after, 0.5 * e_before) << "before " << e_before << " after " << e_after;
  EXPECT_LT(e_after, 0.015);
}

TEST(JointCentres, WithoutNeighbouringSensorsThereIsNothingToRefine) {
  const Skeleton s = *Skeleton::build(rig::default_skeleton_desc());
  for (const char* name : {"3", "6"}) {
    Calibration cal;
    cal.skeleton = rig::default_skeleton_desc();
    for (const auto& m : testing::mounts_for(*standard_layout(name, s), 0.0f, 1))
      cal.sensors.push_back({m.sensor, m.segment, m.segment, m.segment_from_sensor});
    JointCentreEstimator est(cal);
    EXPECT_EQ(est.pair_count(), 0) << name;
    int changed = -1;
    auto same = est.refine(cal, &changed);
    ASSERT_TRUE(same);
    EXPECT_EQ(changed, 0);
  }
}

TEST(ModelRefiner, RebuildsOnScheduleAndKeepsSolving) {
  const Skeleton truth = wearer_skeleton();
  const auto layout = *standard_layout("all", truth);
  const auto mounts = testing::mounts_for(layout, glm::radians(10.0f), 8);
  Calibration cal;
  cal.skeleton = rig::default_skeleton_desc();
  for (const auto& m : mounts) cal.sensors.push_back({m.sensor, m.segment, m.segment, m.segment_from_sensor});
  auto model = std::make_unique<SolverModel>(*make_solver_model(cal));
  ModelRefiner refiner(cal, *model, 100.0);
  std::mt19937_64 noise(3);
  std::vector<devices::SensorSample> tick;
  int rebuilds = 0, due = 0;
  const auto poses = moving(truth, 450, 7);
  for (size_t i = 0; i < poses.size(); ++i) {
    testing::sense(truth, poses[i], mounts, tick, &noise, 0.001f, glm::radians(0.5f));
    if (refiner.add(tick, *model)) {
      ++due;
      auto next = refiner.rebuild();
      if (next) model = std::move(*next), ++rebuilds;
    }
  }
  EXPECT_EQ(due, 3);       // after 1, 2 and 4 s at 100 Hz
  EXPECT_EQ(rebuilds, 2);  // the first had too few samples per joint (min 120)
  EXPECT_EQ(refiner.refined_joints(), truth.joint_count() - 1);
}

// What the motion showed, written into a calibration that can be saved: the limb lengths of a
// layout-11 wearer end up in the calibration's skeleton.
TEST(ModelRefiner, RefinedCalibrationCarriesTheLimbLengths) {
  const Skeleton truth = wearer_skeleton();
  const auto mounts = testing::mounts_for(*standard_layout("11", truth), glm::radians(10.0f), 4);
  Calibration cal;
  cal.skeleton = rig::default_skeleton_desc();
  for (const auto& m : mounts) cal.sensors.push_back({m.sensor, m.segment, m.segment, m.segment_from_sensor});
  auto model = *make_solver_model(cal);
  ModelRefiner refiner(cal, model, 100.0);
  std::mt19937_64 noise(5);
  std::vector<devices::SensorSample> tick;
  for (const Pose& p : moving(truth, 500, 9)) {
    testing::sense(truth, p, mounts, tick, &noise, 0.001f, glm::radians(0.5f));
    refiner.add(tick, model);
  }
  int joints = -1, limbs = -1;
  auto refined = refiner.refined_calibration(&joints, &limbs);
  ASSERT_TRUE(refined) << refined.error().what();
  EXPECT_EQ(limbs, 4);
  EXPECT_EQ(joints, 2);  // the hips: pelvis and thighs are neighbours
  const Skeleton fitted = *Skeleton::build(refined->skeleton);
  for (const char* j : {"l_knee", "r_knee", "l_ankle", "r_ankle", "l_elbow", "r_elbow", "l_wrist", "r_wrist"})
    EXPECT_NEAR(length_of(fitted, j), length_of(truth, j), 0.006f) << j;
  // And it round-trips through the file format.
  auto back = calibration_from_json(calibration_to_json(*refined));
  ASSERT_TRUE(back) << back.error().what();
  EXPECT_NEAR(length_of(*Skeleton::build(back->skeleton), "l_knee"), length_of(truth, "l_knee"), 0.006f);
}

}  // namespace
}  // namespace mimic::solver::functional_calibration_test
