// The Flock of Birds driver against the virtual Flock on a real pseudo-terminal: no mock of the
// serial layer anywhere. Every record format, standalone and group mode, point and stream,
// faults on the line, a unit that stops answering and comes back.
#include <algorithm>
#include <map>

#include <gtest/gtest.h>

#include "flock_test_support.h"
#include "mimic/devices/flock.h"
#include "mimic/devices/source.h"

namespace mimic::devices::flock_driver_test {
namespace {

namespace fl = flock;
using namespace std::chrono_literals;

struct Rig {
  std::unique_ptr<sim::VirtualFlock> sim;
  std::unique_ptr<FlockSource> driver;
};

Rig start(sim::VirtualFlockConfig sc, const std::function<void(FlockConfig&)>& tweak = {}) {
  Rig r;
  auto f = sim::VirtualFlock::create(std::move(sc));
  EXPECT_TRUE(f) << f.error().what();
  r.sim = std::move(*f);
  EXPECT_TRUE(r.sim->start());
  FlockConfig dc = test::fast_driver(r.sim->slave_path(), 1);
  if (tweak) tweak(dc);
  r.driver = std::make_unique<FlockSource>(dc);
  auto s = r.driver->start();
  EXPECT_TRUE(s) << s.error().what();
  return r;
}

// Checks a sample against the static pose of its bird (sensor = the bird's place in address order).
void expect_pose(const SensorSample& s, fl::Format f, float scale = 1.0f) {
  const SensorSample truth = test::static_pose(s.sensor);
  EXPECT_TRUE(s.flags & kSampleValid);
  if (fl::has_position(f)) {
    EXPECT_LT(glm::length(s.position_m - truth.position_m * scale), 0.0006f * scale)
        << fl::format_name(f) << " sensor " << s.sensor;
  }
  if (f != fl::Format::position) {
    EXPECT_GT(std::abs(glm::dot(s.orientation, truth.orientation)), 0.99998f)
        << fl::format_name(f) << " sensor " << s.sensor;
  }
}

TEST(FlockDriver, EveryRecordFormatStandaloneStream) {
  for (fl::Format f : fl::kAllFormats) {
    Rig r = start(test::fast_sim(1), [f](FlockConfig& c) { c.format = f; });
    const auto got = test::collect(*r.driver, 5);
    ASSERT_GE(got.size(), 5u) << fl::format_name(f);
    for (const auto& s : got) {
      EXPECT_EQ(s.sensor, 0);  // the standalone bird (address 1) is sensor 0
      expect_pose(s, f);
      EXPECT_GT(s.host_time_s, 0.0);
    }
    for (size_t i = 1; i < got.size(); ++i) EXPECT_GE(got[i].host_time_s, got[i - 1].host_time_s);
    const DeviceStatus st = r.driver->status();
    EXPECT_EQ(st.state, DeviceState::streaming);
    EXPECT_NE(st.description.find("6DFOB 3.67"), std::string::npos) << st.description;
  }
}

// The unit's first answer comes later than the driver waits (a slow USB adapter, a loaded
// host): the driver asks again, and the late answer must not shift every later one (the model
// and revision read from the wrong bytes).
TEST(FlockDriver, ALateFirstAnswerDoesNotShiftTheOthers) {
  sim::VirtualFlockConfig sc = test::fast_sim(1);
  sc.first_reply_delay_s = 0.36;  // the driver waits 0.3 s
  Rig r = start(sc);
  const auto got = test::collect(*r.driver, 5);
  ASSERT_GE(got.size(), 5u);
  for (const auto& s : got) expect_pose(s, fl::Format::position_quaternion);
  const DeviceStatus st = r.driver->status();
  EXPECT_NE(st.description.find("6DFOB 3.67"), std::string::npos) << st.description;
}

TEST(FlockDriver, FourBirdsGroupModeEveryFormatWithButtons) {
  for (fl::Format f : fl::kAllFormats) {
    Rig r = start(test::fast_sim(4), [f](FlockConfig& c) {
      c.birds = 4;
      c.format = f;
      c.button = true;
    });
    const auto got = test::collect(*r.driver, 24);
    ASSERT_GE(got.size(), 24u) << fl::format_name(f);
    std::map<int, int> per_bird;
    for (const auto& s : got) {
      ++per_bird[s.sensor];
      expect_pose(s, f);
      EXPECT_TRUE(s.flags & kSampleButton);
      EXPECT_EQ(s.buttons, test::static_pose(s.sensor).buttons);
    }
    EXPECT_EQ(per_bird.size(), 4u);
    for (int i = 0; i < 4; ++i) EXPECT_GE(per_bird[i], 4) << i;
    if (f == fl::Format::matrix) {
      // Query a slave bird through its FBB address while the group streams.
      auto st = r.driver->query_status(3);
      ASSERT_TRUE(st) << st.error().what();
      EXPECT_FALSE(st->master);
      EXPECT_EQ(st->format, fl::Format::matrix);
      auto addr = r.driver->examine(fl::param::kFbbAddress, 3);
      ASSERT_TRUE(addr);
      EXPECT_EQ((*addr)[0], 3);
      EXPECT_GE(test::collect(*r.driver, 8).size(), 8u);  // and the stream came back
    }
    const FlockInfo info = r.driver->info();
    EXPECT_EQ(info.sensor_addresses, (std::vector<int>{1, 2, 3, 4}));
    EXPECT_EQ(info.flock_status.size(), 14u);
    EXPECT_TRUE(r.sim->stats().group_mode);
  }
}

TEST(FlockDriver, ExtendedRangeControllerScalesTo144Inches) {
  sim::VirtualFlockConfig sc = test::fast_sim(3);
  sc.erc = true;
  sc.provider = test::static_provider(3.0f);  // up to ~1.3 m away: beyond 36 in
  Rig r = start(sc, [](FlockConfig& c) {
    c.birds = 3;
    c.erc = true;
  });
  const auto got = test::collect(*r.driver, 12);
  ASSERT_GE(got.size(), 12u);
  for (const auto& s : got) {
    EXPECT_LE(s.sensor, 2);  // the ERC holds address 1; the birds at 2..4 are sensors 0..2
    expect_pose(s, fl::Format::position_quaternion, 3.0f);
  }
  EXPECT_EQ(r.driver->info().model, "6DERC");
}

TEST(FlockDriver, Range72InchesAndRates) {
  sim::VirtualFlockConfig sc = test::fast_sim(1);
  sc.provider = test::static_provider(2.0f);  // ~1 m: needs the 72 in range
  Rig r = start(sc, [](FlockConfig& c) {
    c.range_72in = true;
    c.measurement_rate_hz = 60;
    c.report_every = 2;
  });
  const auto got = test::collect(*r.driver, 4);
  ASSERT_GE(got.size(), 4u);
  for (const auto& s : got) expect_pose(s, fl::Format::position_quaternion, 2.0f);
  EXPECT_NEAR(r.driver->info().measurement_rate_hz, 60.0, 0.5);
}

TEST(FlockDriver, HemisphereSelectsWhichMirrorImageIsReported) {
  // Sensors behind the transmitter (Mimic -Z = Flock -X): right only in the aft hemisphere.
  sim::VirtualFlockConfig sc = test::fast_sim(2);
  sc.provider = [](double, int bird, SensorSample& out) {
    const SensorSample s = test::static_pose(bird);
    out.position_m = {s.position_m.x, s.position_m.y, -s.position_m.z};
  };
  for (fl::Hemisphere h : {fl::Hemisphere::aft, fl::Hemisphere::forward}) {
    Rig r = start(sc, [h](FlockConfig& c) {
      c.birds = 2;
      c.hemisphere = h;
    });
    const auto got = test::collect(*r.driver, 6);
    ASSERT_GE(got.size(), 6u);
    for (const auto& s : got) {
      const glm::vec3 p = test::static_pose(s.sensor).position_m;
      const glm::vec3 truth(p.x, p.y, -p.z);
      const glm::vec3 expected = h == fl::Hemisphere::aft ? truth : -truth;
      EXPECT_LT(glm::length(s.position_m - expected), 0.0006f) << fl::hemisphere_name(h);
    }
  }
}

TEST(FlockDriver, PointModeStandaloneGroupAndPerBird) {
  {
    Rig r = start(test::fast_sim(1), [](FlockConfig& c) {
      c.stream = false;
      c.point_rate_hz = 50;
    });
    const auto got = test::collect(*r.driver, 5);
    ASSERT_GE(got.size(), 5u);
    for (const auto& s : got) expect_pose(s, fl::Format::position_quaternion);
    EXPECT_FALSE(r.sim->stats().streaming);
  }
  {
    Rig r = start(test::fast_sim(4), [](FlockConfig& c) {
      c.birds = 4;
      c.stream = false;
      c.format = fl::Format::position_matrix;
    });
    const auto got = test::collect(*r.driver, 16);
    ASSERT_GE(got.size(), 16u);
    std::map<int, int> per_bird;
    for (const auto& s : got) {
      ++per_bird[s.sensor];
      expect_pose(s, fl::Format::position_matrix);
    }
    EXPECT_EQ(per_bird.size(), 4u);
  }
  {
    // Without group mode, each bird is polled through its FBB address; records carry no
    // address byte and the driver labels them with the bird it asked.
    Rig r = start(test::fast_sim(3), [](FlockConfig& c) {
      c.birds = 3;
      c.stream = false;
      c.group = false;
      c.format = fl::Format::position_angles;
    });
    const auto got = test::collect(*r.driver, 9);
    ASSERT_GE(got.size(), 9u);
    std::map<int, int> per_bird;
    for (const auto& s : got) {
      ++per_bird[s.sensor];
      expect_pose(s, fl::Format::position_angles);
    }
    EXPECT_EQ(per_bird.size(), 3u);
    EXPECT_FALSE(r.sim->stats().group_mode);
  }
}

TEST(FlockDriver, GarbageTornRecordsAndPhaseErrorsAreSkipped) {
  Rig r = start(test::fast_sim(4), [](FlockConfig& c) { c.birds = 4; });
  ASSERT_GE(test::collect(*r.driver, 8).size(), 8u);
  const uint64_t resyncs0 = r.driver->status().resyncs;
  for (int i = 0; i < 3; ++i) {
    r.sim->inject_garbage(30);
    r.sim->tear_next_record();
    r.sim->phase_error_next_record();
    r.sim->drop_byte_next_record();
    std::this_thread::sleep_for(30ms);
  }
  const auto got = test::collect(*r.driver, 60);
  ASSERT_GE(got.size(), 60u);
  int wrong = 0;
  for (const auto& s : got) {
    const SensorSample truth = test::static_pose(s.sensor);
    if (s.sensor > 3 || glm::length(s.position_m - truth.position_m) > 0.001f) ++wrong;
  }
  // The protocol has no checksum: a stray phased byte right after a record's first byte can
  // splice a well-formed record; everything else must be rejected.
  EXPECT_LE(wrong, 1);
  EXPECT_GE(r.driver->status().resyncs, resyncs0 + 9);
  EXPECT_GE(r.sim->stats().faults_injected, 9u);
}

TEST(FlockDriver, RandomLineFaultsDoNotStopTheStream) {
  sim::VirtualFlockConfig sc = test::fast_sim(2);
  sc.fault_rate = 0.2;
  sc.seed = 11;
  Rig r = start(sc, [](FlockConfig& c) { c.birds = 2; });
  const auto got = test::collect(*r.driver, 60);
  EXPECT_GE(got.size(), 60u);
  EXPECT_GT(r.driver->status().resyncs, 0u);
}

TEST(FlockDriver, SilentDeviceGoesStaleThenReconnects) {
  Rig r = start(test::fast_sim(2), [](FlockConfig& c) { c.birds = 2; });
  ASSERT_GE(test::collect(*r.driver, 4).size(), 4u);
  r.sim->go_silent(900ms);
  bool saw_stale = false, saw_disconnected = false;
  const auto until = std::chrono::steady_clock::now() + 3s;
  std::vector<SensorSample> buf(64);
  while (std::chrono::steady_clock::now() < until) {
    r.driver->poll(buf);
    const DeviceStatus st = r.driver->status();
    saw_stale |= st.state == DeviceState::stale;
    // Re-initialising: disconnected between attempts, connecting during them.
    saw_disconnected |= st.state == DeviceState::disconnected || st.state == DeviceState::connecting;
    if (saw_disconnected && st.state == DeviceState::streaming && st.reconnects >= 1) break;
    std::this_thread::sleep_for(5ms);
  }
  EXPECT_TRUE(saw_stale);
  EXPECT_TRUE(saw_disconnected);
  const DeviceStatus st = r.driver->status();
  EXPECT_GE(st.reconnects, 1u);
  EXPECT_EQ(st.state, DeviceState::streaming);
  const auto after = test::collect(*r.driver, 8);
  EXPECT_GE(after.size(), 8u);
}

TEST(FlockDriver, PortThatVanishesIsReportedDisconnected) {
  Rig r = start(test::fast_sim(1));
  ASSERT_GE(test::collect(*r.driver, 3).size(), 3u);
  r.sim.reset();  // the pty goes away, like a USB adapter pulled out
  const auto until = std::chrono::steady_clock::now() + 2s;
  while (std::chrono::steady_clock::now() < until && r.driver->status().state != DeviceState::disconnected)
    std::this_thread::sleep_for(5ms);
  const DeviceStatus st = r.driver->status();
  EXPECT_EQ(st.state, DeviceState::disconnected);
  EXPECT_FALSE(st.last_error.empty());
  std::vector<SensorSample> buf(16);
  r.driver->poll(buf);
  EXPECT_EQ(r.driver->poll(buf), 0u);
  r.driver->stop();  // returns promptly while the thread is retrying
}

TEST(FlockDriver, ResetDeviceIsReinitialised) {
  Rig r = start(test::fast_sim(3), [](FlockConfig& c) { c.birds = 3; });
  ASSERT_GE(test::collect(*r.driver, 6).size(), 6u);
  r.sim->reset();  // as an RTS pulse would: stream stops, configuration is lost
  const auto until = std::chrono::steady_clock::now() + 3s;
  while (std::chrono::steady_clock::now() < until && r.driver->status().reconnects == 0)
    std::this_thread::sleep_for(10ms);
  EXPECT_GE(r.driver->status().reconnects, 1u);
  std::vector<SensorSample> flush(256);
  r.driver->poll(flush);
  const auto got = test::collect(*r.driver, 9);
  ASSERT_GE(got.size(), 9u);
  for (const auto& s : got) expect_pose(s, fl::Format::position_quaternion);
  EXPECT_TRUE(r.sim->stats().configured);
}

TEST(FlockDriver, ErrorCodeQuery) {
  Rig r = start(test::fast_sim(1));
  auto e = r.driver->query_error();
  ASSERT_TRUE(e) << e.error().what();
  EXPECT_EQ(e->code, 0);
  // Another program writes a bad command byte on the same line: error 6.
  {
    test::RawHost intruder(r.sim->slave_path());
    intruder.send({'x'});
    std::this_thread::sleep_for(30ms);
  }
  e = r.driver->query_error();
  ASSERT_TRUE(e) << e.error().what();
  EXPECT_EQ(e->code, 6);
  EXPECT_EQ(e->text, "invalid RS232 command");
  // Status of each bird while streaming in group mode is in the next test; here the master.
  auto st = r.driver->query_status();
  ASSERT_TRUE(st) << st.error().what();
  EXPECT_TRUE(st->master);
  EXPECT_TRUE(st->running);
  EXPECT_EQ(st->format, fl::Format::position_quaternion);
  EXPECT_FALSE(r.driver->examine(200));  // no such parameter
  // Streaming resumes after the query.
  std::vector<SensorSample> flush(256);
  r.driver->poll(flush);
  EXPECT_GE(test::collect(*r.driver, 5).size(), 5u);
}

TEST(FlockDriver, ClearErrorsWhenNothingAnswers) {
  FlockConfig c = test::fast_driver("/dev/nonexistent-flock", 1);
  FlockSource missing(c);
  auto s = missing.start();
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().code, Errc::not_found);

