// The broker transport against real nats-server processes on loopback: publishers into one
// scene, relays serving it with Mimic's protocol, credentials, and faults (a broker down at
// start, a cluster node killed while frames flow, a relay restarted).
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <thread>

#include "mimic/net/nats.h"
#include "nats_broker.h"
#include "net_test_support.h"

namespace mimic::net {
namespace {

using ::mimic::test::NatsBroker;
using ::mimic::test::NatsCluster;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

constexpr uint16_t kDofs = 12;

#define REQUIRE_NATS()                                                                  \
  do {                                                                                  \
    if (!MIMIC_WITH_NATS) GTEST_SKIP() << "built without NATS (MIMIC_WITH_NATS=OFF)";   \
    ASSERT_FALSE(::mimic::test::nats_server_binary().empty()) << "nats-server missing: run scripts/setup.sh"; \
  } while (0)

// Publishes `avatars` avatars at `hz` from a thread, as mimic run --nats does: encoded pose
// frames stamped with the wall clock at publish time.
class TestPublisher {
 public:
  TestPublisher(const NatsOptions& o, int avatars, double hz = 90) {
    auto p = NatsPublisher::create(o);
    if (!p) throw std::runtime_error(p.error().what());
    pub_ = std::move(*p);
    for (int i = 0; i < avatars; ++i) {
      auto idx = pub_->add_avatar("avatar" + std::to_string(i + 1), kDofs, "model of " + o.name + " " + std::to_string(i));
      if (!idx) throw std::runtime_error(idx.error().what());
    }
    thread_ = std::thread([this, avatars, hz] {
      avatar::Pose pose;
      pose.dof_rad.assign(kDofs, 0.1f);
      std::vector<uint8_t> buf(pose_packet_bytes(kDofs));
      std::vector<uint32_t> seq(size_t(avatars), 0);
      auto next = Clock::now();
      while (!stop_) {
        for (int i = 0; i < avatars; ++i) {
          PoseHeader h;
          h.avatar = uint16_t(i);
          h.sequence = ++seq[size_t(i)];
          h.time_us = wall_clock_us();
          pose.root_position_m.x = float(h.sequence) * 1e-3f;
          const size_t n = encode_pose(h, pose, buf);
          pub_->publish_pose(i, std::span<const uint8_t>(buf.data(), n));
        }
        next += std::chrono::microseconds(int64_t(1e6 / hz));
        std::this_thread::sleep_until(next);
      }
    });
  }
  ~TestPublisher() {
    stop_ = true;
    thread_.join();
  }
  NatsPublisher& get() { return *pub_; }

 private:
  std::unique_ptr<NatsPublisher> pub_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// A relay as mimic relay runs it: a Server on its own thread fed from the broker.
class TestRelay {
 public:
  explicit TestRelay(const NatsOptions& o, uint16_t port = 0) {
    ServerOptions so;
    so.listen = "127.0.0.1:" + std::to_string(port);
    auto s = Server::create(so);
    if (!s) throw std::runtime_error(s.error().what());
    server_ = std::move(*s);
    auto f = NatsSceneFeed::create(o, *server_);
    if (!f) throw std::runtime_error(f.error().what());
    feed_ = std::move(*f);
    thread_ = std::thread([this] { server_->run(); });
  }
  ~TestRelay() {
    server_->stop();
    thread_.join();
    feed_.reset();  // while the server it feeds is not running
  }
  std::string endpoint() const { return server_->endpoint(); }
  uint16_t port() const { return server_->port(); }
  NatsSceneFeed& feed() { return *feed_; }

