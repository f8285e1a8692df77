// End to end through two processes: one `mimic run` walks a simulated body and serves its tracker
// samples over VRPN (`--vrpn`, device Sensors0); a second `mimic run --source vrpn:Sensors0@…`
// reads them as VRPN's clients do and solves its own avatar from them. Both serve their avatars
// over VRPN too, and the test reads both with Mimic's VRPN remote: the second avatar follows the
// first within the solver's accuracy for the 6-sensor layout. Then the first process is killed and
// started again on the same port: the second shows its source stale, then recovers by itself.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <thread>

#include "mimic/net/vrpn_client.h"
#include "mimic/rig/skeleton.h"
#include "free_port.h"
#include "mimic_proc.h"

namespace vrpn_source_test {

namespace {

using mimic::net::VrpnReport;
using mimic::net::VrpnTrackerRemote;
using mimic::test::Proc;

// Avatar0's frames served on `port`, by capture time: every joint's world position.
struct Watch {
  std::unique_ptr<VrpnTrackerRemote> remote;
  std::map<double, std::map<int, glm::dvec3>> frames;
  explicit Watch(uint16_t port) {
    VrpnTrackerRemote::Options o;
    o.tracker = *mimic::net::parse_vrpn_address("Avatar0@127.0.0.1:" + std::to_string(port));
    o.retry_after_s = 0.2;
    remote = std::move(*VrpnTrackerRemote::create(o));
  }
  void poll() {
    std::array<VrpnReport, 64> r;
    std::array<mimic::net::VrpnButtonEvent, 4> b;
    size_t nb = 0;
    for (size_t n; (n = remote->poll(r, b, nb)) > 0;)
      for (size_t i = 0; i < n; ++i) frames[r[i].capture_unix_s][r[i].sensor] = r[i].position;
  }
  double newest() const { return frames.empty() ? 0 : frames.rbegin()->first; }
};

double unix_now_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::vector<std::string> sender_args(uint16_t vrpn_port) {
  return {"run",
          "--listen",
          "127.0.0.1:0",
          "--source",
          "sim:walk?sensors=6&seed=5",
          "--vrpn",
          "127.0.0.1:" + std::to_string(vrpn_port),
          "--quiet",
          "--duration",
          "60"};
}

TEST(VrpnSource, ASecondMimicSolvesTheFirstOnesTrackersOverVrpn) {
  const uint16_t a_port = mimic::test::free_tcp_udp_port(), b_port = mimic::test::free_tcp_udp_port();
  ASSERT_NE(a_port, 0);
  ASSERT_NE(b_port, 0);
  auto a = std::make_unique<Proc>(sender_args(a_port));
  ASSERT_EQ(a->first_line(30).rfind("serving on ", 0), 0u);
  Proc b({"run", "--listen", "127.0.0.1:0", "--source",
          "vrpn:Sensors0@127.0.0.1:" + std::to_string(a_port) + "?layout=6", "--vrpn",
          "127.0.0.1:" + std::to_string(b_port), "--duration", "60", "--json"});
  ASSERT_EQ(b.first_line(30).rfind("serving on ", 0), 0u);

  // Frames of the two avatars captured within 2 ms of each other (each process stamps its frames
  // when it solves them; the second solves the first's samples a fraction of a millisecond
  // later): the second avatar's joints near the first's (the first solves with the simulated
  // rig's exact mounts, the second with the layout's instructed ones; both walk the same samples).
  Watch wa(a_port), wb(b_port);
  const size_t joints = size_t(mimic::rig::Skeleton::build(mimic::rig::default_skeleton_desc())->joint_count());
  std::vector<double> mean_error_m;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(40);
  while (mean_error_m.size() < 50 && std::chrono::steady_clock::now() < end) {
    wa.poll();
    wb.poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    mean_error_m.clear();
    for (const auto& [t, jb] : wb.frames) {
      auto near = wa.frames.lower_bound(t - 0.002);
      if (near == wa.frames.end() || near->first > t + 0.002 || near->second.size() != joints || jb.size() != joints)
        continue;
      double sum = 0;
      for (size_t j = 0; j < joints; ++j) sum += glm::distance(near->second.at(int(j)), jb.at(int(j)));
      mean_error_m.push_back(sum / double(joints));
    }
  }
  ASSERT_GE(mean_error_m.size(), 50u) << "the two avatars were not both seen";
  std::sort(mean_error_m.begin(), mean_error_m.end());
  const double median_m = mean_error_m[mean_error_m.size() / 2];
  std::printf("second avatar from the first's trackers over VRPN: median mean joint distance %.1f mm (%zu frames)\n",
              median_m * 1e3, mean_error_m.size());
  EXPECT_LT(median_m, 0.05) << "median of the mean joint distance";

  // The sender dies: the second keeps running, its source silent (its avatar's frames go out
  // stale); a new sender on the same port is found again without anything done.
  a.reset();
  b.wait_for_err("\n", 0.5);  // what it printed while the sender lived
  ASSERT_TRUE(b.wait_for_err("SILENT", 30, b.err().size())) << "the source should show silent:\n" << b.err();
  const double restarted = unix_now_s();
  a = std::make_unique<Proc>(sender_args(a_port));
  ASSERT_EQ(a->first_line(30).rfind("serving on ", 0), 0u);
  const auto again = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (wb.newest() <= restarted + 0.5 && std::chrono::steady_clock::now() < again) {
    wb.poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_GT(wb.newest(), restarted + 0.5) << "the second avatar should move again";
  b.signal(SIGINT);
  ASSERT_EQ(b.wait(30), 0) << b.err();
  const std::string out = b.out();
  const auto report = nlohmann::json::parse(out.substr(out.find('{')), nullptr, false);
  ASSERT_FALSE(report.is_discarded());
  ASSERT_TRUE(report.contains("sources")) << out;
  EXPECT_GE(report["sources"][0]["reconnects"].get<int>(), 1) << report.dump();
  EXPECT_NE(report["sources"][0]["description"].get<std::string>().find("vrpn:Sensors0@"), std::string::npos);
}

}  // namespace

}  // namespace vrpn_source_test
