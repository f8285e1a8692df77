// End to end over loopback: `mimic subscribe` outlives its server's restarts and its own stalls.
// The server is killed and started again on the same port (a publisher in another process goes
// on meanwhile); a viewer is stopped (SIGSTOP) past the server's idle timeout and continued.
#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>

#include "mimic_proc.h"

namespace reconnect_cli_test {

namespace {

using mimic::test::endpoint_of;
using mimic::test::Proc;

nlohmann::json last_json(const std::string& out) {
  const auto start = out.rfind("\n{");
  const std::string text = start == std::string::npos ? out : out.substr(start + 1);
  return nlohmann::json::parse(text, nullptr, false);
}

void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }

// The latencies of every "pose ..." line of `mimic subscribe` (capture to arrival, ms).
std::vector<double> latencies_ms(const std::string& out) {
  std::vector<double> v;
  std::istringstream in(out.substr(0, out.rfind('\n') + 1));  // whole lines only
  for (std::string line; std::getline(in, line);) {
    const auto at = line.find(" latency_ms=");
    if (line.rfind("pose ", 0) != 0 || at == std::string::npos) continue;
    char* end = nullptr;
    const double ms = std::strtod(line.c_str() + at + 12, &end);
    EXPECT_NE(end, line.c_str() + at + 12) << "unreadable line: " << line;
    v.push_back(ms);
  }
  return v;
}

// The server dies (SIGKILL: no goodbye) and comes back 2 s later on the same port. The viewer
// stays, reconnects, and reports the outage and the frames the publisher sent meanwhile.
TEST(ReconnectCli, SubscriberOutlivesAServerRestartAndCountsWhatItMissed) {
  auto server = std::make_unique<Proc>(std::vector<std::string>{"run", "--listen", "127.0.0.1:0", "--quiet"});
  const std::string ep = endpoint_of(*server);
  ASSERT_FALSE(ep.empty()) << server->err();
  Proc guest({"run", "--publish", ep, "--source", "sim:walk?seed=3", "--duration", "40", "--quiet"});
  ASSERT_EQ(guest.first_line(20.0), "publishing into " + ep) << guest.err();
  Proc sub({"subscribe", "--connect", ep, "--duration", "14", "--json"});
  ASSERT_TRUE(sub.ok());
  sleep_s(3.0);
  server->signal(SIGKILL);
  server->wait(10.0);
  sleep_s(2.0);  // down for at least this long: no frame can come meanwhile
  server = std::make_unique<Proc>(std::vector<std::string>{"run", "--listen", ep, "--quiet"});
  ASSERT_EQ(endpoint_of(*server), ep) << server->err();
  ASSERT_EQ(sub.wait(60.0), 0) << sub.err();
  const auto j = last_json(sub.out());
  ASSERT_FALSE(j.is_discarded()) << sub.out();
  EXPECT_GE(j["cuts"].get<int>(), 1) << j.dump();
  EXPECT_GE(j["outages"].get<int>(), 1) << j.dump();
  EXPECT_GE(j["outage_s"].get<double>(), 2.0) << j.dump();
  // The guest's avatar went on at 90 Hz while the server was down: counted by sequence.
  EXPECT_GE(j["lost_across_sessions"].get<int>(), 30) << j.dump();
  EXPECT_GE(j["lost"].get<int>(), j["lost_across_sessions"].get<int>());
  EXPECT_EQ(j["avatars"], 2) << j.dump();
  EXPECT_NE(sub.err().find("connection cut"), std::string::npos) << sub.err();
  EXPECT_NE(sub.err().find("frames again after"), std::string::npos) << sub.err();
}

// Viewers stopped past the server's 10 s idle timeout are cut by it; continued, they come
// back (over TCP and over UDP) and show the newest frames, not the seconds of frames their
// sockets held: every frame a viewer takes in is fresh.
TEST(ReconnectCli, StoppedViewersComeBackWithTheNewestFrames) {
  Proc server({"run", "--listen", "127.0.0.1:0", "--quiet", "--json"});
  const std::string ep = endpoint_of(server);
  ASSERT_FALSE(ep.empty()) << server.err();
  Proc tcp({"subscribe", "--connect", ep, "--duration", "22"});
  Proc udp({"subscribe", "--connect", ep, "--duration", "22", "--udp"});
  ASSERT_TRUE(tcp.wait_for_out("pose avatar=", 20.0)) << tcp.err();
  ASSERT_TRUE(udp.wait_for_out("pose avatar=", 20.0)) << udp.err();
  tcp.signal(SIGSTOP);
  udp.signal(SIGSTOP);
  sleep_s(12.5);
  tcp.signal(SIGCONT);
  udp.signal(SIGCONT);
  // Both drained at once: a viewer whose output pipe filled up would stall again.
  int tcp_rc = -1, udp_rc = -1;
  for (int i = 0; i < 1200 && (tcp_rc == -1 || udp_rc == -1); ++i) {
    if (tcp_rc == -1) tcp_rc = tcp.wait(0.025);
    if (udp_rc == -1) udp_rc = udp.wait(0.025);
  }
  EXPECT_EQ(tcp_rc, 0) << tcp.err();
  EXPECT_EQ(udp_rc, 0) << udp.err();
  for (Proc* p : {&tcp, &udp}) {
    EXPECT_NE(p->err().find("connection cut"), std::string::npos) << p->err();
    EXPECT_NE(p->err().find("frames again after"), std::string::npos) << p->err();
    const auto lat = latencies_ms(p->out());
    ASSERT_GT(lat.size(), 100u);
    // A frame kept through the stop would be over 12 s old when shown.
    EXPECT_LT(*std::max_element(lat.begin(), lat.end()), 5000.0);
  }
  server.signal(SIGINT);
  ASSERT_EQ(server.wait(20.0), 0) << server.err();
  const auto r = last_json(server.out());
  ASSERT_FALSE(r.is_discarded()) << server.out();
  EXPECT_GE(r["server"]["sessions_timed_out"].get<int>(), 2) << r.dump();
  // Nothing came before a HELLO on any reconnection.
  EXPECT_FALSE(r["server"].contains("rejected_by_reason") && r["server"]["rejected_by_reason"].contains("unexpected"))
      << r.dump();
}

}  // namespace

}  // namespace reconnect_cli_test
