#include "mimic/sim/open_source.h"

#include <gtest/gtest.h>

#include "mimic/sim/sim_source.h"
#include "test_data.h"
#include "test_motion.h"

namespace mimic::sim::open_source_test {
namespace {

devices::SourceSpec spec(const char* text) {
  auto s = devices::parse_source_spec(text);
  EXPECT_TRUE(s) << text << ": " << s.error().what();
  return *s;
}

TEST(SourceParams, RigParametersFromASpec) {
  const auto motion = test::swing_motion();
  auto c = rig_config_from_spec(
      spec("sim:walk?sensors=11&rate=120&noise_mm=2.5&noise_deg=0.25&drift_mm=0.5&drift_deg=0.1&latency_ms=30&"
           "dropout=0.1&burst=3&seed=9"),
      motion->skeleton());
  ASSERT_TRUE(c) << c.error().what();
  EXPECT_EQ(c->sensors.size(), 11u);
  EXPECT_EQ(c->rate_hz, 120.0);
  EXPECT_EQ(c->position_noise_mm, 2.5);
  EXPECT_EQ(c->orientation_noise_deg, 0.25);
  EXPECT_EQ(c->bias_walk_mm_per_sqrt_s, 0.5);
  EXPECT_EQ(c->bias_walk_deg_per_sqrt_s, 0.1);
  EXPECT_DOUBLE_EQ(c->latency_s, 0.030);
  EXPECT_EQ(c->dropout_probability, 0.1);
  EXPECT_EQ(c->dropout_burst, 3);
  EXPECT_EQ(c->seed, 9u);
}

TEST(SourceParams, DefaultsAreARealisticTracker) {
  const auto motion = test::swing_motion();
  auto c = rig_config_from_spec(spec("sim:walk"), motion->skeleton());
  ASSERT_TRUE(c);
  EXPECT_EQ(c->sensors.size(), 6u);
  EXPECT_EQ(c->rate_hz, 100.0);
  EXPECT_EQ(c->position_noise_mm, 1.0);
  EXPECT_EQ(c->orientation_noise_deg, 0.5);
  EXPECT_EQ(c->latency_s, 0.0);
  EXPECT_EQ(c->dropout_probability, 0.0);
  EXPECT_EQ(c->seed, 1u);
  EXPECT_EQ(rig_config_from_spec(spec("sim:walk?sensors=all"), motion->skeleton())->sensors.size(),
            static_cast<size_t>(motion->skeleton().joint_count()));
}

TEST(SourceParams, BadValuesAreRejectedWithTheirName) {
  for (const char* bad : {"sim:walk?sensors=5", "sim:walk?dropout=2", "sim:walk?noise_mm=-1", "sim:walk?rate=abc",
                          "sim:walk?burst=0", "replay:x.mlog?speed=-2", "sim:walk?noise=3"}) {
    auto s = devices::parse_source_spec(bad);
    EXPECT_FALSE(s) << bad;
  }
}

TEST(SourceParams, ReplayOptionsFromASpec) {
  auto o = replay_options_from_spec(spec("replay:session.mlog?speed=2.5&loop=yes&from=12"));
  ASSERT_TRUE(o);
  EXPECT_EQ(o->speed, 2.5);
  EXPECT_TRUE(o->loop);
  EXPECT_EQ(o->from_s, 12.0);
  o = replay_options_from_spec(spec("replay:session.mlog"));
  EXPECT_EQ(o->speed, 1.0);
  EXPECT_FALSE(o->loop);
  EXPECT_EQ(o->from_s, 0.0);
}

TEST(SourceParams, LogHeaderDescribesASimulatedSource) {
  const auto motion = test::swing_motion();
  const auto s = spec("sim:swing?sensors=3&seed=4&rate=50");
  auto rig = SensorRig::create(motion, *rig_config_from_spec(s, motion->skeleton())).value();
  SimSource source(std::move(rig), std::make_shared<ManualClock>(), "sim:swing, 3 sensors");
  const LogHeader h = log_header_for(s, source);
  EXPECT_EQ(h.source, "sim:swing?sensors=3&seed=4&rate=50");
  EXPECT_EQ(h.device, "sim:swing, 3 sensors");
  EXPECT_EQ(h.seed, 4u);
  EXPECT_EQ(h.rate_hz, 50.0);
  ASSERT_EQ(h.sensors.size(), 3u);
  EXPECT_EQ(h.sensors[2].name, "r_hand");
  EXPECT_EQ(h.sensors[2].segment, "r_wrist");
  EXPECT_EQ(h.sensors[2].id, 2);
  EXPECT_NE(h.description.find("swing"), std::string::npos);
}

TEST(SourceParams, LogHeaderOfAReplayKeepsTheOriginalLayout) {
  LogContents log;
  log.header.source = "flock:/dev/ttyUSB0?birds=2";
  log.header.sensors = {{1, "bird1", "", {}}, {2, "bird2", "", {}}};
  log.header.rate_hz = 103.3;
  log.header.calibration_json = "{}";
  auto replay = ReplaySource::create(log, {}, std::make_shared<ManualClock>()).value();
  const LogHeader h = log_header_for(spec("replay:old.mlog"), *replay);
  EXPECT_EQ(h.source, "replay:old.mlog");
  ASSERT_EQ(h.sensors.size(), 2u);
  EXPECT_EQ(h.sensors[1].id, 2);
  EXPECT_EQ(h.rate_hz, 103.3);
  EXPECT_EQ(h.calibration_json, "{}");
  EXPECT_NE(h.description.find("flock:/dev/ttyUSB0"), std::string::npos);
}

}  // namespace
}  // namespace mimic::sim::open_source_test

