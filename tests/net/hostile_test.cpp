// Attacks on the scene server from the network, each the way it was found: one packet, a
// forged datagram, a flood, a scene too large for the backlog, guessed secrets. Each test fails
// without the bound it checks (docs/security.md lists them).
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "forged_udp.h"
#include "net_test_support.h"

namespace mimic::net::hostile_test {
namespace {

using namespace mimic::net::test;

constexpr uint16_t kDofs = 52;

size_t rss_bytes() {
  std::ifstream f("/proc/self/statm");
  size_t pages = 0, resident = 0;
  f >> pages >> resident;
  return resident * 4096;
}

Bytes topology_packet(uint16_t slot, uint8_t lod, uint32_t vertex_count, std::vector<uint32_t> indices = {}) {
  MeshTopology t{slot, lod, vertex_count, std::move(indices)};
  // Written by hand: encode_mesh_topology refuses counts past what a frame holds, an attacker
  // does not.
  Bytes b(mesh_topology_packet_bytes(t.indices.size()));
  size_t at = 0;
  auto put = [&](uint64_t v, int n) {
    for (int i = 0; i < n; ++i) b[at++] = uint8_t(v >> (8 * i));
  };
  put(kMagic, 1);
  put(kProtocolVersion, 1);
  put(uint8_t(MsgType::mesh_topology), 1);
  put(0, 1);
  put(b.size() - kHeaderBytes, 4);
  put(t.avatar, 2);
  put(t.lod, 1);
  put(t.vertex_count, 4);
  put(t.indices.size(), 4);
  for (uint32_t i : t.indices) put(i, 4);
  return b;
}

Bytes mesh_packet(uint16_t slot, uint8_t lod, uint32_t seq, size_t vertices) {
  std::vector<glm::vec3> p(vertices, glm::vec3(0.1f));
  if (vertices > 1) p[1] = glm::vec3(0.5f);
  Bytes b(mesh_packet_bytes(vertices));
  b.resize(encode_mesh({slot, lod, seq, wall_clock_us()}, p, b));
  return b;
}

// A raw publisher with one avatar in slot 0 (its model accepted).
std::unique_ptr<RawPeer> raw_publisher(ServerThread& st, const std::string& secret = "") {
  const uint64_t before = st.stats().avatars;
  auto p = std::make_unique<RawPeer>(st.port());
  EXPECT_TRUE(p->send(hello_packet(Role::publisher, secret)));
  EXPECT_FALSE(read_packet(*p).empty());  // WELCOME
  EXPECT_TRUE(p->send(model_packet(0, kDofs, 100)));
  EXPECT_TRUE(pump({}, [&] { return st.stats().avatars == before + 1; }));
  return p;
}

std::unique_ptr<Client> connect_client(const ServerThread& st, Role role, bool udp = false) {
  ClientOptions o;
  o.connect = st.endpoint();
  o.role = role;
  o.udp = udp;
  auto c = Client::connect(o);
  EXPECT_TRUE(c) << c.error().what();
  return c ? std::move(*c) : nullptr;
}

TEST(Hostile, TopologyVertexCountsPastAFrameAreRefusedByTheCodec) {
  MeshTopology t;
  EXPECT_EQ(decode_mesh_topology(topology_packet(0, 0, 0xFFFFFFFFu), t), Reject::oversized);
  EXPECT_EQ(decode_mesh_topology(topology_packet(0, 0, 100'000'000u), t), Reject::oversized);
  EXPECT_EQ(decode_mesh_topology(topology_packet(0, 0, kMaxMeshVertices + 1), t), Reject::oversized);
  EXPECT_EQ(decode_mesh_topology(topology_packet(0, 0, kMaxMeshVertices, {0, 1, 2}), t), Reject::ok);
  // The largest topology's frame still fits a packet.
  EXPECT_LE(mesh_packet_bytes(kMaxMeshVertices), kMaxMeshBytes);
  Bytes out(mesh_topology_packet_bytes(0));
  EXPECT_EQ(encode_mesh_topology({0, 0, kMaxMeshVertices + 1, {}}, out), 0u);
}

// The packet that ended `mimic run`: a topology of 0xFFFFFFFF vertices (std::bad_alloc), or of
// 100,000,000 (600 MB zero-filled). Now the sender's session ends and nothing is allocated.
TEST(Hostile, OneTopologyPacketNeitherKillsNorGrowsTheServer) {
  ServerThread st;
  auto viewer = connect_client(st, Role::subscriber);
  auto pub = raw_publisher(st);
  const size_t rss_before = rss_bytes();
  for (uint32_t count : {0xFFFFFFFFu, 100'000'000u}) {
    auto attacker = raw_publisher(st);
    ASSERT_TRUE(attacker->send(topology_packet(0, 0, count)));
    EXPECT_TRUE(attacker->wait_closed(5.0));
  }
  EXPECT_GE(st.stats().rejected[size_t(Reject::oversized)], 2u);
  EXPECT_LT(rss_bytes(), rss_before + (32u << 20));
  // The scene goes on: the first publisher's frames reach the viewer.
  for (uint32_t seq = 1; seq <= 5; ++seq) ASSERT_TRUE(pub->send(pose_packet(0, seq, kDofs)));
  EXPECT_TRUE(pump({viewer.get()}, [&] { return viewer->stats().frames >= 5; }));
}

// Topologies within a frame's size still add up: every avatar and LOD of a publisher can send
// one. Their frame buffers are bounded in total; one over the bound is refused (the publisher
// stays, its other avatars too).
TEST(Hostile, TopologiesAreBoundedInTotal) {
  ServerOptions o;
  o.max_mesh_bytes = 4u << 20;
  ServerThread st(o);
  auto attacker = raw_publisher(st);
  const uint32_t big = 500'000;  // a 3 MB frame each
  ASSERT_TRUE(attacker->send(topology_packet(0, 0, big, {0, 1, 2})));
  ASSERT_TRUE(attacker->send(topology_packet(0, 1, big, {0, 1, 2})));
  ASSERT_TRUE(pump({}, [&] { return st.stats().mesh_topologies_refused == 1; }));
  EXPECT_FALSE(attacker->closed());
  // The same LOD again replaces its own buffer: within the bound.
  ASSERT_TRUE(attacker->send(topology_packet(0, 0, big, {0, 1, 2})));
  ASSERT_TRUE(attacker->send(pose_packet(0, 1, kDofs)));
  EXPECT_TRUE(pump({}, [&] { return st.stats().frames_in == 1; }));
  EXPECT_EQ(st.stats().mesh_topologies_refused, 1u);
}

// A mesh frame is drawn with its topology's indices: one with more (or fewer) vertices than the
// topology is refused, never resized into the buffers or forwarded.
TEST(Hostile, MeshFramesMustMatchTheirTopology) {
  ServerThread st;
  ClientOptions vo;
  vo.connect = st.endpoint();
  vo.mesh_lod = 0;
  auto viewer = Client::connect(vo);
  ASSERT_TRUE(viewer);
  auto pub = raw_publisher(st);
  ASSERT_TRUE(pub->send(topology_packet(0, 0, 4, {0, 1, 2, 0, 2, 3})));
  ASSERT_TRUE(pub->send(pose_packet(0, 1, kDofs)));
  ASSERT_TRUE(pub->send(mesh_packet(0, 0, 1, 4)));
  ASSERT_TRUE(pump({viewer->get()}, [&] { return (*viewer)->stats().mesh_frames == 1; }));
  ASSERT_TRUE(pub->send(mesh_packet(0, 0, 2, 5000)));
  EXPECT_TRUE(pub->wait_closed(5.0));
  EXPECT_EQ(st.stats().rejected[size_t(Reject::malformed)], 1u);
  pump_for({viewer->get()}, 0.3);
  EXPECT_EQ((*viewer)->stats().mesh_frames, 1u);
  EXPECT_EQ((*viewer)->avatars().begin()->second.mesh_positions_m.size(), 4u);
}

// poll() does a bounded amount of work: a flood that keeps the socket readable cannot hold the
// caller (the realtime loop) inside it.
TEST(Hostile, PollDoesBoundedWorkWhateverArrives) {
  ServerOptions o;
  o.poll_max_handlers = 32;
  auto server = Server::create(o);
  ASSERT_TRUE(server);
  Server& srv = **server;
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(srv.port());
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  // Fewer than the socket's default receive buffer holds, so the kernel drops none of them.
  const uint8_t junk[32] = {'M'};
  int sent = 0;
  for (int i = 0; i < 200; ++i)
    sent += ::sendto(fd, junk, sizeof junk, 0, reinterpret_cast<const sockaddr*>(&to), sizeof to) == sizeof junk;
  ::close(fd);
  ASSERT_EQ(sent, 200);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  srv.poll();
  EXPECT_LE(srv.stats().udp_datagrams_in, 32u);
  EXPECT_GE(srv.stats().poll_budget_hit, 1u);
  // The rest is handled by later polls: nothing is lost to the budget but time.
  for (int i = 0; i < 100 && srv.stats().udp_datagrams_in < uint64_t(sent); ++i) srv.poll();
  EXPECT_EQ(srv.stats().udp_datagrams_in, uint64_t(sent));
}

// A registration forged to come from the server's own UDP port made the server answer itself,
// forever (60,367 sendto in 4 s, no frames to anyone). It is ignored now.
TEST(Hostile, ARegistrationFromTheServersOwnPortIsIgnored) {
  mimic::test::ForgedUdp forged;
  if (!forged.ok()) GTEST_SKIP() << "raw sockets need CAP_NET_RAW (run as root to forge the source address)";
  ServerThread st;
  auto viewer = connect_client(st, Role::subscriber, true);
  ASSERT_TRUE(viewer);
  auto pub = raw_publisher(st);
  ASSERT_TRUE(pump({viewer.get()}, [&] { return viewer->udp_active(); }));
  const uint64_t challenges_before = st.stats().udp_challenges;
  UdpRegister reg;
  reg.token = viewer->session_token();
  Bytes d(kUdpRegisterBytes);
  encode_udp_register(reg, d);
  ASSERT_TRUE(forged.send("127.0.0.1", st.port(), "127.0.0.1", st.port(), d));
  ASSERT_TRUE(pump({viewer.get()}, [&] { return st.stats().udp_own_address >= 1; }));
  pump_for({viewer.get()}, 0.5);
  const ServerStats s = st.stats();
  EXPECT_EQ(s.udp_challenges, challenges_before);
  EXPECT_LT(s.udp_datagrams_in, 100u);
  // The viewer's frames still flow.
  const uint64_t frames = viewer->stats().frames;
  for (uint32_t seq = 1; seq <= 5; ++seq) ASSERT_TRUE(pub->send(pose_packet(0, seq, kDofs)));
  EXPECT_TRUE(pump({viewer.get()}, [&] { return viewer->stats().frames >= frames + 5; }));
}

// Whatever sends registrations (a forged source, another server answering back), a session
// gets a bounded number of answers.
TEST(Hostile, RegistrationAnswersAreRateLimitedPerSession) {
  ServerOptions o;
  o.udp_answers_per_s = 10;
  ServerThread st(o);
  auto viewer = connect_client(st, Role::subscriber, true);
  ASSERT_TRUE(pump({viewer.get()}, [&] { return viewer->udp_active(); }));
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(st.port());
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  UdpRegister reg;
  reg.token = viewer->session_token();
  Bytes d(kUdpRegisterBytes);
  encode_udp_register(reg, d);
  const uint64_t in_before = st.stats().udp_datagrams_in;
  for (int i = 0; i < 300; ++i) {
    ::sendto(fd, d.data(), d.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
    if (i % 50 == 49) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  // Until the server has read what reached it (the kernel may drop some of a burst).
  uint64_t seen = 0;
  for (int quiet = 0; quiet < 10;) {
    pump_for({viewer.get()}, 0.05);
    const uint64_t now = st.stats().udp_datagrams_in;
    quiet = now == seen ? quiet + 1 : 0;
    seen = now;
  }
  ASSERT_GE(seen - in_before, 150u);
  int answers = 0;
  uint8_t buf[64];
  for (;;) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 200) <= 0) break;
    answers += ::recv(fd, buf, sizeof buf, 0) > 0;
  }
  ::close(fd);
  EXPECT_LE(answers, 40);  // 10 of burst, 10 a second while the flood lasts
  EXPECT_GE(st.stats().udp_answers_limited, seen - in_before - 40);
}

// 512 avatars of the default 17 KB body made every joiner "slow" before its WELCOME: the scene
// is sent to a joiner whatever its size (models are shared, one queued per avatar).
TEST(Hostile, AJoinerGetsASceneLargerThanTheControlBacklog) {
  ServerOptions o;
  o.max_control_backlog_bytes = 256 * 1024;
  ServerThread st(o);
  constexpr int kAvatars = 40;
  for (int i = 0; i < kAvatars; ++i)
    ASSERT_TRUE(st.call([&] {
      return st.server()
          .add_avatar("a" + std::to_string(i), kDofs, std::string(17 * 1024, char('a' + i % 26)))
          .has_value();
    }));
  auto joiner = connect_client(st, Role::subscriber);
  ASSERT_TRUE(joiner);
  EXPECT_TRUE(pump(
      {joiner.get()}, [&] { return joiner->avatars().size() == size_t(kAvatars); }, 10.0));
  EXPECT_EQ(st.stats().sessions_closed_slow, 0u);
  EXPECT_EQ(st.stats().subscribers, 1u);
}

// A stalled subscriber holds the scene's current models, shared with everyone, never copies:
// fifteen 60 KB models later it is still there, and the memory held is those models.
TEST(Hostile, AStalledSubscriberPinsOnlyTheCurrentModels) {
  ServerOptions o;
  o.send_buffer_bytes = 4096;
  o.max_control_backlog_bytes = 256 * 1024;
  ServerThread st(o);
  RawPeer stalled(st.port(), 2048);
  ASSERT_TRUE(stalled.send(hello_packet(Role::subscriber)));
  auto sub = connect_client(st, Role::subscriber);
  auto pub = connect_client(st, Role::publisher);
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return st.stats().subscribers == 2; }));
  for (int i = 0; i < 15; ++i)
    ASSERT_TRUE(pub->add_avatar("big" + std::to_string(i), kDofs, std::string(60 * 1024, char('a' + i))));
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->stats().models == 15u; }));
  const ServerStats s = st.stats();
  EXPECT_EQ(s.sessions_closed_slow, 0u);
  EXPECT_EQ(s.subscribers, 2u);
  EXPECT_LE(s.model_bytes_held, 16u * (60 * 1024 + 128));
}

