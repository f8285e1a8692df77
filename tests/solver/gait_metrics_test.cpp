// The gait figures of `mimic eval-solver` on poses whose answer is known.
#include "mimic/solver/gait_metrics.h"

#include <gtest/gtest.h>

#include <vector>

namespace mimic::solver::gait_metrics_test {
namespace {

using rig::Pose;
using rig::RigidTransform;
using rig::Skeleton;

// A body standing still, solved as the truth except for one frame where the solved body (and
// so both its ankles) is 20 cm to the side and 3 cm lower: the foot jumps there and back, and
// sinks 3 cm under the floor the truth's feet stand on.
TEST(GaitMetrics, AJumpingFootAndOneUnderTheFloorAreMeasured) {
  const Skeleton s = *Skeleton::build(rig::default_skeleton_desc());
  GaitAccumulator gait(s, s, 120.0);
  std::vector<RigidTransform> truth(s.joint_count()), solved(s.joint_count());
  Pose p = s.zero_pose();
  p.root_position_m = {0, rig::standing_root_height_m(s), 0};
  forward_kinematics(s, p, truth);
  for (int k = 0; k < 60; ++k) {
    Pose q = p;
    if (k == 30) q.root_position_m += glm::vec3(0.2f, -0.03f, 0);
    forward_kinematics(s, q, solved);
    gait.add(truth, solved);
  }
  const GaitReport r = gait.report();
  EXPECT_NEAR(r.largest_ankle_move_mm, 1000.0 * glm::length(glm::vec2(0.2f, 0.03f)), 0.5);
  EXPECT_NEAR(r.largest_ankle_move_truth_mm, 0.0, 1e-6);
  EXPECT_NEAR(r.floor_penetration_mm, 30.0, 0.5);
  EXPECT_EQ(r.steps_truth, 0);
  EXPECT_NEAR(r.lower_body_mpjpe_cm, 100.0 * glm::length(glm::vec2(0.2f, 0.03f)) / 60.0, 0.05);
}

}  // namespace
}  // namespace mimic::solver::gait_metrics_test
