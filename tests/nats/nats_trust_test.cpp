// The broker as a trust boundary and its faults, against real nats-server processes running the
// shipped configuration (config/nats/, docs/security.md, The broker): each publisher's user writes
// only its own subjects and bucket keys, relays only read; what a publisher may still send is
// bounded at the relay (sequence jumps, model sizes, the models it keeps) and at the publisher
// (topologies on request); a broker restarted with an empty store gets the models back; a model
// put that waits for JetStream does not hold back pose frames.
#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "mimic/net/nats.h"
#include "nats_broker.h"
#include "nats_test_fixtures.h"
#include "../net/net_test_support.h"
#include "nats_kv.h"

namespace mimic::net::nats_trust_test {
namespace {

TEST(NatsLinkState, StatusLineText) {
  char buf[96];
  NatsLinkState s;
  s.connected = true;
  format_nats_state(s, buf, sizeof buf);
  EXPECT_STREQ(buf, " | nats up");
  s.disconnects = 2;
  s.last_outage_s = 0.031;
  format_nats_state(s, buf, sizeof buf);
  EXPECT_STREQ(buf, " | nats up (2 outages, last 0.031 s)");
  s.connected = false;
  s.down_s = 1.25;
  format_nats_state(s, buf, sizeof buf);
  EXPECT_STREQ(buf, " | nats DOWN 1.2 s");
  EXPECT_EQ(format_nats_state(s, buf, 8), 7) << "cut to the buffer";
}

// A tick message of one avatar as a publisher sends it: the key's value, then its POSE packet.
std::string poses_message(const std::string& key_hex, uint32_t sequence) {
  rig::Pose pose;
  pose.dof_rad.assign(kDofs, 0.5f);
  PoseHeader h;
  h.sequence = sequence;
  h.time_us = wall_clock_us();
  std::vector<uint8_t> packet(pose_packet_bytes(kDofs));
  packet.resize(encode_pose(h, pose, packet));
  const uint64_t key = std::stoull(key_hex, nullptr, 16);
  std::string m(8, '\0');
  for (size_t b = 0; b < 8; ++b) m[b] = char(uint8_t(key >> (8 * b)));
  m.append(reinterpret_cast<const char*>(packet.data()), packet.size());
  return m;
}

std::vector<uint8_t> model_packet(const std::string& name, size_t model_bytes) {
  AvatarModel m;
  m.revision = 1;
  m.dof_count = kDofs;
  m.name = name;
  m.model_bytes.assign(model_bytes, 'j');
  std::vector<uint8_t> packet(avatar_model_packet_bytes(m));
  encode_avatar_model(m, packet);
  return packet;
}

// The newest sequence a viewer has of its (only) avatar.
uint32_t newest_sequence(const Client& c) {
  return c.avatars().empty() ? 0 : c.avatars().begin()->second.last.sequence;
}

TEST(NatsTrust, EachPublisherWritesOnlyItsOwnSubjectsAndKeysAndRelaysOnlyRead) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  TestPublisher pub(options(broker.url_as("hostA"), "hostA"), 1);
  TestRelay relay(options(broker.url_as("relay"), "relay"));
  auto v = viewer(relay.endpoint());
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return sees_all(*v, 1, 30); }, 15))
      << relay.feed().stats().last_error;
  const std::string key = pub.get().key(0), owned = "hostA." + key;
  ::mimic::test::NatsProbe reader(broker.url_as("relay"));
  ASSERT_TRUE(reader.ok());
  ASSERT_TRUE(reader.open_bucket("mimic_lobby"));
  ASSERT_TRUE(reader.holds(owned));
  ASSERT_TRUE(reader.subscribe("mimic.lobby.poses.hostA"));

  // Another publisher's user: hostA's subject, hostA's bucket key (put and delete) are refused by
  // the broker; its own subject naming hostA's avatar is refused by the relay.
  ::mimic::test::NatsProbe mallory(broker.url_as("mallory"));
  ASSERT_TRUE(mallory.ok());
  ASSERT_TRUE(mallory.open_bucket("mimic_lobby"));
  EXPECT_FALSE(mallory.put(owned, model_packet("hostA/avatar1", 100))) << "overwrote another publisher's model";
  EXPECT_FALSE(mallory.remove(owned)) << "deleted another publisher's model";
  const uint32_t ahead = newest_sequence(*v) + 1'000'000;
  for (uint32_t i = 0; i < 16; ++i) {
    mallory.publish("mimic.lobby.poses.hostA", poses_message(key, ahead + i));
    mallory.publish("mimic.lobby.poses.mallory", poses_message(key, ahead + i));
  }
  // A relay's user writes nothing of a scene.
  ::mimic::test::NatsProbe relay_user(broker.url_as("relay"));
  ASSERT_TRUE(relay_user.open_bucket("mimic_lobby"));
  EXPECT_FALSE(relay_user.put(owned, model_packet("hostA/avatar1", 100)));
  relay_user.publish("mimic.lobby.poses.hostA", poses_message(key, ahead + 100));
  relay_user.publish("mimic.lobby.status.hostA", R"({"publisher":"hostA","avatars":[]})");

  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return relay.feed().stats().foreign >= 16; }, 10))
      << relay.feed().stats().foreign;
  const uint64_t frames = v->stats().frames;
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return v->stats().frames > frames + 90; }, 15))
      << "hostA's frames stopped";
  EXPECT_LT(newest_sequence(*v), ahead) << "a frame of another user reached the viewer";
  EXPECT_TRUE(reader.holds(owned));
  // Nothing but hostA's own frames on hostA's subject (the broker dropped the others).
  std::vector<uint8_t> m;
  for (int i = 0; i < 50 && reader.next(m, 2000);) {
    ASSERT_GE(m.size(), 8u + kHeaderBytes);
    PoseHeader h;
    rig::Pose pose;
    ASSERT_EQ(decode_pose(std::span<const uint8_t>(m.data() + 8, m.size() - 8), h, pose), Reject::ok);
    EXPECT_LT(h.sequence, ahead);
    ++i;
  }
  EXPECT_NE(broker.log().find("Publish Violation - User \"mallory\", Subject \"mimic.lobby.poses.hostA\""),
            std::string::npos);
  EXPECT_NE(broker.log().find("Publish Violation - User \"relay\""), std::string::npos);
  EXPECT_EQ(v->avatars().begin()->second.name, "hostA/avatar1");
}

