// Pose frames as UDP datagrams (capability kCapUdpPose): registration with the session token,
// frames on the datagram path, what overtakes what, resume, hostile datagrams.
#include <gtest/gtest.h>

#include <optional>

#include "net_test_support.h"

namespace mimic::net::udp_test {
namespace {

using namespace mimic::net::test;

constexpr uint16_t kDofs = 52;

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
  p.root_position_m = {0.1f, 0.9f, -0.2f};
  p.dof_rad.assign(kDofs, v);
  return p;
}

// Publishes seq = first..last, each taken by every subscriber before the next.
void publish_range(Client& pub, uint8_t slot, uint32_t first, uint32_t last, std::vector<Client*> subs) {
  std::vector<Client*> all = subs;
  all.push_back(&pub);
  for (uint32_t s = first; s <= last; ++s) {
    ASSERT_TRUE(pub.publish_pose(slot, {0, 0, s, wall_clock_us()}, pose_with(0.001f * float(s))));
    ASSERT_TRUE(pump(
        all,
        [&] {
          for (Client* c : subs)
            if (c->avatars().empty() || c->avatars().begin()->second.last.sequence < s) return false;
          return true;
        },
        2.0))
        << "frame " << s;
  }
}

// A UDP socket of our own on loopback, for datagrams the client library would never send.
struct RawUdp {
  int fd = -1;
  explicit RawUdp(uint16_t port) {
    fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::connect(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a), 0);
  }
  ~RawUdp() { ::close(fd); }
  void send(const Bytes& b) const { EXPECT_EQ(::send(fd, b.data(), b.size(), 0), ssize_t(b.size())); }
  // Bytes of the first datagram within `timeout_s`, empty if none came.
  Bytes receive(double timeout_s) const {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, int(timeout_s * 1000)) <= 0) return {};
    Bytes b(2048);
    const ssize_t n = ::recv(fd, b.data(), b.size(), 0);
    b.resize(n > 0 ? size_t(n) : 0);
    return b;
  }
};

Bytes register_packet(const SessionToken& token, uint64_t nonce = 0) {
  Bytes b(kUdpRegisterBytes);
  b.resize(encode_udp_register({token, nonce}, b));
  return b;
}

SessionToken token_of(uint8_t fill) {
  SessionToken t;
  t.bytes.fill(fill);
  return t;
}

// Registers `udp` for the session `token` the way the client does: the first request is
// answered with a nonce, echoing it registers. The nonce, or 0 when the server did not answer.
uint64_t register_by_echo(const RawUdp& udp, const SessionToken& token) {
  udp.send(register_packet(token));
  UdpRegister challenge;
  if (decode_udp_register(udp.receive(2.0), challenge) != Reject::ok || challenge.nonce == 0) return 0;
  udp.send(register_packet(token, challenge.nonce));
  UdpRegister ack;
  if (decode_udp_register(udp.receive(2.0), ack) != Reject::ok || ack.nonce != challenge.nonce) return 0;
  return ack.nonce;
}

// A publisher with one avatar ("alice") and a UDP subscriber that holds its model and whose
// address the server has registered; empty pointers (and a failure) if that does not happen.
struct RegisteredPair {
  std::unique_ptr<Client> pub, sub;
  std::optional<uint8_t> slot;
};

RegisteredPair registered_pair(ServerThread& st) {
  RegisteredPair r{connect_as(st, Role::publisher, false), connect_as(st, Role::subscriber, true), {}};
  if (!r.pub || !r.sub) return {};
  auto slot = r.pub->add_avatar("alice", kDofs, std::string(100, 'a'));
  if (!slot || !pump({r.pub.get(), r.sub.get()}, [&] { return r.sub->udp_active() && r.sub->avatars().size() == 1; })) {
    ADD_FAILURE() << "the subscriber never got the model and a registered address";
    return {};
  }
  r.slot = *slot;
  return r;
}

