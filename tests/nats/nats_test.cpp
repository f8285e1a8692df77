// The broker transport against real nats-server processes on loopback: publishers into one
// scene, relays serving it with Mimic's protocol, credentials, and faults (a broker down at
// start, a cluster node killed while frames flow, a relay restarted).
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <future>
#include <set>
#include <thread>

#include "mimic/net/nats.h"
#include "nats_broker.h"
#include "nats_test_fixtures.h"
#include "../net/net_test_support.h"
#include "nats_kv.h"

namespace mimic::net::nats_test {
namespace {

using ::mimic::test::NatsBroker;
using ::mimic::test::NatsCluster;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

TEST(NatsNames, TargetsScenesAndStableKeys) {
  auto t = parse_nats_target("nats://a:1,nats://b:2/lobby");
  ASSERT_TRUE(t);
  EXPECT_EQ(t->servers, "nats://a:1,nats://b:2");
  EXPECT_EQ(t->scene, "lobby");
  auto d = parse_nats_target("nats://127.0.0.1:4222");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->scene, "default");
  EXPECT_FALSE(parse_nats_target("127.0.0.1:4222"));
  EXPECT_FALSE(parse_nats_target("nats://h:1/a.b"));  // a dot would split the subject
  EXPECT_FALSE(check_scene_name("*"));
  EXPECT_FALSE(check_scene_name(""));
  // The key depends only on the names: the same across restarts, different between avatars.
  EXPECT_EQ(nats_avatar_key("hostA", "avatar1"), nats_avatar_key("hostA", "avatar1"));
  EXPECT_NE(nats_avatar_key("hostA", "avatar1"), nats_avatar_key("hostB", "avatar1"));
  EXPECT_NE(nats_avatar_key("hostA", "avatar1"), nats_avatar_key("hostA", "avatar2"));
  EXPECT_EQ(nats_avatar_key("a", "b").size(), 16u);
}

// Addresses as mimic shows them: credentials in an address never reach a terminal or a log.
TEST(NatsNames, ShownAddressesCarryNoCredentials) {
  EXPECT_EQ(nats_display_servers("nats://alice:s3cret@h:4222"), "nats://h:4222");
  EXPECT_EQ(nats_display_servers("nats://tok@a:1,nats://b:2,nats://u:p@c:3"), "nats://a:1,nats://b:2,nats://c:3");
  EXPECT_EQ(nats_display_servers("nats://h:4222"), "nats://h:4222");
}

TEST(Nats, TwoPublishersOneSceneTwoRelaysSameAvatarsAndLatency) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  TestPublisher a(options(broker.url_as("hostA"), "hostA"), 1), b(options(broker.url_as("hostB"), "hostB"), 2);
  TestRelay r1(options(broker.url_as("relay"), "relay1")), r2(options(broker.url_as("relay"), "relay2"));
  auto v1 = viewer(r1.endpoint()), v2 = viewer(r2.endpoint());
  ASSERT_TRUE(test::pump(
      {v1.get(), v2.get()}, [&] { return sees_all(*v1, 3, 30) && sees_all(*v2, 3, 30); }, 15))
      << v1->avatars().size() << " " << v2->avatars().size() << " " << r1.feed().stats().last_error << broker.log();
  std::vector<std::string> n1, n2;
  for (const auto& [id, m] : v1->avatars()) n1.push_back(m.name + "|" + m.model_bytes);
  for (const auto& [id, m] : v2->avatars()) n2.push_back(m.name + "|" + m.model_bytes);
  std::sort(n1.begin(), n1.end());
  std::sort(n2.begin(), n2.end());
  EXPECT_EQ(n1, n2);
  EXPECT_EQ(n1[0], "hostA/avatar1|model of hostA 0");
  EXPECT_EQ(n1[2], "hostB/avatar2|model of hostB 1");

  // A viewer joining late gets every model at once from the bucket.
  TestRelay late(options(broker.url_as("relay"), "relay3"));
  auto v3 = viewer(late.endpoint());
  ASSERT_TRUE(test::pump(
      {v3.get()}, [&] { return v3->avatars().size() == 3; }, 10));

