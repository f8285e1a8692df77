// The attack suite: `mimic run` on loopback, attacked from outside as its hardening review did —
// one mesh topology packet, a registration forged from the server's own port, descriptors
// exhausted under a 256-descriptor limit, a scene larger than a joiner's backlog, a stopped
// process — while a viewer watches. Each attack must leave the service running and the viewer
// receiving frames. docs/security.md lists the limits behind each.
#include <gtest/gtest.h>

#include <poll.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "forged_udp.h"
#include "mimic/net/client.h"
#include "mimic/net/frame_codec.h"
#include "mimic_proc.h"
#include "raw_peer.h"

namespace attack_test {

namespace {

using mimic::test::endpoint_of;
using mimic::test::Proc;
namespace net = mimic::net;
using mimic::net::test::Bytes;
using mimic::net::test::Clock;
using mimic::net::test::RawPeer;

uint16_t port_of(const std::string& endpoint) {
  return static_cast<uint16_t>(std::stoi(endpoint.substr(endpoint.rfind(':') + 1)));
}

nlohmann::json last_json(const std::string& out) {
  const auto start = out.rfind("\n{");
  const std::string text = start == std::string::npos ? out : out.substr(start + 1);
  return nlohmann::json::parse(text, nullptr, false);
}

size_t rss_kib(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stoul(line.substr(6));
  return 0;
}

std::unique_ptr<net::Client> viewer(const std::string& endpoint, bool udp = false) {
  net::ClientOptions o;
  o.connect = endpoint;
  o.udp = udp;
  auto c = net::Client::connect(o);
  return c ? std::move(*c) : nullptr;
}

bool pump(net::Client& c, const std::function<bool()>& done, double timeout_s) {
  const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  while (Clock::now() < end) {
    if (done()) return true;
    (void)c.run_until(Clock::now() + std::chrono::milliseconds(5));
  }
  return done();
}

// The viewer receives at least `n` more frames within `timeout_s`.
bool frames_keep_coming(net::Client& c, uint64_t n, double timeout_s) {
  const uint64_t before = c.stats().frames;
  return pump(
      c, [&] { return c.stats().frames >= before + n; }, timeout_s);
}

Bytes hello(net::Role role) {
  net::Hello h;
  h.role = role;
  h.name = "attacker";
  Bytes b(net::kMaxHelloBytes);
  b.resize(net::encode_hello(h, b));
  return b;
}

Bytes model(uint16_t slot, size_t bytes) {
  net::AvatarModel m{slot, 0, 4, "attacker", std::string(bytes, 'm')};
  Bytes b(net::avatar_model_packet_bytes(m));
  net::encode_avatar_model(m, b);
  return b;
}

// A mesh topology of `vertex_count` vertices and no triangles, written byte by byte (the
// encoder refuses counts a frame cannot hold; an attacker does not use it).
Bytes topology(uint32_t vertex_count) {
  Bytes b{'M', net::kProtocolVersion, uint8_t(net::MsgType::mesh_topology), 0, 11, 0, 0, 0};
  const uint8_t payload[11] = {0,
                               0,
                               0,
                               uint8_t(vertex_count),
                               uint8_t(vertex_count >> 8),
                               uint8_t(vertex_count >> 16),
                               uint8_t(vertex_count >> 24),
                               0,
                               0,
                               0,
                               0};
  b.insert(b.end(), payload, payload + 11);
  return b;
}

std::vector<std::string> run_args() {
  return {"run", "--listen", "127.0.0.1:0", "--duration", "60", "--quiet", "--json"};
}

nlohmann::json stop(Proc& run) {
  run.signal(SIGINT);
  EXPECT_EQ(run.wait(15.0), 0) << run.err();
  return last_json(run.out());
}

// 19 bytes ended `mimic run` (std::bad_alloc), or grew it by 600 MB, for every viewer.
TEST(Attack, OneMeshTopologyPacketNeitherKillsNorGrowsMimicRun) {
  Proc run(run_args());
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  auto v = viewer(ep);
  ASSERT_TRUE(v);
  ASSERT_TRUE(frames_keep_coming(*v, 10, 10.0));
  const size_t rss_before = rss_kib(run.pid());
  for (uint32_t count : {0xFFFFFFFFu, 100'000'000u}) {
    RawPeer attacker(port_of(ep));
    ASSERT_TRUE(attacker.send(hello(net::Role::publisher)));
    ASSERT_TRUE(attacker.send(model(0, 64)));
    ASSERT_TRUE(attacker.send(topology(count)));
    attacker.wait_closed(5.0);  // until the server closes it
  }
  EXPECT_EQ(run.wait(0.2), -1) << "mimic run ended: " << run.err();
  EXPECT_TRUE(frames_keep_coming(*v, 30, 10.0));
  EXPECT_LT(rss_kib(run.pid()), rss_before + 64 * 1024);
  const auto j = stop(run);
  EXPECT_GE(j["server"]["rejected_by_reason"]["oversized"].get<int>(), 2) << j.dump();
}

// A registration forged from the server's own UDP port made it answer itself without end:
// 60,367 sendto in 4 s and no frames for the viewer while it lasted.
TEST(Attack, ARegistrationForgedFromTheServersOwnPortFreezesNothing) {
  mimic::test::ForgedUdp forged;
  if (!forged.ok()) GTEST_SKIP() << "raw sockets need CAP_NET_RAW (run as root to forge the source address)";
  Proc run(run_args());
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  auto v = viewer(ep, true);
  ASSERT_TRUE(v);
  ASSERT_TRUE(pump(
      *v, [&] { return v->udp_active(); }, 10.0));
  net::UdpRegister reg;
  reg.token = v->session_token();
  Bytes d(net::kUdpRegisterBytes);
  net::encode_udp_register(reg, d);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(forged.send("127.0.0.1", port_of(ep), "127.0.0.1", port_of(ep), d));
  EXPECT_TRUE(frames_keep_coming(*v, 90, 10.0));
  const auto j = stop(run);
  EXPECT_GE(j["server"]["udp_own_address"].get<int>(), 3) << j.dump();
  EXPECT_LT(j["server"]["udp_challenges"].get<int>(), 20) << j.dump();
}

// Under a descriptor limit it cannot raise (here 256, hard), 300 idle subscribers from five
// addresses — inside the per-address limit — used to make accept() fail with EMFILE and retry at
// once, for ever: no frames for anyone. Sessions now stop short of the limit ("server full").
TEST(Attack, ExhaustingDescriptorsDoesNotFreezeTheLoop) {
  Proc run(run_args(), {"/usr/bin/prlimit", "--nofile=256:256"});
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  auto v = viewer(ep);
  ASSERT_TRUE(v);
  ASSERT_TRUE(frames_keep_coming(*v, 10, 10.0));
  std::vector<std::unique_ptr<RawPeer>> crowd;
  const char* from[] = {"127.0.0.2", "127.0.0.3", "127.0.0.4", "127.0.0.5", "127.0.0.6"};
  for (int i = 0; i < 300; ++i) {
    crowd.push_back(std::make_unique<RawPeer>(port_of(ep), 0, from[i % 5]));
    if (crowd.back()->connected()) crowd.back()->send(hello(net::Role::subscriber));
  }
  EXPECT_TRUE(frames_keep_coming(*v, 90, 10.0));
  EXPECT_EQ(run.wait(0.1), -1) << run.err();
  const auto j = stop(run);
  EXPECT_LE(j["server"]["max_sessions"].get<int>(), 256 - 64) << j.dump();
  EXPECT_GE(j["server"]["rejected_by_reason"]["server_full"].get<int>(), 1) << j.dump();
}

// Nine 1 MB models from one (unauthenticated, loopback) publisher made a scene nobody could
// join: every new subscriber was closed as "slow" before its WELCOME.
TEST(Attack, ASceneLargerThanTheBacklogCanStillBeJoined) {
  Proc run(run_args());
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  RawPeer pub(port_of(ep));
  ASSERT_TRUE(pub.send(hello(net::Role::publisher)));
  for (uint16_t slot = 0; slot < 9; ++slot) ASSERT_TRUE(pub.send(model(slot, 1'000'000)));
  Proc sub({"subscribe", "--connect", ep, "--count", "20", "--json"});
  ASSERT_EQ(sub.wait(30.0), 0) << sub.err();
  const auto j = last_json(sub.out());
  EXPECT_EQ(j["avatars"], 10) << sub.out();
  EXPECT_GE(j["model_bytes"].get<double>(), 9e6);
  const auto r = stop(run);
  EXPECT_EQ(r["server"]["sessions_closed_slow"], 0) << r.dump();
}

// A loop held up (here: the process stopped for 400 ms, as a busy machine would) reports the
// ticks it missed, in --json and on the status line.
TEST(Attack, MissedTicksAreReported) {
  Proc run({"run", "--listen", "127.0.0.1:0", "--duration", "60", "--json"});
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  ASSERT_TRUE(run.wait_for_err(" fps", 10.0)) << run.err();
  run.signal(SIGSTOP);
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  run.signal(SIGCONT);
  EXPECT_TRUE(run.wait_for_err("missed ", 10.0)) << run.err();
  const auto j = stop(run);
  EXPECT_GE(j["missed_ticks"].get<int>(), 20) << j.dump();
  EXPECT_GE(j["longest_gap_ms"].get<double>(), 300.0) << j.dump();
}

// `mimic subscribe --mesh-lod 2` against a run deforming LOD 0 silently got no mesh frames; it
// is refused with the LODs served, and says so.
TEST(Attack, AnUnservedMeshLodIsRefusedWithAReason) {
  Proc run(run_args());
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  Proc sub({"subscribe", "--connect", ep, "--mesh-lod", "2", "--count", "5"});
  EXPECT_NE(sub.wait(15.0), 0);
  EXPECT_NE(sub.err().find("mesh LOD 2 is not served here (served: 0)"), std::string::npos) << sub.err();
  Proc ok({"subscribe", "--connect", ep, "--mesh-lod", "0", "--count", "5"});
  EXPECT_EQ(ok.wait(15.0), 0) << ok.err();
  stop(run);
}

// Credentials in a broker address (nats://USER:PASSWORD@HOST) never reach the terminal, the
// first line that scripts and logs keep, or an error message.
TEST(Attack, CredentialsInABrokerAddressAreNeverShown) {
  Proc run({"run", "--listen", "127.0.0.1:0", "--nats", "nats://alice:s3cret@127.0.0.1:1", "--duration", "0.5"});
  run.wait(30.0);
  EXPECT_EQ(run.out().find("s3cret"), std::string::npos) << run.out();
  EXPECT_EQ(run.err().find("s3cret"), std::string::npos) << run.err();
  EXPECT_EQ(run.err().find("alice"), std::string::npos) << run.err();
}

}  // namespace

}  // namespace attack_test
