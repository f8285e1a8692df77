// The VRPN tracker remote against Mimic's VRPN server over loopback, in both ways VRPN clients
// connect (call-back over UDP, tcp://), and against servers that misbehave: a wrong cookie, a
// server that goes silent or away (the remote reconnects by itself).
#include "mimic/net/vrpn_client.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <thread>

#include "mimic/net/vrpn_server.h"
#include "vrpn_test_server.h"

namespace mimic::net::vrpn_client_test {
namespace {

using PeerServer = ::mimic::test::vrpn::Server;

TEST(VrpnAddress, ParsesTheFormsVrpnClientsWrite) {
  auto a = parse_vrpn_address("Tracker0@localhost");
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_EQ(a->device, "Tracker0");
  EXPECT_EQ(a->host, "localhost");
  EXPECT_EQ(a->port, 3883);
  EXPECT_FALSE(a->tcp_only);
  auto b = parse_vrpn_address("RigidBody1@tcp://10.0.0.5:3884");
  ASSERT_TRUE(b);
  EXPECT_TRUE(b->tcp_only);
  EXPECT_EQ(b->host, "10.0.0.5");
  EXPECT_EQ(b->port, 3884);
  EXPECT_EQ(b->text(), "RigidBody1@tcp://10.0.0.5:3884");
  for (const char* bad : {"", "Tracker0", "@host", "Tracker0@", "Tracker0@tcp://", "T@host:99999", "T@host:0"})
    EXPECT_FALSE(parse_vrpn_address(bad)) << bad;
}

struct Served {
  std::unique_ptr<VrpnServer> server;
  rig::Skeleton skeleton = *rig::Skeleton::build(rig::default_skeleton_desc());
  Served() {
    server = std::move(*VrpnServer::create("127.0.0.1:0"));
    EXPECT_TRUE(server->add_avatar(skeleton));
  }
};

// Polls both sides until `done` or a generous deadline (the machine may be loaded).
template <class F>
bool run_until(VrpnTrackerRemote& remote, VrpnServer* server, F&& done, std::vector<VrpnReport>& got,
               double timeout_s = 20) {
  std::array<VrpnReport, 64> reports;
  std::array<VrpnButtonEvent, 8> buttons;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    if (server) server->poll();
    size_t nb = 0;
    const size_t n = remote.poll(reports, buttons, nb);
    got.insert(got.end(), reports.begin(), reports.begin() + long(n));
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return false;
}

void expect_samples_read_back(bool tcp_only) {
  Served s;
  const int32_t sensor = 3;
  const glm::vec3 p{0.25f, 1.5f, -0.75f};
  const glm::quat q = glm::normalize(glm::quat(0.9f, 0.1f, -0.3f, 0.2f));
  VrpnTrackerRemote::Options o;
  o.tracker = *parse_vrpn_address(std::string("Sensors0@") + (tcp_only ? "tcp://" : "") + s.server->endpoint());
  auto remote = VrpnTrackerRemote::create(o);
  ASSERT_TRUE(remote) << remote.error().what();
  std::vector<VrpnReport> got;
  ASSERT_TRUE(run_until(
      **remote, s.server.get(), [&] { return (*remote)->link() == VrpnLink::connected; }, got))
      << (*remote)->last_error();
  // Until the server has the remote's UDP description (in call-back mode) reports may go on TCP;
  // either way every one must come back exact.
  int sent = 0;
  ASSERT_TRUE(run_until(
      **remote, s.server.get(),
      [&] {
        s.server->send_sample(0, sensor, p, q, 1700000000.5 + 0.01 * sent++);
        s.server->flush();
        return got.size() >= 5;
      },
      got));
  for (const auto& r : got) {
    EXPECT_EQ(r.sensor, sensor);
    EXPECT_NEAR(r.position.x, p.x, 1e-6);
    EXPECT_NEAR(r.position.y, p.y, 1e-6);
    EXPECT_NEAR(r.position.z, p.z, 1e-6);
    EXPECT_NEAR(r.orientation.w, q.w, 1e-6);
    EXPECT_NEAR(r.orientation.x, q.x, 1e-6);
    EXPECT_NEAR(r.orientation.y, q.y, 1e-6);
    EXPECT_NEAR(r.orientation.z, q.z, 1e-6);
    EXPECT_GE(r.capture_unix_s, 1700000000.5 - 1e-6);
    EXPECT_LT(r.capture_unix_s, 1700000100.0);
  }
  if (tcp_only) {
    EXPECT_EQ((*remote)->stats().udp_datagrams, 0u);
  } else {
    EXPECT_GT((*remote)->stats().udp_datagrams, 0u) << "reports should come by UDP";
  }
  // Pings are answered by the server's sender of the same name.
  ASSERT_TRUE(run_until(
      **remote, s.server.get(), [&] { return (*remote)->stats().pongs > 0; }, got));
}

TEST(VrpnTrackerRemote, ReadsMimicsVrpnServerThroughTheCallBack) { expect_samples_read_back(false); }
TEST(VrpnTrackerRemote, ReadsMimicsVrpnServerOverTcp) { expect_samples_read_back(true); }

// The independent peer numbers its senders and types unlike Mimic's server: the remote maps them
// by name. Reports, button changes and pongs, in both connection modes.
void expect_peer_read(bool tcp_only) {
  PeerServer peer({"Buttons0", "Tracker0"});
  ASSERT_TRUE(peer.ok());
  VrpnTrackerRemote::Options o;
  o.tracker = *parse_vrpn_address(std::string("Tracker0@") + (tcp_only ? "tcp://" : "") +
                                  "127.0.0.1:" + std::to_string(peer.port()));
  o.button_device = "Buttons0";
  auto remote = std::move(*VrpnTrackerRemote::create(o));
  std::array<VrpnReport, 64> reports;
  std::array<VrpnButtonEvent, 8> buttons;
  std::vector<VrpnReport> got;
  std::vector<VrpnButtonEvent> pressed;
  const double pos[3] = {1.5, -2.25, 0.125}, quat[4] = {0.0, 0.6, 0.0, 0.8};
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < end && (got.size() < 3 || pressed.empty() || remote->stats().pongs == 0)) {
    if (remote->link() == VrpnLink::connected) {
      peer.send_pos_quat("Tracker0", 7, pos, quat, 1700000001, 500000);
      peer.send_pos_quat("Buttons0", 1, pos, quat, 1700000001, 500000);  // another device's: not ours
      peer.send_button("Buttons0", 2, true);
    }
    size_t nb = 0;
    const size_t n = remote->poll(reports, buttons, nb);
    got.insert(got.end(), reports.begin(), reports.begin() + long(n));
    pressed.insert(pressed.end(), buttons.begin(), buttons.begin() + long(nb));
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_GE(got.size(), 3u) << remote->last_error();
  for (const auto& r : got) {
    EXPECT_EQ(r.sensor, 7);
    EXPECT_EQ(r.position, glm::dvec3(1.5, -2.25, 0.125));
    EXPECT_EQ(r.orientation, glm::dquat(0.8, 0.0, 0.6, 0.0));
    EXPECT_DOUBLE_EQ(r.capture_unix_s, 1700000001.5);
  }
  ASSERT_FALSE(pressed.empty());
  EXPECT_EQ(pressed.front().button, 2);
  EXPECT_TRUE(pressed.front().pressed);
  EXPECT_GT(remote->stats().pongs, 0u);
  EXPECT_GT(peer.pings(), 0);
  if (!tcp_only) {
    EXPECT_GT(remote->stats().udp_datagrams, 0u);
  }
}

TEST(VrpnTrackerRemote, ReadsAnIndependentPeerThroughTheCallBack) { expect_peer_read(false); }
TEST(VrpnTrackerRemote, ReadsAnIndependentPeerOverTcp) { expect_peer_read(true); }

// Killing the peer makes the remote drop it (counted); a peer restarted on the same port is found
// again without anything done by the caller.
TEST(VrpnTrackerRemote, APeerKilledAndRestartedIsCountedAndRecovered) {
  auto peer = std::make_unique<PeerServer>(std::vector<std::string>{"Tracker0"});
  const uint16_t port = peer->port();
  VrpnTrackerRemote::Options o;
  o.tracker = *parse_vrpn_address("Tracker0@127.0.0.1:" + std::to_string(port));
  o.retry_after_s = 0.05;
  o.silent_after_s = 1.0;
  auto remote = std::move(*VrpnTrackerRemote::create(o));
  std::vector<VrpnReport> got;
  ASSERT_TRUE(run_until(
      *remote, nullptr, [&] { return remote->link() == VrpnLink::connected; }, got));
  peer.reset();
  ASSERT_TRUE(run_until(
      *remote, nullptr, [&] { return remote->stats().drops == 1; }, got));
  peer = std::make_unique<PeerServer>(std::vector<std::string>{"Tracker0"}, port);
  ASSERT_TRUE(peer->ok());
  const double pos[3] = {0, 1, 0}, quat[4] = {0, 0, 0, 1};
  ASSERT_TRUE(run_until(
      *remote, nullptr,
      [&] {
        if (remote->link() == VrpnLink::connected) peer->send_pos_quat("Tracker0", 0, pos, quat, 1, 0);
        return !got.empty();
      },
      got))
      << remote->last_error();
  EXPECT_EQ(remote->stats().connects, 2u);
  EXPECT_EQ(remote->stats().drops, 1u);
}

// Motive and Vicon serve one device per rigid body: several devices read on one connection, each
// report saying whose it is.
TEST(VrpnTrackerRemote, ReadsSeveralTrackerDevicesOnOneConnection) {
  PeerServer peer({"Head", "LeftHand", "Prop"});
  VrpnTrackerRemote::Options o;
  o.tracker = *parse_vrpn_address("Head@tcp://127.0.0.1:" + std::to_string(peer.port()));
  o.more_trackers = {"LeftHand"};
  auto remote = std::move(*VrpnTrackerRemote::create(o));
  std::vector<VrpnReport> got;
  const double head[3] = {0, 1.7, 0}, hand[3] = {0.3, 1.0, 0.2}, q[4] = {0, 0, 0, 1};
  ASSERT_TRUE(run_until(
      *remote, nullptr,
      [&] {
        if (remote->link() == VrpnLink::connected) {
          peer.send_pos_quat("Head", 0, head, q, 1, 0);
          peer.send_pos_quat("LeftHand", 0, hand, q, 1, 0);
          peer.send_pos_quat("Prop", 0, hand, q, 1, 0);  // not asked for
        }
        bool h = false, l = false;
        for (const auto& r : got) (r.device == 0 ? h : l) = true;
        return h && l && got.size() >= 6;
      },
      got))
      << remote->last_error();
  for (const auto& r : got) {
    ASSERT_TRUE(r.device == 0 || r.device == 1);
    EXPECT_EQ(r.position.y, r.device == 0 ? 1.7 : 1.0);
  }
}

TEST(VrpnTrackerRemote, ReconnectsWhenTheServerGoesAwayAndComesBack) {
  auto s = std::make_unique<Served>();
  const std::string endpoint = s->server->endpoint();
  VrpnTrackerRemote::Options o;
  o.tracker = *parse_vrpn_address("Avatar0@tcp://" + endpoint);
  o.retry_after_s = 0.05;
  auto remote = std::move(*VrpnTrackerRemote::create(o));
  std::vector<VrpnReport> got;
  ASSERT_TRUE(run_until(
      *remote, s->server.get(), [&] { return remote->link() == VrpnLink::connected; }, got));
  s.reset();  // the server goes away
  ASSERT_TRUE(run_until(
      *remote, nullptr, [&] { return remote->link() != VrpnLink::connected; }, got));
  EXPECT_EQ(remote->stats().drops, 1u);
  EXPECT_FALSE(remote->last_error().empty());
  // A new server on the same port: the remote finds it by itself.
  auto again = VrpnServer::create(endpoint);
  ASSERT_TRUE(again) << again.error().what();
  rig::Skeleton sk = *rig::Skeleton::build(rig::default_skeleton_desc());
  ASSERT_TRUE((*again)->add_avatar(sk));
  ASSERT_TRUE(run_until(
      *remote, again->get(), [&] { return remote->stats().connects == 2; }, got))
      << remote->last_error();
  rig::Pose pose = sk.zero_pose();
  ASSERT_TRUE(run_until(
      *remote, again->get(),
      [&] {
        (*again)->send_pose(0, pose, 1700000000.0);
        (*again)->flush();
        return !got.empty();
      },
      got));
  EXPECT_EQ(got.front().sensor >= 0 && got.front().sensor < sk.joint_count(), true);
}

// A TCP listener that answers with whatever bytes it is given, then stays silent.
struct FakeServer {
  int fd = -1;
  uint16_t port = 0;
  FakeServer() {
    fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    EXPECT_EQ(::listen(fd, 4), 0);
    socklen_t n = sizeof a;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n);
    port = ntohs(a.sin_port);
  }
  ~FakeServer() { ::close(fd); }
};

TEST(VrpnTrackerRemote, RefusesAServerThatIsNotVrpnAndDropsOneThatGoesSilent) {
  FakeServer fake;
  VrpnTrackerRemote::Options o;
  o.tracker = *parse_vrpn_address("Tracker0@tcp://127.0.0.1:" + std::to_string(fake.port));
  o.silent_after_s = 0.3;
  o.retry_after_s = 10;  // one attempt per case
  auto remote = std::move(*VrpnTrackerRemote::create(o));
  std::vector<VrpnReport> got;
  std::thread peer([&] {
    const int c = ::accept(fake.fd, nullptr, nullptr);
    const char http[24] = "HTTP/1.1 200 OK\r\n\r\n";
    (void)::write(c, http, sizeof http);
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    ::close(c);
  });
  ASSERT_TRUE(run_until(
      *remote, nullptr, [&] { return remote->link() == VrpnLink::waiting && remote->stats().drops > 0; }, got));
  peer.join();
  EXPECT_NE(remote->last_error().find("cookie"), std::string::npos) << remote->last_error();
  EXPECT_EQ(remote->stats().connects, 0u);
}

TEST(VrpnTrackerRemote, AServerThatNeverAnswersTheHandshakeIsDropped) {
  FakeServer fake;
  VrpnTrackerRemote::Options o;
  o.tracker = *parse_vrpn_address("Tracker0@tcp://127.0.0.1:" + std::to_string(fake.port));
  o.silent_after_s = 0.3;
  o.retry_after_s = 10;
  auto remote = std::move(*VrpnTrackerRemote::create(o));
  std::vector<VrpnReport> got;
  std::thread peer([&] {
    const int c = ::accept(fake.fd, nullptr, nullptr);
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    ::close(c);
  });
  ASSERT_TRUE(run_until(
      *remote, nullptr, [&] { return remote->stats().drops > 0; }, got));
  peer.join();
  EXPECT_NE(remote->last_error().find("handshake"), std::string::npos) << remote->last_error();
}

TEST(VrpnTrackerRemote, AnUnknownHostIsAClearError) {
  VrpnTrackerRemote::Options o;
  o.tracker = *parse_vrpn_address("Tracker0@no-such-host.invalid");
  auto remote = VrpnTrackerRemote::create(o);
  ASSERT_FALSE(remote);
  EXPECT_NE(remote.error().message.find("no-such-host.invalid"), std::string::npos);
}

}  // namespace
}  // namespace mimic::net::vrpn_client_test