  // Publish (wall clock in the frame) to arrival at a viewer through one relay: an upper bound
  // of publish-to-relay. A figure, not an assertion (a shared machine).
  std::vector<double> latency_ms;
  v1->on_pose = [&](const RemoteAvatar& m, uint64_t now_us) {
    latency_ms.push_back(double(now_us - m.last.time_us) * 1e-3);
  };
  test::pump_for({v1.get(), v2.get(), v3.get()}, 3.0);
  ASSERT_GT(latency_ms.size(), 200u);
  std::printf("[ figure ] publish -> nats-server -> relay -> viewer latency over %zu frames: p50 %.3f ms p99 %.3f ms\n",
              latency_ms.size(), percentile(latency_ms, 0.5), percentile(latency_ms, 0.99));
  const auto rs = r1.feed().stats();
  std::printf("[ figure ] publish -> nats-server -> relay (the relay's own count): p50 %.3f ms p99 %.3f ms\n",
              rs.latency_ms_p50, rs.latency_ms_p99);
  EXPECT_EQ(rs.rejected, 0u);
}

// How many pose frames per second one loopback nats-server carries from publishers to relays:
// a figure for docs/scaling.md (publishers of 50 avatars each at 90 Hz into three relays).
TEST(Nats, BrokerThroughputFigure) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  std::vector<std::unique_ptr<TestRelay>> relays;
  for (int i = 0; i < 3; ++i)
    relays.push_back(std::make_unique<TestRelay>(options(broker.url_as("relay"), "relay" + std::to_string(i))));
  TestPublisher a(options(broker.url_as("hostA"), "hostA"), 50), b(options(broker.url_as("hostB"), "hostB"), 50);
  auto v = viewer(relays[0]->endpoint());
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return sees_all(*v, 100, 10); }, 20));
  const uint64_t in0 =
      relays[0]->feed().stats().frames + relays[1]->feed().stats().frames + relays[2]->feed().stats().frames;
  const uint64_t pub0 = a.get().stats().frames + b.get().stats().frames;
  const double cpu0 = broker.cpu_seconds();
  const auto t0 = Clock::now();
  test::pump_for({v.get()}, 3.0);
  const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
  const uint64_t in1 =
      relays[0]->feed().stats().frames + relays[1]->feed().stats().frames + relays[2]->feed().stats().frames;
  const uint64_t pub1 = a.get().stats().frames + b.get().stats().frames;
  const double cpu = (broker.cpu_seconds() - cpu0) / dt;
  const auto rs = relays[0]->feed().stats();
  std::printf(
      "[ figure ] broker: %.0f frames/s in, %.0f frames/s out to 3 relays (100 avatars at 90 Hz) at %.0f%% of one "
      "core; "
      "relay p50 %.3f ms p99 %.3f ms; viewer lost %llu of %llu\n",
      double(pub1 - pub0) / dt, double(in1 - in0) / dt, cpu * 100, rs.latency_ms_p50, rs.latency_ms_p99,
      static_cast<unsigned long long>(v->stats().lost), static_cast<unsigned long long>(v->stats().frames));
  EXPECT_GT(in1, in0);
}

TEST(Nats, WrongCredentialsAreRefusedWithAClearMessage) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("auth", {"mimic", "s3cret", ""});
  ASSERT_TRUE(broker.start());
  auto o = options(broker.url(), "hostA");  // a broker of one user, no credentials in the address
  o.user = "mimic";
  o.password = "wrong";
  auto p = NatsPublisher::create(o);
  ASSERT_FALSE(p);
  EXPECT_NE(p.error().message.find("refused the credentials"), std::string::npos) << p.error().message;
  EXPECT_NE(p.error().message.find("MIMIC_NATS_PASSWORD"), std::string::npos);
  o.password.clear();
  o.user.clear();
  EXPECT_FALSE(NatsPublisher::create(o)) << "no credentials at all";
  o.user = "mimic";
  o.password = "s3cret";
  auto ok = NatsPublisher::create(o);
  ASSERT_TRUE(ok) << ok.error().what();
  EXPECT_TRUE((*ok)->connected());
}

