// Network trackers record, calibrate and replay like any other source: a VRPN tracker (the
// independent test peer, and Mimic's own VRPN server in another process) and VRChat-style OSC
// trackers (liblo's oscsend) into `mimic record` and `mimic calibrate`, then the log back through
// `mimic record --source replay:` and `mimic run`.
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "free_port.h"
#include "mimic/net/vrpn_client.h"
#include "mimic/sim/log.h"
#include "mimic_proc.h"
#include "run_mimic.h"
#include "vrpn_test_server.h"

namespace record_network_test {

namespace {

using mimic::test::Outcome;
using mimic::test::Proc;
using mimic::test::run_mimic;

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("net_" + name + "." + std::to_string(::getpid()))).string();
}

// Sensor i of the peer, in the sender's frame: millimetres, Z up (as OptiTrack Motive and Vicon
// Tracker set up by default), for a person standing at the origin facing the sender's +Y.
const double kSenderMm[3][3] = {{0, 0, 1650}, {-700, 50, 1400}, {700, 50, 1400}};

TEST(RecordNetwork, AVrpnTrackerRecordsWithItsMountsAndReplaysIdentically) {
  ::mimic::test::vrpn::Server peer({"Tracker0"});
  ASSERT_TRUE(peer.ok());
  const std::string log = temp_path("vrpn.mlog"), again = temp_path("vrpn_again.mlog");
  std::filesystem::remove(log);
  // Z-up millimetres → Mimic's Y up, metres: the sender's X, Y, Z become Mimic's x, -z, y.
  const std::string spec =
      "vrpn:Tracker0@127.0.0.1:" + std::to_string(peer.port()) + "?layout=3&axes=x,-z,y&scale=0.001";
  Proc record({"record", "--source", spec, "--duration", "3", "--out", log, "--quiet"});
  int status = -1;
  const double quat[4] = {0, 0, 0, 1};
  for (uint32_t k = 0; status < 0 && k < 4000; ++k) {
    for (int s = 0; s < 3; ++s)
      peer.send_pos_quat("Tracker0", s, kSenderMm[s], quat, 1000 + k / 100, (k % 100) * 10000);
    status = record.wait(0.01);
  }
  if (status < 0) status = record.wait(30);
  ASSERT_EQ(status, 0) << record.err();

  auto contents = mimic::sim::read_log(log);
  ASSERT_TRUE(contents) << contents.error().what();
  // The header says where each sensor was worn (layout 3: head and both hands), so a replay
  // solves them there.
  const auto& h = contents->header;
  EXPECT_EQ(h.source, spec);
  ASSERT_EQ(h.sensors.size(), 3u);
  std::map<uint16_t, std::string> name, segment;
  for (const auto& s : h.sensors) name[s.id] = s.name, segment[s.id] = s.segment;
  EXPECT_EQ(segment[0], "head");
  EXPECT_EQ(name[1], "l_hand");
  EXPECT_EQ(segment[1], "l_wrist");
  EXPECT_EQ(name[2], "r_hand");
  // Every sample is the peer's report in Mimic's frame and units.
  ASSERT_GT(contents->samples.size(), 30u);
  for (const auto& sample : contents->samples) {
    ASSERT_LT(sample.sensor, 3);
    const double* mm = kSenderMm[sample.sensor];
    EXPECT_NEAR(sample.position_m.x, mm[0] / 1000, 1e-5);
    EXPECT_NEAR(sample.position_m.y, mm[2] / 1000, 1e-5);
    EXPECT_NEAR(sample.position_m.z, -mm[1] / 1000, 1e-5);
  }

  // Replayed unpaced and recorded again: the same samples and the same sensors.
  const Outcome r = run_mimic("record --source 'replay:" + log + "?speed=0' --out " + again + " --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  auto replayed = mimic::sim::read_log(again);
  ASSERT_TRUE(replayed) << replayed.error().what();
  ASSERT_EQ(replayed->samples.size(), contents->samples.size());
  for (size_t i = 0; i < contents->samples.size(); ++i) {
    EXPECT_EQ(replayed->samples[i].sensor, contents->samples[i].sensor) << i;
    EXPECT_EQ(replayed->samples[i].position_m, contents->samples[i].position_m) << i;
    EXPECT_EQ(replayed->samples[i].orientation, contents->samples[i].orientation) << i;
  }
  ASSERT_EQ(replayed->header.sensors.size(), 3u);
  EXPECT_EQ(replayed->header.sensors[0].segment, h.sensors[0].segment);

  // And the log drives the solver: the solved head stands under its sensor (read back over VRPN).
  const uint16_t out = mimic::test::free_port(SOCK_STREAM);
  Proc run({"run", "--listen", "127.0.0.1:0", "--quiet", "--source", "replay:" + log + "?loop=1", "--vrpn",
            "127.0.0.1:" + std::to_string(out), "--duration", "30"});
  ASSERT_EQ(run.first_line(30).rfind("serving on ", 0), 0u) << run.err();
  mimic::net::VrpnTrackerRemote::Options o;
  o.tracker = *mimic::net::parse_vrpn_address("Avatar0@127.0.0.1:" + std::to_string(out));
  auto remote = std::move(*mimic::net::VrpnTrackerRemote::create(o));
  const int head = 18;  // docs/vrpn.md: Avatar<i>'s sensor numbers are joint indices
  // The head sensor sits 16 cm above the head joint (the layout's strap place). The first
  // reports may come before the replay's first samples are solved (the body still in its
  // rest pose, a loaded machine's start): the newest report is read until it stands there.
  const glm::dvec3 expected(kSenderMm[0][0] / 1000, kSenderMm[0][2] / 1000 - 0.16, -kSenderMm[0][1] / 1000);
  std::optional<glm::dvec3> head_at;
  std::array<mimic::net::VrpnReport, 64> reports;
  std::array<mimic::net::VrpnButtonEvent, 2> buttons;
  const auto there = [&] { return head_at && glm::length(*head_at - expected) < 0.1; };
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!there() && std::chrono::steady_clock::now() < end) {
    size_t nb = 0;
    const size_t n = remote->poll(reports, buttons, nb);
    for (size_t i = 0; i < n; ++i)
      if (reports[i].sensor == head) head_at = reports[i].position;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_TRUE(head_at) << run.err();
  EXPECT_NEAR(head_at->x, kSenderMm[0][0] / 1000, 0.1);
  EXPECT_NEAR(head_at->y, kSenderMm[0][2] / 1000 - 0.16, 0.1);
  EXPECT_NEAR(head_at->z, -kSenderMm[0][1] / 1000, 0.1);
  std::filesystem::remove(log);
  std::filesystem::remove(again);
}

// The chain the hardware guide describes, with Mimic's own VRPN server standing in for the
// tracker's: a standing person's six sensors served as `Sensors0`, calibrated from over VRPN.
TEST(RecordNetwork, CalibrateReadsAVrpnTracker) {
  const uint16_t vrpn = mimic::test::free_port(SOCK_STREAM);
  Proc sender({"run", "--listen", "127.0.0.1:0", "--source", "sim:idle?sensors=6", "--vrpn",
               "127.0.0.1:" + std::to_string(vrpn), "--duration", "120", "--quiet"});
  ASSERT_EQ(sender.first_line(30).rfind("serving on ", 0), 0u) << sender.err();
  const std::string out = temp_path("calib.json");
  std::filesystem::remove(out);
  const Outcome r = run_mimic("calibrate --source 'vrpn:Sensors0@127.0.0.1:" + std::to_string(vrpn) +
                              "?layout=6' --out " + out + " --countdown 0.5 --seconds 0.5 --max-motion-deg 15");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("sensors 6/6"), std::string::npos) << r.output;
  std::ifstream in(out);
  const auto j = nlohmann::json::parse(in);
  ASSERT_EQ(j.at("sensors").size(), 6u);
  // Mimic's default body is 1.75 m tall; the calibration measures the wearer from the sensors.
  EXPECT_NEAR(j.at("height_m").get<double>(), 1.75, 0.12);
  std::filesystem::remove(out);
}