 private:
  std::unique_ptr<Server> server_;
  std::unique_ptr<NatsSceneFeed> feed_;
  std::thread thread_;
};

std::unique_ptr<Client> viewer(const std::string& endpoint) {
  ClientOptions o;
  o.connect = endpoint;
  o.name = "viewer";
  auto c = Client::connect(o);
  if (!c) throw std::runtime_error(c.error().what());
  return std::move(*c);
}

NatsOptions options(const std::string& servers, const std::string& name, const std::string& scene = "lobby") {
  NatsOptions o;
  o.servers = servers;
  o.name = name;
  o.scene = scene;
  return o;
}

bool sees_all(const Client& c, size_t avatars, uint64_t frames_each = 1) {
  if (c.avatars().size() != avatars) return false;
  for (const auto& [id, a] : c.avatars())
    if (a.frames < frames_each) return false;
  return true;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(q * double(v.size() - 1) + 0.5))];
}

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

TEST(Nats, TwoPublishersOneSceneTwoRelaysSameAvatarsAndLatency) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  TestPublisher a(options(broker.url(), "hostA"), 1), b(options(broker.url(), "hostB"), 2);
  TestRelay r1(options(broker.url(), "relay1")), r2(options(broker.url(), "relay2"));
  auto v1 = viewer(r1.endpoint()), v2 = viewer(r2.endpoint());
  ASSERT_TRUE(test::pump({v1.get(), v2.get()}, [&] { return sees_all(*v1, 3, 30) && sees_all(*v2, 3, 30); }, 15))
      << v1->avatars().size() << " " << v2->avatars().size() << " " << r1.feed().stats().last_error;
  std::vector<std::string> n1, n2;
  for (const auto& [id, m] : v1->avatars()) n1.push_back(m.name + "|" + m.model_bytes);
  for (const auto& [id, m] : v2->avatars()) n2.push_back(m.name + "|" + m.model_bytes);
  std::sort(n1.begin(), n1.end());
  std::sort(n2.begin(), n2.end());
  EXPECT_EQ(n1, n2);
  EXPECT_EQ(n1[0], "hostA/avatar1|model of hostA 0");
  EXPECT_EQ(n1[2], "hostB/avatar2|model of hostB 1");

  // A viewer joining late gets every model at once from the bucket.
  TestRelay late(options(broker.url(), "relay3"));
  auto v3 = viewer(late.endpoint());
  ASSERT_TRUE(test::pump({v3.get()}, [&] { return v3->avatars().size() == 3; }, 10));

  // Publish (wall clock in the frame) to arrival at a viewer through one relay: an upper bound
  // of publish-to-relay. A figure, not an assertion (a shared machine).
  std::vector<double> latency_ms;
  v1->on_pose = [&](const RemoteAvatar& m, uint64_t now_us) { latency_ms.push_back(double(now_us - m.last.time_us) * 1e-3); };
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
  for (int i = 0; i < 3; ++i) relays.push_back(std::make_unique<TestRelay>(options(broker.url(), "relay" + std::to_string(i))));
  TestPublisher a(options(broker.url(), "hostA"), 50), b(options(broker.url(), "hostB"), 50);
  auto v = viewer(relays[0]->endpoint());
  ASSERT_TRUE(test::pump({v.get()}, [&] { return sees_all(*v, 100, 10); }, 20));
  const uint64_t in0 = relays[0]->feed().stats().frames + relays[1]->feed().stats().frames + relays[2]->feed().stats().frames;
  const uint64_t pub0 = a.get().stats().frames + b.get().stats().frames;
  const double cpu0 = broker.cpu_seconds();
  const auto t0 = Clock::now();
  test::pump_for({v.get()}, 3.0);
  const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
  const uint64_t in1 = relays[0]->feed().stats().frames + relays[1]->feed().stats().frames + relays[2]->feed().stats().frames;
  const uint64_t pub1 = a.get().stats().frames + b.get().stats().frames;
  const double cpu = (broker.cpu_seconds() - cpu0) / dt;
  const auto rs = relays[0]->feed().stats();
  std::printf("[ figure ] broker: %.0f frames/s in, %.0f frames/s out to 3 relays (100 avatars at 90 Hz) at %.0f%% of one core; "
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
  auto o = options(broker.url(), "hostA");
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
  TestPublisher pub(options(broker.url(), "hostA"), 1);
  EXPECT_FALSE(pub.get().connected());
  TestRelay relay(options(broker.url(), "relay"));
  EXPECT_FALSE(relay.feed().connected());
  auto v = viewer(relay.endpoint());  // the relay serves its viewers meanwhile
  test::pump_for({v.get()}, 0.5);
  EXPECT_EQ(v->avatars().size(), 0u);
  ASSERT_TRUE(broker.start());
  ASSERT_TRUE(test::pump({v.get()}, [&] { return sees_all(*v, 1, 20); }, 15))
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
  const std::string pub_urls = cluster.urls(), relay_urls = cluster.urls();
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
  ASSERT_TRUE(test::pump({v.get()}, [&] { return sees_all(*v, 2, 90); }, 30)) << relay.feed().stats().last_error;
  const uint64_t frames_before = v->stats().frames, lost_before = v->stats().lost;

  // Kill the node both are on: they move to the others.
  ASSERT_EQ(pub->get().connected_url(), n[0].url());
  ASSERT_EQ(relay.feed().connected_url(), n[0].url());
  cluster.nodes[0].kill();
  ASSERT_TRUE(test::pump({v.get()}, [&] { return v->stats().frames > frames_before + 180; }, 20))
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
              static_cast<unsigned long long>(lost), static_cast<unsigned long long>(pub->get().stats().frames_dropped));
  EXPECT_LT(lost, 2u * 90u * 3u);
  // A late viewer after the failures still gets both models from the surviving node.
  TestRelay late(options(n[2].url(), "late"));
  auto v2 = viewer(late.endpoint());
  EXPECT_TRUE(test::pump({v2.get()}, [&] { return sees_all(*v2, 2, 1); }, 15)) << late.feed().stats().last_error;
}