TEST(Nats, BrokerDownAtStartIsJoinedWhenItComesUp) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("late");  // port chosen, nothing listening yet
  TestPublisher pub(options(broker.url_as("hostA"), "hostA"), 1);
  EXPECT_FALSE(pub.get().connected());
  TestRelay relay(options(broker.url_as("relay"), "relay"));
  EXPECT_FALSE(relay.feed().connected());
  auto v = viewer(relay.endpoint());  // the relay serves its viewers meanwhile
  test::pump_for({v.get()}, 0.5);
  EXPECT_EQ(v->avatars().size(), 0u);
  ASSERT_TRUE(broker.start());
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return sees_all(*v, 1, 20); }, 15))
      << "publisher: " << pub.get().stats().last_error << " relay: " << relay.feed().stats().last_error;
  EXPECT_TRUE(pub.get().connected());
  EXPECT_GT(pub.get().stats().frames_dropped, 0u) << "frames of the outage are dropped, not queued";
}

TEST(Nats, ClusterNodeKilledWhileFramesFlow) {
  REQUIRE_NATS();
  NatsCluster cluster;
  ASSERT_TRUE(cluster.start());
  // Publisher and relay both on node 1 (in list order, not at random), both knowing every node.
  const auto& n = cluster.nodes;
  const std::string pub_urls = cluster.urls_as("hostA"), relay_urls = cluster.urls_as("relay");
  auto po = options(pub_urls, "hostA");
  auto ro = options(relay_urls, "relay");
  po.randomize = false;
  ro.randomize = false;
  // The model bucket on all three nodes (JetStream waits for the cluster's leader).
  std::unique_ptr<TestPublisher> pub;
  for (int attempt = 0; attempt < 50 && !pub; ++attempt) {
    try {
      pub = std::make_unique<TestPublisher>(po, 2);
    } catch (const std::exception&) {
      std::this_thread::sleep_for(200ms);
    }
  }
  ASSERT_TRUE(pub);
  TestRelay relay(ro);
  auto v = viewer(relay.endpoint());
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return sees_all(*v, 2, 90); }, 30))
      << relay.feed().stats().last_error;
  const uint64_t frames_before = v->stats().frames, lost_before = v->stats().lost;

  // Kill the node both are on: they move to the others.
  ASSERT_EQ(pub->get().connected_url(), n[0].url());
  ASSERT_EQ(relay.feed().connected_url(), n[0].url());
  cluster.nodes[0].kill();
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return v->stats().frames > frames_before + 180; }, 20))
      << "frames stopped after node 1 died: " << pub->get().stats().last_error;
  EXPECT_NE(pub->get().connected_url(), n[0].url());
  EXPECT_NE(relay.feed().connected_url(), n[0].url());
  // No model lost: both avatars still there, with their models, never removed.
  EXPECT_EQ(v->avatars().size(), 2u);
  for (const auto& [id, m] : v->avatars()) EXPECT_FALSE(m.model_bytes.empty());
  EXPECT_GE(pub->get().stats().reconnects, 1u);
  EXPECT_GE(relay.feed().stats().reconnects, 1u);
  // Only the outages' frames are lost: at 90 Hz and two avatars, a few seconds' worth at most.
  const uint64_t lost = v->stats().lost - lost_before;
  std::printf("[ figure ] a node failure: viewer lost %llu frames (of 2 avatars at 90 Hz), publisher dropped %llu\n",
              static_cast<unsigned long long>(lost),
              static_cast<unsigned long long>(pub->get().stats().frames_dropped));
  EXPECT_LT(lost, 2u * 90u * 3u);
  // A late viewer after the failures still gets both models from the surviving node.
  TestRelay late(options(n[2].url_as("relay"), "late"));
  auto v2 = viewer(late.endpoint());
  EXPECT_TRUE(test::pump(
      {v2.get()}, [&] { return sees_all(*v2, 2, 1); }, 15))
      << late.feed().stats().last_error;
}

