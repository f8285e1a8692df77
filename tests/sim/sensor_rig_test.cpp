#include "mimic/sim/sensor_rig.h"

#include <cmath>
#include <cstring>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "mimic/core/alloc_counter.h"
#include "test_motion.h"

namespace mimic::sim::sensor_rig_test {
namespace {

using devices::SensorSample;

RigConfig config_for(const std::string& layout, const rig::Motion& motion) {
  RigConfig c;
  c.sensors = make_layout(layout, motion.skeleton()).value();
  return c;
}

std::vector<SensorSample> run(SensorRig& rig, int ticks) {
  std::vector<SensorSample> all(static_cast<size_t>(ticks * rig.sensor_count()));
  for (int k = 0; k < ticks; ++k)
    rig.step(std::span<SensorSample>(all).subspan(static_cast<size_t>(k * rig.sensor_count())));
  return all;
}

bool same_bits(const SensorSample& a, const SensorSample& b) {
  return a.sensor == b.sensor && a.flags == b.flags && a.buttons == b.buttons &&
         std::memcmp(&a.device_time_s, &b.device_time_s, sizeof(double)) == 0 &&
         std::memcmp(&a.host_time_s, &b.host_time_s, sizeof(double)) == 0 &&
         std::memcmp(&a.position_m, &b.position_m, sizeof(a.position_m)) == 0 &&
         std::memcmp(&a.orientation, &b.orientation, sizeof(a.orientation)) == 0;
}

// Rotation vector of q (angle·axis, radians), for unit q near identity.
glm::dvec3 rotation_vector(glm::quat q) {
  if (q.w < 0) q = -q;
  const glm::dvec3 v(q.x, q.y, q.z);
  const double s = glm::length(v);
  if (s < 1e-12) return glm::dvec3(0.0);
  return v * (2.0 * std::atan2(s, static_cast<double>(q.w)) / s);
}

TEST(SensorLayout, NamedLayoutsHaveTheDocumentedSensors) {
  const auto motion = test::swing_motion();
  const auto& sk = motion->skeleton();
  EXPECT_EQ(make_layout("3", sk)->size(), 3u);
  EXPECT_EQ(make_layout("6", sk)->size(), 6u);
  EXPECT_EQ(make_layout("11", sk)->size(), 11u);
  EXPECT_EQ(make_layout("all", sk)->size(), static_cast<size_t>(sk.joint_count()));
  for (const auto& name : layout_names()) {
    auto layout = make_layout(name, sk);
    ASSERT_TRUE(layout) << name;
    std::set<std::string> names;
    for (const auto& m : *layout) {
      names.insert(m.name);
      EXPECT_GE(sk.find_joint(m.segment), 0) << m.segment;
    }
    EXPECT_EQ(names.size(), layout->size()) << "duplicate sensor names in layout " << name;
  }
  const auto eleven = *make_layout("11", sk);
  EXPECT_EQ(eleven[0].name, "head");
  EXPECT_EQ(eleven[1].segment, "l_wrist");
  EXPECT_EQ(eleven[10].name, "chest");
  EXPECT_EQ(make_layout("5", sk).error().code, Errc::not_found);
}

TEST(SensorRig, RejectsUnusableConfigurations) {
  const auto motion = test::swing_motion();
  auto c = config_for("3", *motion);
  EXPECT_FALSE(SensorRig::create(nullptr, c));
  auto bad = c;
  bad.rate_hz = 0;
  EXPECT_FALSE(SensorRig::create(motion, bad));
  bad = c;
  bad.position_noise_mm = -1;
  EXPECT_FALSE(SensorRig::create(motion, bad));
  bad = c;
  bad.dropout_probability = 1.5;
  EXPECT_FALSE(SensorRig::create(motion, bad));
  bad = c;
  bad.dropout_burst = 0;
  EXPECT_FALSE(SensorRig::create(motion, bad));
  bad = c;
  bad.sensors[1].segment = "tail";
  auto r = SensorRig::create(motion, bad);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("tail"), std::string::npos);
  bad.sensors.clear();
  EXPECT_FALSE(SensorRig::create(motion, bad));
}

TEST(SensorRig, SameSeedGivesIdenticalSamplesAndOtherSeedsDiffer) {
  const auto motion = test::swing_motion();
  auto c = config_for("6", *motion);
  c.position_noise_mm = 2;
  c.orientation_noise_deg = 1;
  c.bias_walk_mm_per_sqrt_s = 1;
  c.bias_walk_deg_per_sqrt_s = 0.5;
  c.dropout_probability = 0.02;
  c.dropout_burst = 3;
  c.seed = 42;
  auto a = SensorRig::create(motion, c).value();
  auto b = SensorRig::create(motion, c).value();
  const auto sa = run(a, 300), sb = run(b, 300);
  for (size_t i = 0; i < sa.size(); ++i) ASSERT_TRUE(same_bits(sa[i], sb[i])) << "sample " << i;

  a.reset();
  const auto again = run(a, 300);
  for (size_t i = 0; i < sa.size(); ++i) ASSERT_TRUE(same_bits(sa[i], again[i])) << "after reset, sample " << i;

  c.seed = 43;
  auto d = SensorRig::create(motion, c).value();
  const auto sd = run(d, 300);
  size_t differing = 0;
  for (size_t i = 0; i < sa.size(); ++i) differing += same_bits(sa[i], sd[i]) ? 0 : 1;
  EXPECT_GT(differing, sa.size() * 9 / 10);
}

TEST(SensorRig, SensorsDrawFromIndependentStreams) {
  // Sensor i's noise depends only on (seed, i): the head (sensor 0) is measured identically
  // whether the layout has 3 or 11 sensors.
  const auto motion = test::swing_motion();
  auto c3 = config_for("3", *motion);
  auto c11 = config_for("11", *motion);
  c3.position_noise_mm = c11.position_noise_mm = 5;
  auto r3 = SensorRig::create(motion, c3).value();
  auto r11 = SensorRig::create(motion, c11).value();
  const auto s3 = run(r3, 50), s11 = run(r11, 50);
  for (int k = 0; k < 50; ++k) EXPECT_TRUE(same_bits(s3[static_cast<size_t>(k * 3)], s11[static_cast<size_t>(k * 11)]));
  EXPECT_NE(s11[0].position_m, s11[1].position_m);
}

TEST(SensorRig, TruePoseIsForwardKinematicsComposedWithTheMount) {
  const auto motion = test::swing_motion();
  RigConfig c;
  rig::RigidTransform mount;
  mount.rotation = glm::angleAxis(0.7f, glm::normalize(glm::vec3(1, 2, -1)));
  mount.translation = {0.03f, -0.05f, 0.1f};
  c.sensors = {{"forearm", "l_elbow", mount}, {"shin", "r_knee", mount}};
  c.world_from_reference.rotation = glm::angleAxis(1.2f, glm::vec3(0, 1, 0));
  c.world_from_reference.translation = {0.5f, 1.0f, -2.0f};
  auto rig = SensorRig::create(motion, c).value();

  const auto& sk = motion->skeleton();
  rig::Pose pose = sk.zero_pose();
  std::vector<rig::RigidTransform> w(static_cast<size_t>(sk.joint_count()));
  std::vector<SensorSample> out(2);
  for (int k = 0; k < 200; ++k) {
    const double t = rig.step(out);
    EXPECT_DOUBLE_EQ(t, k / c.rate_hz);
    motion->sample(t, pose);
    rig::forward_kinematics(sk, pose, w);
    for (int i = 0; i < 2; ++i) {
      const auto& seg = w[static_cast<size_t>(sk.find_joint(c.sensors[i].segment))];
      const glm::vec3 expect_p = seg.apply(mount.translation);
      const glm::quat expect_q = seg.rotation * mount.rotation;
      const auto& truth = rig.true_world_from_sensor(i);
      EXPECT_LT(glm::length(truth.translation - expect_p), 1e-5f);
      EXPECT_GT(std::abs(glm::dot(truth.rotation, expect_q)), 1.0f - 1e-6f);
      // No faults configured: the sample is the truth seen from the reference frame.
      const glm::vec3 ref_p =
          glm::inverse(c.world_from_reference.rotation) * (expect_p - c.world_from_reference.translation);
      EXPECT_LT(glm::length(out[i].position_m - ref_p), 1e-5f);
      EXPECT_GT(std::abs(glm::dot(out[i].orientation, glm::inverse(c.world_from_reference.rotation) * expect_q)),
                1.0f - 1e-6f);
      EXPECT_EQ(out[i].flags, devices::kSampleValid);
      EXPECT_EQ(out[i].sensor, i);
    }
    for (size_t j = 0; j < pose.dof_rad.size(); ++j) EXPECT_EQ(rig.true_pose().dof_rad[j], pose.dof_rad[j]);
  }
}

TEST(SensorRig, NoiseStatisticsMatchTheConfiguration) {
  const auto motion = test::swing_motion();
  auto c = config_for("11", *motion);
  c.position_noise_mm = 3.0;
  c.orientation_noise_deg = 2.0;
  c.seed = 7;
  auto rig = SensorRig::create(motion, c).value();
  std::vector<SensorSample> out(11);
  glm::dvec3 sum_p(0), sum_p2(0), sum_r(0), sum_r2(0);
  const int ticks = 1000;
  for (int k = 0; k < ticks; ++k) {
    rig.step(out);
    for (int i = 0; i < 11; ++i) {
      const auto& truth = rig.true_reference_from_sensor(i);
      const glm::dvec3 e_mm = glm::dvec3(out[i].position_m - truth.translation) * 1000.0;
      const glm::dvec3 e_deg =
          rotation_vector(glm::inverse(truth.rotation) * out[i].orientation) * (180.0 / 3.14159265358979);
      sum_p += e_mm;
      sum_p2 += e_mm * e_mm;
      sum_r += e_deg;
      sum_r2 += e_deg * e_deg;
    }
  }
  const double n = ticks * 11.0;
  for (int a = 0; a < 3; ++a) {
    const double mean_p = sum_p[a] / n, sd_p = std::sqrt(sum_p2[a] / n - mean_p * mean_p);
    const double mean_r = sum_r[a] / n, sd_r = std::sqrt(sum_r2[a] / n - mean_r * mean_r);
    EXPECT_NEAR(mean_p, 0.0, 0.1) << "axis " << a;  // standard error ≈ 0.03 mm
    EXPECT_NEAR(sd_p, 3.0, 0.15) << "axis " << a;
    EXPECT_NEAR(mean_r, 0.0, 0.07) << "axis " << a;
    EXPECT_NEAR(sd_r, 2.0, 0.1) << "axis " << a;
  }
}

TEST(SensorRandom, GaussiansHaveUnitVarianceAndNoObviousCorrelation) {
  SensorRandom r(123, 4);
  double s = 0, s2 = 0, lag = 0, prev = 0;
  const int n = 200000;
  int beyond3 = 0;
  for (int i = 0; i < n; ++i) {
    const double g = r.gaussian();
    s += g;
    s2 += g * g;
    lag += g * prev;
    prev = g;
    beyond3 += std::abs(g) > 3 ? 1 : 0;
  }
  EXPECT_NEAR(s / n, 0.0, 0.01);
  EXPECT_NEAR(s2 / n, 1.0, 0.015);
  EXPECT_NEAR(lag / n, 0.0, 0.01);
  EXPECT_NEAR(beyond3 / double(n), 0.0027, 0.0007);
  SensorRandom a(1, 0), b(1, 1), c(2, 0);
  const uint64_t x = a.next_u64();
  EXPECT_NE(x, b.next_u64());
  EXPECT_NE(x, c.next_u64());
}

TEST(SensorRig, BiasDriftsLikeARandomWalk) {
  const auto motion = test::swing_motion();
  auto c = config_for("all", *motion);
  c.bias_walk_mm_per_sqrt_s = 2.0;
  c.rate_hz = 50;
  const int n_sensors = static_cast<int>(c.sensors.size());
  std::vector<SensorSample> out(c.sensors.size());
  // Position error after T seconds has std σ·√T; pool sensors, axes and seeds.
  double sum2_early = 0, sum2_late = 0;
  int count = 0;
  for (uint64_t seed = 1; seed <= 8; ++seed) {
    c.seed = seed;
    auto rig = SensorRig::create(motion, c).value();
    for (int k = 0; k < 200; ++k) {  // 4 s
      rig.step(out);
      if (k == 24 || k == 199) {
        for (int i = 0; i < n_sensors; ++i) {
          const glm::dvec3 e = glm::dvec3(out[i].position_m - rig.true_reference_from_sensor(i).translation) * 1000.0;
          (k == 24 ? sum2_early : sum2_late) += glm::dot(e, e);
        }
        if (k == 199) count += 3 * n_sensors;
      }
    }
  }
  const double sd_early = std::sqrt(sum2_early / count), sd_late = std::sqrt(sum2_late / count);
  EXPECT_NEAR(sd_early, 2.0 * std::sqrt(0.5), 0.25);
  EXPECT_NEAR(sd_late, 2.0 * std::sqrt(4.0), 0.6);
}

TEST(SensorRig, LatencyShiftsHostTimeOnly) {
  const auto motion = test::swing_motion();
  auto c = config_for("3", *motion);
  c.rate_hz = 120;
  c.latency_s = 0.035;
  auto late = SensorRig::create(motion, c).value();
  c.latency_s = 0;
  auto prompt = SensorRig::create(motion, c).value();
  std::vector<SensorSample> a(3), b(3);
  for (int k = 0; k < 100; ++k) {
    late.step(a, 10.0);
    prompt.step(b);
    for (int i = 0; i < 3; ++i) {
      EXPECT_DOUBLE_EQ(a[i].device_time_s, k / 120.0);
      EXPECT_NEAR(a[i].host_time_s, k / 120.0 + 0.035 + 10.0, 1e-9);
      EXPECT_EQ(a[i].position_m, b[i].position_m);  // measured at the same instant
    }
  }
  EXPECT_NEAR(late.next_host_time_s(), 100 / 120.0 + 0.035, 1e-12);
}

TEST(SensorRig, DropoutsComeInBurstsAndRepeatTheLastGoodValue) {
  const auto motion = test::swing_motion();
  auto c = config_for("3", *motion);
  c.position_noise_mm = 1;
  c.orientation_noise_deg = 0.5;
  c.seed = 99;
  auto clean = SensorRig::create(motion, c).value();
  c.dropout_probability = 0.05;
  c.dropout_burst = 4;
  auto lossy = SensorRig::create(motion, c).value();
  const int ticks = 20000;
  const auto a = run(clean, ticks), b = run(lossy, ticks);
  for (int i = 0; i < 3; ++i) {
    int stale = 0, run_length = 0;
    SensorSample last_good{};
    for (int k = 0; k < ticks; ++k) {
      const auto& s = b[static_cast<size_t>(k * 3 + i)];
      const auto& ref = a[static_cast<size_t>(k * 3 + i)];
      EXPECT_DOUBLE_EQ(s.device_time_s, ref.device_time_s);
      if (s.flags & devices::kSampleStale) {
        EXPECT_FALSE(s.flags & devices::kSampleValid);
        EXPECT_EQ(s.position_m, last_good.position_m);
        EXPECT_EQ(s.orientation, last_good.orientation);
        ++stale;
        ++run_length;
      } else {
        // Surviving samples carry exactly the noise they would have had without dropouts.
        EXPECT_TRUE(same_bits(s, ref)) << "sensor " << i << " tick " << k;
        if (run_length > 0) {
          EXPECT_EQ(run_length % 4, 0) << "burst of " << run_length;
        }
        run_length = 0;
        last_good = s;
      }
    }
    // A burst of 4 starts after a geometric number of good ticks: stale share 4p / (1 + 3p).
    EXPECT_NEAR(stale / double(ticks), 0.2 / 1.15, 0.02) << "sensor " << i;
  }
}

TEST(SensorRig, StepNeverAllocates) {
  const auto motion = test::swing_motion();
  auto c = config_for("all", *motion);
  c.position_noise_mm = 1;
  c.orientation_noise_deg = 1;
  c.bias_walk_deg_per_sqrt_s = 1;
  c.dropout_probability = 0.1;
  auto rig = SensorRig::create(motion, c).value();
  std::vector<SensorSample> out(c.sensors.size());
  rig.step(out);
  const uint64_t before = thread_allocation_count();
  for (int k = 0; k < 500; ++k) rig.step(out);
  EXPECT_EQ(thread_allocation_count(), before);
}

}  // namespace
}  // namespace mimic::sim::sensor_rig_test

namespace mimic::sim::sensor_rig_test {
namespace {

TEST(SensorRig, BuiltInWalkStepsWithoutAllocating) {
  const auto skeleton = rig::Skeleton::build(rig::default_skeleton_desc()).value();
  std::shared_ptr<const rig::Motion> walk(rig::make_builtin_motion("walk", skeleton).value());
  RigConfig c;
  c.sensors = make_layout("11", skeleton).value();
  c.position_noise_mm = 1;
  auto rig = SensorRig::create(walk, c).value();
  std::vector<devices::SensorSample> out(11);
  rig.step(out);
  const uint64_t before = thread_allocation_count();
  for (int k = 0; k < 300; ++k) rig.step(out);
  EXPECT_EQ(thread_allocation_count(), before);
}

}  // namespace
}  // namespace mimic::sim::sensor_rig_test
