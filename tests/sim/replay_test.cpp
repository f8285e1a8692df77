#include "mimic/sim/replay_source.h"

#include <unistd.h>

#include <filesystem>
#include <vector>

#include <gtest/gtest.h>

#include "mimic/core/alloc_counter.h"
#include "mimic/core/file.h"

namespace mimic::sim::replay_test {
namespace {

using devices::SensorSample;

// 10 ticks of 3 sensors at 10 Hz, recorded at host times 5.0, 5.1, ... 5.9.
LogContents ten_ticks(double rate_hz = 10) {
  LogContents log;
  log.header.rate_hz = rate_hz;
  log.header.source = "sim:test";
  for (int k = 0; k < 10; ++k)
    for (uint16_t i = 0; i < 3; ++i) {
      SensorSample s;
      s.sensor = i;
      s.device_time_s = k * 0.1;
      s.host_time_s = 5.0 + k * 0.1;
      s.position_m = {float(k), float(i), 0};
      log.samples.push_back(s);
    }
  log.complete = true;
  return log;
}

std::unique_ptr<ReplaySource> make(LogContents log, ReplayOptions o, std::shared_ptr<ManualClock> clock) {
  auto r = ReplaySource::create(std::move(log), o, clock);
  EXPECT_TRUE(r) << r.error().what();
  return std::move(*r);
}

int tick_of(const SensorSample& s) { return static_cast<int>(s.position_m.x); }

TEST(ReplaySource, RealTimeKeepsTheRecordedSpacing) {
  auto clock = std::make_shared<ManualClock>(100.0);
  auto src = make(ten_ticks(), {}, clock);
  std::vector<SensorSample> out(64);
  ASSERT_TRUE(src->start());
  ASSERT_EQ(src->poll(out), 3u);
  EXPECT_EQ(tick_of(out[0]), 0);
  EXPECT_DOUBLE_EQ(out[0].host_time_s, 100.0);
  clock->set(100.0999);
  EXPECT_EQ(src->poll(out), 0u);
  clock->set(100.1);
  ASSERT_EQ(src->poll(out), 3u);
  EXPECT_EQ(tick_of(out[2]), 1);
  EXPECT_EQ(out[2].sensor, 2);
  EXPECT_NEAR(out[2].host_time_s, 100.1, 1e-9);
  EXPECT_NEAR(out[2].device_time_s, 0.1, 1e-12);
  clock->set(100.45);  // ticks 2..4 are due
  ASSERT_EQ(src->poll(out), 9u);
  EXPECT_EQ(tick_of(out[8]), 4);
  EXPECT_FALSE(src->finished());
  clock->set(101.0);
  ASSERT_EQ(src->poll(out), 15u);
  EXPECT_TRUE(src->finished());
  EXPECT_EQ(src->status().state, devices::DeviceState::disconnected);
  EXPECT_EQ(src->status().records, 30u);
  clock->set(200.0);
  EXPECT_EQ(src->poll(out), 0u);
}

TEST(ReplaySource, SpeedScalesTheTimeLine) {
  auto clock = std::make_shared<ManualClock>(0.0);
  ReplayOptions o;
  o.speed = 4;
  auto src = make(ten_ticks(), o, clock);
  std::vector<SensorSample> out(64);
  ASSERT_TRUE(src->start());
  EXPECT_EQ(src->poll(out), 3u);
  clock->set(0.05);  // 0.2 s of log time
  ASSERT_EQ(src->poll(out), 6u);
  EXPECT_EQ(tick_of(out[5]), 2);
  EXPECT_NEAR(out[5].host_time_s, 0.05, 1e-9);
  EXPECT_NEAR(out[5].device_time_s, 0.2, 1e-12) << "device time stays as recorded";
}

TEST(ReplaySource, UnpacedReplayDeliversEverythingAtOnceInOrder) {
  auto clock = std::make_shared<ManualClock>(0.0);
  ReplayOptions o;
  o.speed = 0;
  o.keep_log_times = true;
  auto src = make(ten_ticks(), o, clock);
  ASSERT_TRUE(src->start());
  std::vector<SensorSample> buf(4), all;
  size_t n;
  while ((n = src->poll(buf)) > 0) all.insert(all.end(), buf.begin(), buf.begin() + static_cast<long>(n));
  ASSERT_EQ(all.size(), 30u);
  for (size_t i = 0; i < all.size(); ++i) {
    EXPECT_EQ(tick_of(all[i]), static_cast<int>(i / 3));
    EXPECT_EQ(all[i].sensor, i % 3);
    EXPECT_NEAR(all[i].host_time_s, 5.0 + static_cast<double>(i / 3) * 0.1, 1e-12);
  }
  EXPECT_TRUE(src->finished());
}

TEST(ReplaySource, FromOffsetSkipsTheBeginning) {
  auto clock = std::make_shared<ManualClock>(10.0);
  ReplayOptions o;
  o.from_s = 0.35;  // first released tick is 4 (log 5.4), 0.05 s after start
  auto src = make(ten_ticks(), o, clock);
  std::vector<SensorSample> out(64);
  ASSERT_TRUE(src->start());
  EXPECT_EQ(src->poll(out), 0u);
  clock->set(10.05);
  ASSERT_EQ(src->poll(out), 3u);
  EXPECT_EQ(tick_of(out[0]), 4);
  EXPECT_NEAR(out[0].host_time_s, 10.05, 1e-9);

  o.from_s = 0.9;  // exactly the last tick
  EXPECT_TRUE(ReplaySource::create(ten_ticks(), o, clock));
  o.from_s = 0.95;
  auto past = ReplaySource::create(ten_ticks(), o, clock);
  ASSERT_FALSE(past);
  EXPECT_EQ(past.error().code, Errc::out_of_range);
  EXPECT_NE(past.error().message.find("past the end"), std::string::npos);
  o.from_s = -1;
  EXPECT_FALSE(ReplaySource::create(ten_ticks(), o, clock));
  o = {};
  o.speed = -1;
  EXPECT_FALSE(ReplaySource::create(ten_ticks(), o, clock));
}

TEST(ReplaySource, LoopingRepeatsTheSegmentWithIncreasingTimes) {
  auto clock = std::make_shared<ManualClock>(0.0);
  ReplayOptions o;
  o.loop = true;
  o.from_s = 0.5;  // segment: ticks 5..9, cycle 0.4 + 0.1 = 0.5 s
  auto src = make(ten_ticks(), o, clock);
  EXPECT_NEAR(src->cycle_s(), 0.5, 1e-12);
  std::vector<SensorSample> out(256);
  ASSERT_TRUE(src->start());
  clock->set(1.2499);  // 2.5 passes minus a hair: ticks 5..9, 5..9, 5..7
  const size_t n = src->poll(out);
  ASSERT_EQ(n, 39u);
  const int expect_ticks[] = {5, 6, 7, 8, 9, 5, 6, 7, 8, 9, 5, 6, 7};
  double prev_host = -1, prev_device = -1;
  for (size_t t = 0; t < 13; ++t) {
    const auto& s = out[t * 3];
    EXPECT_EQ(tick_of(s), expect_ticks[t]) << t;
    EXPECT_NEAR(s.host_time_s, 0.1 * static_cast<double>(t), 1e-9) << t;
    EXPECT_GT(s.host_time_s, prev_host);
    EXPECT_GT(s.device_time_s, prev_device);
    prev_host = s.host_time_s;
    prev_device = s.device_time_s;
  }
  EXPECT_EQ(src->loops_completed(), 2u);
  EXPECT_FALSE(src->finished());
  EXPECT_EQ(src->status().state, devices::DeviceState::streaming);
}

TEST(ReplaySource, LoopPeriodFallsBackToTheMeanSpacing) {
  auto clock = std::make_shared<ManualClock>(0.0);
  ReplayOptions o;
  o.loop = true;
  auto src = make(ten_ticks(/*rate_hz=*/0), o, clock);
  EXPECT_NEAR(src->cycle_s(), 1.0, 1e-9);
}

TEST(ReplaySource, DamagedLogReplaysUpToTheDamageAndSaysWhere) {
  std::vector<uint8_t> bytes;
  LogHeader h;
  h.source = "sim:test";
  encode_log_prefix(h, bytes);
  for (int k = 0; k < 5; ++k) {
    SensorSample s;
    s.host_time_s = k * 0.01;
    encode_sample_record(s, bytes);
  }
  const size_t cut = bytes.size() - 10;  // the last sample loses its tail
  const auto dir = std::filesystem::temp_directory_path() / ("mimic_replay_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "damaged.mlog").string();
  ASSERT_TRUE(write_file_atomic(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), cut)));
  auto clock = std::make_shared<ManualClock>(0.0);
  ReplayOptions o;
  o.speed = 0;
  auto src = ReplaySource::open(path, o, clock);
  ASSERT_TRUE(src) << src.error().what();
  std::vector<SensorSample> out(16);
  ASSERT_TRUE((*src)->start());
  EXPECT_EQ((*src)->poll(out), 4u);
  EXPECT_NE((*src)->status().last_error.find("damage at byte " + std::to_string(bytes.size() - 63)), std::string::npos)
      << (*src)->status().last_error;
  EXPECT_FALSE(ReplaySource::open((dir / "nope.mlog").string(), o, clock));
}

TEST(ReplaySource, EmptyLogFinishesAtOnceAndPollNeverAllocates) {
  auto clock = std::make_shared<ManualClock>(0.0);
  auto empty = make(LogContents{}, {}, clock);
  std::vector<SensorSample> out(8);
  ASSERT_TRUE(empty->start());
  EXPECT_TRUE(empty->finished());
  EXPECT_EQ(empty->poll(out), 0u);

  ReplayOptions o;
  o.loop = true;
  auto src = make(ten_ticks(), o, clock);
  ASSERT_TRUE(src->start());
  const uint64_t before = thread_allocation_count();
  for (int i = 0; i < 100; ++i) {
    clock->advance(0.05);
    src->poll(out);
  }
  EXPECT_EQ(thread_allocation_count(), before);
}

}  // namespace
}  // namespace mimic::sim::replay_test
