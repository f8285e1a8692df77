// End to end: `mimic run --vrpn PORT` serves the avatar as VRPN trackers; a client written from
// VRPN's documented wire format (tests/support/vrpn_test_client.h) connects the way VRPN's own
// clients do by default (a UDP request, then the server calls back over TCP) and reads Avatar0
// (one sensor per joint) and Sensors0 (the tracker samples) as UDP datagrams.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <map>
#include <set>
#include <thread>

#include "mimic/rig/skeleton.h"
#include "free_port.h"
#include "run_mimic.h"
#include "vrpn_test_client.h"

namespace vrpn_cli_test {

namespace {

using mimic::test::Child;

TEST(VrpnCli, RunServesAvatarJointsAndSensorSamples) {
  const uint16_t port = mimic::test::free_tcp_udp_port();
  ASSERT_NE(port, 0);
  Child run({mimic::test::mimic_binary(), "run", "--listen", "127.0.0.1:0", "--vrpn", std::to_string(port), "--quiet",
             "--duration", "20", "--json"});
  ASSERT_GT(run.pid, 0);
  const std::string first = run.line();
  ASSERT_EQ(first.rfind("serving on ", 0), 0u) << first;

  mimic::test::vrpn::Client c;
  const auto nap = [] { std::this_thread::sleep_for(std::chrono::milliseconds(1)); };
  ASSERT_TRUE(c.connect_lob(port, nap));
  c.handshake({"Avatar0", "Sensors0"}, true);
  const auto skeleton = *mimic::rig::Skeleton::build(mimic::rig::default_skeleton_desc());
  const size_t joints = size_t(skeleton.joint_count());
  std::map<std::string, std::map<int, int>> counts;
  c.pump(nap, 10, [&] {
    counts.clear();
    for (const auto& r : c.reports) counts[r.device][r.sensor]++;
    if (counts["Avatar0"].size() < joints || counts["Sensors0"].size() < 6) return false;
    for (const auto& [s, n] : counts["Avatar0"])
      if (n < 30) return false;
    return true;
  });
  ASSERT_EQ(counts["Avatar0"].size(), joints);
  ASSERT_EQ(counts["Sensors0"].size(), 6u);  // sim:walk wears the 6-sensor layout
  EXPECT_EQ(c.server_cookie.substr(0, 14), "vrpn: ver. 07.");
  EXPECT_GT(c.datagrams, 0u);
  EXPECT_LE(c.max_datagram, 1472u);
  EXPECT_EQ(c.bad_datagrams, 0u);

  // The reports are the walking body: unit quaternions, the head above the pelvis by about the
  // trunk's length, the feet near the floor, timestamps on the wall clock.
  const double now_s = double(
      std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count());
  const int head = skeleton.find_joint("head"), pelvis = skeleton.find_joint("pelvis"),
            l_ankle = skeleton.find_joint("l_ankle");
  std::map<int, mimic::test::vrpn::Report> last;
  for (const auto& r : c.reports) {
    const double qn =
        std::sqrt(r.quat[0] * r.quat[0] + r.quat[1] * r.quat[1] + r.quat[2] * r.quat[2] + r.quat[3] * r.quat[3]);
    EXPECT_NEAR(qn, 1.0, 1e-3) << r.device << " " << r.sensor;
    EXPECT_NEAR(double(r.seconds), now_s, 30.0);
    EXPECT_TRUE(r.udp);
    if (r.device == "Avatar0") last[r.sensor] = r;
  }
  EXPECT_GT(last[head].pos[1] - last[pelvis].pos[1], 0.4);
  EXPECT_LT(last[head].pos[1] - last[pelvis].pos[1], 0.8);
  EXPECT_LT(last[l_ankle].pos[1], 0.25);
  EXPECT_GT(last[pelvis].pos[1], 0.7);

  c.ping(0);
  c.pump(nap, 3, [&] { return c.pongs > 0; });
  EXPECT_GE(c.pongs, 1);
  // Past the run's 100 warm-up frames, so the allocation count below covers frames sent to us.
  c.pump(nap, 1.5, [] { return false; });

  ASSERT_EQ(::kill(run.pid, SIGINT), 0);
  const std::string rest = run.rest();
  EXPECT_EQ(run.wait(), 0);
  const size_t json_at = rest.rfind("{\"avatars\"");  // the summary line
  ASSERT_NE(json_at, std::string::npos) << rest;
  const auto j = nlohmann::json::parse(rest.substr(json_at));
  EXPECT_EQ(j["vrpn"]["connections"].get<int>(), 1);
  EXPECT_GT(j["vrpn"]["reports"].get<int>(), 20 * int(joints));
  EXPECT_EQ(j["loop_allocations"].get<int>(), 0);  // the VRPN output allocates nothing per frame
}

}  // namespace

}  // namespace vrpn_cli_test