TEST(Nats, RelayRestartedViewersReconnectAndResume) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  TestPublisher pub(options(broker.url_as("hostA"), "hostA"), 1);
  auto relay = std::make_unique<TestRelay>(options(broker.url_as("relay"), "relay"));
  const uint16_t port = relay->port();
  auto v = viewer(relay->endpoint());
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return sees_all(*v, 1, 30); }, 15));
  relay.reset();  // the relay process goes away
  test::pump_for({v.get()}, 0.3);
  const uint64_t frames_down = v->stats().frames;
  relay = std::make_unique<TestRelay>(options(broker.url_as("relay"), "relay"), port);
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return v->stats().frames > frames_down + 60 && v->avatars().size() == 1; }, 15));
  EXPECT_GE(v->stats().reconnects, 1u);
}

TEST(Nats, PublisherRestartKeepsItsAvatarKeys) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  TestRelay relay(options(broker.url_as("relay"), "relay"));
  auto v = viewer(relay.endpoint());
  std::string key_before;
  {
    TestPublisher pub(options(broker.url_as("hostA"), "hostA"), 1);
    key_before = pub.get().key(0);
    ASSERT_TRUE(test::pump(
        {v.get()}, [&] { return sees_all(*v, 1, 20); }, 15));
  }
  // A clean stop takes the avatar out of the scene.
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return v->avatars().empty(); }, 10));
  TestPublisher again(options(broker.url_as("hostA"), "hostA"), 1);
  EXPECT_EQ(again.get().key(0), key_before);
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return sees_all(*v, 1, 20); }, 15));
  EXPECT_EQ(v->avatars().begin()->second.name, "hostA/avatar1");
  EXPECT_EQ(relay.feed().stats().rejected, 0u) << "sequence numbers starting again are accepted";
}

TEST(Nats, OneBrokerThreeRelaysTwoPublishersManyViewers) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  TestPublisher a(options(broker.url_as("hostA"), "hostA"), 2), b(options(broker.url_as("hostB"), "hostB"), 2);
  std::vector<std::unique_ptr<TestRelay>> relays;
  for (int i = 0; i < 3; ++i)
    relays.push_back(std::make_unique<TestRelay>(options(broker.url_as("relay"), "relay" + std::to_string(i))));
  constexpr int kViewersPerRelay = 20;
  std::vector<std::unique_ptr<Client>> viewers;
  std::vector<Client*> all;
  for (auto& r : relays)
    for (int i = 0; i < kViewersPerRelay; ++i) {
      viewers.push_back(viewer(r->endpoint()));
      all.push_back(viewers.back().get());
    }
  ASSERT_TRUE(test::pump(
      all, [&] { return std::all_of(all.begin(), all.end(), [](Client* c) { return sees_all(*c, 4, 20); }); }, 30));
  // The arithmetic of docs/scaling.md at small scale, by counts over a few seconds: every relay
  // takes each published frame once (the broker sends P frames to R relays: R·P), and every
  // viewer behind it gets each of them (V·P per relay).
  auto published = [&] { return a.get().stats().frames + b.get().stats().frames; };
  auto relay_in = [&](size_t i) { return relays[i]->feed().stats().frames; };
  uint64_t viewer_frames0 = 0;
  for (Client* c : all) viewer_frames0 += c->stats().frames;
  const uint64_t p0 = published(), r0[3] = {relay_in(0), relay_in(1), relay_in(2)};
  test::pump_for(all, 3.0);
  uint64_t viewer_frames1 = 0;
  for (Client* c : all) viewer_frames1 += c->stats().frames;
  const double p = double(published() - p0);
  double relays_in = 0;
  for (size_t i = 0; i < 3; ++i) {
    const double in = double(relay_in(i) - r0[i]);
    relays_in += in;
    EXPECT_GT(in, 0.9 * p) << "relay " << i << " took " << in << " of " << p << " published frames";
  }
  const double got = double(viewer_frames1 - viewer_frames0);
  std::printf(
      "[ figure ] 2 publishers x 2 avatars, 3 relays x %d viewers: published %.0f frames, broker out %.0f (%.2f x 3 "
      "relays), viewers got %.0f (%.2f x %d viewers)\n",
      kViewersPerRelay, p, relays_in, relays_in / p / 3, got, got / p / double(all.size()), int(all.size()));
  EXPECT_GT(got, 0.9 * p * double(all.size()));
}

