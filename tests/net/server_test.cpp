#include <gtest/gtest.h>

#include "mimic/rig/skeleton.h"
#include "net_test_support.h"

namespace mimic::net::server_test {
namespace {

using namespace mimic::net::test;

constexpr uint16_t kDofs = 52;

std::unique_ptr<Client> subscriber(const ServerThread& st, uint8_t mesh_lod = kNoMesh) {
  ClientOptions o;
  o.connect = st.endpoint();
  o.role = Role::subscriber;
  o.mesh_lod = mesh_lod;
  auto c = Client::connect(o);
  EXPECT_TRUE(c) << c.error().what();
  return c ? std::move(*c) : nullptr;
}

std::unique_ptr<Client> publisher(const ServerThread& st, const std::string& secret = "") {
  ClientOptions o;
  o.connect = st.endpoint();
  o.role = Role::publisher;
  o.secret = secret;
  auto c = Client::connect(o);
  EXPECT_TRUE(c) << c.error().what();
  return c ? std::move(*c) : nullptr;
}

rig::Pose pose_with(float v, size_t dofs = kDofs) {
  rig::Pose p;
  p.root_position_m = {0.1f, 0.9f, -0.2f};
  p.dof_rad.assign(dofs, v);
  return p;
}

// Publishes frames seq = first..last; after each, drives everyone until every subscriber in
// `others` has taken it (so the publisher's own latest-wins never merges two frames, however
// loaded the machine is).
void publish_range(Client& pub, uint8_t slot, uint32_t first, uint32_t last, std::vector<Client*> others) {
  std::vector<Client*> all = others;
  all.push_back(&pub);
  for (uint32_t s = first; s <= last; ++s) {
    std::vector<uint64_t> before;
    for (Client* c : others) before.push_back(c->stats().frames);
    ASSERT_TRUE(pub.publish_pose(slot, {0, 0, s, wall_clock_us()}, pose_with(0.001f * float(s))));
    pump(
        all,
        [&] {
          for (size_t i = 0; i < others.size(); ++i)
            if (others[i]->stats().frames <= before[i]) return false;
          return true;
        },
        2.0);
    if (others.empty()) pump_for(all, 0.0005);
  }
}

TEST(Server, HandshakeNegotiatesCapabilities) {
  ServerThread st;
  auto sub = subscriber(st);
  ASSERT_TRUE(sub);
  EXPECT_TRUE(sub->connected());
  EXPECT_FALSE(sub->session_token().empty());
  EXPECT_EQ(sub->negotiated_capabilities(), kCapPose | kCapResume);  // mesh not asked for
  auto mesh_sub = subscriber(st, 0);
  EXPECT_EQ(mesh_sub->negotiated_capabilities(), kCapPose | kCapResume | kCapMesh | kCapMeshUv);
  EXPECT_TRUE(pump({}, [&] { return st.stats().subscribers == 2; }));
}

TEST(Server, UnknownVersionRangeIsRejectedWithTheServerRange) {
  ServerThread st;
  RawPeer peer(st.port());
  ASSERT_TRUE(peer.send(hello_packet(Role::subscriber, "", kProtocolVersion + 1, kProtocolVersion + 4)));
  const Bytes reply = peer.read(2.0, 8);
  RejectMsg r;
  ASSERT_EQ(decode_reject(reply, r), Reject::ok);
  EXPECT_EQ(r.reason, Reject::unsupported_version);
  EXPECT_EQ(r.server_max_version, kProtocolVersion);
  EXPECT_TRUE(peer.wait_closed(2.0));
  EXPECT_EQ(st.stats().rejected[size_t(Reject::unsupported_version)], 1u);
}

TEST(Server, ModelOnJoinThenPoses) {
  ServerThread st;
  auto sub = subscriber(st);
  auto pub = publisher(st);
  const std::string model(3000, 'b');
  auto slot = pub->add_avatar("alice", kDofs, model);
  ASSERT_TRUE(slot);
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->avatars().size() == 1; }));
  const RemoteAvatar& a = sub->avatars().begin()->second;
  EXPECT_EQ(a.name, "alice");
  EXPECT_EQ(a.model_bytes, model);
  EXPECT_EQ(a.dof_count, kDofs);
  EXPECT_EQ(sub->stats().model_bytes, avatar_model_packet_bytes({0, 0, kDofs, "alice", model}));

  publish_range(*pub, *slot, 1, 40, {sub.get()});
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->stats().frames == 40; }));
  const RemoteAvatar& b = sub->avatars().begin()->second;
  EXPECT_EQ(b.last.sequence, 40u);
  EXPECT_EQ(b.lost, 0u);
  EXPECT_NEAR(b.pose.dof_rad[10], 0.040f, kAngleStep_rad);
  EXPECT_NEAR(b.pose.root_position_m.y, 0.9f, 1e-4f);
  EXPECT_EQ(sub->stats().frame_bytes, 40 * pose_packet_bytes(kDofs));
}