TEST(RecordNetwork, OscTrackersRecordWithSlimeVrsAssignment) {
  if (std::system("command -v oscsend > /dev/null") != 0) GTEST_SKIP() << "oscsend (liblo-tools) missing";
  const uint16_t osc = mimic::test::free_port(SOCK_DGRAM);
  const std::string log = temp_path("osc.mlog");
  std::filesystem::remove(log);
  Proc record({"record", "--source", "osc-trackers:127.0.0.1:" + std::to_string(osc), "--duration", "4", "--out", log,
               "--quiet"});
  int status = -1;
  for (int round = 0; status < 0 && round < 400; ++round) {
    for (const char* which : {"head", "1"}) {
      const std::string base = "oscsend 127.0.0.1 " + std::to_string(osc) + " /tracking/trackers/" + which;
      const std::string y = std::string(which) == "head" ? "1.62" : "0.98";
      ASSERT_EQ(std::system((base + "/position fff 0.1 " + y + " 0.2").c_str()), 0);
      ASSERT_EQ(std::system((base + "/rotation fff 0 90 0").c_str()), 0);
    }
    status = record.wait(0.05);
  }
  if (status < 0) status = record.wait(30);
  ASSERT_EQ(status, 0) << record.err();
  auto contents = mimic::sim::read_log(log);
  ASSERT_TRUE(contents) << contents.error().what();
  std::map<uint16_t, std::string> segment;
  for (const auto& s : contents->header.sensors) segment[s.id] = s.segment;
  EXPECT_EQ(segment[0], "head");
  EXPECT_EQ(segment[1], "pelvis");
  std::map<uint16_t, int> count;
  for (const auto& s : contents->samples) {
    if (s.flags & mimic::devices::kSampleStale) continue;  // a gap between oscsend's rounds
    ++count[s.sensor];
    // Unity's frame is left-handed with +X to the right: Mimic's +X is the left, so x flips.
    EXPECT_NEAR(s.position_m.x, -0.1, 1e-4);
    EXPECT_NEAR(s.position_m.y, s.sensor == 0 ? 1.62 : 0.98, 1e-4);
  }
  EXPECT_GT(count[0], 3);
  EXPECT_GT(count[1], 3);
  std::filesystem::remove(log);
}

TEST(RecordNetwork, VmcBonesAreAPoseAndSayHowToRecordDevices) {
  const Outcome r = run_mimic("record --source vmc:127.0.0.1:0 --out " + temp_path("bones.mlog") + " --duration 1");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("map=SERIAL:SEGMENT"), std::string::npos) << r.output;
}

}  // namespace

}  // namespace record_network_test
