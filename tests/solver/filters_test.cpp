#include "mimic/solver/filters.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

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

// Σ|x[t+1] − 2x[t] + x[t−1]|²: the sample-to-sample shake.
double second_difference_energy(const std::vector<glm::vec3>& x) {
  double e = 0;
  for (size_t t = 1; t + 1 < x.size(); ++t) {
    const glm::vec3 d = x[t + 1] - 2.0f * x[t] + x[t - 1];
    e += glm::dot(d, d);
  }
  return e;
}

// A walker's sensor at 120 Hz: 1.5 m/s forward, swaying ±10 cm at 1.5 Hz.
glm::vec3 walking(double t) {
  return {0.1f * static_cast<float>(std::sin(2 * M_PI * 1.5 * t)), 1.0f, 1.5f * static_cast<float>(t)};
}

constexpr double kDt = 1.0 / 120.0;

TEST(FixedLagTaps, StraightLinesComeOutAsLateAsAsked) {
  for (int window = 2; window <= kMaxSmootherTaps; ++window)
    for (float lag : {0.0f, 0.5f, 1.0f}) {
      const auto h = fixed_lag_taps({window, lag, 0.0f});
      double sum = 0, moment = 0;
      for (int k = 0; k < kMaxSmootherTaps; ++k) {
        if (k >= window) {
          EXPECT_EQ(h[static_cast<size_t>(k)], 0.0f);
        }
        sum += h[static_cast<size_t>(k)];
        moment += static_cast<double>(k) * h[static_cast<size_t>(k)];
      }
      EXPECT_NEAR(sum, 1.0, 1e-5) << window << " " << lag;
      EXPECT_NEAR(moment, lag, 1e-5) << window << " " << lag;
    }
  // Three samples, one late: the least second-difference gain is 2/7, 3/7, 2/7.
  const auto h = fixed_lag_taps({3, 1.0f, 0.0f});
  EXPECT_NEAR(h[0], 2.0f / 7, 1e-5f);
  EXPECT_NEAR(h[1], 3.0f / 7, 1e-5f);
  EXPECT_NEAR(h[2], 2.0f / 7, 1e-5f);
  EXPECT_EQ(fixed_lag_taps({1, 0.0f, 0.0f})[0], 1.0f);
}

TEST(FixedLagSmoother, NoisyWalkShakesLessAndStaysOnTime) {
  std::mt19937_64 rng(3);
  std::normal_distribution<float> n(0.0f, 0.001f);
  FixedLagSmoother smoother;  // the defaults: 8 samples, straight lines on time
  std::vector<glm::vec3> in, out, truth;
  glm::quat q(1, 0, 0, 0);
  for (int k = 0; k < 1200; ++k) {
    const glm::vec3 clean = walking(k * kDt);
    glm::vec3 p = clean + glm::vec3(n(rng), n(rng), n(rng));
    in.push_back(p);
    smoother.filter(p, q);
    out.push_back(p);
    truth.push_back(clean);
  }
  EXPECT_LT(second_difference_energy(out), second_difference_energy(in) / 3.0);
  // On time: nearer the body now than the body one sample ago is.
  double err_now = 0, one_sample = 0;
  for (size_t k = 8; k < out.size(); ++k) {
    err_now += glm::length(out[k] - truth[k]);
    one_sample += glm::length(truth[k] - truth[k - 1]);
  }
  EXPECT_LT(err_now, 0.5 * one_sample);
}

TEST(FixedLagSmoother, NoisyTurnShakesLess) {
  std::mt19937_64 rng(4);
  std::normal_distribution<float> n(0.0f, glm::radians(0.5f));
  FixedLagSmoother smoother;
  const glm::vec3 axis = glm::normalize(glm::vec3(1, 2, 3));
  std::vector<glm::vec3> in, out;  // rotation vectors (a swing of ±0.6 rad at 1 Hz)
  glm::vec3 p(0.0f);
  for (int k = 0; k < 1200; ++k) {
    const float angle = 0.6f * static_cast<float>(std::sin(2 * M_PI * k * kDt));
    glm::quat q = glm::angleAxis(angle, axis) * glm::angleAxis(n(rng), glm::vec3(1, 0, 0)) *
                  glm::angleAxis(n(rng), glm::vec3(0, 1, 0)) * glm::angleAxis(n(rng), glm::vec3(0, 0, 1));
    in.push_back(glm::axis(q) * glm::angle(q));
    smoother.filter(p, q);
    out.push_back(glm::axis(q) * glm::angle(q));
  }
  EXPECT_LT(second_difference_energy(out), second_difference_energy(in) / 3.0);
}

