// Measurements of the scene server on loopback, shared by bench/net and `mimic bench`.
// Figures, not pass/fail: timings depend on the machine and its load.
#pragma once

#include <cstdint>

#include "mimic/core/result.h"

namespace mimic::net {

struct LatencyResult {
  double p50_us = 0, p99_us = 0, max_us = 0;
  uint64_t samples = 0;
};

// A local avatar published through a Server to one subscribing Client over loopback TCP (or, with
// `udp`, as datagrams once the subscriber's address is registered), both driven by the calling
// thread: time from handing the encoded frame to the server until the subscriber has decoded it
// (encode excluded; the send, kernel loopback and decode included).
Result<LatencyResult> measure_loopback_latency(int frames, uint16_t dof_count, bool udp = false);

struct FanoutResult {
  int subscribers = 0, avatars = 0;
  double rate_hz = 0, seconds = 0;
  uint64_t frames_expected = 0;   // subscribers × avatars × ticks
  uint64_t frames_received = 0;   // pose frames the subscribers decoded
  uint64_t frames_dropped = 0;    // server latest-wins drops
  uint64_t lost = 0;              // sequence gaps seen by subscribers
  double tick_p50_us = 0, tick_p99_us = 0;  // publish + fan-out of one tick on the server thread
  double achieved_rate_hz = 0;    // ticks / time from the first tick to the last frame sent
  uint64_t late_ticks = 0;        // ticks started more than one period after they were due
  bool kept_up = false;           // nothing lost or dropped, and at least 99% of the rate
};

// `subscribers` raw TCP subscribers (read by one extra thread) and `avatars` local avatars
// published at `rate_hz` for `seconds`.
Result<FanoutResult> measure_fanout(int subscribers, int avatars, double rate_hz, double seconds);

}  // namespace mimic::net
