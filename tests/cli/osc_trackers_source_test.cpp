// `--source osc-trackers:PORT` end to end: liblo's oscsend (a third-party OSC implementation)
// sends VRChat-style OSC tracker messages for a person standing still — head, hip, chest, feet,
// knees, elbows as SlimeVR assigns them, in Unity's frame with Euler degrees — to a running
// `mimic run`, which solves its avatar from them; the test reads the avatar back over VRPN.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <map>
#include <string>
#include <thread>

#include "mimic/net/vrpn_client.h"
#include "free_port.h"
#include "mimic_proc.h"

namespace osc_trackers_source_test {

namespace {

using mimic::net::VrpnTrackerRemote;
using mimic::test::Proc;

TEST(OscTrackersSource, LibloTrackersPlaceTheSolvedAvatar) {
  if (std::system("command -v oscsend > /dev/null") != 0) GTEST_SKIP() << "oscsend (liblo-tools) missing";
  const uint16_t osc = mimic::test::free_port(SOCK_DGRAM), vrpn = mimic::test::free_port(SOCK_STREAM);
  Proc run({"run", "--listen", "127.0.0.1:0", "--source", "osc-trackers:127.0.0.1:" + std::to_string(osc), "--vrpn",
            "127.0.0.1:" + std::to_string(vrpn), "--duration", "60"});
  ASSERT_EQ(run.first_line(30).rfind("serving on ", 0), 0u);
  // Unity's frame: +X is the person's right. Standing, facing +Z.
  const std::map<std::string, std::string> at = {
      {"head", "0 1.62 0"},     {"1", "0 0.98 -0.05"},   {"2", "0 1.30 0.08"},
      {"3", "-0.10 0.07 0.05"}, {"4", "0.10 0.07 0.05"}, {"5", "-0.10 0.50 0.06"},
      {"6", "0.10 0.50 0.06"},  {"7", "-0.22 1.10 0"},   {"8", "0.22 1.10 0"}};
  VrpnTrackerRemote::Options o;
  o.tracker = *mimic::net::parse_vrpn_address("Avatar0@127.0.0.1:" + std::to_string(vrpn));
  auto remote = std::move(*mimic::net::VrpnTrackerRemote::create(o));
  std::map<int, glm::dvec3> joints;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(40);
  for (int round = 0; std::chrono::steady_clock::now() < end && (round < 8 || joints.size() < 2); ++round) {
    for (const auto& [which, xyz] : at) {
      const std::string base = "oscsend 127.0.0.1 " + std::to_string(osc) + " /tracking/trackers/" + which;
      ASSERT_EQ(std::system((base + "/position fff " + xyz).c_str()), 0);
      ASSERT_EQ(std::system((base + "/rotation fff 0 0 0").c_str()), 0);
    }
    std::array<mimic::net::VrpnReport, 64> r;
    std::array<mimic::net::VrpnButtonEvent, 2> b;
    size_t nb = 0;
    for (int k = 0; k < 50; ++k) {
      const size_t n = remote->poll(r, b, nb);
      for (size_t i = 0; i < n; ++i) joints[r[i].sensor] = r[i].position;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  }
  ASSERT_TRUE(joints.count(0)) << run.err();
  // The pelvis where the hip tracker is (within the layout's strap offset), the head above it.
  EXPECT_NEAR(joints[0].y, 0.98, 0.12);
  EXPECT_NEAR(joints[0].x, 0.0, 0.08);
  const int head = 18;  // docs/vrpn.md: Avatar<i>'s sensor numbers
  ASSERT_TRUE(joints.count(head));
  EXPECT_GT(joints[head].y, joints[0].y + 0.4);
}

}  // namespace

}  // namespace osc_trackers_source_test