// A stream of frames far ahead of an avatar's newest, beside its publisher's live stream (what
// its own credentials, or a broker without permissions, let through): refused and counted, the
// live stream goes on. When the publisher's frames stop and come back far ahead (an outage), the
// relay follows after a few frames.
TEST(NatsTrust, ARelayRefusesASequenceJumpBesideALiveStream) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  TestPublisher pub(options(broker.url_as("hostA"), "hostA"), 1);
  TestRelay relay(options(broker.url_as("relay"), "relay"));
  auto v = viewer(relay.endpoint());
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return sees_all(*v, 1, 30); }, 15));
  const std::string key = pub.get().key(0);
  ::mimic::test::NatsProbe same_user(broker.url_as("hostA"));
  ASSERT_TRUE(same_user.ok());
  const uint32_t ahead = newest_sequence(*v) + 1'000'000;
  for (uint32_t i = 0; i < 16; ++i)
    ASSERT_TRUE(same_user.publish("mimic.lobby.poses.hostA", poses_message(key, ahead + i)));
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return relay.feed().stats().seq_jumps_refused >= 16; }, 10))
      << relay.feed().stats().seq_jumps_refused;
  const uint64_t frames = v->stats().frames;
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return v->stats().frames > frames + 90; }, 15))
      << "the live stream was frozen";
  EXPECT_LT(newest_sequence(*v), ahead);

  // The live stream stops; a stream far ahead comes: it is followed.
  pub.pause(true);
  test::pump_for({v.get()}, 1.0);
  const uint32_t later = newest_sequence(*v) + 5'000;
  for (uint32_t i = 0; i < 10; ++i) {
    ASSERT_TRUE(same_user.publish("mimic.lobby.poses.hostA", poses_message(key, later + i)));
    test::pump_for({v.get()}, 0.02);
  }
  EXPECT_TRUE(test::pump(
      {v.get()}, [&] { return newest_sequence(*v) >= later + 9; }, 10))
      << newest_sequence(*v);
}

