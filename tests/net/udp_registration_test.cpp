// UDP registration by return routability: frames go only to an address that echoed the server's
// nonce, from the TCP peer's host, for as long as it keeps refreshing.
#include <gtest/gtest.h>

#include <thread>

#include "net_test_support.h"

namespace mimic::net::udp_registration_test {
namespace {

using namespace mimic::net::test;

constexpr uint16_t kDofs = 52;

// A UDP socket on loopback, bound to `from` (any 127.x.y.z), sending to the server's port.
struct Udp {
  int fd = -1;
  Udp(uint16_t port, const char* from = "127.0.0.1") {
    fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in l{};
    l.sin_family = AF_INET;
    ::inet_pton(AF_INET, from, &l.sin_addr);
    EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&l), sizeof l), 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::connect(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a), 0);
  }
  ~Udp() { ::close(fd); }
  void send(const SessionToken& token, uint64_t nonce) const {
    Bytes b(kUdpRegisterBytes);
    b.resize(encode_udp_register({token, nonce}, b));
    EXPECT_EQ(::send(fd, b.data(), b.size(), 0), ssize_t(b.size()));
  }
  Bytes receive(double timeout_s) const {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, int(timeout_s * 1000)) <= 0) return {};
    Bytes b(2048);
    const ssize_t n = ::recv(fd, b.data(), b.size(), 0);
    b.resize(n > 0 ? size_t(n) : 0);
    return b;
  }
  // Every datagram that arrives within `seconds`.
  std::vector<Bytes> drain(double seconds) const {
    std::vector<Bytes> all;
    const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
    while (Clock::now() < end) {
      Bytes b = receive(0.02);
      if (!b.empty()) all.push_back(std::move(b));
    }
    return all;
  }
  // The client's handshake by hand: request, echo the nonce; the nonce if registered, else 0.
  uint64_t register_by_echo(const SessionToken& token) const {
    send(token, 0);
    UdpRegister challenge;
    if (decode_udp_register(receive(1.0), challenge) != Reject::ok || challenge.nonce == 0) return 0;
    send(token, challenge.nonce);
    UdpRegister ack;
    if (decode_udp_register(receive(1.0), ack) != Reject::ok || ack.nonce != challenge.nonce) return 0;
    return ack.nonce;
  }
};

std::unique_ptr<Client> connect_as(const ServerThread& st, Role role, bool udp) {
  ClientOptions o;
  o.connect = st.endpoint();
  o.role = role;
  o.udp = udp;
  auto c = Client::connect(o);
  EXPECT_TRUE(c) << c.error().what();
  return c ? std::move(*c) : nullptr;
}

rig::Pose pose_with(float v) {
  rig::Pose p;
  p.dof_rad.assign(kDofs, v);
  return p;
}

// A subscriber over a raw TCP connection (from `from`) that asked for UDP: its WELCOME.
Welcome raw_udp_subscriber(RawPeer& stream) {
  Hello h;
  h.role = Role::subscriber;
  h.capabilities = kCapPose | kCapResume | kCapUdpPose;
  h.name = "raw";
  Bytes hello(kMaxHelloBytes);
  hello.resize(encode_hello(h, hello));
  EXPECT_TRUE(stream.send(hello));
  Welcome w;
  EXPECT_EQ(decode_welcome(read_packet(stream), w), Reject::ok);
  EXPECT_TRUE(w.capabilities & kCapUdpPose);
  return w;
}

size_t pose_datagrams(const std::vector<Bytes>& all) {
  size_t n = 0;
  for (const auto& d : all) n += d.size() > 2 && d[2] == uint8_t(MsgType::pose);
  return n;
}

// A registration "from" an address that never asked (what a spoofed source address looks like
// to the server: the datagram arrives, its sender never sees the answer) gets one challenge of
// the request's size, never a pose frame; the real subscriber keeps its frames.
TEST(UdpRegistration, AnAddressThatNeverEchoesGetsNoFrames) {
  ServerThread st;
  auto pub = connect_as(st, Role::publisher, false);
  auto sub = connect_as(st, Role::subscriber, true);
  auto slot = pub->add_avatar("alice", kDofs, std::string(100, 'a'));
  ASSERT_TRUE(slot);
  ASSERT_TRUE(pump({pub.get(), sub.get()}, [&] { return sub->udp_active() && sub->avatars().size() == 1; }));

  Udp victim(st.port());
  victim.send(sub->session_token(), 0);  // as if the subscriber spoofed the victim's address
  uint32_t seq = 0;
  const auto until = Clock::now() + std::chrono::milliseconds(600);
  std::vector<Bytes> at_victim;
  while (Clock::now() < until) {
    ASSERT_TRUE(pub->publish_pose(*slot, {0, 0, ++seq, wall_clock_us()}, pose_with(0.1f)));
    pump_for({pub.get(), sub.get()}, 0.01);
    for (auto& d : victim.drain(0.0)) at_victim.push_back(std::move(d));
  }
  for (auto& d : victim.drain(0.2)) at_victim.push_back(std::move(d));
  ASSERT_TRUE(pump({pub.get(), sub.get()}, [&] { return sub->avatars().begin()->second.last.sequence == seq; }));
  EXPECT_EQ(pose_datagrams(at_victim), 0u) << "frames were reflected at an address that never asked";
  ASSERT_EQ(at_victim.size(), 1u);
  EXPECT_EQ(at_victim[0].size(), kUdpRegisterBytes);  // no amplification
  EXPECT_GT(sub->stats().udp_frames, seq / 2);        // the subscriber's own registration stands
  const ServerStats s = st.stats();
  EXPECT_EQ(s.udp_registered, 1u);
  EXPECT_GE(s.udp_challenges, 2u);
}