  // A pty with no unit behind it: the line is there, nobody answers.
  auto silent = sim::VirtualFlock::create(test::fast_sim(1));
  ASSERT_TRUE(silent);  // created but never started
  FlockSource mute(test::fast_driver((*silent)->slave_path(), 1));
  s = mute.start();
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().code, Errc::timeout);
  EXPECT_NE(s.error().message.find("no answer to EXAMINE 0"), std::string::npos) << s.error().message;
  EXPECT_EQ(mute.status().state, DeviceState::disconnected);

  // A flock with fewer units than configured: auto-configuration leaves bird 4 out.
  auto small = sim::VirtualFlock::create(test::fast_sim(3));
  ASSERT_TRUE(small);
  ASSERT_TRUE((*small)->start());
  FlockConfig four = test::fast_driver((*small)->slave_path(), 4);
  FlockSource too_many(four);
  s = too_many.start();
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("FBB address"), std::string::npos) << s.error().message;
}

TEST(FlockDriver, ConfigFromSourceSpec) {
  auto spec =
      parse_source_spec("flock:/dev/ttyS3?birds=4&baud=38400&format=pos_matrix&mode=point&hemisphere=lower&erc=1");
  ASSERT_TRUE(spec);
  auto c = flock_config_from_spec(*spec);
  ASSERT_TRUE(c) << c.error().what();
  EXPECT_EQ(c->path, "/dev/ttyS3");
  EXPECT_EQ(c->birds, 4);
  EXPECT_EQ(c->baud, 38400);
  EXPECT_EQ(c->format, fl::Format::position_matrix);
  EXPECT_FALSE(c->stream);
  EXPECT_EQ(c->hemisphere, fl::Hemisphere::lower);
  EXPECT_TRUE(c->erc);
  FlockConfig bad;
  bad.birds = 3;
  bad.group = false;
  bad.path = "/dev/null";
  EXPECT_EQ(FlockSource(bad).start().error().code, Errc::invalid_argument);
}

TEST(FlockDriver, PollNeverBlocksAndStopIsClean) {
  Rig r = start(test::fast_sim(1));
  std::vector<SensorSample> buf(4);
  r.driver->stop();
  EXPECT_EQ(r.driver->status().state, DeviceState::disconnected);
  r.driver->poll(buf);  // leftovers, if any
  EXPECT_EQ(r.driver->poll(buf), 0u);
  // Shutdown leaves the flock asleep ('B' 'G').
  const auto until = std::chrono::steady_clock::now() + 1s;
  while (!r.sim->stats().sleeping && std::chrono::steady_clock::now() < until) std::this_thread::sleep_for(5ms);
  EXPECT_TRUE(r.sim->stats().sleeping);
}

}  // namespace
}  // namespace mimic::devices::flock_driver_test