// Models are bounded at the relay (one model's size, all it keeps), refused ones counted, and
// what it kept goes when the bucket's keys go.
TEST(NatsTrust, ARelayBoundsTheModelsItKeepsAndGivesThemBack) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  ::mimic::test::NatsProbe mallory(broker.url_as("mallory"));
  ASSERT_TRUE(mallory.ok());
  ASSERT_TRUE(mallory.open_bucket("mimic_lobby", /*create=*/true));
  auto ro = options(broker.url_as("relay"), "relay");
  ro.max_model_bytes = 4096;
  ro.max_scene_model_bytes = 16 * 3000;
  TestRelay relay(ro);
  auto v = viewer(relay.endpoint());
  ASSERT_TRUE(mallory.put("mallory." + nats_avatar_key("mallory", "big"), model_packet("mallory/big", 8000)));
  ASSERT_TRUE(mallory.put("mallory.not-an-avatar-key", model_packet("mallory/junk", 100)));
  std::vector<std::string> keys;
  for (int i = 0; i < 40; ++i) {
    keys.push_back("mallory." + nats_avatar_key("mallory", "junk" + std::to_string(i)));
    ASSERT_TRUE(mallory.put(keys.back(), model_packet("mallory/junk", 3000)));
  }
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return relay.feed().stats().models_refused >= 2 + 24; }, 15))
      << relay.feed().stats().models_refused;
  EXPECT_TRUE(test::pump(
      {v.get()}, [&] { return relay.feed().stats().held == 16; }, 5))
      << "kept, waiting for a heartbeat";
  auto st = relay.feed().stats();
  EXPECT_EQ(st.models, 16u);
  EXPECT_EQ(st.model_bytes, 16u * 3000u);
  EXPECT_TRUE(v->avatars().empty());
  for (const auto& k : keys) ASSERT_TRUE(mallory.remove(k));
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return relay.feed().stats().model_bytes == 0; }, 15))
      << relay.feed().stats().model_bytes;
  EXPECT_TRUE(test::pump(
      {v.get()}, [&] { return relay.feed().stats().held == 0; }, 5));
}

// A relay's two-byte mesh request with the topology flag, repeated: the publisher sends the
// topology a bounded number of times, not once per request.
TEST(NatsTrust, MeshRequestsCannotMakeAPublisherFloodTheBroker) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  TestPublisher pub(options(broker.url_as("hostM"), "hostM"), 1, 90, /*mesh_lod=*/1);
  const std::string owned = "hostM." + pub.get().key(0);
  ::mimic::test::NatsProbe watcher(broker.url_as("relay")), asker(broker.url_as("relay"));
  ASSERT_TRUE(watcher.ok() && asker.ok());
  ASSERT_TRUE(watcher.subscribe("mimic.lobby.mesh." + owned + ".1"));
  const auto start = Clock::now();
  for (int i = 0; i < 19; ++i) {
    ASSERT_TRUE(asker.publish("mimic.lobby.want." + owned, std::string("\x01\x01", 2)));
    std::this_thread::sleep_for(300ms);
  }
  std::this_thread::sleep_for(500ms);
  const double elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
  int topologies = 0, frames = 0;
  for (std::vector<uint8_t> m; watcher.next(m, 200);) {
    Header h;
    ASSERT_EQ(decode_header(m, h), Reject::ok);
    topologies += h.type == MsgType::mesh_topology;
    frames += h.type == MsgType::mesh;
  }
  const auto st = pub.get().stats();
  std::printf(
      "[ figure ] 19 topology requests over %.1f s: %d topologies and %d mesh frames sent, %llu requests "
      "over the topology bound\n",
      elapsed_s, topologies, frames, static_cast<unsigned long long>(st.topologies_refused));
  EXPECT_GE(topologies, 1);
  EXPECT_LE(topologies, 2 + int(elapsed_s / 5.0) + 1);
  EXPECT_GT(st.topologies_refused, 0u);
  EXPECT_GT(frames, 0) << "mesh frames while asked";
}

