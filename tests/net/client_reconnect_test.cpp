// A viewer comes back after any cut (an idle timeout after a stall, a restarted server), shows
// the newest frames rather than what its sockets buffered, and counts what the cut cost.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "mimic/net/pose_stream.h"
#include "net_test_support.h"

namespace mimic::net::client_reconnect_test {
namespace {

using namespace mimic::net::test;

constexpr uint16_t kDofs = 52;

std::unique_ptr<Client> join(const std::string& endpoint, Role role, bool udp = false) {
  ClientOptions o;
  o.connect = endpoint;
  o.role = role;
  o.udp = udp;
  auto c = Client::connect(o);
  EXPECT_TRUE(c) << c.error().what();
  return c ? std::move(*c) : nullptr;
}

rig::Pose pose_with(float v) {
  rig::Pose p;
  p.root_position_m = {0.1f, 0.9f, -0.2f};
  p.dof_rad.assign(kDofs, v);
  return p;
}

// A publisher at about 100 Hz for `seconds`, driving only the clients in `driven`.
uint32_t publish_for(Client& pub, uint8_t slot, uint32_t seq, double seconds, std::vector<Client*> driven) {
  driven.push_back(&pub);
  const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  while (Clock::now() < end) {
    ++seq;
    EXPECT_TRUE(pub.publish_pose(slot, {0, 0, seq, wall_clock_us()}, pose_with(0.001f * float(seq % 1000))));
    pump_for(driven, 0.01);
  }
  return seq;
}

// The subscriber is not driven for 3 s (its process stopped, its caller busy) while frames go
// on; the server's idle timeout (1.5 s here) cuts it meanwhile. Woken, it neither stops nor plays
// back what its socket held: it comes back with the newest frames and counts the rest as lost.
void stalled_viewer_comes_back(bool udp) {
  ServerOptions so;
  so.idle_timeout_s = 1.5;
  ServerThread st(so);
  auto pub = join(st.endpoint(), Role::publisher);
  auto sub = join(st.endpoint(), Role::subscriber, udp);
  ASSERT_TRUE(pub && sub);
  const uint8_t slot = *pub->add_avatar("walker", kDofs, "model");
  uint32_t seq = publish_for(*pub, slot, 0, 0.5, {sub.get()});
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->stats().frames >= 10; }));
  const uint32_t seen_before = sub->avatars().begin()->second.last.sequence;

  seq = publish_for(*pub, slot, seq, 3.0, {});  // the subscriber is not driven
  const uint32_t newest_at_wake = seq;
  std::vector<uint32_t> after;
  sub->on_pose = [&](const RemoteAvatar& a, uint64_t) { after.push_back(a.last.sequence); };
  std::string cut_reason;
  sub->on_cut = [&](const std::string& why) { cut_reason = why; };
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  while (after.size() < 20 && Clock::now() < deadline) {
    ASSERT_TRUE(sub->run_until(Clock::now() + std::chrono::milliseconds(1))) << "the cut ended the session";
    seq = publish_for(*pub, slot, seq, 0.01, {});
  }
  ASSERT_GE(after.size(), 20u) << cut_reason;
  EXPECT_GE(sub->stats().cuts, 1u);
  EXPECT_GE(sub->stats().stall_resyncs, 1u);
  EXPECT_FALSE(cut_reason.empty());
  // Not one frame from the stall: the first is the newest published then (give or take the
  // last few still on their way to the server on a loaded machine), not the one after the
  // last seen before it, ~300 frames older.
  EXPECT_GE(after.front() + 10, newest_at_wake) << "first frame after the stall " << after.front() << ", newest "
                                                << newest_at_wake << ", last seen before " << seen_before;
  // What was skipped is counted, by sequence.
  EXPECT_GE(sub->stats().lost, uint64_t(after.front() - seen_before - 1));
  EXPECT_EQ(sub->stats().outages, 1u);
  EXPECT_GE(sub->stats().outage_s, 2.5);
  EXPECT_EQ(st.stats().rejected[size_t(Reject::unexpected)], 0u);
}

TEST(ClientReconnect, StalledViewerComesBackWithTheNewestFrames) { stalled_viewer_comes_back(false); }
TEST(ClientReconnect, StalledUdpViewerComesBackWithTheNewestFrames) { stalled_viewer_comes_back(true); }

