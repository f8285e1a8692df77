#include "mimic/solver/swing_twist.h"

#include "../../solver/src/axis_turn.h"
#include "../../solver/src/fast_trig.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace mimic::solver::swing_twist_test {
namespace {

using rig::Skeleton;

Skeleton default_skeleton() { return *Skeleton::build(rig::default_skeleton_desc()); }

float quat_angle_deg(glm::quat a, glm::quat b) {
  const glm::quat d = glm::normalize(a) * glm::conjugate(glm::normalize(b));
  return glm::degrees(2.0f * std::asin(std::min(1.0f, glm::length(glm::vec3(d.x, d.y, d.z)))));
}

// The decompositions' atan2: within 4·10⁻⁷ rad of the exact angle everywhere in the plane (on
// the axes and diagonals, near them, at tiny and large radii), with libm's signs and quadrants.
TEST(SwingTwist, FastAtan2IsWithinFloatRoundingOfTheExactAngle) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), log_radius(-20.0, 20.0);
  double worst = 0;
  for (int i = 0; i < 200000; ++i) {
    double a = angle(rng);
    if (i % 4 == 0) a = std::round(a / (M_PI / 4)) * (M_PI / 4) + 1e-6 * (i % 7 - 3);  // near axes and diagonals
    const double r = std::exp(log_radius(rng));
    const float x = static_cast<float>(r * std::cos(a)), y = static_cast<float>(r * std::sin(a));
    const double exact = std::atan2(static_cast<double>(y), static_cast<double>(x));
    worst = std::max(worst, std::abs(detail::fast_atan2(y, x) - exact));
  }
  EXPECT_LT(worst, 4e-7);
  for (float y : {0.0f, -0.0f, 1.0f, -1.0f})
    for (float x : {0.0f, -0.0f, 1.0f, -1.0f}) EXPECT_EQ(detail::fast_atan2(y, x), std::atan2(y, x)) << y << ", " << x;
}

// The FK's turns: a half angle's sine and cosine within 1.5·10⁻⁷ of the exact ones at every DOF
// angle (±π and beyond), and a turn about a coordinate axis the general quaternion product's.
TEST(SwingTwist, TurnsAboutCoordinateAxesMatchTheGeneralProduct) {
  double worst = 0;
  for (int i = -40000; i <= 40000; ++i) {
    const float h = 2.5f * static_cast<float>(i) / 40000.0f;
    float s = 0, c = 0;
    detail::half_sincos(h, s, c);
    worst = std::max(
        {worst, std::abs(s - std::sin(static_cast<double>(h))), std::abs(c - std::cos(static_cast<double>(h)))});
  }
  EXPECT_LT(worst, 1.5e-7);
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int i = 0; i < 1000; ++i) {
    const glm::quat r = glm::normalize(glm::quat(u(rng), u(rng), u(rng), u(rng)));
    glm::vec3 axis(0.0f);
    axis[i % 3] = i % 2 ? 1.0f : -1.0f;
    const float angle = 3.5f * u(rng);
    glm::vec3 axis_world;
    const glm::quat turned = detail::turned(r, axis, detail::axis_kind(axis), angle, &axis_world);
    const glm::quat general = r * glm::angleAxis(angle, axis);
    EXPECT_LT(
        glm::length(glm::vec4(turned.x - general.x, turned.y - general.y, turned.z - general.z, turned.w - general.w)),
        1e-6f);
    EXPECT_LT(glm::length(axis_world - r * axis), 1e-6f);
  }
}

TEST(SwingTwist, TwistAngleOfAPureTwistIsItsAngle) {
  const glm::vec3 axis = glm::normalize(glm::vec3(1, 2, -1));
  for (float deg : {-170.0f, -90.0f, 0.0f, 30.0f, 179.0f})
    EXPECT_NEAR(twist_angle_rad(glm::angleAxis(glm::radians(deg), axis), axis), glm::radians(deg), 1e-4f);
  // A swing perpendicular to the axis has no twist.
  EXPECT_NEAR(twist_angle_rad(glm::angleAxis(1.0f, glm::vec3(1, 0, 0)), glm::vec3(0, 1, 0)), 0.0f, 1e-6f);
}

// Every joint of the default skeleton: random DOF values inside the limits give back the same
// rotation, and (away from gimbal lock) the same values.
TEST(SwingTwist, JointRotationsRoundTripThroughNamedDofs) {
  const Skeleton s = default_skeleton();
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    for (int j = 0; j < s.joint_count(); ++j) {
      std::vector<float> truth(s.dof_count(), 0.0f), solved(s.dof_count(), 0.0f);
      for (int d = s.dof_begin(j); d < s.dof_end(j); ++d) {
        const auto& f = s.dof(d);
        std::uniform_real_distribution<float> u(f.min_rad, f.max_rad);
        truth[d] = u(rng);
      }
      const int n = s.dof_end(j) - s.dof_begin(j);
      const glm::quat q = s.local_rotation(j, truth);
      // From the zero posture: the same rotation (wide joints have two Euler branches inside
      // their limits, so the values may be the other branch).
      joint_dofs_from_rotation(s, j, q, solved);
      EXPECT_LT(quat_angle_deg(s.local_rotation(j, solved), q), 0.05f) << s.joint_name(j);
      // Warm-started near the truth (as from the previous frame): the same values.
      for (int d = s.dof_begin(j); d < s.dof_end(j); ++d) solved[d] = truth[d] + 0.1f;
      joint_dofs_from_rotation(s, j, q, solved);
      EXPECT_LT(quat_angle_deg(s.local_rotation(j, solved), q), 0.05f) << s.joint_name(j);
      for (int d = s.dof_begin(j); d < s.dof_end(j); ++d) {
        EXPECT_GE(solved[d], s.dof(d).min_rad - 1e-6f);
        EXPECT_LE(solved[d], s.dof(d).max_rad + 1e-6f);
        if (n == 3 && std::abs(truth[s.dof_begin(j) + 1]) > glm::radians(80.0f)) continue;
        EXPECT_NEAR(solved[d], truth[d], 1e-3f) << s.dof(d).name;
      }
    }
  }
}