namespace mimic::sim::open_source_test {
namespace {

std::vector<devices::SensorSample> poll_all(devices::SensorSource& source) {
  std::vector<devices::SensorSample> all, buf(64);
  size_t n;
  while ((n = source.poll(buf)) > 0) all.insert(all.end(), buf.begin(), buf.begin() + static_cast<long>(n));
  return all;
}

TEST(OpenSensorSource, SimOnTheBuiltInWalk) {
  auto clock = std::make_shared<ManualClock>(50.0);
  auto source = open_sensor_source(spec("sim:walk?sensors=3&rate=50&seed=3"), clock);
  ASSERT_TRUE(source) << source.error().what();
  ASSERT_TRUE((*source)->start());
  clock->set(50.5);  // ticks 0..25
  const auto samples = poll_all(**source);
  ASSERT_EQ(samples.size(), 26u * 3u);
  EXPECT_NEAR(samples.back().host_time_s, 50.5, 1e-9);
  EXPECT_GT(samples[0].position_m.y, 1.4f) << "the head sensor rides at head height";
  EXPECT_NE((*source)->status().description.find("sim:walk"), std::string::npos);
  // The walk moves forward.
  EXPECT_GT(std::abs(samples.back().position_m.z - samples[0].position_m.z), 0.1f);
  const auto* sim = dynamic_cast<const SimSource*>(source->get());
  ASSERT_NE(sim, nullptr);
  EXPECT_EQ(sim->rig().config().seed, 3u);
  EXPECT_EQ(open_sensor_source(spec("sim:moonwalk"), clock).error().code, Errc::not_found);
}

TEST(OpenSensorSource, BvhClipDrivesTheRig) {
  const std::string clip = test::shared_data("bvh/02_04.bvh");
  auto clock = std::make_shared<ManualClock>(0.0);
  auto source = open_sensor_source(*devices::parse_source_spec("bvh:" + clip + "?sensors=6&loop=1"), clock);
  ASSERT_TRUE(source) << source.error().what();
  ASSERT_TRUE((*source)->start());
  clock->set(0.2);
  EXPECT_EQ(poll_all(**source).size(), 21u * 6u);
  auto missing = open_sensor_source(spec("bvh:/nonexistent/clip.bvh"), clock);
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find("/nonexistent/clip.bvh"), std::string::npos);
}

TEST(OpenSensorSource, NonTrackerSchemesSayWhy) {
  auto r = open_sensor_source(spec("spacemouse"));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, Errc::unsupported);
  EXPECT_NE(r.error().message.find("6-DOF input"), std::string::npos);
  EXPECT_FALSE(open_sensor_source(spec("replay:/nonexistent/x.mlog")));
}

}  // namespace
}  // namespace mimic::sim::open_source_test