// The models of a scene are bounded in total: one past the bound is refused and counted, the
// publisher keeps its session and its other avatars.
TEST(Hostile, ModelsAreBoundedInTotal) {
  ServerOptions o;
  o.max_model_bytes_held = 1u << 20;
  ServerThread st(o);
  RawPeer pub(st.port());
  ASSERT_TRUE(pub.send(hello_packet(Role::publisher)));
  for (uint16_t slot = 0; slot < 4; ++slot) ASSERT_TRUE(pub.send(model_packet(slot, kDofs, 400 * 1024)));
  ASSERT_TRUE(pump({}, [&] { return st.stats().models_refused == 2; }));
  EXPECT_EQ(st.stats().avatars, 2u);
  EXPECT_FALSE(pub.closed());
  EXPECT_LE(st.stats().model_bytes_held, o.max_model_bytes_held);
  // Local avatars are held to it too.
  EXPECT_FALSE(
      st.call([&] { return st.server().add_avatar("local", kDofs, std::string(400 * 1024, 'l')).has_value(); }));
}

std::string reject_message(RawPeer& peer) {
  for (;;) {
    const Bytes p = read_packet(peer, 3.0);
    if (p.empty()) return "";
    RejectMsg r;
    if (decode_reject(p, r) == Reject::ok) return r.message;
  }
}