TEST(Server, LateJoinerGetsModelAndLatestPoseAtOnce) {
  ServerThread st;
  auto pub = publisher(st);
  auto witness = subscriber(st);  // proves each frame reached the server before the next
  auto slot = pub->add_avatar("bob", kDofs, std::string(500, 'x'));
  ASSERT_TRUE(slot);
  ASSERT_TRUE(pump({pub.get(), witness.get()}, [&] { return witness->avatars().size() == 1; }));
  publish_range(*pub, *slot, 1, 30, {witness.get()});
  EXPECT_EQ(st.stats().frames_in, 30u);
  auto late = subscriber(st);
  ASSERT_TRUE(pump(
      {late.get()}, [&] { return late->stats().frames >= 1; }, 2.0));
  ASSERT_EQ(late->avatars().size(), 1u);
  EXPECT_EQ(late->avatars().begin()->second.last.sequence, 30u);
  EXPECT_EQ(late->stats().frames, 1u);
  EXPECT_EQ(late->stats().models, 1u);
}

TEST(Server, StalledSubscriberDropsItsOwnFramesOthersGetAll) {
  ServerOptions opt;
  opt.send_buffer_bytes = 4096;
  ServerThread st(opt);
  RawPeer stalled(st.port(), 2048);
  ASSERT_TRUE(stalled.send(hello_packet(Role::subscriber)));  // ... and never reads again
  auto sub = subscriber(st);
  auto pub = publisher(st);
  auto slot = pub->add_avatar("carol", kDofs, "m");
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->avatars().size() == 1; }));
  const uint32_t n = 600;
  publish_range(*pub, *slot, 1, n, {sub.get()});
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->stats().frames == n; }));
  EXPECT_EQ(sub->stats().lost, 0u);
  uint64_t stalled_dropped = 0, healthy_dropped = 0;
  for (const auto& s : st.sessions()) {
    if (s.role != Role::subscriber) continue;
    if (s.name == "raw")
      stalled_dropped = s.frames_dropped;
    else
      healthy_dropped = s.frames_dropped;
  }
  EXPECT_GT(stalled_dropped, 0u);
  EXPECT_EQ(healthy_dropped, 0u);
  // The stalled peer, reading at last, finds the newest frame at the end of what it gets.
  PacketReader r;
  feed(r, stalled.read_until_quiet(0.2));
  uint32_t last_seq = 0, frames = 0;
  for (;;) {
    std::span<const uint8_t> p;
    ASSERT_EQ(r.next(p), Reject::ok);
    if (p.empty()) break;
    if (p[2] == uint8_t(MsgType::pose)) {
      last_seq = pose_sequence(p);
      frames++;
    }
  }
  EXPECT_EQ(last_seq, n);
  EXPECT_LT(frames, n);
}

