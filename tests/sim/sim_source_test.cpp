#include "mimic/sim/sim_source.h"

#include <vector>

#include <gtest/gtest.h>

#include "mimic/core/alloc_counter.h"
#include "test_motion.h"

namespace mimic::sim::sim_source_test {
namespace {

using devices::SensorSample;

SensorRig make_rig(double latency_s) {
  const auto motion = test::swing_motion();
  RigConfig c;
  c.sensors = make_layout("3", motion->skeleton()).value();
  c.rate_hz = 100;
  c.latency_s = latency_s;
  c.position_noise_mm = 1;
  c.seed = 5;
  return SensorRig::create(motion, c).value();
}

TEST(SimSource, ReleasesEachTickWhenTheClockPassesItsHostTime) {
  auto clock = std::make_shared<ManualClock>(100.0);
  SimSource source(make_rig(0.02), clock, "sim:test");
  std::vector<SensorSample> out(64);
  EXPECT_EQ(source.poll(out), 0u) << "nothing before start()";
  ASSERT_TRUE(source.start());
  EXPECT_EQ(source.status().state, devices::DeviceState::streaming);
  EXPECT_EQ(source.status().description, "sim:test");
  EXPECT_EQ(source.poll(out), 0u);  // tick 0 arrives at 100.02
  clock->set(100.0199);
  EXPECT_EQ(source.poll(out), 0u);
  clock->set(100.02);
  ASSERT_EQ(source.poll(out), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(out[i].sensor, i);
    EXPECT_DOUBLE_EQ(out[i].device_time_s, 0.0);
    EXPECT_DOUBLE_EQ(out[i].host_time_s, 100.02);
  }
  EXPECT_EQ(source.poll(out), 0u) << "a tick is delivered once";
  clock->set(100.035);
  ASSERT_EQ(source.poll(out), 3u);
  EXPECT_DOUBLE_EQ(out[0].device_time_s, 0.01);
  EXPECT_EQ(source.status().records, 2u);
}

TEST(SimSource, LatePollsGetEveryMissedTickInOrderAcrossSmallBuffers) {
  auto clock = std::make_shared<ManualClock>(0.0);
  SimSource source(make_rig(0.0), clock, "sim:test");
  ASSERT_TRUE(source.start());
  clock->set(0.995);  // ticks 0..99 are due
  std::vector<SensorSample> buf(7), all(400);
  const uint64_t before = thread_allocation_count();
  size_t n;
  size_t total = 0;
  while ((n = source.poll(buf)) > 0) {
    ASSERT_LE(n, buf.size());
    for (size_t i = 0; i < n; ++i) all[total++] = buf[i];
  }
  EXPECT_EQ(thread_allocation_count(), before) << "poll allocated";
  ASSERT_EQ(total, 300u);

  auto reference = make_rig(0.0);
  std::vector<SensorSample> tick(3);
  for (int k = 0; k < 100; ++k) {
    reference.step(tick);
    for (int i = 0; i < 3; ++i) {
      const auto& s = all[static_cast<size_t>(k * 3 + i)];
      EXPECT_EQ(s.sensor, i);
      EXPECT_EQ(s.position_m, tick[i].position_m);
      EXPECT_EQ(s.orientation, tick[i].orientation);
      EXPECT_DOUBLE_EQ(s.host_time_s, k / 100.0);
    }
  }
}

TEST(SimSource, StopSilencesAndStartRestartsTheTimeLine) {
  auto clock = std::make_shared<ManualClock>(5.0);
  SimSource source(make_rig(0.0), clock, "sim:test");
  ASSERT_TRUE(source.start());
  std::vector<SensorSample> out(16);
  clock->set(5.05);
  EXPECT_EQ(source.poll(out), 16u);
  source.stop();
  EXPECT_EQ(source.status().state, devices::DeviceState::disconnected);
  clock->set(6.0);
  EXPECT_EQ(source.poll(out), 0u);
  ASSERT_TRUE(source.start());
  ASSERT_EQ(source.poll(out), 3u);
  EXPECT_DOUBLE_EQ(out[0].device_time_s, 0.0);
  EXPECT_DOUBLE_EQ(out[0].host_time_s, 6.0);
}

}  // namespace
}  // namespace mimic::sim::sim_source_test