TEST(UdpPoses, SubscriberGetsPoseFramesAsDatagrams) {
  ServerThread st;
  ASSERT_TRUE(st.call([&] { return st.server().udp(); }));
  auto pub = connect_as(st, Role::publisher, false);
  auto udp_sub = connect_as(st, Role::subscriber, true);
  auto tcp_sub = connect_as(st, Role::subscriber, false);
  EXPECT_EQ(udp_sub->negotiated_capabilities(), kCapPose | kCapResume | kCapUdpPose);
  EXPECT_EQ(tcp_sub->negotiated_capabilities(), kCapPose | kCapResume);
  auto slot = pub->add_avatar("alice", kDofs, std::string(800, 'a'));
  ASSERT_TRUE(slot);
  ASSERT_TRUE(pump({pub.get(), udp_sub.get(), tcp_sub.get()}, [&] {
    return udp_sub->udp_active() && udp_sub->avatars().size() == 1 && tcp_sub->avatars().size() == 1;
  }));
  publish_range(*pub, *slot, 1, 40, {udp_sub.get(), tcp_sub.get()});

  // Every frame arrived on the datagram path, none twice, none lost; the TCP subscriber beside
  // it got the same frames on its stream.
  const auto& u = udp_sub->stats();
  EXPECT_EQ(u.frames, 40u);
  EXPECT_EQ(u.udp_frames, 40u);
  EXPECT_EQ(u.lost, 0u);
  EXPECT_EQ(u.out_of_order, 0u);
  EXPECT_EQ(u.frame_bytes, 40 * pose_packet_bytes(kDofs));
  const RemoteAvatar& a = udp_sub->avatars().begin()->second;
  EXPECT_EQ(a.last.sequence, 40u);
  EXPECT_NEAR(a.pose.dof_rad[7], 0.040f, kAngleStep_rad);
  EXPECT_NEAR(a.pose.root_position_m.y, 0.9f, 1e-4f);
  EXPECT_EQ(tcp_sub->stats().frames, 40u);
  EXPECT_EQ(tcp_sub->stats().udp_frames, 0u);
  const ServerStats s = st.stats();
  EXPECT_EQ(s.udp_registered, 1u);
  EXPECT_EQ(s.udp_frames_out, 40u);
  EXPECT_EQ(s.frames_out, 80u);
}

TEST(UdpPoses, ModelsStillComeFirstForLateJoinersAndNewAvatars) {
  ServerThread st;
  auto pub = connect_as(st, Role::publisher, false);
  auto witness = connect_as(st, Role::subscriber, false);
  auto first = pub->add_avatar("still", kDofs, std::string(300, 's'));
  ASSERT_TRUE(first);
  ASSERT_TRUE(pump({pub.get(), witness.get()}, [&] { return witness->avatars().size() == 1; }));
  publish_range(*pub, *first, 1, 5, {witness.get()});

  // A late joiner asking for UDP gets the model and the latest pose at once, though the avatar
  // never moves again.
  auto late = connect_as(st, Role::subscriber, true);
  ASSERT_TRUE(pump({late.get()}, [&] { return late->udp_active() && late->stats().frames >= 1; }));
  EXPECT_EQ(late->avatars().begin()->second.last.sequence, 5u);

  // A new avatar after the address is registered: its model travels on TCP, its one and only
  // frame as a datagram, whichever arrives first.
  auto second = pub->add_avatar("once", kDofs, std::string(200000, 'o'));
  ASSERT_TRUE(second);
  bool published = false;
  ASSERT_TRUE(pump({pub.get(), late.get(), witness.get()}, [&] {
    if (!published && witness->avatars().size() == 2) {
      EXPECT_TRUE(pub->publish_pose(*second, {0, 0, 1, wall_clock_us()}, pose_with(0.5f)));
      published = true;
    }
    auto it = late->avatars().find(witness->avatars().rbegin()->first);
    return published && it != late->avatars().end() && it->second.has_pose;
  }));
  EXPECT_EQ(late->avatars().size(), 2u);
  EXPECT_GE(late->stats().udp_frames, 1u);
}