// A broker restarted on the same port with an empty store: the publisher creates the bucket
// again and puts its models again, a relay that joins afterwards sees the scene, and the relay
// that was there follows the publisher's frames (far ahead after the outage).
TEST(NatsTrust, ABrokerRestartedWithAnEmptyStoreGetsTheModelsBack) {
  REQUIRE_NATS();
  auto broker = std::make_unique<NatsBroker>();
  broker->configure("first");
  ASSERT_TRUE(broker->start());
  const uint16_t port = broker->port;
  TestPublisher pub(options(broker->url_as("hostA"), "hostA"), 1);
  TestRelay relay(options(broker->url_as("relay"), "relay"));
  auto v = viewer(relay.endpoint());
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return sees_all(*v, 1, 30); }, 15));
  EXPECT_EQ(pub.get().link_state().disconnects, 0u);

  broker.reset();  // killed, its store removed
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return !pub.get().link_state().connected; }, 10));
  test::pump_for({v.get()}, 3.5);  // long enough for the publisher's sequence to move far ahead
  EXPECT_GT(pub.get().link_state().down_s, 1.0);
  const uint32_t seq_down = newest_sequence(*v);
  auto again = std::make_unique<NatsBroker>();
  again->port = port;
  again->configure("second");
  ASSERT_TRUE(again->start());

  TestRelay late(options(again->url_as("relay"), "late"));
  auto v2 = viewer(late.endpoint());
  ASSERT_TRUE(test::pump(
      {v.get(), v2.get()}, [&] { return sees_all(*v2, 1, 30); }, 20))
      << "publisher: " << pub.get().stats().last_error << " late relay: " << late.feed().stats().last_error;
  EXPECT_EQ(v2->avatars().begin()->second.name, "hostA/avatar1");
  ASSERT_TRUE(test::pump(
      {v.get(), v2.get()}, [&] { return newest_sequence(*v) > seq_down + 300; }, 15))
      << "the first relay did not follow the publisher's frames after the outage";
  const auto link = pub.get().link_state();
  EXPECT_TRUE(link.connected);
  EXPECT_EQ(link.disconnects, 1u);
  EXPECT_GT(link.last_outage_s, 3.0);
  // The puts stop failing once the bucket is back.
  const uint64_t failures = pub.get().stats().model_failures;
  test::pump_for({v.get(), v2.get()}, 1.0);
  EXPECT_EQ(pub.get().stats().model_failures, failures);
}

// Two nodes of three hang (SIGSTOP: their connections stay open, nothing is answered): a model
// put waits for JetStream, which cannot store it without them, while core NATS on the third
// node carries the pose frames. They must keep flowing meanwhile (a put once held the lock the
// sender takes for every tick, for as long as it waited: what a failover that moves the
// bucket's leader does for a moment, here for as long as the nodes hang).
TEST(NatsTrust, AModelPutWaitingForJetStreamDoesNotHoldBackPoseFrames) {
  REQUIRE_NATS();
  NatsCluster cluster;
  ASSERT_TRUE(cluster.start());
  auto po = options(cluster.urls_as("hostA"), "hostA");
  auto ro = options(cluster.urls_as("relay"), "relay");
  po.randomize = false;
  ro.randomize = false;
  po.model_ttl_s = 3;  // models put again every second
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
  ASSERT_EQ(pub->get().connected_url(), cluster.nodes[0].url());
  // The relay's count of pose frames, sampled as time goes by, from the moment the nodes hang:
  // the first model put after it (the models are put again every second) waits its second for
  // JetStream and then fails. Frames must reach the relay while it waits: a put that held the
  // sender back let none through until it gave up. The middle of that second is looked at, so a
  // busy machine's late wake-ups at either end do not matter; nor does the rate (load slows the
  // publisher's ticks and the relay alike): frames arriving at all is what a held sender stops.
  using Clock = std::chrono::steady_clock;
  std::vector<std::pair<Clock::time_point, uint64_t>> arrived;  // (when, frames so far)
  const uint64_t failures0 = pub->get().stats().model_failures;
  const uint64_t in0 = relay.feed().stats().frames, ticks0 = pub->ticks();
  cluster.nodes[1].signal(SIGSTOP);
  cluster.nodes[2].signal(SIGSTOP);
  Clock::time_point failed_at{};
  const bool failed = test::pump(
      {v.get()},
      [&] {
        arrived.emplace_back(Clock::now(), relay.feed().stats().frames);
        if (pub->get().stats().model_failures == failures0) return false;
        failed_at = Clock::now();
        return true;
      },
      30);
  test::pump_for({v.get()}, 1.0);
  const uint64_t in = relay.feed().stats().frames - in0, ticks = pub->ticks() - ticks0;
  const auto frames_at = [&](Clock::time_point t) {
    uint64_t n = in0;
    for (const auto& [when, frames] : arrived)
      if (when <= t) n = frames;
    return n;
  };
  const uint64_t while_waiting = frames_at(failed_at - 200ms) - frames_at(failed_at - 800ms);
  std::printf(
      "[ figure ] two nodes of three hung: %llu frames reached the relay in the middle 0.6 s of a model put's 1 s "
      "wait; %llu of %llu frames since the nodes hung, %llu failed puts\n",
      static_cast<unsigned long long>(while_waiting), static_cast<unsigned long long>(in),
      static_cast<unsigned long long>(ticks * 2),
      static_cast<unsigned long long>(pub->get().stats().model_failures - failures0));
  ASSERT_TRUE(failed) << "no model put waited";
  EXPECT_GT(while_waiting, 0u) << "pose frames waited for the model put";
  EXPECT_GT(in, 0u);
  EXPECT_TRUE(pub->get().connected());
  cluster.nodes[1].signal(SIGCONT);
  cluster.nodes[2].signal(SIGCONT);
}