// Guessing the publishers' secret costs time: each wrong guess doubles its address's wait, and
// a guess during the wait is refused unchecked (even the right one).
TEST(Hostile, WrongSecretsMakeTheirAddressWait) {
  ServerOptions o;
  o.secret = "right";
  o.secret_backoff_s = 0.3;
  o.secret_backoff_max_s = 0.6;
  ServerThread st(o);
  int checked = 0, waited = 0;
  for (int i = 0; i < 10; ++i) {
    RawPeer guess(st.port());
    ASSERT_TRUE(guess.send(hello_packet(Role::publisher, "guess" + std::to_string(i))));
    const std::string m = reject_message(guess);
    checked += m.find("shared secret") != std::string::npos;
    waited += m.find("wait") != std::string::npos;
  }
  EXPECT_LE(checked, 3);
  EXPECT_GE(waited, 7);
  EXPECT_EQ(st.stats().secret_backoffs, uint64_t(waited));
  {
    RawPeer during(st.port());
    ASSERT_TRUE(during.send(hello_packet(Role::publisher, "right")));
    EXPECT_NE(reject_message(during).find("wait"), std::string::npos);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  // Another address was never held up.
  RawPeer other(st.port(), 0, "127.0.0.2");
  ASSERT_TRUE(other.send(hello_packet(Role::publisher, "right")));
  Welcome w;
  EXPECT_EQ(decode_welcome(read_packet(other), w), Reject::ok);
  RawPeer after(st.port());
  ASSERT_TRUE(after.send(hello_packet(Role::publisher, "right")));
  EXPECT_EQ(decode_welcome(read_packet(after), w), Reject::ok);
}

// Client ids come from the CSPRNG: they say nothing of how many sessions came before.
TEST(Hostile, ClientIdsAreNotSequential) {
  ServerThread st;
  std::vector<uint32_t> ids;
  std::vector<std::unique_ptr<RawPeer>> peers;
  for (int i = 0; i < 6; ++i) {
    peers.push_back(std::make_unique<RawPeer>(st.port()));
    ASSERT_TRUE(peers.back()->send(hello_packet(Role::subscriber)));
    Welcome w;
    ASSERT_EQ(decode_welcome(read_packet(*peers.back()), w), Reject::ok);
    ids.push_back(w.client_id);
  }
  int consecutive = 0;
  for (size_t i = 1; i < ids.size(); ++i) consecutive += ids[i] == ids[i - 1] + 1;
  EXPECT_EQ(consecutive, 0);
  EXPECT_EQ(std::set<uint32_t>(ids.begin(), ids.end()).size(), ids.size());
}

// A subscriber asking for mesh frames at a LOD the server does not serve is told so, with the
// LODs it does serve, instead of silently getting nothing.
TEST(Hostile, AnUnservedMeshLodIsRefusedWithTheLodsServed) {
  ServerOptions o;
  o.mesh_lods_served = 0b0001;
  ServerThread st(o);
  RawPeer peer(st.port());
  Hello h;
  h.role = Role::subscriber;
  h.capabilities = kCapPose | kCapMesh;
  h.mesh_lod = 2;
  h.name = "viewer";
  Bytes b(kMaxHelloBytes);
  b.resize(encode_hello(h, b));
  ASSERT_TRUE(peer.send(b));
  const Bytes p = read_packet(peer);
  RejectMsg r;
  ASSERT_EQ(decode_reject(p, r), Reject::ok);
  EXPECT_EQ(r.reason, Reject::unavailable);
  EXPECT_NE(r.message.find("mesh LOD 2"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("served: 0"), std::string::npos) << r.message;
  ClientOptions ok;
  ok.connect = st.endpoint();
  ok.mesh_lod = 0;
  EXPECT_TRUE(Client::connect(ok));
}

}  // namespace
}  // namespace mimic::net::hostile_test

