#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

#include "mimic/rig/joint_angles.h"

namespace mimic::rig::joint_angles_test {
namespace {

constexpr double kPi = 3.14159265358979323846;

double misfit_deg(const glm::dquat& a, const glm::dquat& b) {
  // atan2 of the relative rotation keeps precision near zero (acos does not).
  const glm::dquat r = glm::inverse(glm::normalize(a)) * glm::normalize(b);
  return glm::degrees(2.0 * std::atan2(glm::length(glm::dvec3(r.x, r.y, r.z)), std::abs(r.w)));
}

const glm::dvec3 X{1, 0, 0}, Y{0, 1, 0}, Z{0, 0, 1};

// Every ordered choice of three distinct signed coordinate axes (48 sets).
std::vector<std::array<glm::dvec3, 3>> all_orthogonal_axis_sets() {
  std::vector<std::array<glm::dvec3, 3>> sets;
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const auto& p : perms)
    for (int signs = 0; signs < 8; ++signs) {
      std::array<glm::dvec3, 3> s;
      for (int k = 0; k < 3; ++k) {
        glm::dvec3 a(0.0);
        a[p[k]] = (signs >> k & 1) ? -1.0 : 1.0;
        s[k] = a;
      }
      sets.push_back(s);
    }
  return sets;
}

TEST(JointAngles, ThreeOrthogonalAxesAreExactForEveryAxisOrder) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  for (const auto& axes : all_orthogonal_axis_sets()) {
    for (int trial = 0; trial < 50; ++trial) {
      const double truth[3] = {u(rng), u(rng) * 0.5, u(rng)};
      const glm::dquat q = rotation_from_dofs(axes, truth);
      const double prev[3] = {0, 0, 0};
      double out[3];
      dofs_from_rotation(axes, q, prev, out);
      EXPECT_LT(misfit_deg(rotation_from_dofs(axes, out), q), 1e-6);
    }
  }
}

TEST(JointAngles, ReturnsTheValuesNearestThePrevious) {
  const std::array<glm::dvec3, 3> axes{-Y, Z, -X};  // the shoulder's order
  const double truth[3] = {0.4, -0.7, 1.1};
  const glm::dquat q = rotation_from_dofs(axes, truth);
  double out[3];
  dofs_from_rotation(axes, q, truth, out);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(out[k], truth[k], 1e-9);
  // Previous values a full turn away: the same rotation, unwrapped towards them.
  const double far[3] = {0.4 + 2 * kPi, -0.7 - 2 * kPi, 1.1 + 4 * kPi};
  dofs_from_rotation(axes, q, far, out);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(out[k], far[k], 1e-9);
  // Previous values on the other Euler branch pick that branch.
  const double other[3] = {0.4 + kPi, kPi + 0.7, 1.1 + kPi};
  dofs_from_rotation(axes, q, other, out);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(out[k], other[k], 1e-9);
}

TEST(JointAngles, ASpinningSequenceNeverFlips) {
  // A joint turning steadily about its first axis past ±180° and on for two full turns, with
  // wobble on the others: every step stays small and the angle keeps growing.
  const std::array<glm::dvec3, 3> axes{Z, Y, X};
  double prev[3] = {0, 0, 0.2};
  for (int i = 1; i <= 1440; ++i) {
    const double t = i * glm::radians(0.5);
    const double truth[3] = {t, 0.3 * std::sin(3 * t), 0.2 * std::cos(2 * t)};
    double out[3];
    dofs_from_rotation(axes, rotation_from_dofs(axes, truth), prev, out);
    for (int k = 0; k < 3; ++k) {
      ASSERT_LT(std::abs(out[k] - prev[k]), glm::radians(3.0)) << "step " << i << " axis " << k;
      EXPECT_NEAR(out[k], truth[k], 1e-7);
    }
    std::copy(out, out + 3, prev);
  }
  EXPECT_NEAR(prev[0], 4 * kPi, 1e-7);
}

TEST(JointAngles, GimbalLockKeepsTheFirstAngleAndStaysExact) {
  const std::array<glm::dvec3, 3> axes{X, Y, Z};
  const double truth[3] = {0.3, kPi / 2, 0.5};
  const glm::dquat q = rotation_from_dofs(axes, truth);
  const double prev[3] = {0.25, 1.5, 0.0};
  double out[3];
  dofs_from_rotation(axes, q, prev, out);
  EXPECT_LT(misfit_deg(rotation_from_dofs(axes, out), q), 1e-6);
  EXPECT_NEAR(out[0], 0.25, 1e-6) << "the coupled angle stays where it was";
}