// A resumed subscriber is sent the model again (one queued on the dead connection may not have
// reached it); the client knows the revision, so its avatar and frames simply go on.
TEST(Server, SubscriberResumesWithTheModelAgainAndItsFramesGoOn) {
  ServerThread st;
  auto pub = publisher(st);
  auto slot = pub->add_avatar("dan", kDofs, std::string(2000, 'd'));
  auto sub = subscriber(st);
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->avatars().size() == 1; }));
  int announced = 0;
  sub->on_model = [&](const RemoteAvatar&) { ++announced; };
  const SessionToken token = sub->session_token();
  publish_range(*pub, *slot, 1, 5, {sub.get()});
  sub->drop_connection();
  publish_range(*pub, *slot, 6, 10, {});
  ASSERT_TRUE(pump({sub.get(), pub.get()},
                   [&] { return sub->stats().resumed == 1 && sub->avatars().begin()->second.last.sequence == 10; }));
  EXPECT_EQ(sub->session_token(), token);
  EXPECT_EQ(sub->stats().models, 2u);  // sent again, the same revision
  EXPECT_EQ(announced, 0);             // ... which is no news to the client's caller
  EXPECT_EQ(st.stats().resumed, 1u);
  publish_range(*pub, *slot, 11, 20, {sub.get()});
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->avatars().begin()->second.last.sequence == 20; }));
}

TEST(Server, SubscriberReconnectsToARestartedServer) {
  uint16_t port = 0;
  std::unique_ptr<Client> sub;
  {
    ServerThread st;
    port = st.port();
    st.call([&] { return *st.server().add_avatar("old", kDofs, "old model"); });
    sub = subscriber(st);
    ASSERT_TRUE(pump({sub.get()}, [&] { return sub->avatars().size() == 1; }));
  }
  ServerOptions opt;
  opt.listen = "127.0.0.1:" + std::to_string(port);
  ServerThread st(opt);
  st.call([&] { return *st.server().add_avatar("new-a", kDofs, "a"); });
  st.call([&] { return *st.server().add_avatar("new-b", kDofs, "b"); });
  ASSERT_TRUE(pump({sub.get()}, [&] { return sub->avatars().size() == 2 && sub->stats().reconnects >= 1; }));
  for (const auto& [id, a] : sub->avatars()) EXPECT_NE(a.name, "old");
  EXPECT_EQ(sub->stats().resumed, 0u);
}

// A publisher whose host went away keeps its loop running: reconnecting never blocks it.
TEST(Server, ReconnectingDoesNotBlockTheCaller) {
  std::unique_ptr<Client> pub;
  {
    ServerThread st;
    pub = publisher(st);
    ASSERT_TRUE(pub->add_avatar("p", kDofs, "m"));
    pump_for({pub.get()}, 0.05);
  }
  for (int i = 0; i < 10; ++i) {
    const auto t0 = Clock::now();
    EXPECT_TRUE(pub->publish_pose(0, {0, 0, uint32_t(i + 1), 0}, pose_with(0.1f)));
    EXPECT_TRUE(pub->run_until(Clock::now() + std::chrono::milliseconds(20)));
    // Bound far above the 20 ms asked for, far below the 3 s connect timeout.
    EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), 1.0);
  }
  EXPECT_GE(pub->stats().reconnects, 1u);
  EXPECT_FALSE(pub->connected());
}

TEST(Server, ReusedAvatarIdStillSendsTheNewModelOnResume) {
  ServerThread st;
  const uint16_t first = st.call([&] { return *st.server().add_avatar("first", kDofs, "first model"); });
  auto sub = subscriber(st);
  ASSERT_TRUE(pump({sub.get()}, [&] { return sub->avatars().size() == 1; }));
  sub->drop_connection();
  st.call([&] { st.server().remove_avatar(first); });
  const uint16_t second = st.call([&] { return *st.server().add_avatar("second", kDofs, "second model"); });
  EXPECT_EQ(second, first);  // the id is reused
  ASSERT_TRUE(pump({sub.get()}, [&] {
    return sub->stats().resumed == 1 && sub->avatars().size() == 1 && sub->avatars().begin()->second.name == "second";
  }));
  EXPECT_EQ(sub->avatars().begin()->second.model_bytes, "second model");
}