namespace mimic::net::hostile_test {
namespace {

size_t open_descriptors() {
  size_t n = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator("/proc/self/fd")) ++n;
  return n;
}

// Out of descriptors, accept() fails at once with EMFILE while the connection waits in the
// backlog: retried at once, that spun the event loop for ever. The server waits instead, and
// takes the waiting connections once descriptors are free again.
TEST(Hostile, AcceptBacksOffWhenOutOfDescriptors) {
  auto server = Server::create(ServerOptions{});
  ASSERT_TRUE(server);
  Server& srv = **server;
  constexpr int kClients = 40;
  std::vector<std::unique_ptr<RawPeer>> clients;
  for (int i = 0; i < kClients; ++i) {
    clients.push_back(std::make_unique<RawPeer>(srv.port()));
    ASSERT_TRUE(clients.back()->connected());  // in the backlog: nobody polls the server yet
  }
  rlimit saved{};
  ASSERT_EQ(getrlimit(RLIMIT_NOFILE, &saved), 0);
  rlimit low = saved;
  low.rlim_cur = open_descriptors() + 10;  // room for ten of them
  ASSERT_EQ(setrlimit(RLIMIT_NOFILE, &low), 0);
  const auto end = Clock::now() + std::chrono::milliseconds(300);
  while (Clock::now() < end) {
    srv.poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  const ServerStats during = srv.stats();
  ASSERT_EQ(setrlimit(RLIMIT_NOFILE, &saved), 0);
  EXPECT_GE(during.accept_errors, 1u);
  EXPECT_LE(during.accept_errors, 20u) << "accept() retried without waiting";
  EXPECT_LT(during.sessions_accepted, uint64_t(kClients));
  // Descriptors back: the rest are taken after the wait.
  const auto until = Clock::now() + std::chrono::seconds(5);
  while (Clock::now() < until && srv.stats().sessions_accepted < uint64_t(kClients)) {
    srv.poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(srv.stats().sessions_accepted, uint64_t(kClients));
}

}  // namespace
}  // namespace mimic::net::hostile_test
