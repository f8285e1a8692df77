// The fan-out capacity bench measures what it says: real sockets, every frame counted, bytes per
// avatar-frame from what arrived (no timing assertions: the machine is shared).
#include <gtest/gtest.h>

#include "mimic/net/loopback_bench.h"

namespace mimic::net {
namespace {

TEST(FanoutBench, EverySubscriberReceivesEveryFrameOverTcpAndUdp) {
  for (auto t : {FanoutTransport::tcp, FanoutTransport::udp}) {
    for (bool lean : {true, false}) {
      FanoutOptions o;
      o.subscribers = 20;
      o.avatars = 3;
      o.seconds = 0.3;
      o.transport = t;
      o.lean = lean;
      auto c = measure_fanout_capacity(o);
      ASSERT_TRUE(c) << c.error().what();
      const auto& r = c->result;
      const uint64_t ticks = uint64_t(0.3 * 90);
      EXPECT_EQ(c->streams, 60u);
      EXPECT_EQ(r.frames_expected, 60u * ticks);
      EXPECT_EQ(r.frames_received, r.frames_expected) << fanout_transport_name(t) << (lean ? " lean" : "");
      EXPECT_EQ(r.lost, 0u);
      // The default skeleton: POSE frames are 150 bytes; the walk on the lean stream far less.
      if (lean) {
        EXPECT_LT(c->bytes_per_avatar_frame, 64.0);
      } else {
        EXPECT_DOUBLE_EQ(c->bytes_per_avatar_frame, 150.0);
      }
      EXPECT_GT(c->cpu_us_per_tick, 0.0);
    }
  }
}

// Through a real nats-server the bench starts, and a relay in-process: every frame accounted
// for (received, or lost by sequence number: a loaded machine may make the publisher's
// latest-wins drop one), the publish-to-relay latency measured.
TEST(FanoutBench, ThroughABrokerAndARelay) {
  if (auto ready = fanout_nats_available(); !ready) GTEST_SKIP() << ready.error().what();
  FanoutOptions o;
  o.subscribers = 20;
  o.avatars = 3;
  o.seconds = 0.3;
  o.transport = FanoutTransport::nats;
  auto c = measure_fanout_capacity(o);
  ASSERT_TRUE(c) << c.error().what();
  const auto& r = c->result;
  EXPECT_EQ(r.frames_expected, 60u * uint64_t(0.3 * 90));
  EXPECT_GT(r.frames_received, 0u);
  EXPECT_EQ(r.frames_received + r.lost, r.frames_expected);
  EXPECT_LT(c->bytes_per_avatar_frame, 64.0);
  EXPECT_GT(c->publish_to_relay_ms_p50, 0.0);
  EXPECT_GE(c->publish_to_relay_ms_p99, c->publish_to_relay_ms_p50);
  EXPECT_GT(c->fanouts_per_tick, 0.0);
  EXPECT_GT(r.tick_p50_us, 0.0);
}

}  // namespace
}  // namespace mimic::net