// Datagrams do not queue behind the stream: a subscriber whose TCP side is stalled under a
// large model (it reads nothing there) still gets every pose frame on its UDP address.
TEST(UdpPoses, AStalledStreamDoesNotHoldBackDatagrams) {
  ServerThread st;
  RawPeer stream(st.port(), 4096);
  Hello h;
  h.role = Role::subscriber;
  h.capabilities = kCapPose | kCapResume | kCapUdpPose;
  h.name = "stalled";
  Bytes hello(kMaxHelloBytes);
  hello.resize(encode_hello(h, hello));
  ASSERT_TRUE(stream.send(hello));
  Bytes got = stream.read(2.0, kHeaderBytes);
  Header wh;
  ASSERT_EQ(decode_header(got, wh), Reject::ok);
  if (got.size() < kHeaderBytes + wh.payload_bytes) {
    const Bytes more = stream.read(2.0, kHeaderBytes + wh.payload_bytes - got.size());
    got.insert(got.end(), more.begin(), more.end());
  }
  got.resize(kHeaderBytes + wh.payload_bytes);
  Welcome w;
  ASSERT_EQ(decode_welcome(got, w), Reject::ok);
  ASSERT_TRUE(w.capabilities & kCapUdpPose);
  RawUdp udp(st.port());
  ASSERT_NE(register_by_echo(udp, w.session_token), 0u);

  // From now on the stream is never read: a 900 kB model stalls it.
  auto pub = connect_as(st, Role::publisher, false);
  auto slot = pub->add_avatar("big", kDofs, std::string(900000, 'b'));
  ASSERT_TRUE(slot);
  ASSERT_TRUE(pump({pub.get()}, [&] { return st.stats().avatars == 1; }));
  pump_for({pub.get()}, 0.1);
  uint32_t last = 0;
  for (uint32_t seq = 1; seq <= 10; ++seq) {
    ASSERT_TRUE(pub->publish_pose(*slot, {0, 0, seq, wall_clock_us()}, pose_with(0.01f)));
    pump_for({pub.get()}, 0.01);
    const Bytes d = udp.receive(1.0);
    PoseHeader ph;
    rig::Pose p;
    ASSERT_EQ(decode_pose(d, ph, p), Reject::ok) << "frame " << seq << " did not come as a datagram";
    EXPECT_GT(ph.sequence, last);
    last = ph.sequence;
  }
  EXPECT_EQ(last, 10u);
  EXPECT_FALSE(stream.closed());
}

TEST(UdpPoses, ResumedSubscriberRegistersItsAddressAgain) {
  ServerThread st;
  // Named references, not a structured binding: lambdas below capture them (Clang 14 cannot
  // capture structured bindings).
  RegisteredPair pair = registered_pair(st);
  auto& pub = pair.pub;
  auto& sub = pair.sub;
  auto& slot = pair.slot;
  ASSERT_TRUE(pub && sub && slot);
  publish_range(*pub, *slot, 1, 10, {sub.get()});
  sub->drop_connection();
  EXPECT_FALSE(sub->udp_active());
  ASSERT_TRUE(pump({pub.get(), sub.get()}, [&] { return sub->connected() && sub->udp_active(); }));
  EXPECT_EQ(sub->stats().resumed, 1u);
  const uint64_t udp_before = sub->stats().udp_frames;
  publish_range(*pub, *slot, 11, 30, {sub.get()});
  EXPECT_EQ(sub->avatars().begin()->second.last.sequence, 30u);
  EXPECT_GE(sub->stats().udp_frames - udp_before, 19u);  // the first may still take the stream
  EXPECT_EQ(st.stats().udp_registered, 2u);
}

TEST(UdpPoses, WithoutUdpOnTheServerFramesStayOnTcp) {
  ServerOptions o;
  o.udp = false;
  ServerThread st(o);
  auto pub = connect_as(st, Role::publisher, false);
  auto sub = connect_as(st, Role::subscriber, true);
  EXPECT_EQ(sub->negotiated_capabilities() & kCapUdpPose, 0u);
  auto slot = pub->add_avatar("alice", kDofs, std::string(100, 'a'));
  ASSERT_TRUE(slot);
  ASSERT_TRUE(pump({pub.get(), sub.get()}, [&] { return sub->avatars().size() == 1; }));
  publish_range(*pub, *slot, 1, 10, {sub.get()});
  EXPECT_EQ(sub->stats().frames, 10u);
  EXPECT_EQ(sub->stats().udp_frames, 0u);
  EXPECT_FALSE(sub->udp_active());
}