// An avatar joins while the viewer is stalled (a viewer skinning a newcomer under load): its model
// is among the bytes the stalled viewer drops to resume at the newest frames. The resumed session
// brings it again, so the viewer has both avatars, each with frames; the first one is no news.
TEST(ClientReconnect, AModelDroppedWithAStallsBufferedBytesComesAgain) {
  ServerThread st;
  auto pub = join(st.endpoint(), Role::publisher);
  auto sub = join(st.endpoint(), Role::subscriber);
  ASSERT_TRUE(pub && sub);
  std::vector<std::string> announced;
  sub->on_model = [&](const RemoteAvatar& a) { announced.push_back(a.name); };
  const uint8_t first = *pub->add_avatar("first", kDofs, "first model");
  uint32_t seq = publish_for(*pub, first, 0, 0.3, {sub.get()});
  ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->stats().frames >= 5; }));
  // Not driven for 1.5 s (over the 1 s stall limit): the second avatar's model waits in its socket.
  const uint8_t second = *pub->add_avatar("second", kDofs, "second model");
  uint32_t seq2 = 0;
  const auto quiet_until = Clock::now() + std::chrono::milliseconds(1500);
  while (Clock::now() < quiet_until) {
    seq = publish_for(*pub, first, seq, 0.005, {});
    seq2 = publish_for(*pub, second, seq2, 0.005, {});
  }
  auto both_moving = [&] {
    if (sub->avatars().size() != 2) return false;
    for (const auto& entry : sub->avatars())
      if (!entry.second.has_pose) return false;
    return true;
  };
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  while (!both_moving() && Clock::now() < deadline) {
    ASSERT_TRUE(sub->run_until(Clock::now() + std::chrono::milliseconds(1))) << "the cut ended the session";
    seq = publish_for(*pub, first, seq, 0.005, {});
    seq2 = publish_for(*pub, second, seq2, 0.005, {});
  }
  EXPECT_GE(sub->stats().stall_resyncs, 1u);
  EXPECT_GE(sub->stats().resumed, 1u);
  ASSERT_TRUE(both_moving()) << sub->avatars().size() << " avatar(s)";
  EXPECT_EQ(announced, (std::vector<std::string>{"first", "second"}));
}

// The server restarts; the publisher (another process) goes on meanwhile. The viewer's new
// session is a new scene, but the same avatar of the same publisher carries its sequence: the
// frames published while the server was down count as lost, and the outage is timed.
TEST(ClientReconnect, LossIsCarriedAcrossAServerRestart) {
  uint16_t port = 0;
  std::unique_ptr<Client> pub, sub;
  uint32_t seq = 0;
  uint8_t slot = 0;
  {
    ServerThread st;
    port = st.port();
    pub = join(st.endpoint(), Role::publisher);
    sub = join(st.endpoint(), Role::subscriber);
    ASSERT_TRUE(pub && sub);
    slot = *pub->add_avatar("walker", kDofs, "model");
    seq = publish_for(*pub, slot, seq, 0.3, {sub.get()});
    ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->stats().frames >= 5; }));
  }
  const uint32_t last_before = sub->avatars().begin()->second.last.sequence;
  const uint64_t lost_before = sub->stats().lost;
  std::vector<uint32_t> after;
  sub->on_pose = [&](const RemoteAvatar& a, uint64_t) { after.push_back(a.last.sequence); };
  seq = publish_for(*pub, slot, seq, 1.0, {sub.get()});  // the server is down
  ServerOptions so;
  so.listen = "127.0.0.1:" + std::to_string(port);
  ServerThread st(so);
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  while (sub->stats().outages == 0 && Clock::now() < deadline) seq = publish_for(*pub, slot, seq, 0.01, {sub.get()});
  ASSERT_EQ(sub->stats().outages, 1u);
  EXPECT_EQ(sub->stats().resumed, 0u);  // a new session: the scene came back anew
  ASSERT_FALSE(after.empty());
  const uint64_t missed = after.front() - last_before - 1;
  EXPECT_GE(missed, 50u);  // a second at 100 Hz, give or take a loaded machine
  EXPECT_EQ(sub->stats().lost_across_sessions, missed);
  EXPECT_GE(sub->stats().lost - lost_before, missed);
  EXPECT_GE(sub->stats().outage_s, 1.0);
  EXPECT_GE(sub->stats().cuts, 1u);
}

