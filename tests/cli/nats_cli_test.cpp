// End to end with a real nats-server: `mimic run --nats` refused on wrong credentials, serving
// its local listeners while the broker is down and joining it when it comes up (status line),
// `mimic relay` and `mimic subscribe --connect nats://...` taking the scene from the broker.
// Built with the broker transport only (the mimic::nats target; MIMIC_HAVE_NATS).
#if MIMIC_HAVE_NATS
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "mimic/net/client.h"
#include "mimic/net/nats.h"
#include "mimic_proc.h"
#include "nats_broker.h"
#include "test_data.h"
#include "nats_kv.h"

namespace nats_cli_test {

namespace {

using mimic::test::endpoint_of;
using mimic::test::Proc;

nlohmann::json last_json(const std::string& out) {
  const auto start = out.rfind("\n{");
  const std::string text = start == std::string::npos ? out : out.substr(start + 1);
  return nlohmann::json::parse(text, nullptr, false);
}

// `mimic relay` of `scene` on a port of its own, for a minute at most.
std::vector<std::string> relay_args(const std::string& url, const std::string& scene) {
  return {"relay", "--nats", url, "--scene", scene, "--listen", "127.0.0.1:0", "--duration", "60", "--json", "--quiet"};
}

// The JSON summary a running mimic prints on SIGUSR1.
nlohmann::json json_now(Proc& p) {
  const size_t mark = p.out().size();
  p.signal(SIGUSR1);
  if (!p.wait_for_out("\n", 10.0, mark)) return nlohmann::json();
  return last_json(p.out());
}

// A viewer of `endpoint` (mesh frames at `mesh_lod` when given).
std::unique_ptr<mimic::net::Client> viewer(const std::string& endpoint, uint8_t mesh_lod = mimic::net::kNoMesh) {
  mimic::net::ClientOptions o;
  o.connect = endpoint;
  o.mesh_lod = mesh_lod;
  auto c = mimic::net::Client::connect(o);
  return c ? std::move(*c) : nullptr;
}

// Drives the clients until `done` or the timeout.
bool pump(const std::vector<mimic::net::Client*>& clients, const std::function<bool()>& done, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    for (auto* c : clients) (void)c->run_until(std::chrono::steady_clock::now() + std::chrono::milliseconds(2));
    if (done()) return true;
  }
  return done();
}

#define REQUIRE_NATS_SERVER()                                                                               \
  do {                                                                                                      \
    ASSERT_FALSE(mimic::test::nats_server_binary().empty()) << "nats-server missing: run scripts/setup.sh"; \
  } while (0)

TEST(NatsCli, WrongCredentialsRefusedWithAClearMessage) {
  REQUIRE_NATS_SERVER();
  mimic::test::NatsBroker broker;
  broker.configure("auth", {"mimic", "s3cret", ""});
  ASSERT_TRUE(broker.start());
  // Credentials come from the environment only.
  ::setenv("MIMIC_NATS_USER", "mimic", 1);
  ::setenv("MIMIC_NATS_PASSWORD", "wrong", 1);
  Proc run({"run", "--listen", "127.0.0.1:0", "--nats", broker.url(), "--duration", "5", "--quiet"});
  const int status = run.wait(15.0);
  ::unsetenv("MIMIC_NATS_USER");
  ::unsetenv("MIMIC_NATS_PASSWORD");
  EXPECT_NE(status, 0);
  EXPECT_NE(run.err().find("refused the credentials"), std::string::npos) << run.err();
  EXPECT_EQ(run.out().find("serving on"), std::string::npos) << "refused before serving anything";
}

TEST(NatsCli, RunServesLocallyWhileTheBrokerIsDownThenJoinsItRelayAndSubscribeSeeTheScene) {
  REQUIRE_NATS_SERVER();
  mimic::test::NatsBroker broker;
  broker.configure("late");  // nothing listens on its port yet
  Proc run({"run", "--listen", "127.0.0.1:0", "--nats", broker.url_as("hostA"), "--scene", "stage", "--nats-name",
            "hostA", "--duration", "40", "--json"});
  ASSERT_TRUE(run.ok());
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  // The local listener serves meanwhile.
  Proc local({"subscribe", "--connect", ep, "--count", "30", "--json"});
  ASSERT_EQ(local.wait(15.0), 0) << local.err();
  EXPECT_EQ(last_json(local.out())["frames"], 30);
  // The status line says the broker is away before it comes (redrawn twice a second; a loaded
  // machine under the sanitizers can take seconds).
  ASSERT_TRUE(run.wait_for_err(" s: local only", 20.0)) << run.err();

  ASSERT_TRUE(broker.start());
  Proc relay({"relay", "--nats", broker.url_as("relay"), "--scene", "stage", "--listen", "127.0.0.1:0", "--duration",
              "40", "--json", "--quiet"});
  const std::string relay_ep = endpoint_of(relay);
  ASSERT_FALSE(relay_ep.empty()) << relay.err();
  Proc via_relay({"subscribe", "--connect", relay_ep, "--count", "60", "--json"});
  ASSERT_EQ(via_relay.wait(20.0), 0) << via_relay.err();
  const auto j = last_json(via_relay.out());
  EXPECT_EQ(j["frames"], 60);
  EXPECT_EQ(j["avatars"], 1);
  EXPECT_EQ(j["models"], 1);
  Proc direct({"subscribe", "--connect", broker.url_as("relay") + "/stage", "--count", "60", "--json"});
  ASSERT_EQ(direct.wait(20.0), 0) << direct.err();
  EXPECT_EQ(last_json(direct.out())["frames"], 60);
  // The broker goes away and comes back: the status line shows the outage, and after it how
  // many there were and how long the last one lasted.
  broker.kill();
  std::this_thread::sleep_for(std::chrono::seconds(1));  // the status line is redrawn twice a second
  ASSERT_TRUE(broker.start());
  ASSERT_TRUE(run.wait_for_err("nats up (1 outage, last ", 15.0)) << run.err();

  run.signal(SIGINT);
  ASSERT_EQ(run.wait(10.0), 0) << run.err();
  // The status line said so while the broker was away, and after.
  EXPECT_NE(run.err().find("not reachable: serving the local listeners"), std::string::npos) << run.err();
  EXPECT_NE(run.err().find("nats DOWN "), std::string::npos);
  EXPECT_NE(run.err().find("nats up"), std::string::npos);
  const auto summary = last_json(run.out());
  EXPECT_GT(summary["nats"]["frames"].get<double>(), 60.0) << run.out();
  EXPECT_GT(summary["nats"]["frames_dropped"].get<double>(), 0.0) << "frames of the outage are dropped, not queued";
  // A clean leave takes the avatar out of the scene: the relay's viewers see it go.
  relay.signal(SIGINT);
  ASSERT_EQ(relay.wait(10.0), 0) << relay.err();
  const auto rj = last_json(relay.out());
  EXPECT_EQ(rj["nats"]["avatars"], 0) << relay.out();
  EXPECT_EQ(rj["nats"]["rejected"], 0);
}

// Mesh frames through the broker: a viewer behind a relay asking for the LOD `mimic run`
// deforms at gets the same mesh as a viewer of that mimic run, frame for frame.
TEST(NatsCli, AMeshViewerBehindARelayGetsTheDirectServersMeshFrames) {
  REQUIRE_NATS_SERVER();
  mimic::test::NatsBroker broker;
  broker.configure("mesh");
  ASSERT_TRUE(broker.start());
  Proc run({"run", "--listen", "127.0.0.1:0", "--nats", broker.url_as("hostM"), "--scene", "mesh", "--nats-name",
            "hostM", "--mesh-lod", "2", "--duration", "60", "--json", "--quiet"});
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  Proc relay(relay_args(broker.url_as("relay"), "mesh"));
  const std::string relay_ep = endpoint_of(relay);
  ASSERT_FALSE(relay_ep.empty()) << relay.err();

  // Pose viewers only, so far: nothing asks for mesh frames, none crosses the broker.
  auto poses = viewer(relay_ep);
  ASSERT_TRUE(poses);
  ASSERT_TRUE(pump(
      {poses.get()}, [&] { return poses->stats().frames >= 90; }, 20));
  const auto before = json_now(run);
  EXPECT_EQ(before["nats"]["mesh_requests"], 0) << run.out();
  EXPECT_EQ(before["nats"]["mesh_frames"], 0);

  auto via_relay = viewer(relay_ep, 2), other_lod = viewer(relay_ep, 1);
  ASSERT_TRUE(via_relay && other_lod);
  // Every mesh frame by sequence number, as each viewer decoded it.
  std::map<uint32_t, std::vector<glm::vec3>> from_direct, from_relay;
  uint64_t wrong_lod = 0;
  via_relay->on_mesh = [&](const mimic::net::RemoteAvatar& a) {
    from_relay[a.mesh_last.sequence] = a.mesh_positions_m;
    wrong_lod += a.mesh_last.lod != 2;
  };
  ASSERT_TRUE(pump(
      {poses.get(), via_relay.get(), other_lod.get()}, [&] { return from_relay.size() >= 20; }, 30))
      << relay.err();
  // Mesh frames for the broker cost the loop no allocation, nor does a direct mesh viewer
  // joining (below).
  const auto during = json_now(run);
  EXPECT_EQ(during["loop_allocations"], 0);
  EXPECT_GT(during["nats"]["mesh_frames"].get<int>(), 0);

  auto direct = viewer(ep, 2);
  ASSERT_TRUE(direct);
  direct->on_mesh = [&](const mimic::net::RemoteAvatar& a) { from_direct[a.mesh_last.sequence] = a.mesh_positions_m; };
  auto common = [&] {
    size_t n = 0;
    for (const auto& [seq, p] : from_relay) n += from_direct.count(seq);
    return n;
  };
  const std::vector<mimic::net::Client*> all = {poses.get(), direct.get(), via_relay.get(), other_lod.get()};
  ASSERT_TRUE(pump(
      all, [&] { return common() >= 30; }, 30))
      << "relay " << from_relay.size() << " direct " << from_direct.size() << "\n"
      << relay.err();
  size_t equal = 0;
  for (const auto& [seq, p] : from_relay)
    if (auto it = from_direct.find(seq); it != from_direct.end()) equal += it->second == p;
  EXPECT_EQ(equal, common()) << "the same vertices for the same frame, bit for bit";
  EXPECT_EQ(wrong_lod, 0u);
  const auto& r = via_relay->avatars().begin()->second;
  const auto& d = direct->avatars().begin()->second;
  EXPECT_EQ(r.mesh_indices, d.mesh_indices) << "the same topology";
  EXPECT_GT(r.mesh_vertex_count, 0u);
  EXPECT_EQ(r.mesh_vertex_count, d.mesh_vertex_count);
  // The direct server has no mesh at LOD 1 either (mimic run deforms at --mesh-lod 2).
  EXPECT_EQ(other_lod->stats().mesh_frames, 0u);
  EXPECT_EQ(poses->stats().mesh_frames, 0u);
  EXPECT_EQ(json_now(run)["loop_allocations"], 0) << "a direct mesh viewer joined";

  run.signal(SIGINT);
  ASSERT_EQ(run.wait(15.0), 0) << run.err();
  relay.signal(SIGINT);
  ASSERT_EQ(relay.wait(15.0), 0) << relay.err();
  const auto rj = last_json(relay.out());
  const auto pj = last_json(run.out());
  std::printf(
      "[ figure ] mesh LOD 2 through the broker: %llu vertices, %.0f bytes a frame; publisher sent %d mesh "
      "frames (mesh_want received %d), relay served %d; the direct viewer got %zu, the relay's %zu\n",
      static_cast<unsigned long long>(r.mesh_vertex_count), double(mimic::net::mesh_packet_bytes(r.mesh_vertex_count)),
      pj["nats"]["mesh_frames"].get<int>(), pj["nats"]["mesh_requests"].get<int>(),
      rj["nats"]["mesh_frames"].get<int>(), from_direct.size(), from_relay.size());
  EXPECT_EQ(rj["nats"]["rejected"], 0);
  EXPECT_GT(rj["server"]["mesh_frames_out"].get<int>(), 0);
}

// A publisher killed without a clean stop: the relay's viewers see its avatar leave after its
// missed heartbeats, its model ages out of the bucket, and the restarted publisher (same name,
// same avatar key) comes back.
TEST(NatsCli, ASigkilledPublishersAvatarLeavesAndItsRestartBringsItBack) {
  REQUIRE_NATS_SERVER();
  mimic::test::NatsBroker broker;
  broker.configure("crash");
  ASSERT_TRUE(broker.start());
  const std::vector<std::string> run_args = {"run",     "--listen",   "127.0.0.1:0", "--nats", broker.url_as("hostK"),
                                             "--scene", "crash",      "--nats-name", "hostK",  "--nats-model-ttl",
                                             "3",       "--duration", "60",          "--quiet"};
  auto run = std::make_unique<Proc>(run_args);
  ASSERT_FALSE(endpoint_of(*run).empty()) << run->err();
  Proc relay(relay_args(broker.url_as("relay"), "crash"));
  const std::string relay_ep = endpoint_of(relay);
  ASSERT_FALSE(relay_ep.empty()) << relay.err();
  auto v = viewer(relay_ep);
  ASSERT_TRUE(v);
  ASSERT_TRUE(pump(
      {v.get()}, [&] { return v->avatars().size() == 1 && v->stats().frames >= 30; }, 20));
  // The bucket key is publisher.key; a relay's user may read the bucket.
  const std::string key = "hostK." + mimic::net::nats_avatar_key("hostK", "avatar1");
  mimic::test::NatsProbe probe(broker.url_as("relay"));
  ASSERT_TRUE(probe.ok());
  ASSERT_TRUE(probe.open_bucket("mimic_crash"));
  EXPECT_TRUE(probe.holds(key));
  const uint16_t id_before = v->avatars().begin()->first;

  run->signal(SIGKILL);
  EXPECT_EQ(run->wait(10.0), 128 + SIGKILL);
  const auto killed = std::chrono::steady_clock::now();
  ASSERT_TRUE(pump(
      {v.get()}, [&] { return v->avatars().empty(); }, 20))
      << "the dead publisher's avatar stayed";
  const double gone_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - killed).count();
  ASSERT_TRUE(pump(
      {v.get()}, [&] { return !probe.holds(key); }, 20))
      << "its model stayed in the bucket";
  const double expired_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - killed).count();
  std::printf(
      "[ figure ] SIGKILLed publisher: its avatar left the relay's viewer %.1f s later, its model the bucket "
      "%.1f s later (heartbeat 1 s, 3 missed; TTL 3 s)\n",
      gone_s, expired_s);

  run = std::make_unique<Proc>(run_args);
  ASSERT_FALSE(endpoint_of(*run).empty()) << run->err();
  const uint64_t frames_before = v->stats().frames;
  ASSERT_TRUE(pump(
      {v.get()}, [&] { return v->avatars().size() == 1 && v->stats().frames >= frames_before + 30; }, 20));
  EXPECT_EQ(v->avatars().begin()->second.name, "hostK/avatar1");
  // The relay hands out its lowest free id: with nobody else arriving, the one it had
  // (docs/scaling.md says so).
  EXPECT_EQ(v->avatars().begin()->first, id_before);
  EXPECT_TRUE(probe.holds(key)) << "the same key again";
  run->signal(SIGINT);
  ASSERT_EQ(run->wait(15.0), 0) << run->err();
  relay.signal(SIGINT);
  ASSERT_EQ(relay.wait(15.0), 0);
  const auto rj = last_json(relay.out());
  EXPECT_EQ(rj["nats"]["expired"], 1) << relay.out();
  EXPECT_EQ(rj["nats"]["rejected"], 0);
}

}  // namespace

}  // namespace nats_cli_test
#endif  // MIMIC_HAVE_NATS