TEST(Nats, RelayRestartedViewersReconnectAndResume) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  TestPublisher pub(options(broker.url(), "hostA"), 1);
  auto relay = std::make_unique<TestRelay>(options(broker.url(), "relay"));
  const uint16_t port = relay->port();
  auto v = viewer(relay->endpoint());
  ASSERT_TRUE(test::pump({v.get()}, [&] { return sees_all(*v, 1, 30); }, 15));
  relay.reset();  // the relay process goes away
  test::pump_for({v.get()}, 0.3);
  const uint64_t frames_down = v->stats().frames;
  relay = std::make_unique<TestRelay>(options(broker.url(), "relay"), port);
  ASSERT_TRUE(test::pump({v.get()}, [&] { return v->stats().frames > frames_down + 60 && v->avatars().size() == 1; }, 15));
  EXPECT_GE(v->stats().reconnects, 1u);
}

TEST(Nats, PublisherRestartKeepsItsAvatarKeys) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  TestRelay relay(options(broker.url(), "relay"));
  auto v = viewer(relay.endpoint());
  std::string key_before;
  {
    TestPublisher pub(options(broker.url(), "hostA"), 1);
    key_before = pub.get().key(0);
    ASSERT_TRUE(test::pump({v.get()}, [&] { return sees_all(*v, 1, 20); }, 15));
  }
  // A clean stop takes the avatar out of the scene.
  ASSERT_TRUE(test::pump({v.get()}, [&] { return v->avatars().empty(); }, 10));
  TestPublisher again(options(broker.url(), "hostA"), 1);
  EXPECT_EQ(again.get().key(0), key_before);
  ASSERT_TRUE(test::pump({v.get()}, [&] { return sees_all(*v, 1, 20); }, 15));
  EXPECT_EQ(v->avatars().begin()->second.name, "hostA/avatar1");
  EXPECT_EQ(relay.feed().stats().rejected, 0u) << "sequence numbers starting again are accepted";
}

TEST(Nats, OneBrokerThreeRelaysTwoPublishersManyViewers) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  TestPublisher a(options(broker.url(), "hostA"), 2), b(options(broker.url(), "hostB"), 2);
  std::vector<std::unique_ptr<TestRelay>> relays;
  for (int i = 0; i < 3; ++i) relays.push_back(std::make_unique<TestRelay>(options(broker.url(), "relay" + std::to_string(i))));
  constexpr int kViewersPerRelay = 20;
  std::vector<std::unique_ptr<Client>> viewers;
  std::vector<Client*> all;
  for (auto& r : relays)
    for (int i = 0; i < kViewersPerRelay; ++i) {
      viewers.push_back(viewer(r->endpoint()));
      all.push_back(viewers.back().get());
    }
  ASSERT_TRUE(test::pump(all, [&] {
    return std::all_of(all.begin(), all.end(), [](Client* c) { return sees_all(*c, 4, 20); });
  }, 30));
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
  std::printf("[ figure ] 2 publishers x 2 avatars, 3 relays x %d viewers: published %.0f frames, broker out %.0f (%.2f x 3 "
              "relays), viewers got %.0f (%.2f x %d viewers)\n",
              kViewersPerRelay, p, relays_in, relays_in / p / 3, got, got / p / double(all.size()),
              int(all.size()));
  EXPECT_GT(got, 0.9 * p * double(all.size()));
}

}  // namespace
}  // namespace mimic::net