// The node the publisher is on is killed four times (and started again in between, so the
// cluster is whole for the next), the bucket's copies on three nodes: the longest pause a viewer
// sees across each failover. A failover that moved the bucket's leader once cost 2 s (a model
// put on reconnect held the pose sender's lock while JetStream elected a new leader).
TEST(NatsTrust, ClusterFailoversCostWellUnderASecond) {
  REQUIRE_NATS();
  NatsCluster cluster;
  ASSERT_TRUE(cluster.start());
  auto po = options(cluster.urls_as("hostA"), "hostA");
  auto ro = options(cluster.urls_as("relay"), "relay");
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
  uint64_t last_us = 0, worst_us = 0;
  v->on_pose = [&](const RemoteAvatar&, uint64_t now_us) {
    if (last_us) worst_us = std::max(worst_us, now_us - last_us);
    last_us = now_us;
  };
  std::vector<double> pauses_ms;
  double worst_outage_s = 0;  // the publisher's or the relay's own link, callback to callback
  for (int kill = 0; kill < 4; ++kill) {
    test::pump_for({v.get()}, 1.0);
    const std::string on = pub->get().connected_url();
    int node = -1;
    for (int i = 0; i < 3; ++i)
      if (cluster.nodes[i].url() == on) node = i;
    ASSERT_GE(node, 0) << "publisher on " << on;
    worst_us = 0;
    const uint64_t frames = v->stats().frames;
    cluster.nodes[node].kill();
    ASSERT_TRUE(test::pump(
        {v.get()}, [&] { return v->stats().frames > frames + 360; }, 20))
        << "frames stopped: " << pub->get().stats().last_error;
    pauses_ms.push_back(double(worst_us) * 1e-3);
    worst_outage_s =
        std::max({worst_outage_s, pub->get().link_state().last_outage_s, relay.feed().link_state().last_outage_s});
    std::printf(
        "[ figure ] failover %d: node %d killed, relay %s; viewer pause %.0f ms, publisher outage %.0f ms, relay "
        "outage %.0f ms\n",
        kill + 1, node + 1, relay.feed().connected_url() == on ? "was on it" : "elsewhere", pauses_ms.back(),
        pub->get().link_state().last_outage_s * 1e3, relay.feed().link_state().last_outage_s * 1e3);
    ASSERT_TRUE(cluster.nodes[node].start());
    test::pump_for({v.get()}, 3.0);  // it rejoins, and JetStream catches up
  }
  std::printf("[ figure ] longest pause at the viewer across 4 failovers of the publisher's node:");
  for (double p : pauses_ms) std::printf(" %.0f ms", p);
  std::printf(" (frames every 11 ms)\n");
  // The links themselves come back within a second; what the viewer sees also holds whatever a
  // loaded machine adds (one run on a load of 10 saw 265 ms once, with a link outage of 1 ms),
  // and stays well below the 2 s of a put holding the sender back.
  EXPECT_LT(worst_outage_s, 1.0);
  EXPECT_LT(*std::max_element(pauses_ms.begin(), pauses_ms.end()), 1500.0);
  EXPECT_GE(pub->get().link_state().disconnects, 4u);
}

}  // namespace
}  // namespace mimic::net::nats_trust_test