TEST(FixedLagSmoother, SharpBendsStayOnTheirPath) {
  // A foot's swing: a 20 cm radius turned at 2.5 turns per second (49 m/s² inwards), no noise.
  // Smooth taps alone cut the corner by millimetres; past the bend the sharp taps take over.
  SmootherParams smooth_only;
  smooth_only.curvature_weight = 0.0003f;
  SmootherParams with_switch = smooth_only;
  with_switch.bend = 0.01f;
  with_switch.sharp_curvature_weight = 0.1f;
  FixedLagSmoother a(smooth_only, {1}), b(with_switch, {1});
  glm::quat q(1, 0, 0, 0);
  double err_a = 0, err_b = 0;
  for (int k = 0; k < 240; ++k) {
    const double phase = 2 * M_PI * 2.5 * k * kDt;
    const glm::vec3 p(0.2f * static_cast<float>(std::cos(phase)), 0.2f * static_cast<float>(std::sin(phase)), 0);
    glm::vec3 pa = p, pb = p;
    a.filter(pa, q);
    b.filter(pb, q);
    if (k < 8) continue;
    err_a += glm::length(pa - p);
    err_b += glm::length(pb - p);
  }
  EXPECT_GT(err_a / 232, 0.002);  // the bias the switch is for
  EXPECT_LT(err_b, 0.5 * err_a);
}

TEST(FixedLagSmoother, FollowsAStepWithinItsWindow) {
  FixedLagSmoother smoother;
  glm::quat q(1, 0, 0, 0);
  for (int k = 0; k < 10; ++k) {
    glm::vec3 p(0.0f);
    smoother.filter(p, q);
    EXPECT_EQ(p, glm::vec3(0.0f));
  }
  for (int k = 0; k < 20; ++k) {
    glm::vec3 p(0, 0, 0.1f);  // 10 cm, as a re-seated strap
    const glm::quat turned = glm::angleAxis(0.3f, glm::vec3(0, 1, 0));
    glm::quat r = turned;
    smoother.filter(p, r);
    EXPECT_GT(p.z, -0.05f) << k;  // taps below zero overshoot, but not by half the step
    EXPECT_LT(p.z, 0.15f) << k;
    if (k >= kMaxSmootherTaps - 1) {
      EXPECT_NEAR(p.z, 0.1f, 1e-6f) << k;  // the whole window is the new place
      EXPECT_GT(std::abs(glm::dot(r, turned)), 0.99999f) << k;
    }
  }
}

TEST(SensorFilterBank, WalkingSensorShakesLessWithoutLag) {
  std::mt19937_64 rng(5);
  std::normal_distribution<float> n(0.0f, 0.001f);
  SensorFilterConfig no_smoothing;
  no_smoothing.position_smoother.window = no_smoothing.rotation_smoother.window = 1;
  SensorFilterBank smoothed(0), unsmoothed(0, no_smoothing);
  std::vector<devices::SensorSample> a(1), b(1);
  std::vector<glm::vec3> raw, out, out_unsmoothed, truth;
  for (int k = 0; k < 1200; ++k) {
    const glm::vec3 clean = walking(k * kDt);
    a[0] = sample_at(k * kDt, clean + glm::vec3(n(rng), n(rng), n(rng)));
    b[0] = a[0];
    raw.push_back(a[0].position_m);
    smoothed.process(a);
    unsmoothed.process(b);
    out.push_back(a[0].position_m);
    out_unsmoothed.push_back(b[0].position_m);
    truth.push_back(clean);
  }
  // The One Euro filter alone lets most of the noise through at walking speed; the smoother takes it.
  EXPECT_LT(second_difference_energy(out), second_difference_energy(raw) / 3.0);
  EXPECT_LT(second_difference_energy(out), second_difference_energy(out_unsmoothed) / 3.0);
  double err = 0, one_sample = 0;
  for (size_t k = 120; k < out.size(); ++k) {
    err += glm::length(out[k] - truth[k]);
    one_sample += glm::length(truth[k] - truth[k - 1]);
  }
  EXPECT_LT(err, one_sample);  // less than a sample late
}

TEST(SensorFilterBank, BridgedDropoutDoesNotJerk) {
  SensorFilterBank bank(0);
  std::vector<devices::SensorSample> s(1);
  std::vector<glm::vec3> out;
  for (int k = 0; k < 200; ++k) {
    s[0] = sample_at(k * kDt, {1.0f * static_cast<float>(k * kDt), 1, 0});  // 1 m/s
    if (k >= 100 && k < 104) s[0].flags = devices::kSampleStale;            // 4 samples lost
    bank.process(s);
    ASSERT_TRUE(s[0].flags & devices::kSampleValid) << k;
    out.push_back(s[0].position_m);
  }
  for (size_t k = 51; k + 1 < out.size(); ++k) {
    const glm::vec3 d = out[k + 1] - 2.0f * out[k] + out[k - 1];
    EXPECT_LT(glm::length(d), 0.001f) << k;  // under 1 mm per sample² (the step is 8.3 mm)
    EXPECT_NEAR(out[k].x, static_cast<double>(k) * kDt, 0.002) << k;
  }
}

}  // namespace
}  // namespace mimic::solver::filters_test
