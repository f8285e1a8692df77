// End to end: `mimic sim flock` serves a virtual Flock of Birds on a pty; Mimic's Flock driver
// opens the printed path and reads the flock.
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "mimic/devices/flock.h"
#include "mimic/sim/log.h"
#include "run_mimic.h"
#include "test_data.h"

extern char** environ;

namespace sim_flock_cli_test {

namespace {

using namespace std::chrono_literals;

using mimic::test::Child;

std::vector<mimic::devices::SensorSample> collect(mimic::devices::SensorSource& src, size_t want) {
  std::vector<mimic::devices::SensorSample> got, buf(64);
  const auto until = std::chrono::steady_clock::now() + 5s;
  while (got.size() < want && std::chrono::steady_clock::now() < until) {
    const size_t n = src.poll(buf);
    got.insert(got.end(), buf.begin(), buf.begin() + static_cast<long>(n));
    if (n == 0) std::this_thread::sleep_for(2ms);
  }
  return got;
}

TEST(SimFlockCli, DriverReadsFourBirdsInGroupMode) {
  const std::string mimic = mimic::test::mimic_binary();
  Child sim({mimic, "sim", "flock", "--birds", "4", "--seed", "3", "--busy", "0.05"});
  ASSERT_GT(sim.pid, 0);
  const std::string path = sim.line();  // the first line is the pty path
  ASSERT_EQ(path.rfind("/dev/pts/", 0), 0u) << path;

  auto spec = mimic::devices::parse_source_spec("flock:" + path + "?birds=4&baud=115200&format=pos_quat");
  ASSERT_TRUE(spec) << spec.error().what();
  auto cfg = mimic::devices::flock_config_from_spec(*spec);
  ASSERT_TRUE(cfg) << cfg.error().what();
  cfg->auto_config_wait = 150ms;
  cfg->settle = 30ms;
  mimic::devices::FlockSource flock(*cfg);
  auto started = flock.start();
  ASSERT_TRUE(started) << started.error().what();
  const auto got = collect(flock, 40);
  ASSERT_GE(got.size(), 40u);
  std::map<int, int> per_bird;
  for (const auto& s : got) {
    ++per_bird[s.sensor];
    // The built-in body, seen from a transmitter behind it: in front (+Z), within reach.
    EXPECT_LT(glm::length(s.position_m), 1.6f);
    EXPECT_GT(s.position_m.z, -0.01f);
    EXPECT_NEAR(glm::length(s.orientation), 1.0f, 1e-3f);
  }
  EXPECT_EQ(per_bird.size(), 4u);
  const auto status = flock.status();
  EXPECT_EQ(status.state, mimic::devices::DeviceState::streaming);
  EXPECT_NE(status.description.find("6DFOB 3.67"), std::string::npos) << status.description;
  flock.stop();

  ::kill(sim.pid, SIGTERM);
  EXPECT_EQ(sim.wait(), 0);
}

TEST(SimFlockCli, ExtendedRangeWithMotionAndLog) {
  const std::string mimic = mimic::test::mimic_binary();
  const auto log = std::filesystem::temp_directory_path() / ("mimic-flock-" + std::to_string(::getpid()) + ".mlog");
  Child sim(
      {mimic, "sim", "flock", "--birds", "3", "--ert", "--motion", "idle", "--busy", "0.05", "--log", log.string()});
  ASSERT_GT(sim.pid, 0);
  const std::string path = sim.line();
  ASSERT_EQ(path.rfind("/dev/pts/", 0), 0u) << path;
  mimic::devices::FlockConfig cfg;
  cfg.path = path;
  cfg.birds = 3;
  cfg.erc = true;
  cfg.auto_config_wait = 150ms;
  cfg.settle = 30ms;
  cfg.reply_timeout = 3000ms;  // a loaded machine may start the simulator late
  mimic::devices::FlockSource flock(cfg);
  auto started = flock.start();
  ASSERT_TRUE(started) << started.error().what();
  const auto got = collect(flock, 15);
  ASSERT_GE(got.size(), 15u);
  for (const auto& s : got) EXPECT_LE(s.sensor, 2);  // birds at 2..4 behind the ERC: sensors 0..2
  EXPECT_EQ(flock.info().model, "6DERC");
  flock.stop();
  ::kill(sim.pid, SIGINT);
  EXPECT_EQ(sim.wait(), 0);
  // The log holds the poses served and the bytes both ways; the bytes the unit sent decode to
  // records of the birds the driver saw.
  auto contents = mimic::sim::read_log(log.string());
  ASSERT_TRUE(contents) << contents.error().what();
  EXPECT_TRUE(contents->complete);
  EXPECT_EQ(contents->header.sensors.size(), 3u);
  ASSERT_FALSE(contents->samples.empty());
  for (const auto& s : contents->samples) EXPECT_LE(s.sensor, 2);  // numbered as the driver numbers them
  std::vector<uint8_t> to_device, from_device;
  for (const auto& c : contents->raw) {
    auto& v = c.direction == mimic::sim::RawDirection::to_device ? to_device : from_device;
    v.insert(v.end(), c.bytes.begin(), c.bytes.end());
  }
  const std::vector<uint8_t> auto_config = {'P', 50, 4};  // 3 birds + the ERC
  EXPECT_NE(std::search(to_device.begin(), to_device.end(), auto_config.begin(), auto_config.end()), to_device.end());
  mimic::devices::flock::StreamDecoder decoder({mimic::devices::flock::Format::position_quaternion, false, true});
  decoder.set_valid_addresses(0b11100);
  size_t records = 0;
  decoder.feed(from_device, [&](const mimic::devices::flock::RawRecord&, size_t) { ++records; });
  EXPECT_GE(records, got.size());
  std::filesystem::remove(log);
}

// The documented walk travels a 1.2 m circle: the simulator places the transmitter behind it
// and adds the extended range controller, so a driver reads every sensor in range and in the
// forward hemisphere. Refusing the ERC (--no-ert) gets the saturation warning instead.
TEST(SimFlockCli, WalkDefaultsKeepSensorsInRange) {
  const std::string mimic = mimic::test::mimic_binary();
  const auto log =
      std::filesystem::temp_directory_path() / ("mimic-flock-walk-" + std::to_string(::getpid()) + ".mlog");
  Child sim({mimic, "sim", "flock", "--birds", "6", "--motion", "walk", "--busy", "0.05", "--log", log.string()}, true);
  ASSERT_GT(sim.pid, 0);
  std::string path, notes;
  for (int i = 0; i < 10 && path.empty(); ++i) {
    const std::string l = sim.line();
    if (l.rfind("/dev/pts/", 0) == 0)
      path = l;
    else
      notes += l + "\n";
  }
  ASSERT_FALSE(path.empty()) << notes;
  EXPECT_NE(notes.find("extended range controller"), std::string::npos) << notes;
  mimic::devices::FlockConfig cfg;
  cfg.path = path;
  cfg.birds = 6;
  cfg.erc = true;
  cfg.auto_config_wait = 150ms;
  cfg.settle = 30ms;
  cfg.reply_timeout = 3000ms;  // a loaded machine may start the simulator late
  mimic::devices::FlockSource flock(cfg);
  auto started = flock.start();
  ASSERT_TRUE(started) << started.error().what();
  const auto got = collect(flock, 600);
  ASSERT_GE(got.size(), 600u);
  const double pinned_m = 144 * 0.0254 * 0.999;
  for (const auto& s : got) {
    EXPECT_GE(s.position_m.z, 0.0f);  // forward hemisphere: in front of the transmitter
    for (int a = 0; a < 3; ++a) EXPECT_LT(std::abs(s.position_m[a]), pinned_m);
  }
  flock.stop();
  ::kill(sim.pid, SIGINT);
  const std::string rest = sim.rest();
  EXPECT_EQ(sim.wait(), 0);
  EXPECT_EQ(rest.find("warning"), std::string::npos) << rest;
  // The ground truth served agrees: every pose within the 144 in range, in front.
  auto contents = mimic::sim::read_log(log.string());
  ASSERT_TRUE(contents) << contents.error().what();
  ASSERT_FALSE(contents->samples.empty());
  for (const auto& s : contents->samples) {
    EXPECT_GE(s.position_m.z, 0.0f);
    for (int a = 0; a < 3; ++a) EXPECT_LT(std::abs(s.position_m[a]), pinned_m);
  }
  std::filesystem::remove(log);

  Child standard({mimic, "sim", "flock", "--birds", "6", "--motion", "walk", "--no-ert", "--busy", "0.05"}, true);
  path.clear();
  notes.clear();
  for (int i = 0; i < 10 && path.empty(); ++i) {
    const std::string l = standard.line();
    if (l.rfind("/dev/pts/", 0) == 0)
      path = l;
    else
      notes += l + "\n";
  }
  ASSERT_FALSE(path.empty()) << notes;
  EXPECT_NE(notes.find("warning: the motion spans"), std::string::npos) << notes;
  cfg.path = path;
  cfg.erc = false;
  mimic::devices::FlockSource flock36(cfg);
  started = flock36.start();
  ASSERT_TRUE(started) << started.error().what();
  EXPECT_GE(collect(flock36, 300).size(), 300u);
  flock36.stop();
  ::kill(standard.pid, SIGINT);
  const std::string summary = standard.rest();
  EXPECT_EQ(standard.wait(), 0);
  EXPECT_NE(summary.find("records saturated"), std::string::npos) << summary;
}

TEST(SimFlockCli, HelpAndBadOptions) {
  const std::string mimic = mimic::test::mimic_binary();
  {
    Child help({mimic, "sim", "flock", "--help"});
    const std::string text = help.rest();
    EXPECT_EQ(help.wait(), 0);
    for (const char* opt : {"--birds", "--motion", "--bvh", "--baud", "--ert", "--seed", "--log", "--rate", "--faults"})
      EXPECT_NE(text.find(opt), std::string::npos) << opt;
  }
  {
    Child bad({mimic, "sim", "flock", "--birds", "15"}, true);
    const std::string text = bad.rest();
    EXPECT_EQ(bad.wait(), 2);
    EXPECT_NE(text.find("--birds: Value 15 not in range 1 to 14"), std::string::npos) << text;
  }
  {
    Child bad({mimic, "sim", "flock", "--baud", "1234"}, true);
    bad.rest();
    EXPECT_EQ(bad.wait(), 2);
  }
}

}  // namespace

}  // namespace sim_flock_cli_test
