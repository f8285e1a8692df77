// The VRPN server against a client written from VRPN's documented wire format
// (tests/support/vrpn_test_client.h), over loopback, in both ways VRPN clients connect.
#include "mimic/net/vrpn_server.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

#include "vrpn_test_client.h"

namespace mimic::net::vrpn_server_test {
namespace {

using ::mimic::test::vrpn::Client;

struct Fixture {
  std::unique_ptr<VrpnServer> server;
  rig::Skeleton skeleton;
  rig::Pose pose;
  std::vector<rig::RigidTransform> world_from_joint;
  Fixture() : skeleton(*rig::Skeleton::build(rig::default_skeleton_desc())) {
    auto s = VrpnServer::create("127.0.0.1:0");
    EXPECT_TRUE(s) << s.error().what();
    server = std::move(*s);
    EXPECT_TRUE(server->add_avatar(skeleton));
    pose = skeleton.zero_pose();
    pose.root_position_m = {0.5f, 0.95f, -1.25f};
    pose.dof_rad[size_t(skeleton.find_dof("l_elbow_flexion"))] = 1.0f;
    world_from_joint.resize(size_t(skeleton.joint_count()));
    rig::forward_kinematics(skeleton, pose, world_from_joint);
  }
  std::function<void()> poll() {
    return [this] { server->poll(); };
  }
};

// Every joint of the avatar arrives once per frame as Avatar0's sensor <joint index>, with the
// joint's world position and orientation.
void expect_frame(const Fixture& f, const Client& c, bool udp) {
  std::map<int, ::mimic::test::vrpn::Report> by_sensor;
  for (const auto& r : c.reports)
    if (r.device == "Avatar0") by_sensor[r.sensor] = r;
  ASSERT_EQ(by_sensor.size(), size_t(f.skeleton.joint_count()));
  for (const auto& [j, r] : by_sensor) {
    const auto& t = f.world_from_joint[size_t(j)];
    EXPECT_EQ(r.udp, udp);
    EXPECT_NEAR(r.pos[0], t.translation.x, 1e-6) << f.skeleton.joint_name(j);
    EXPECT_NEAR(r.pos[1], t.translation.y, 1e-6);
    EXPECT_NEAR(r.pos[2], t.translation.z, 1e-6);
    EXPECT_NEAR(r.quat[0], t.rotation.x, 1e-6);
    EXPECT_NEAR(r.quat[3], t.rotation.w, 1e-6);
    EXPECT_EQ(r.seconds, 1700000000u);
    EXPECT_NEAR(double(r.microseconds), 250000.0, 1.0);
  }
}

TEST(VrpnServer, TcpClientGetsCookieDescriptionsReportsAndPongs) {
  Fixture f;
  Client c;
  ASSERT_TRUE(c.connect_tcp(f.server->port()));
  c.handshake({"Avatar0"}, false);
  c.ping(0);
  c.pump(f.poll(), 3, [&] { return c.types.size() >= 3 && c.pongs > 0; });
  EXPECT_EQ(c.server_cookie.substr(0, 16), "vrpn: ver. 07.35");
  EXPECT_EQ(c.server_cookie[18], '0');
  EXPECT_EQ(c.server_udp_port, 0);  // a client that came over TCP gets no UDP offer
  std::set<std::string> names;
  for (const auto& [id, n] : c.senders) names.insert(n);
  EXPECT_EQ(names, (std::set<std::string>{"Avatar0", "Sensors0"}));
  EXPECT_EQ(c.pongs, 1);
  EXPECT_EQ(f.server->stats().clients, 1);

  f.server->send_pose(0, f.pose, 1700000000.25);
  f.server->send_sample(0, 3, {0.1f, 0.2f, 0.3f}, glm::quat(1, 0, 0, 0), 1700000000.25);
  f.server->flush();
  const size_t want = size_t(f.skeleton.joint_count()) + 1;
  c.pump(f.poll(), 3, [&] { return c.reports.size() >= want; });
  ASSERT_EQ(c.reports.size(), want);
  expect_frame(f, c, false);
  const auto& s = c.reports.back();
  EXPECT_EQ(s.device, "Sensors0");
  EXPECT_EQ(s.sensor, 3);
  EXPECT_NEAR(s.pos[2], 0.3, 1e-6);
  EXPECT_EQ(f.server->stats().reports, want);
}

TEST(VrpnServer, LobbedClientIsCalledBackAndGetsReportsAsDatagrams) {
  Fixture f;
  Client c;
  ASSERT_TRUE(c.connect_lob(f.server->port(), f.poll()));
  c.handshake({"Avatar0"}, true);
  c.pump(f.poll(), 3, [&] { return c.types.size() >= 3 && c.server_udp_port > 0; });
  EXPECT_EQ(c.server_udp_host, "127.0.0.1");
  EXPECT_GT(c.server_udp_port, 0);
  // The client's UDP description has been read once the server answers a ping after it.
  c.ping(0);
  c.pump(f.poll(), 3, [&] { return c.pongs > 0; });
  f.server->send_pose(0, f.pose, 1700000000.25);
  f.server->flush();
  c.pump(f.poll(), 3, [&] { return c.reports.size() >= size_t(f.skeleton.joint_count()); });
  expect_frame(f, c, true);
  // 88 bytes a report: whole messages packed into datagrams of at most 1,472 bytes.
  EXPECT_LE(c.max_datagram, 1472u);
  EXPECT_EQ(c.datagrams, (size_t(f.skeleton.joint_count()) * 88 + 1407) / 1408);
  EXPECT_EQ(c.bad_datagrams, 0u);
  EXPECT_EQ(f.server->stats().lob_requests, 1u);
}

TEST(VrpnServer, RefusesBadCookiesAndMalformedRequests) {
  Fixture f;
  {
    Client c;
    ASSERT_TRUE(c.connect_tcp(f.server->port()));
    c.handshake({"Avatar0"}, false, "vrpn: ver. 06.00");
    c.pump(f.poll(), 2, [&] { return c.closed; });
    EXPECT_TRUE(c.closed);
  }
  {
    Client c;
    EXPECT_FALSE(c.connect_lob(f.server->port(), f.poll(), "127.0.0.1 80", 0.5));  // a port below 1024
  }
  {
    Client c;
    EXPECT_FALSE(c.connect_lob(f.server->port(), f.poll(), "evil;host 5000", 0.5));
  }
  EXPECT_EQ(f.server->stats().refused, 3u);
  EXPECT_EQ(f.server->stats().connections, 0u);
}

// docs/vrpn.md lists Avatar<i>'s sensor numbers for the default skeleton: keep it true.
TEST(VrpnServer, DocumentedSensorOrderOfTheDefaultSkeleton) {
  const auto s = *rig::Skeleton::build(rig::default_skeleton_desc());
  const std::vector<std::string> documented = {
      "pelvis",     "spine_lower", "l_hip", "r_hip",      "spine_mid",  "l_knee",  "r_knee", "spine_upper",
      "l_ankle",    "r_ankle",     "neck",  "l_clavicle", "r_clavicle", "l_toes",  "r_toes", "neck_upper",
      "l_shoulder", "r_shoulder",  "head",  "l_elbow",    "r_elbow",    "l_wrist", "r_wrist"};
  std::vector<std::string> names;
  for (int j = 0; j < s.joint_count(); ++j) names.push_back(s.joint_name(j));
  EXPECT_EQ(names, documented);
}

TEST(VrpnServer, BadListenAddressesFail) {
  EXPECT_FALSE(VrpnServer::create("not-an-address:3883"));
  EXPECT_FALSE(VrpnServer::create("127.0.0.1:99999"));
  auto a = VrpnServer::create("127.0.0.1:0");
  ASSERT_TRUE(a);
  auto b = VrpnServer::create("127.0.0.1:" + std::to_string((*a)->port()));
  EXPECT_FALSE(b);                   // the port is taken
  auto c = VrpnServer::create("0");  // a bare port: loopback
  ASSERT_TRUE(c);
  EXPECT_EQ((*c)->endpoint().rfind("127.0.0.1:", 0), 0u);
}

}  // namespace
}  // namespace mimic::net::vrpn_server_test