TEST(Server, ResumedSubscriberHearsOfAvatarsThatLeft) {
  ServerThread st;
  const uint16_t gone = st.call([&] { return *st.server().add_avatar("gone", kDofs, "g"); });
  st.call([&] { return *st.server().add_avatar("stays", kDofs, "s"); });
  auto sub = subscriber(st);
  ASSERT_TRUE(pump({sub.get()}, [&] { return sub->avatars().size() == 2; }));
  sub->drop_connection();
  st.call([&] { st.server().remove_avatar(gone); });
  ASSERT_TRUE(pump({sub.get()}, [&] { return sub->stats().resumed == 1 && sub->avatars().size() == 1; }));
  EXPECT_EQ(sub->avatars().begin()->second.name, "stays");
  EXPECT_EQ(sub->stats().models, 3u);  // the one that stays, sent again
}

TEST(Server, PublisherResumeKeepsTheAvatar) {
  ServerThread st;
  auto pub = publisher(st);
  auto slot = pub->add_avatar("eve", kDofs, "model");
  auto sub = subscriber(st);
  bool removed = false;
  sub->on_removed = [&](uint16_t) { removed = true; };
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->avatars().size() == 1; }));
  const uint16_t id = sub->avatars().begin()->first;
  publish_range(*pub, *slot, 1, 5, {sub.get()});
  pub->drop_connection();
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return pub->stats().resumed == 1; }));
  publish_range(*pub, *slot, 6, 10, {sub.get()});
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->avatars().begin()->second.last.sequence == 10; }));
  EXPECT_FALSE(removed);
  EXPECT_EQ(sub->avatars().begin()->first, id);
  EXPECT_EQ(sub->stats().models, 1u);
  // A clean leave removes the avatar at once.
  pub->close();
  EXPECT_TRUE(pump({sub.get()}, [&] { return removed; }));
  EXPECT_TRUE(sub->avatars().empty());
}

TEST(Server, PublisherNeedsTheSecretWhenOneIsSet) {
  ServerOptions opt;
  opt.secret = "open sesame";
  ServerThread st(opt);
  ClientOptions o;
  o.connect = st.endpoint();
  o.role = Role::publisher;
  auto bad = Client::connect(o);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("unauthorized"), std::string::npos);
  // After the wrong guess's back-off (docs/security.md).
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  o.secret = "open sesame";
  EXPECT_TRUE(Client::connect(o));
  auto sub = subscriber(st);  // subscribers need none
  EXPECT_TRUE(sub);
  EXPECT_EQ(st.stats().rejected[size_t(Reject::unauthorized)], 1u);
}

TEST(Server, NonLoopbackListenRequiresASecret) {
  ServerOptions opt;
  opt.listen = "0.0.0.0:0";
  auto s = Server::create(opt);
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("secret"), std::string::npos);
  opt.secret = "x";
  EXPECT_TRUE(Server::create(opt));
  opt.listen = "nonsense";
  EXPECT_FALSE(Server::create(opt));
}