// Mesh frames cross the broker only while a relay has a viewer that wants the LOD the
// publisher deforms at: the relay asks (mesh_want, with the topology until it has it), the
// publisher sends at most mesh_max_hz, and stops a few seconds after the last ask.
TEST(Nats, MeshFramesFlowOnlyWhileARelayViewerAsksForTheirLod) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  auto po = options(broker.url_as("hostM"), "hostM");
  po.mesh_max_hz = 15;
  TestPublisher pub(po, 1, 90, /*mesh_lod=*/1);
  TestRelay relay(options(broker.url_as("relay"), "relay"));
  auto poses = viewer(relay.endpoint());
  ASSERT_TRUE(test::pump(
      {poses.get()}, [&] { return sees_all(*poses, 1, 90); }, 15));
  EXPECT_EQ(pub.get().stats().mesh_requests, 0u) << "nobody asked";
  EXPECT_EQ(pub.mesh_sent(), 0u);
  EXPECT_EQ(pub.get().stats().mesh_frames, 0u);

  // A viewer of another LOD: the publisher's heartbeat says it offers LOD 1 only, so the relay
  // does not ask.
  auto other = viewer(relay.endpoint(), 2);
  test::pump_for({poses.get(), other.get()}, 1.5);
  EXPECT_EQ(relay.feed().stats().mesh_requests, 0u);
  EXPECT_EQ(pub.mesh_sent(), 0u);

  auto mesh = viewer(relay.endpoint(), 1);
  uint64_t wrong_lod = 0;
  mesh->on_mesh = [&](const RemoteAvatar& a) {
    const auto sent = test_positions(a.mesh_last.sequence);
    bool same = a.mesh_last.lod == 1 && a.mesh_positions_m.size() == sent.size();
    for (size_t i = 0; same && i < sent.size(); ++i)
      same = glm::length(a.mesh_positions_m[i] - sent[i]) < 1e-4f;  // 16-bit steps
    wrong_lod += !same;
  };
  auto mesh_frames = [&] { return mesh->avatars().empty() ? 0 : mesh->avatars().begin()->second.mesh_frames; };
  ASSERT_TRUE(test::pump(
      {poses.get(), other.get(), mesh.get()}, [&] { return mesh_frames() >= 20; }, 15))
      << "publisher: " << pub.get().stats().last_error << " relay: " << relay.feed().stats().last_error;
  const RemoteAvatar& a = mesh->avatars().begin()->second;
  EXPECT_EQ(a.mesh_indices, test_topology(1).indices);
  EXPECT_EQ(a.mesh_vertex_count, 4u);
  EXPECT_EQ(wrong_lod, 0u) << "every frame at the LOD asked, with the positions its sequence was sent with";
  EXPECT_EQ(other->stats().mesh_frames, 0u);
  EXPECT_EQ(poses->stats().mesh_frames, 0u);
  // The rate bound: 15 mesh frames a second against 90 pose frames.
  const uint64_t poses0 = pub.get().stats().frames, meshes0 = pub.mesh_sent();
  test::pump_for({poses.get(), other.get(), mesh.get()}, 2.0);
  const double ratio = double(pub.mesh_sent() - meshes0) / double(pub.get().stats().frames - poses0);
  std::printf("[ figure ] mesh frames per pose frame at mesh_max_hz 15 and 90 Hz poses: %.3f\n", ratio);
  EXPECT_LE(ratio, 15.0 / 90.0 * 1.2);
  EXPECT_GT(ratio, 0.0);

  // The mesh viewer leaves: the relay stops asking, the publisher stops sending.
  mesh.reset();
  ASSERT_TRUE(test::pump(
      {poses.get(), other.get()},
      [&] {
        const uint64_t before = pub.mesh_sent();
        test::pump_for({poses.get(), other.get()}, 0.5);
        return pub.mesh_sent() == before;
      },
      15));
  EXPECT_EQ(relay.feed().stats().rejected, 0u);
}