// By default the UDP address must be on the TCP peer's host: 127.0.0.2 is not 127.0.0.1 to the
// server, so a registration from there is not even answered; with udp_from_any_address it is.
TEST(UdpRegistration, OnlyFromTheTcpPeersAddressUnlessConfigured) {
  for (const bool any : {false, true}) {
    ServerOptions o;
    o.udp_from_any_address = any;
    ServerThread st(o);
    RawPeer stream(st.port());
    const Welcome w = raw_udp_subscriber(stream);
    Udp other_host(st.port(), "127.0.0.2");
    const uint64_t nonce = other_host.register_by_echo(w.session_token);
    if (any) {
      EXPECT_NE(nonce, 0u);
      EXPECT_TRUE(pump({}, [&] { return st.stats().udp_registered == 1; }));
    } else {
      EXPECT_EQ(nonce, 0u);
      EXPECT_TRUE(pump({}, [&] { return st.stats().udp_wrong_address >= 1; }));
      EXPECT_EQ(st.stats().udp_registered, 0u);
      Udp same_host(st.port(), "127.0.0.1");
      EXPECT_NE(same_host.register_by_echo(w.session_token), 0u);
    }
  }
}

// A registration that is not refreshed expires: frames stop going to the address (they travel
// on the stream again) until it registers anew.
TEST(UdpRegistration, RegistrationsExpireUnlessRefreshed) {
  ServerOptions o;
  o.udp_registration_timeout_s = 0.4;
  o.housekeeping_period_ms = 50;
  ServerThread st(o);
  RawPeer stream(st.port(), 1 << 20);
  const Welcome w = raw_udp_subscriber(stream);
  Udp udp(st.port());
  ASSERT_NE(udp.register_by_echo(w.session_token), 0u);
  auto pub = connect_as(st, Role::publisher, false);
  auto slot = pub->add_avatar("bob", kDofs, "m");
  ASSERT_TRUE(pump({pub.get()}, [&] { return st.stats().avatars == 1; }));
  pump_for({pub.get()}, 0.05);
  ASSERT_TRUE(pub->publish_pose(*slot, {0, 0, 1, wall_clock_us()}, pose_with(0.1f)));
  pump_for({pub.get()}, 0.05);
  EXPECT_EQ(pose_datagrams(udp.drain(0.2)), 1u);
  ASSERT_TRUE(pump(
      {pub.get()}, [&] { return st.stats().udp_expired == 1; }, 3.0));
  ASSERT_TRUE(pub->publish_pose(*slot, {0, 0, 2, wall_clock_us()}, pose_with(0.2f)));
  pump_for({pub.get()}, 0.05);
  EXPECT_EQ(pose_datagrams(udp.drain(0.3)), 0u);
  for (const auto& s : st.sessions())
    if (s.name == "raw") {
      EXPECT_FALSE(s.udp);
    }
  // The real client refreshes every second and so never expires at a 5 s timeout; here it
  // re-registers by itself after the expiry of a short one.
}

// A subscriber that leaves with BYE gives up its token for UDP too: a registration with it
// afterwards is refused and never reaches the session (the server once kept the token's UDP
// entry after BYE cleared the token, and a datagram then read the freed session: ASan finds it).
TEST(UdpRegistration, ATokenIsGoneForUdpAfterBye) {
  ServerThread st;
  Bytes bye(kHeaderBytes);
  SessionToken token;
  {
    RawPeer stream(st.port());
    const Welcome w = raw_udp_subscriber(stream);
    token = w.session_token;
    Udp udp(st.port());
    EXPECT_NE(udp.register_by_echo(token), 0u);
    bye.resize(encode_bye(bye));
    ASSERT_TRUE(stream.send(bye));
    // The server ends the session on BYE.
    const auto until = Clock::now() + std::chrono::seconds(2);
    while (st.stats().subscribers != 0 && Clock::now() < until)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ASSERT_EQ(st.stats().subscribers, 0u);
  }
  const uint64_t unauthorized_before = st.stats().rejected[static_cast<size_t>(Reject::unauthorized)];
  Udp again(st.port());
  again.send(token, 0);
  EXPECT_TRUE(again.receive(0.3).empty()) << "a token given up with BYE was answered";
  EXPECT_GT(st.stats().rejected[static_cast<size_t>(Reject::unauthorized)], unauthorized_before);
}

}  // namespace
}  // namespace mimic::net::udp_registration_test
