#include "mimic/solver/filters.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace mimic::solver::filters_test {
namespace {

devices::SensorSample sample_at(double t, glm::vec3 p, glm::quat q = glm::quat(1, 0, 0, 0)) {
  devices::SensorSample s;
  s.sensor = 0;
  s.device_time_s = s.host_time_s = t;
  s.position_m = p;
  s.orientation = q;
  return s;
}

TEST(OneEuro, StillSignalIsSmoothedHard) {
  std::mt19937_64 rng(1);
  std::normal_distribution<float> n(0.0f, 0.001f);
  OneEuroVec3 f(OneEuroParams{1.0f, 4.0f, 1.0f});
  double raw = 0, out = 0;
  for (int k = 0; k < 2000; ++k) {
    const glm::vec3 x(n(rng), n(rng), n(rng));
    const glm::vec3 y = f.filter(x, 0.01f);
    if (k < 200) continue;
    raw += glm::dot(x, x);
    out += glm::dot(y, y);
  }
  EXPECT_LT(out, 0.1 * raw);  // noise power down by more than 10x
}

TEST(OneEuro, FastMotionLagsLittleAndPredictionPaysTheLagBack) {
  const float speed = 2.0f;  // m/s, a hand in a swing
  OneEuroVec3 f(OneEuroParams{1.0f, 4.0f, 1.0f});
  glm::vec3 y(0.0f);
  for (int k = 0; k <= 200; ++k) y = f.filter(glm::vec3(speed * 0.01f * static_cast<float>(k), 0, 0), 0.01f);
  const float truth = speed * 2.0f;
  const float lag_m = truth - y.x;
  EXPECT_GT(lag_m, 0.0f);
  EXPECT_LT(lag_m, 0.05f);  // under 5 cm at 2 m/s
  const float predicted = y.x + f.velocity().x * (lag_m / speed);
  EXPECT_LT(std::abs(truth - predicted), 0.1f * lag_m);
}

TEST(OneEuro, QuaternionSignFlipsAreNotMotion) {
  OneEuroQuat f;
  const glm::quat q = glm::angleAxis(0.7f, glm::normalize(glm::vec3(1, 2, 3)));
  for (int k = 0; k < 100; ++k) {
    const glm::quat out = f.filter(k % 2 ? -q : q, 0.01f);
    EXPECT_GT(std::abs(glm::dot(out, q)), 0.99999f) << k;
  }
  EXPECT_LT(glm::length(f.angular_velocity()), 1e-3f);
}

TEST(SensorFilterBank, RejectsAnImpossibleJumpAndAcceptsAPersistentOne) {
  SensorFilterConfig c;
  c.accept_after = 5;
  SensorFilterBank bank(0, c);
  std::vector<devices::SensorSample> s(1);
  double t = 0;
  for (int k = 0; k < 50; ++k, t += 0.01) {
    s[0] = sample_at(t, {0, 1, 0});
    bank.process(s);
  }
  s[0] = sample_at(t, {0, 3, 0});  // 2 m in 10 ms
  bank.process(s);
  EXPECT_TRUE(s[0].flags & devices::kSampleOutlier);
  EXPECT_TRUE(s[0].flags & devices::kSampleValid);  // held, so the solver keeps the segment
  EXPECT_NEAR(s[0].position_m.y, 1.0f, 0.01f);
  EXPECT_EQ(bank.outliers(), 1u);
  // The sensor stays there: after accept_after samples it is believed.
  for (int k = 0; k < 6; ++k) {
    t += 0.01;
    s[0] = sample_at(t, {0, 3, 0});
    bank.process(s);
  }
  EXPECT_FALSE(s[0].flags & devices::kSampleOutlier);
  EXPECT_NEAR(s[0].position_m.y, 3.0f, 0.01f);
}

TEST(SensorFilterBank, BridgesShortDropoutsOnly) {
  SensorFilterConfig c;
  c.hold_s = 0.05f;
  SensorFilterBank bank(0, c);
  std::vector<devices::SensorSample> s(1);
  double t = 0;
  for (int k = 0; k < 50; ++k, t += 0.01) {
    s[0] = sample_at(t, {0.01f * static_cast<float>(k), 1, 0});
    bank.process(s);
  }
  int bridged = 0, passed_invalid = 0;
  for (int k = 0; k < 10; ++k, t += 0.01) {
    s[0] = sample_at(t, {0, 0, 0});
    s[0].flags = devices::kSampleStale;  // the driver's "no fresh data"
    bank.process(s);
    if (s[0].flags & devices::kSampleValid) {
      ++bridged;
      EXPECT_GT(s[0].position_m.x, 0.45f);  // carried on along the motion
    } else {
      ++passed_invalid;
    }
  }
  EXPECT_GE(bridged, 4);
  EXPECT_LE(bridged, 6);
  EXPECT_GT(passed_invalid, 0);
}

TEST(SensorFilterBank, DisabledFilteringPassesSamplesThrough) {
  SensorFilterConfig c;
  c.enabled = false;
  SensorFilterBank bank(3, c);
  std::vector<devices::SensorSample> s(1);
  for (int k = 0; k < 10; ++k) {
    s[0] = sample_at(0.01 * k, {0.1f * static_cast<float>(k), 0, 0});
    s[0].sensor = 3;
    bank.process(s);
    EXPECT_FLOAT_EQ(s[0].position_m.x, 0.1f * static_cast<float>(k));
  }
  s[0].sensor = 9;  // beyond the bank: untouched
  s[0].position_m = {5, 5, 5};
  bank.process(s);
  EXPECT_EQ(s[0].position_m, glm::vec3(5, 5, 5));
}

}  // namespace
}  // namespace mimic::solver::filters_test