// Hostile peers are refused and counted; a legitimate subscriber keeps getting every frame.
TEST(Server, HostileInputIsCountedAndHarmsNobody) {
  ServerOptions opt;
  opt.max_packets_per_s = 1000;
  ServerThread st(opt);
  auto sub = subscriber(st);
  auto pub = publisher(st);
  auto slot = pub->add_avatar("frank", kDofs, "m");
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->avatars().size() == 1; }));

  std::vector<std::unique_ptr<RawPeer>> peers;
  auto peer = [&] { return peers.emplace_back(std::make_unique<RawPeer>(st.port())).get(); };
  // Not our protocol at all.
  peer()->send("GET / HTTP/1.1\r\nHost: x\r\n\r\n", 27);
  // Our magic, a future header version.
  Bytes v = hello_packet(Role::subscriber);
  v[1] = 9;
  peer()->send(v);
  // A header announcing a 100 MB packet.
  Bytes big = hello_packet(Role::subscriber);
  big[7] = 0x06;
  peer()->send(big);
  // Unknown message type.
  Bytes unk = hello_packet(Role::subscriber);
  unk[2] = 77;
  peer()->send(unk);
  // Poses before HELLO.
  peer()->send(pose_packet(0, 1, kDofs));
  // Malformed HELLO (bad role).
  Bytes bad_role = hello_packet(Role::subscriber);
  bad_role[kHeaderBytes + 2] = 0;
  peer()->send(bad_role);
  // A publisher sending a malformed pose (lying DOF count).
  RawPeer* liar = peer();
  liar->send(hello_packet(Role::publisher));
  liar->send(model_packet(0, kDofs, 10));
  Bytes lie = pose_packet(0, 1, kDofs);
  lie[kPoseFixedBytes - 2] = 3;
  liar->send(lie);
  // A publisher replaying old frames: out of order, dropped but not fatal.
  RawPeer* replay = peer();
  replay->send(hello_packet(Role::publisher));
  replay->send(model_packet(0, kDofs, 10));
  replay->send(pose_packet(0, 5, kDofs));
  replay->send(pose_packet(0, 4, kDofs));
  replay->send(pose_packet(0, 5, kDofs));
  // Truncated: half a header, then silence (closed by the HELLO timeout).
  peer()->send(hello_packet(Role::subscriber).data(), 5);
  // A flood of HELLO-sized junk after a valid HELLO from a subscriber.
  RawPeer* flood = peer();
  flood->send(hello_packet(Role::subscriber));
  Bytes burst;
  for (int i = 0; i < 8000; ++i) {
    Bytes p = pose_packet(0, uint32_t(i + 1), 4);
    burst.insert(burst.end(), p.begin(), p.end());
  }
  flood->send(burst);

  publish_range(*pub, *slot, 1, 300, {sub.get()});
  auto frank = [&]() -> const RemoteAvatar* {
    for (const auto& [id, a] : sub->avatars())
      if (a.name == "frank") return &a;
    return nullptr;
  };
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return frank() && frank()->last.sequence == 300; }));
  EXPECT_EQ(frank()->frames, 300u);
  EXPECT_EQ(frank()->lost, 0u);

  for (size_t i = 0; i < 6; ++i) EXPECT_TRUE(peers[i]->wait_closed(3.0)) << "peer " << i;
  EXPECT_TRUE(liar->wait_closed(3.0));
  EXPECT_TRUE(flood->wait_closed(3.0));
  EXPECT_TRUE(peers[8]->wait_closed(5.0));  // truncated: the HELLO timeout
  const ServerStats s = st.stats();
  EXPECT_GE(s.rejected[size_t(Reject::bad_magic)], 1u);
  EXPECT_GE(s.rejected[size_t(Reject::unknown_version)], 1u);
  EXPECT_GE(s.rejected[size_t(Reject::oversized)], 1u);
  EXPECT_GE(s.rejected[size_t(Reject::unknown_type)], 1u);
  EXPECT_GE(s.rejected[size_t(Reject::unexpected)], 1u);
  EXPECT_GE(s.rejected[size_t(Reject::malformed)], 2u);
  EXPECT_EQ(s.rejected[size_t(Reject::out_of_order)], 2u);
  EXPECT_GE(s.rejected[size_t(Reject::flood)], 1u);
  EXPECT_GE(s.rejected[size_t(Reject::timeout)], 1u);
  EXPECT_FALSE(replay->closed());
  // The server still serves newcomers.
  auto again = subscriber(st);
  ASSERT_TRUE(again);
  EXPECT_TRUE(pump({again.get()}, [&] { return again->avatars().size() >= 1; }));
}