// Sweeping a rotation through ±180° many times: the angles follow it without jumps.
TEST(SwingTwist, NoFlipsWhenTurningPast180Degrees) {
  const std::array<glm::vec3, 3> axes{glm::vec3(0, 1, 0), glm::vec3(1, 0, 0), glm::vec3(0, 0, 1)};
  std::array<float, 3> angles{0, 0, 0};
  float prev0 = 0;
  for (int k = 1; k <= 2000; ++k) {
    const float yaw = 0.01f * static_cast<float>(k);  // three full turns and more
    const float pitch = 0.4f * std::sin(0.013f * static_cast<float>(k));
    const float roll = 0.3f * std::cos(0.007f * static_cast<float>(k));
    const glm::quat q = glm::angleAxis(yaw, axes[0]) * glm::angleAxis(pitch, axes[1]) * glm::angleAxis(roll, axes[2]);
    angles_from_rotation(q, axes, angles);
    EXPECT_NEAR(angles[0], yaw, 1e-3f) << k;
    EXPECT_NEAR(angles[1], pitch, 1e-3f) << k;
    EXPECT_NEAR(angles[2], roll, 1e-3f) << k;
    EXPECT_LT(std::abs(angles[0] - prev0), 0.02f);
    prev0 = angles[0];
  }
  // One axis: the twist unwraps too.
  std::array<float, 1> t{0};
  const std::array<glm::vec3, 1> one{glm::vec3(0, 0, 1)};
  for (int k = 1; k <= 1000; ++k) {
    angles_from_rotation(glm::angleAxis(-0.01f * static_cast<float>(k), one[0]), one, t);
    EXPECT_NEAR(t[0], -0.01f * static_cast<float>(k), 1e-3f);
  }
}

TEST(SwingTwist, GimbalLockKeepsThePreviousFirstAngle) {
  const std::array<glm::vec3, 3> axes{glm::vec3(1, 0, 0), glm::vec3(0, 1, 0), glm::vec3(0, 0, 1)};
  std::array<float, 3> angles{0.3f, 0.0f, 0.0f};
  const glm::quat q =
      glm::angleAxis(0.3f, axes[0]) * glm::angleAxis(glm::radians(90.0f), axes[1]) * glm::angleAxis(0.2f, axes[2]);
  angles_from_rotation(q, axes, angles);
  for (float a : angles) EXPECT_TRUE(std::isfinite(a));
  const glm::quat back =
      glm::angleAxis(angles[0], axes[0]) * glm::angleAxis(angles[1], axes[1]) * glm::angleAxis(angles[2], axes[2]);
  EXPECT_LT(quat_angle_deg(back, q), 0.1f);
  EXPECT_NEAR(angles[0], 0.3f, 1e-3f);
}

TEST(SwingTwist, TwoAxesGiveTheNearestExpressibleRotation) {
  // Wrist: flexion about −Z then deviation about −Y, asked for a rotation with a twist on top.
  const std::array<glm::vec3, 2> axes{glm::vec3(0, 0, -1), glm::vec3(0, -1, 0)};
  const glm::quat q =
      glm::angleAxis(0.5f, axes[0]) * glm::angleAxis(0.2f, axes[1]) * glm::angleAxis(0.3f, glm::vec3(1, 0, 0));
  std::array<float, 2> a{0, 0};
  angles_from_rotation(q, axes, a);
  auto misfit = [&](float f, float d) {
    return quat_angle_deg(glm::angleAxis(f, axes[0]) * glm::angleAxis(d, axes[1]), q);
  };
  const float got = misfit(a[0], a[1]);
  for (float f = -1.0f; f <= 1.0f; f += 0.01f)
    for (float d = -1.0f; d <= 1.0f; d += 0.01f) EXPECT_LE(got, misfit(f, d) + 1e-3f);
  // An expressible rotation comes back exactly.
  const glm::quat exact = glm::angleAxis(0.5f, axes[0]) * glm::angleAxis(0.2f, axes[1]);
  angles_from_rotation(exact, axes, a);
  EXPECT_NEAR(a[0], 0.5f, 1e-4f);
  EXPECT_NEAR(a[1], 0.2f, 1e-4f);
}

}  // namespace
}  // namespace mimic::solver::swing_twist_test