TEST(JointAngles, OneAxisIsTheClosestTwist) {
  const glm::dvec3 axes[1] = {-X};
  const glm::dquat pure = glm::angleAxis(2.0, -X);
  const double prev[1] = {0};
  double out[1];
  dofs_from_rotation(axes, pure, prev, out);
  EXPECT_NEAR(out[0], 2.0, 1e-12);
  // With a swing added, the answer is the twist and beats every other angle.
  const glm::dquat q = glm::angleAxis(0.3, Z) * glm::angleAxis(1.0, -X);
  dofs_from_rotation(axes, q, prev, out);
  const double best = misfit_deg(glm::angleAxis(out[0], -X), q);
  for (double a = -kPi; a < kPi; a += 0.01) EXPECT_LE(best, misfit_deg(glm::angleAxis(a, -X), q) + 1e-9);
  // Previous a turn on: unwrapped towards it.
  const double near_turn[1] = {2 * kPi + 1.5};
  dofs_from_rotation(axes, pure, near_turn, out);
  EXPECT_NEAR(out[0], 2.0 + 2 * kPi, 1e-12);
}

TEST(JointAngles, TwoAxesAreExactWhenReachableAndBestOtherwise) {
  const std::array<glm::dvec3, 2> axes{Z, -Y};  // the clavicle's
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.2, 1.2);
  for (int trial = 0; trial < 200; ++trial) {
    const double truth[2] = {u(rng), u(rng)};
    const glm::dquat q = rotation_from_dofs(axes, truth);
    const double prev[2] = {0, 0};
    double out[2];
    dofs_from_rotation(axes, q, prev, out);
    EXPECT_LT(misfit_deg(rotation_from_dofs(axes, out), q), 1e-5);
  }
  // Unreachable target: no grid point does better than the answer.
  const glm::dquat q = glm::angleAxis(0.5, X) * glm::angleAxis(0.4, Z) * glm::angleAxis(0.3, Y);
  const double prev[2] = {0, 0};
  double out[2];
  dofs_from_rotation(axes, q, prev, out);
  const double best = misfit_deg(rotation_from_dofs(axes, out), q);
  for (double a = -kPi; a < kPi; a += 0.02)
    for (double b = -kPi; b < kPi; b += 0.02) {
      const double v[2] = {a, b};
      EXPECT_LE(best, misfit_deg(rotation_from_dofs(axes, v), q) + 1e-3);
    }
}

TEST(JointAngles, AimTurnsALinkOntoATarget) {
  const std::array<glm::dvec3, 2> axes{Z, -Y};
  const glm::dvec3 from = glm::normalize(glm::dvec3(0.148, 0, -0.04));
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(-1, 1);
  double prev[2] = {0, 0};
  for (int trial = 0; trial < 200; ++trial) {
    const glm::dvec3 to = glm::normalize(glm::dvec3(u(rng), u(rng), u(rng)));
    double out[2];
    EXPECT_TRUE(dofs_aim(axes, from, to, prev, out));
    EXPECT_LT(glm::length(rotation_from_dofs(axes, out) * from - to), 1e-9);
  }
  // One axis: exact when the target lies on the cone the link sweeps, closest otherwise.
  const glm::dvec3 one[1] = {X};
  double out1[1];
  const double p1[1] = {0};
  EXPECT_TRUE(dofs_aim(one, -Y, glm::dvec3(0, -std::cos(0.7), -std::sin(0.7)), p1, out1));
  EXPECT_NEAR(out1[0], 0.7, 1e-12);
  EXPECT_FALSE(dofs_aim(one, -Y, glm::normalize(glm::dvec3(1, -1, 0)), p1, out1));
  EXPECT_NEAR(out1[0], 0.0, 1e-12);
}

TEST(JointAngles, SolvesASkeletonJointInPlace) {
  auto s = Skeleton::build(default_skeleton_desc());
  ASSERT_TRUE(s);
  const int shoulder = s->find_joint("r_shoulder");
  Pose p = s->zero_pose();
  p.dof_rad[s->dof_begin(shoulder) + 0] = 0.5f;
  p.dof_rad[s->dof_begin(shoulder) + 1] = -1.0f;
  p.dof_rad[s->dof_begin(shoulder) + 2] = 0.8f;
  const glm::dquat target(s->local_rotation(shoulder, p.dof_rad));
  Pose q = s->zero_pose();
  q.dof_rad[0] = 0.123f;  // another joint's value stays
  solve_joint_dofs(*s, shoulder, target, q.dof_rad);
  for (int i = s->dof_begin(shoulder); i < s->dof_end(shoulder); ++i) EXPECT_NEAR(q.dof_rad[i], p.dof_rad[i], 1e-5);
  EXPECT_FLOAT_EQ(q.dof_rad[0], 0.123f);
}

TEST(JointAngles, UnwrapNear) {
  EXPECT_NEAR(unwrap_near(0.1, 2 * kPi), 0.1 + 2 * kPi, 1e-12);
  EXPECT_NEAR(unwrap_near(3.0, -3.0), 3.0 - 2 * kPi, 1e-12);
  EXPECT_NEAR(unwrap_near(-1.0, -1.2), -1.0, 1e-12);
}

}  // namespace
}  // namespace mimic::rig::joint_angles_test
