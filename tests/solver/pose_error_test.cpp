#include "mimic/solver/pose_error.h"

#include <gtest/gtest.h>

#include <cmath>

namespace mimic::solver::pose_error_test {
namespace {

using rig::Pose;
using rig::RigidTransform;
using rig::Skeleton;

TEST(PoseError, IdenticalPosesHaveNoErrorAndToesAreLeftOut) {
  const Skeleton s = *Skeleton::build(rig::default_skeleton_desc());
  PoseErrorAccumulator acc(s, s);
  std::vector<RigidTransform> w(s.joint_count());
  Pose p = s.zero_pose();
  for (int k = 0; k < 10; ++k) {
    p.root_position_m = {0.01f * static_cast<float>(k), 0.9f, 0};  // constant velocity: no jitter
    forward_kinematics(s, p, w);
    acc.add(w, w, 10.0 + k);
  }
  const auto r = acc.report();
  EXPECT_EQ(r.frames, 10);
  EXPECT_EQ(r.joints, s.joint_count() - 2);
  for (const auto& n : r.joint_names) EXPECT_EQ(n.find("toes"), std::string::npos);
  EXPECT_NEAR(r.mpjpe_cm, 0.0, 1e-9);
  EXPECT_NEAR(r.mpjre_deg, 0.0, 1e-3);
  EXPECT_NEAR(r.jitter_mm, 0.0, 1e-3);
  EXPECT_NEAR(r.solve_us_p50, 14.0, 1.0);
  EXPECT_EQ(r.solve_us_max, 19.0);
}

TEST(PoseError, ShiftedAndTurnedBodyMeasuresTheShiftAndTheTurn) {
  const Skeleton s = *Skeleton::build(rig::default_skeleton_desc());
  PoseErrorAccumulator acc(s, s);
  std::vector<RigidTransform> wt(s.joint_count()), ws(s.joint_count());
  Pose truth = s.zero_pose();
  forward_kinematics(s, truth, wt);
  Pose solved = truth;
  solved.root_position_m += glm::vec3(0.02f, 0, 0);  // 2 cm to the left
  forward_kinematics(s, solved, ws);
  acc.add(wt, ws);
  auto r = acc.report();
  EXPECT_NEAR(r.mpjpe_cm, 2.0, 1e-4);
  EXPECT_NEAR(r.end_effector_mm, 20.0, 1e-3);
  EXPECT_NEAR(r.mpjre_deg, 0.0, 1e-3);
  PoseErrorAccumulator turned(s, s);
  solved = truth;
  solved.root_orientation = glm::angleAxis(glm::radians(10.0f), glm::vec3(0, 1, 0));
  forward_kinematics(s, solved, ws);
  turned.add(wt, ws);
  EXPECT_NEAR(turned.report().mpjre_deg, 10.0, 1e-2);
}

TEST(PoseError, JitterIsTheSecondDifference) {
  const Skeleton s = *Skeleton::build(rig::default_skeleton_desc());
  PoseErrorAccumulator acc(s, s);
  std::vector<RigidTransform> wt(s.joint_count()), ws(s.joint_count());
  Pose p = s.zero_pose();
  forward_kinematics(s, p, wt);
  for (int k = 0; k < 3; ++k) {
    Pose q = p;
    q.root_position_m.y += k == 1 ? 0.001f : 0.0f;  // one 1 mm spike
    forward_kinematics(s, q, ws);
    acc.add(wt, ws);
  }
  EXPECT_NEAR(acc.report().jitter_mm, 2.0, 1e-3);  // |0 - 2·1 + 0| mm
  EXPECT_NEAR(acc.report().jitter_truth_mm, 0.0, 1e-6);
}

// A solved body that follows the truth two samples late measures a lag of two samples, and one
// on time measures none.
TEST(PoseError, LagIsTheDelayBehindTheTruth) {
  const Skeleton s = *Skeleton::build(rig::default_skeleton_desc());
  constexpr double kRate = 100.0;
  for (const int delay : {0, 2}) {
    PoseErrorAccumulator acc(s, s);
    acc.set_rate_hz(kRate);
    std::vector<RigidTransform> wt(s.joint_count()), ws(s.joint_count());
    Pose truth = s.zero_pose(), solved = s.zero_pose();
    auto at = [](int k) {
      return glm::vec3(0.3f * std::sin(0.05f * static_cast<float>(k)), 0.9f, 0.01f * static_cast<float>(k));
    };
    for (int k = 0; k < 200; ++k) {
      truth.root_position_m = at(k);
      solved.root_position_m = at(k - delay);
      forward_kinematics(s, truth, wt);
      forward_kinematics(s, solved, ws);
      acc.add(wt, ws);
    }
    EXPECT_NEAR(acc.report().lag_ms, 1000.0 * delay / kRate, 1.0) << "delay " << delay;
  }
}

}  // namespace
}  // namespace mimic::solver::pose_error_test