TEST(UdpPoses, HostileDatagramsAreCountedAndOnlyKnownTokensAnswered) {
  ServerThread st;
  // Named references, not a structured binding: lambdas below capture them (Clang 14 cannot
  // capture structured bindings).
  RegisteredPair pair = registered_pair(st);
  auto& pub = pair.pub;
  auto& sub = pair.sub;
  auto& slot = pair.slot;
  ASSERT_TRUE(pub && sub && slot);
  const uint64_t before = st.stats().udp_datagrams_in;

  RawUdp raw(st.port());
  raw.send({'M', 1});  // truncated header
  Bytes wrong_magic = register_packet(sub->session_token());
  wrong_magic[0] = 'X';
  raw.send(wrong_magic);
  Bytes long_register = register_packet(token_of(42));
  long_register.resize(40, 0);
  long_register[4] = 32;  // a payload longer than the type allows
  raw.send(long_register);
  Bytes bye(16);
  bye.resize(encode_bye(bye));
  raw.send(bye);                                    // a TCP message on the UDP socket
  raw.send(register_packet(token_of(0x5a)));        // nobody's token
  raw.send(register_packet(pub->session_token()));  // a publisher's token: no UDP for publishers
  EXPECT_TRUE(raw.receive(0.3).empty()) << "the server answered a datagram it should not have";
  ASSERT_TRUE(pump({pub.get(), sub.get()}, [&] { return st.stats().udp_datagrams_in >= before + 6; }));
  const ServerStats s = st.stats();
  EXPECT_EQ(s.rejected[size_t(Reject::truncated)], 1u);
  EXPECT_EQ(s.rejected[size_t(Reject::bad_magic)], 1u);
  EXPECT_EQ(s.rejected[size_t(Reject::oversized)], 1u);
  EXPECT_EQ(s.rejected[size_t(Reject::unexpected)], 1u);
  EXPECT_EQ(s.rejected[size_t(Reject::unauthorized)], 2u);
  EXPECT_EQ(s.udp_registered, 1u);

  // The real subscriber's token from another socket moves its frames there once that socket
  // echoed the server's nonce (as after a NAT rebinding); each answer is the request's size.
  raw.send(register_packet(sub->session_token()));
  const Bytes challenge = raw.receive(2.0);
  EXPECT_EQ(challenge.size(), kUdpRegisterBytes);
  UdpRegister echoed;
  ASSERT_EQ(decode_udp_register(challenge, echoed), Reject::ok);
  EXPECT_EQ(echoed.token, sub->session_token());
  ASSERT_NE(echoed.nonce, 0u);
  raw.send(register_packet(sub->session_token(), echoed.nonce));
  UdpRegister ack;
  ASSERT_EQ(decode_udp_register(raw.receive(2.0), ack), Reject::ok);
  EXPECT_EQ(ack.nonce, echoed.nonce);
  ASSERT_TRUE(pub->publish_pose(*slot, {0, 0, 1, wall_clock_us()}, pose_with(0.25f)));
  pump_for({pub.get()}, 0.05);
  const Bytes frame = raw.receive(2.0);
  PoseHeader h;
  rig::Pose p;
  ASSERT_EQ(decode_pose(frame, h, p), Reject::ok);
  EXPECT_EQ(h.sequence, 1u);
  // The subscriber's own next registration (within a second) takes its frames back.
  uint32_t seq = 1;
  ASSERT_TRUE(pump(
      {pub.get(), sub.get()},
      [&] {
        (void)pub->publish_pose(*slot, {0, 0, ++seq, wall_clock_us()}, pose_with(0.25f));
        return sub->stats().udp_frames >= 1;
      },
      5.0));
}

}  // namespace
}  // namespace mimic::net::udp_test