// A publisher's tick of frames crosses the broker as one message (every avatar's frame of
// that tick), so a relay takes it in one piece and fans it out to its viewers once, whenever
// its thread wakes; a message that cannot be framed is refused.
TEST(Nats, APublishersTickIsOneMessageAndOneRelayFanOut) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  ::mimic::test::NatsProbe probe(broker.url_as("relay"));
  ASSERT_TRUE(probe.ok());
  ASSERT_TRUE(probe.subscribe("mimic.lobby.poses.*"));
  TestRelay relay(options(broker.url_as("relay"), "relay"));
  constexpr int kAvatars = 8;
  TestPublisher pub(options(broker.url_as("hostT"), "hostT"), kAvatars);
  std::set<std::string> keys;
  for (int i = 0; i < kAvatars; ++i) keys.insert(pub.get().key(i));
  auto v = viewer(relay.endpoint());
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return sees_all(*v, kAvatars, 20); }, 20));

  // On the wire: each message holds one frame of every avatar, all of the same tick.
  std::vector<uint8_t> m;
  for (int i = 0; i < 30; ++i) {
    ASSERT_TRUE(probe.next(m));
    std::set<std::string> seen;
    std::set<uint32_t> sequences;
    for (size_t at = 0; at < m.size();) {
      ASSERT_LE(at + 8 + kHeaderBytes, m.size());
      uint64_t key = 0;
      for (size_t b = 0; b < 8; ++b) key |= uint64_t(m[at + b]) << (8 * b);
      char text[17];
      std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(key));
      seen.insert(text);
      const std::span<const uint8_t> packet(m.data() + at + 8, pose_packet_bytes(kDofs));
      ASSERT_LE(at + 8 + packet.size(), m.size());
      PoseHeader h;
      rig::Pose pose;
      ASSERT_EQ(decode_pose(packet, h, pose), Reject::ok);
      sequences.insert(h.sequence);
      at += 8 + packet.size();
    }
    EXPECT_EQ(seen, keys) << "message " << i;
    EXPECT_EQ(sequences.size(), 1u) << "one tick per message";
  }

  // At the relay: every frame the publisher sent, and no more fan-outs than ticks (the frames of a
  // tick never straddle two). Both ends are counted with the publisher paused and everything on
  // the way arrived (the counters still for a moment): counted while a tick was in flight, the
  // publisher's sender thread (preempted on a busy machine between a publish and its count) and
  // the relay could disagree by a tick that was never missing.
  const auto relay_total = [&] { return relay.feed().stats().frames + relay.feed().stats().frames_dropped; };
  const auto settle = [&] {
    pub.pause(true);
    uint64_t last = ~uint64_t{0};
    auto still_since = std::chrono::steady_clock::now();
    return test::pump(
        {v.get()},
        [&] {
          const uint64_t now_counts = relay_total() + pub.get().stats().frames + pub.ticks();
          const auto now = std::chrono::steady_clock::now();
          if (now_counts != last) last = now_counts, still_since = now;
          return now - still_since >= 300ms;
        },
        30);
  };
  ASSERT_TRUE(settle());
  const uint64_t f0 = relay.fanouts(), t0 = pub.ticks(), in0 = relay.feed().stats().frames;
  const uint64_t sent0 = pub.get().stats().frames, dropped0 = pub.get().stats().frames_dropped;
  const uint64_t shed0 = relay.feed().stats().frames_dropped;
  pub.pause(false);
  // At least 100 ticks, however long a busy machine takes to publish them.
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return pub.ticks() - t0 >= 100; }, 60));
  const auto sent = [&] { return pub.get().stats().frames - sent0; };
  const auto arrived = [&] { return relay.feed().stats().frames - in0; };
  // A relay whose server thread fell far behind sheds whole ticks from its bounded queue, and
  // counts them: nothing may go missing without being counted.
  const auto shed = [&] { return relay.feed().stats().frames_dropped - shed0; };
  const auto links = [&] {
    const auto r = relay.feed().stats(), p = pub.get().stats();
    return "relay: " + std::to_string(r.frames) + " frames, " + std::to_string(r.frames_dropped) + " shed, " +
           std::to_string(r.early_frames) + " early, " + std::to_string(r.rejected) + " rejected, " +
           std::to_string(r.seq_jumps_refused) + " jumps refused, " + std::to_string(r.reconnects) +
           " reconnects; publisher: " + std::to_string(p.reconnects) + " reconnects";
  };
  ASSERT_TRUE(settle());
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return arrived() + shed() >= sent(); }, 30))
      << arrived() << " of " << sent() << "; " << links();
  const uint64_t fanouts = relay.fanouts() - f0, ticks = pub.ticks() - t0, frames = arrived();
  std::printf(
      "[ figure ] %d avatars at 90 Hz: %llu ticks published, %llu frames sent, %llu into the relay, %llu relay "
      "fan-outs (%.2f per tick)\n",
      kAvatars, static_cast<unsigned long long>(ticks), static_cast<unsigned long long>(sent()),
      static_cast<unsigned long long>(frames), static_cast<unsigned long long>(fanouts),
      double(fanouts) / double(std::max<uint64_t>(ticks, 1)));
  EXPECT_GE(ticks, 100u);
  EXPECT_EQ(frames + shed(), sent()) << links();
  EXPECT_LE(shed(), sent() / 10) << links();
  EXPECT_GE(sent() + (pub.get().stats().frames_dropped - dropped0),
            ticks * kAvatars);  // sent, or superseded in the publisher
  EXPECT_LE(fanouts, ticks);
  pub.pause(false);

  // A message that cannot be framed is counted and changes nothing.
  const uint64_t rejected = relay.feed().stats().rejected;
  ::mimic::test::NatsProbe junk(broker.url_as("hostX"));  // a publisher of its own, on its own subject
  ASSERT_TRUE(junk.publish("mimic.lobby.poses.hostX", std::string(40, 'x')));
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return relay.feed().stats().rejected > rejected; }, 10));
  EXPECT_EQ(v->avatars().size(), size_t(kAvatars));
}