// Connections that never say HELLO (a connection flood) are closed by the HELLO timeout; over
// the session limit a newcomer is told the server is full; subscribers already in carry on.
TEST(Server, ConnectionFloodAndServerFull) {
  ServerOptions opt;
  opt.max_sessions = 40;
  opt.hello_timeout_s = 0.5;
  ServerThread st(opt);
  auto sub = subscriber(st);
  auto pub = publisher(st);
  auto slot = pub->add_avatar("gina", kDofs, "m");
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->avatars().size() == 1; }));
  std::vector<std::unique_ptr<RawPeer>> idle;
  for (int i = 0; i < 38; ++i) idle.push_back(std::make_unique<RawPeer>(st.port()));
  ASSERT_TRUE(pump({}, [&] { return st.stats().sessions_open == 40; }));
  RawPeer extra(st.port());
  RejectMsg r;
  ASSERT_EQ(decode_reject(extra.read(2.0, 8), r), Reject::ok);
  EXPECT_EQ(r.reason, Reject::server_full);
  publish_range(*pub, *slot, 1, 50, {sub.get()});
  EXPECT_EQ(sub->avatars().begin()->second.last.sequence, 50u);
  EXPECT_EQ(sub->stats().lost, 0u);
  for (auto& p : idle) EXPECT_TRUE(p->wait_closed(3.0));
  const ServerStats s = st.stats();
  EXPECT_EQ(s.rejected[size_t(Reject::timeout)], 38u);
  EXPECT_EQ(s.rejected[size_t(Reject::server_full)], 1u);
  auto later = subscriber(st);  // room again
  ASSERT_TRUE(later);
  EXPECT_TRUE(pump({later.get()}, [&] { return later->avatars().size() == 1; }));
}

TEST(Server, MeshFramesAtTheChosenLod) {
  ServerThread st;
  auto thin = subscriber(st, 1);
  auto plain = subscriber(st);
  uint16_t id = st.call([&] { return *st.server().add_avatar("local", kDofs, "model"); });
  ASSERT_TRUE(
      pump({thin.get(), plain.get()}, [&] { return thin->avatars().size() == 1 && plain->avatars().size() == 1; }));
  EXPECT_EQ(st.call([&] { return st.server().mesh_lods_wanted(id); }), 1u << 1);
  MeshTopology topo{id, 1, 4, {0, 1, 2, 0, 2, 3}};
  ASSERT_TRUE(st.call([&] { return st.server().set_mesh_topology(topo).has_value(); }));
  const std::vector<glm::vec3> quad = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  Bytes frame(mesh_packet_bytes(4));
  ASSERT_GT(encode_mesh({id, 1, 1, wall_clock_us()}, quad, frame), 0u);
  EXPECT_EQ(st.call([&] { return st.server().publish_mesh(id, 1, frame); }), Reject::ok);
  Bytes pose(pose_packet_bytes(kDofs));
  encode_pose({id, 0, 1, wall_clock_us()}, pose_with(0.5f), pose);
  EXPECT_EQ(st.call([&] { return st.server().publish_pose(id, pose); }), Reject::ok);
  ASSERT_TRUE(
      pump({thin.get(), plain.get()}, [&] { return thin->stats().mesh_frames == 1 && plain->stats().frames == 1; }));
  const RemoteAvatar& a = thin->avatars().begin()->second;
  EXPECT_EQ(a.mesh_indices, topo.indices);
  ASSERT_EQ(a.mesh_positions_m.size(), 4u);
  EXPECT_NEAR(a.mesh_positions_m[2].y, 1.0f, 1e-4f);
  EXPECT_EQ(plain->stats().mesh_frames, 0u);
  // Out-of-order local frames are refused too.
  EXPECT_EQ(st.call([&] { return st.server().publish_pose(id, pose); }), Reject::out_of_order);
}

}  // namespace
}  // namespace mimic::net::server_test