// A publisher that restarted counts from one again: nothing is carried (no made-up loss).
TEST(ClientReconnect, ARestartedPublisherCarriesNothing) {
  uint16_t port = 0;
  std::unique_ptr<Client> sub;
  {
    ServerThread st;
    port = st.port();
    auto pub = join(st.endpoint(), Role::publisher);
    sub = join(st.endpoint(), Role::subscriber);
    ASSERT_TRUE(pub && sub);
    const uint8_t slot = *pub->add_avatar("walker", kDofs, "model");
    publish_for(*pub, slot, 1000, 0.3, {sub.get()});
    ASSERT_TRUE(pump({sub.get(), pub.get()}, [&] { return sub->stats().frames >= 5; }));
  }
  ServerOptions so;
  so.listen = "127.0.0.1:" + std::to_string(port);
  ServerThread st(so);
  auto pub = join(st.endpoint(), Role::publisher);
  ASSERT_TRUE(pub);
  const uint8_t slot = *pub->add_avatar("walker", kDofs, "model");
  uint32_t seq = 0;
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  while (sub->stats().outages == 0 && Clock::now() < deadline) seq = publish_for(*pub, slot, seq, 0.01, {sub.get()});
  ASSERT_EQ(sub->stats().outages, 1u);
  EXPECT_EQ(sub->stats().lost_across_sessions, 0u);
}

// A server of our own cuts the connection after the handshake and a model, stops listening, and
// then a lean delta the client has no reference for arrives as a datagram. No session is up: the
// client must not ask for a key frame (the request would go out on the next connection before
// its HELLO, and a server refuses that: "unexpected (HELLO expected first)").
TEST(ClientReconnect, NoKeyRequestBetweenSessions) {
  const int lfd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(lfd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ASSERT_EQ(::listen(lfd, 4), 0);
  socklen_t len = sizeof a;
  ::getsockname(lfd, reinterpret_cast<sockaddr*>(&a), &len);
  const int ufd = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (::bind(ufd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(lfd);
    ::close(ufd);
    GTEST_SKIP() << "the UDP port beside the TCP one is taken";
  }
  std::atomic<bool> registered{false}, cut_seen{false}, sent{false};
  std::thread fake([&] {
    const int fd = ::accept(lfd, nullptr, nullptr);
    Bytes out(4096);
    Welcome w;
    w.capabilities = kCapPose | kCapResume | kCapUdpPose | kCapLeanPose;
    w.session_token.bytes.fill(7);
    size_t n = encode_welcome(w, out);
    n += encode_avatar_model({1, 1, kDofs, "walker", "model"}, std::span<uint8_t>(out).subspan(n));
    (void)::send(fd, out.data(), n, MSG_NOSIGNAL);
    // The client registers its UDP address right after WELCOME.
    sockaddr_in from{};
    socklen_t from_len = sizeof from;
    pollfd p{ufd, POLLIN, 0};
    if (::poll(&p, 1, 5000) > 0)
      (void)::recvfrom(ufd, out.data(), out.size(), 0, reinterpret_cast<sockaddr*>(&from), &from_len);
    registered = true;
    ::close(fd);
    ::close(lfd);  // reconnections are refused from now on
    for (int i = 0; i < 500 && !cut_seen; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    LeanPoseEncoder enc;
    enc.update(pose_packet(1, 1, kDofs));
    enc.update(pose_packet(1, 2, kDofs));
    const auto delta = enc.delta();
    (void)::sendto(ufd, delta.data(), delta.size(), 0, reinterpret_cast<sockaddr*>(&from), from_len);
    sent = true;
  });
  ClientOptions o;
  o.connect = "127.0.0.1:" + std::to_string(ntohs(a.sin_port));
  o.udp = true;
  o.lean = true;
  auto c = Client::connect(o);
  ASSERT_TRUE(c) << c.error().what();
  Client& client = **c;
  EXPECT_TRUE(pump({&client}, [&] { return registered && client.avatars().size() == 1 && client.stats().cuts >= 1; }));
  cut_seen = true;
  EXPECT_TRUE(pump({&client}, [&] { return bool(sent); }));
  pump_for({&client}, 0.3);
  fake.join();
  ::close(ufd);
  EXPECT_EQ(client.stats().key_requests, 0u);
  EXPECT_FALSE(client.connected());
}

}  // namespace
}  // namespace mimic::net::client_reconnect_test
