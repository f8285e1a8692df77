// The packet that ended `mimic run`, through the broker: a mesh topology whose vertex count no
// frame can carry, published by a publisher's own user on its own mesh subject (what the
// broker's permissions allow it), reached every relay whose viewers asked for meshes and ended
// it with std::bad_alloc. The relay now refuses it and serves on.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "mimic/net/nats.h"
#include "nats_broker.h"
#include "nats_test_fixtures.h"
#include "../net/net_test_support.h"
#include "nats_kv.h"

namespace mimic::net::nats_hostile_test {
namespace {

// A MESH_TOPOLOGY of `vertices` vertices and no triangles, written byte by byte (the encoder
// refuses counts a frame cannot carry).
std::string bomb_topology(uint32_t vertices) {
  std::string b = {'M', char(kProtocolVersion), char(MsgType::mesh_topology), 0, 11, 0, 0, 0};
  const char payload[11] = {0, 0, 0, char(vertices), char(vertices >> 8), char(vertices >> 16), char(vertices >> 24), 0,
                            0, 0, 0};
  return b + std::string(payload, 11);
}

TEST(NatsHostile, AMeshTopologyNoFrameCanCarryDoesNotKillARelay) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  TestPublisher pub(options(broker.url_as("hostM"), "hostM"), 1, 90, /*mesh_lod=*/0);
  TestRelay relay(options(broker.url_as("relay"), "relay"));
  auto v = viewer(relay.endpoint(), 0);
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return v->stats().mesh_frames >= 10; }, 20))
      << relay.feed().stats().last_error;
  const std::string subject = "mimic.lobby.mesh.hostM." + pub.get().key(0) + ".0";
  ::mimic::test::NatsProbe same_user(broker.url_as("hostM"));
  ASSERT_TRUE(same_user.ok());
  for (uint32_t count : {0xFFFFFFFFu, 100'000'000u}) ASSERT_TRUE(same_user.publish(subject, bomb_topology(count)));
  // The relay serves on: pose and mesh frames keep coming, from the real topology.
  const uint64_t frames = v->stats().frames, meshes = v->stats().mesh_frames;
  ASSERT_TRUE(test::pump(
      {v.get()}, [&] { return v->stats().frames > frames + 90 && v->stats().mesh_frames > meshes + 10; }, 20));
  EXPECT_EQ(v->avatars().begin()->second.mesh_vertex_count, 4u);
  EXPECT_GE(relay.feed().stats().rejected, 2u);
}

}  // namespace
}  // namespace mimic::net::nats_hostile_test
