// A viewer's nats://HOST:PORT/SCENE is joined above the client (open_scene_connection: a relay in
// this process), while net::Client itself speaks TCP/UDP to HOST:PORT only.
#include <gtest/gtest.h>

#include <string>

#include "mimic/net/client.h"
#include "mimic/net/scene_connection.h"
#include "nats_broker.h"
#include "nats_test_fixtures.h"
#include "../net/net_test_support.h"

namespace mimic::net::scene_connection_test {
namespace {

using ::mimic::test::NatsBroker;

TEST(SceneConnection, ABrokersSceneIsServedByARelayTheClientHolds) {
  REQUIRE_NATS();
  NatsBroker broker;
  broker.configure("solo");
  ASSERT_TRUE(broker.start());
  TestPublisher pub(options(broker.url_as("hostA"), "hostA", "stage"), 2);
  ClientOptions o;
  o.connect = broker.url_as("relay") + "/stage";
  o.name = "viewer";
  auto c = open_scene_connection(o);
  ASSERT_TRUE(c) << c.error().what();
  ASSERT_TRUE(test::pump(
      {c->get()}, [&] { return sees_all(**c, 2, 30); }, 15))
      << broker.log();
  EXPECT_EQ((*c)->stats().rejected, 0u);
  c->reset();  // stops the relay it held: nothing left running
}

TEST(SceneConnection, HostPortIsAPlainClientAndPublishersAreNotRelayed) {
  ClientOptions o;
  o.connect = "nats://127.0.0.1:1/stage";
  o.role = Role::publisher;
  auto p = open_scene_connection(o);
  ASSERT_FALSE(p);
  EXPECT_NE(p.error().message.find("mimic run --nats"), std::string::npos) << p.error().message;
  // HOST:PORT goes straight to Client::connect (nothing listens on port 1: refused, not relayed).
  o.connect = "127.0.0.1:1";
  o.role = Role::subscriber;
  o.reconnect = false;
  o.connect_timeout_s = 5;
  EXPECT_FALSE(open_scene_connection(o));
}

TEST(SceneConnection, TheClientItselfRefusesABrokerUrlWithoutShowingIt) {
  ClientOptions o;
  o.connect = "nats://alice:s3cret@127.0.0.1:4222/stage";
  auto c = Client::connect(o);
  ASSERT_FALSE(c);
  EXPECT_EQ(c.error().code, Errc::invalid_argument);
  EXPECT_NE(c.error().message.find("HOST:PORT"), std::string::npos) << c.error().message;
  EXPECT_EQ(c.error().message.find("s3cret"), std::string::npos) << c.error().message;
}

}  // namespace
}  // namespace mimic::net::scene_connection_test
