#include "mimic/solver/steering.h"

#include <gtest/gtest.h>

#include <cmath>

namespace mimic::solver::steering_test {
namespace {

devices::InputFrame frame(glm::vec3 t, glm::vec3 r = glm::vec3(0.0f), uint32_t buttons = 0) {
  devices::InputFrame f;
  f.translation = t;
  f.rotation = r;
  f.buttons = buttons;
  return f;
}

rig::Pose standing_at(glm::vec3 p) {
  rig::Pose pose;
  pose.root_position_m = p;
  return pose;
}

TEST(Steering, DeadZoneIgnoresSmallDeflections) {
  Steering s;
  EXPECT_EQ(s.shape(0.05f), 0.0f);
  EXPECT_EQ(s.shape(-0.08f), 0.0f);
  EXPECT_GT(s.shape(0.2f), 0.0f);
  EXPECT_LT(s.shape(-0.2f), 0.0f);
  EXPECT_FLOAT_EQ(s.shape(1.0f), 1.0f);
  EXPECT_FLOAT_EQ(s.shape(3.0f), 1.0f);  // out-of-range input saturates
  EXPECT_EQ(s.shape(NAN), 0.0f);
  for (int k = 0; k < 10; ++k) s.update(frame({0.07f, 0.07f, -0.07f}, {0, 0.07f, 0}), 0.1);
  EXPECT_EQ(s.offset_m(), glm::vec3(0.0f));
  EXPECT_EQ(s.heading_rad(), 0.0f);
}

TEST(Steering, PushingAwayWalksForwardAtTheConfiguredSpeed) {
  SteeringConfig c;
  c.max_speed_m_s = 2.0f;
  Steering s(c);
  for (int k = 0; k < 50; ++k) s.update(frame({0, 0, -1}), 0.02);  // 1 s at full deflection
  EXPECT_NEAR(s.offset_m().z, 2.0f, 1e-4f);                        // the avatar faces +Z
  EXPECT_NEAR(s.offset_m().x, 0.0f, 1e-6f);
  rig::Pose p = standing_at({1, 0.9f, 1});
  s.apply(p);
  EXPECT_NEAR(p.root_position_m.z, 3.0f, 1e-4f);
  EXPECT_NEAR(p.root_position_m.y, 0.9f, 1e-6f);  // no vertical motion unless enabled
  // Pushing right walks to the avatar's right, which is −X while it faces +Z.
  Steering r(c);
  r.update(frame({1, 0, 0}), 0.1);
  EXPECT_LT(r.offset_m().x, 0.0f);
}

TEST(Steering, TwistingTurnsInPlaceAndWalkingFollowsTheHeading) {
  SteeringConfig c;
  c.max_turn_deg_s = 90.0f;
  c.exponent = 1.0f;
  c.dead_zone = 0.0f;
  Steering s(c);
  rig::Pose p = standing_at({2, 0.9f, -1});
  s.apply(p);                                                                 // latch the pivot where the wearer stands
  for (int k = 0; k < 100; ++k) s.update(frame({0, 0, 0}, {0, 1, 0}), 0.01);  // 1 s: a quarter turn left
  EXPECT_NEAR(s.heading_rad(), glm::radians(90.0f), 1e-4f);
  p = standing_at({2, 0.9f, -1});
  s.apply(p);
  EXPECT_NEAR(glm::length(p.root_position_m - glm::vec3(2, 0.9f, -1)), 0.0f, 1e-5f);  // turned in place
  EXPECT_NEAR(glm::length(p.root_orientation * glm::vec3(0, 0, 1) - glm::vec3(1, 0, 0)), 0.0f, 1e-5f);  // faces +X
  s.update(frame({0, 0, -1}), 0.1);  // forward is now +X
  EXPECT_GT(s.offset_m().x, 0.1f);
  EXPECT_NEAR(s.offset_m().z, 0.0f, 1e-5f);
}

TEST(Steering, ButtonsActOnPressesOnly) {
  Steering s;
  s.update(frame({0, 0, -1}), 0.1);
  ASSERT_NE(s.offset_m(), glm::vec3(0.0f));
  auto ev = s.update(frame({0, 0, 0}, {}, 0b01), 0.01);  // button 1: recalibrate
  EXPECT_TRUE(ev.recalibrate);
  EXPECT_FALSE(ev.reset);
  ev = s.update(frame({0, 0, 0}, {}, 0b01), 0.01);  // still held: no new request
  EXPECT_FALSE(ev.recalibrate);
  ev = s.update(frame({0, 0, 0}, {}, 0b11), 0.01);  // button 2 pressed too: reset
  EXPECT_TRUE(ev.reset);
  EXPECT_EQ(s.offset_m(), glm::vec3(0.0f));
  EXPECT_EQ(s.heading_rad(), 0.0f);
}

TEST(Steering, AStalledLoopDoesNotTeleport) {
  Steering s;
  s.update(frame({0, 0, -1}), 30.0);  // half a minute between steps
  EXPECT_LE(glm::length(s.offset_m()), s.config().max_speed_m_s * 0.1f + 1e-6f);
  s.update(frame({0, 0, -1}), -1.0);
  s.update(frame({0, 0, -1}), NAN);
  EXPECT_LE(glm::length(s.offset_m()), s.config().max_speed_m_s * 0.1f + 1e-6f);
}

}  // namespace
}  // namespace mimic::solver::steering_test