// A model in the bucket whose publisher shows no life (what a crashed publisher leaves until the
// bucket's TTL takes it) is not served; a heartbeat naming it brings it in, and missed heartbeats
// take it out again.
TEST(Nats, AnAvatarIsServedWhileItsPublisherHeartbeatsAndLeavesAfterMissedOnes) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  ::mimic::test::NatsProbe probe(broker.url_as("ghost"));
  ASSERT_TRUE(probe.ok());
  ASSERT_TRUE(probe.open_bucket("mimic_lobby", /*create=*/true));
  const std::string key = nats_avatar_key("ghost", "avatar1");
  AvatarModel m;
  m.revision = 7;
  m.dof_count = kDofs;
  m.name = "ghost/avatar1";
  m.model_bytes = "model of a publisher that died";
  std::vector<uint8_t> packet(avatar_model_packet_bytes(m));
  ASSERT_GT(encode_avatar_model(m, packet), 0u);
  ASSERT_TRUE(probe.put("ghost." + key, packet));  // the bucket key is publisher.key

  TestRelay relay(options(broker.url_as("relay"), "relay"));
  auto v = viewer(relay.endpoint());
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return relay.feed().stats().held == 1; }, 10))
      << relay.feed().stats().last_error;
  test::pump_for({v.get()}, 4.0);  // longer than three missed heartbeats
  EXPECT_TRUE(v->avatars().empty()) << "a model without a living publisher is not shown";

  const std::string beat = R"({"publisher":"ghost","period_ms":300,"avatars":[")" + key + R"("]})";
  ASSERT_TRUE(probe.publish("mimic.lobby.status.ghost", beat));
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return v->avatars().size() == 1; }, 10));
  EXPECT_EQ(v->avatars().begin()->second.name, "ghost/avatar1");
  // Heartbeats keep it (300 ms apart, for 2 s: well past three periods of 300 ms).
  for (int i = 0; i < 8; ++i) {
    test::pump_for({v.get()}, 0.25);
    ASSERT_TRUE(probe.publish("mimic.lobby.status.ghost", beat));
  }
  EXPECT_EQ(v->avatars().size(), 1u);
  EXPECT_EQ(relay.feed().stats().expired, 0u);
  // They stop: three periods later it is gone, and counted.
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return v->avatars().empty(); }, 10));
  EXPECT_TRUE(test::pump(
      {v.get()}, [&] { return relay.feed().stats().held == 1; }, 5))
      << "still in the bucket, held until its publisher speaks again";
  EXPECT_EQ(relay.feed().stats().expired, 1u);
}

}  // namespace
}  // namespace mimic::net::nats_test
