// Bounded memory for stalled subscribers (models are latest-wins and shared), names without
// control characters, and receivers that check what they get.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "net_test_support.h"

namespace mimic::net::backlog_names_test {
namespace {

using namespace mimic::net::test;

constexpr uint16_t kDofs = 52;

std::unique_ptr<Client> connect_as(const ServerThread& st, Role role, const std::string& name = "mimic") {
  ClientOptions o;
  o.connect = st.endpoint();
  o.role = role;
  o.name = name;
  auto c = Client::connect(o);
  return c ? std::move(*c) : nullptr;
}

size_t rss_bytes() {
  std::ifstream f("/proc/self/statm");
  size_t pages = 0, resident = 0;
  f >> pages >> resident;
  return resident * 4096;
}

// 100 subscribers that stop reading, and a publisher re-sending a 512 KiB model 20 times: each
// stalled subscriber holds one write in flight and at most the newest revision queued, shared
// with all the others. Nobody is cut off, and the models in memory stay a few revisions.
TEST(Backlog, StalledSubscribersShareTheNewestModel) {
  ServerOptions o;
  o.send_buffer_bytes = 4096;
  ServerThread st(o);
  std::vector<std::unique_ptr<RawPeer>> stalled;
  for (int i = 0; i < 100; ++i) {
    stalled.push_back(std::make_unique<RawPeer>(st.port(), 2048));
    ASSERT_TRUE(stalled.back()->send(hello_packet(Role::subscriber)));
  }
  auto pub = connect_as(st, Role::publisher);
  ASSERT_TRUE(pub);
  ASSERT_TRUE(pump({pub.get()}, [&] { return st.stats().subscribers == 100; }));
  const size_t rss_before = rss_bytes();
  constexpr size_t kModel = 512 * 1024;
  auto slot = pub->add_avatar("big", kDofs, std::string(kModel, 'a'));
  ASSERT_TRUE(slot);
  ASSERT_TRUE(pump({pub.get()}, [&] { return st.stats().avatars == 1; }));
  // A raw publisher re-sending its model on the same slot.
  RawPeer raw_pub(st.port());
  ASSERT_TRUE(raw_pub.send(hello_packet(Role::publisher)));
  for (int r = 0; r < 20; ++r) ASSERT_TRUE(raw_pub.send(model_packet(0, kDofs, kModel)));
  ASSERT_TRUE(pump(
      {pub.get()}, [&] { return st.stats().model_bytes_out >= 100u * 2 * kModel; }, 10.0));
  pump_for({pub.get()}, 0.3);
  const ServerStats s = st.stats();
  EXPECT_EQ(s.sessions_closed_slow, 0u);
  EXPECT_EQ(s.subscribers, 100u);
  // Current revisions of both avatars, plus at most one older revision each pinned by writes.
  EXPECT_LE(s.model_bytes_held, 4 * (kModel + 64)) << s.model_bytes_held;
  const size_t rss_after = rss_bytes();
  EXPECT_LT(rss_after, rss_before + (64u << 20)) << "grew by " << (rss_after - rss_before) / 1024 << " KiB";
}

// Over the cap on model memory, subscribers whose writes pin old revisions are the slow ones:
// they are cut off, and the memory comes back.
TEST(Backlog, OldRevisionsPinnedOverTheCapCutOffTheirHolders) {
  ServerOptions o;
  o.send_buffer_bytes = 4096;
  o.max_model_bytes_held = 3u << 20;
  ServerThread st(o);
  std::vector<std::unique_ptr<RawPeer>> stalled;
  constexpr size_t kModel = 600 * 1024;
  RawPeer raw_pub(st.port());
  ASSERT_TRUE(raw_pub.send(hello_packet(Role::publisher)));
  for (int r = 0; r < 6; ++r) {
    // A new stalled subscriber joins each revision, so each pins a different one.
    stalled.push_back(std::make_unique<RawPeer>(st.port(), 2048));
    ASSERT_TRUE(stalled.back()->send(hello_packet(Role::subscriber)));
    ASSERT_TRUE(pump({}, [&] { return st.stats().subscribers == stalled.size(); }));
    ASSERT_TRUE(raw_pub.send(model_packet(0, kDofs, kModel)));
    ASSERT_TRUE(pump({}, [&] { return st.stats().avatars == 1 && st.stats().model_bytes_out >= (r + 1) * kModel; }));
  }
  ASSERT_TRUE(pump(
      {}, [&] { return st.stats().model_bytes_held <= o.max_model_bytes_held; }, 5.0))
      << st.stats().model_bytes_held << " held, " << st.stats().sessions_closed_slow << " cut off, "
      << st.stats().subscribers << " subscribers, " << st.stats().model_bytes_out << " out";
  EXPECT_GE(st.stats().sessions_closed_slow, 1u);
}

TEST(Names, ControlCharactersAreRefusedAndEscapedWhenPrinted) {
  EXPECT_TRUE(name_is_printable("alice"));
  EXPECT_TRUE(name_is_printable("Zoë ✓"));
  EXPECT_FALSE(name_is_printable("\x1b]0;hijacked\x07"));
  EXPECT_FALSE(name_is_printable("a\nb"));
  EXPECT_FALSE(name_is_printable("del\x7f"));
  EXPECT_FALSE(name_is_printable("csi\xc2\x9b"));
  EXPECT_EQ(printable("\x1b]0;hijacked\x07"), "\\u001b]0;hijacked\\u0007");
  EXPECT_EQ(printable("Zoë"), "Zoë");
  EXPECT_EQ(printable("a\\b"), "a\\\\b");
  EXPECT_EQ(printable("csi\xc2\x9b"), "csi\\u009b");
  // Bidi overrides, zero-width characters and bytes that are not UTF-8 are refused too.
  EXPECT_FALSE(name_is_printable("avat\u200bar1"));
  EXPECT_FALSE(name_is_printable("evil\u202Etxt.exe"));
  EXPECT_FALSE(name_is_printable("raw\x9b"));
  EXPECT_FALSE(name_is_printable("bad\xff"));
}

TEST(Names, TheServerRefusesControlCharactersInNames) {
  ServerThread st;
  // A publisher named with an escape sequence is refused at HELLO.
  EXPECT_FALSE(connect_as(st, Role::publisher, "\x1b]0;hijacked\x07"));
  // An avatar named so ends its publisher's session; no subscriber ever sees it.
  auto sub = connect_as(st, Role::subscriber);
  auto pub = connect_as(st, Role::publisher);
  ASSERT_TRUE(sub && pub);
  ASSERT_TRUE(pub->add_avatar("\x1b]0;hijacked\x07", kDofs, "m"));
  EXPECT_TRUE(pump(
      {sub.get(), pub.get()}, [&] { return !pub->connected() || !pub->poll(); }, 3.0));
  pump_for({sub.get()}, 0.2);
  EXPECT_TRUE(sub->avatars().empty());
  EXPECT_GE(st.stats().rejected[size_t(Reject::malformed)], 2u);
  // Local avatars are held to the same rule.
  EXPECT_FALSE(st.call([&] { return bool(st.server().add_avatar("bad\x1b[2J", kDofs, "m")); }));
}

// A server of our own (a raw listener) sends a pose whose DOF count is not its model's: the
// client refuses it.
TEST(Receivers, AClientRefusesAPoseWithTheWrongDofCount) {
  const int lfd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(lfd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ASSERT_EQ(::listen(lfd, 1), 0);
  socklen_t len = sizeof a;
  ::getsockname(lfd, reinterpret_cast<sockaddr*>(&a), &len);
  const uint16_t port = ntohs(a.sin_port);
  std::thread fake([lfd] {
    const int fd = ::accept(lfd, nullptr, nullptr);
    uint8_t buf[1024];
    (void)::recv(fd, buf, sizeof buf, 0);  // HELLO
    Bytes out(4096);
    Welcome w;
    w.session_token.bytes[0] = 1;
    w.capabilities = kCapPose;
    size_t n = encode_welcome(w, out);
    AvatarModel m{3, 1, kDofs, "eve", "m"};
    n += encode_avatar_model(m, std::span<uint8_t>(out).subspan(n));
    rig::Pose wrong;
    wrong.dof_rad.assign(10, 0.1f);
    n += encode_pose({3, 0, 1, wall_clock_us()}, wrong, std::span<uint8_t>(out).subspan(n));
    rig::Pose right;
    right.dof_rad.assign(kDofs, 0.2f);
    n += encode_pose({3, 0, 2, wall_clock_us()}, right, std::span<uint8_t>(out).subspan(n));
    (void)::send(fd, out.data(), n, MSG_NOSIGNAL);
    ::usleep(500000);
    ::close(fd);
  });
  ClientOptions o;
  o.connect = "127.0.0.1:" + std::to_string(port);
  o.reconnect = false;
  auto c = Client::connect(o);
  ASSERT_TRUE(c) << c.error().what();
  Client& client = **c;
  pump(
      {&client}, [&] { return client.stats().frames >= 1; }, 2.0);
  EXPECT_EQ(client.stats().wrong_dof_count, 1u);
  EXPECT_EQ(client.stats().frames, 1u);
  ASSERT_EQ(client.avatars().size(), 1u);
  EXPECT_EQ(client.avatars().begin()->second.last.sequence, 2u);
  EXPECT_EQ(client.avatars().begin()->second.pose.dof_rad.size(), kDofs);
  fake.join();
  ::close(lfd);
}

}  // namespace
}  // namespace mimic::net::backlog_names_test
