// Measurements of the scene server on loopback, shared by bench/net and `mimic bench`.
// Figures, not pass/fail: timings depend on the machine and its load.
#pragma once

#include <cstdint>
#include <functional>

#include "mimic/core/result.h"

namespace mimic::bench {

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
  uint64_t frames_expected = 0;             // subscribers × avatars × ticks
  uint64_t frames_received = 0;             // pose frames the subscribers decoded
  uint64_t frames_dropped = 0;              // server latest-wins drops
  uint64_t lost = 0;                        // sequence gaps seen by subscribers
  double tick_p50_us = 0, tick_p99_us = 0;  // publish + fan-out of one tick on the server thread
  double achieved_rate_hz = 0;              // ticks / time from the first tick to the last frame sent
  uint64_t late_ticks = 0;                  // ticks started more than one period after they were due
  bool kept_up = false;                     // nothing lost or dropped, and at least 99% of the rate
};

// `subscribers` raw TCP subscribers (read by one extra thread) and `avatars` local avatars
// published at `rate_hz` for `seconds`.
Result<FanoutResult> measure_fanout(int subscribers, int avatars, double rate_hz, double seconds);

// The fan-out capacity of one server process (`mimic bench --section fanout`): `subscribers`
// real subscriber sockets over loopback (TCP streams, or TCP sessions whose pose frames come as
// UDP datagrams), read by a few receiving threads with epoll, and `avatars` local avatars
// walking (the built-in walk on the default skeleton, phases apart) at `rate_hz`.
// `nats`: the avatars are published into a real nats-server started on a free loopback port,
// and a relay in this process (a Server fed by NatsSceneFeed, as `mimic relay`) serves the
// subscribers over TCP.
enum class FanoutTransport { tcp, udp, nats };
const char* fanout_transport_name(FanoutTransport t);
// Why the nats rows cannot run here (built without NATS, no nats-server installed), or ok.
Status fanout_nats_available();

struct FanoutOptions {
  int subscribers = 1000;
  int avatars = 1;
  double rate_hz = 90;
  double seconds = 3;
  FanoutTransport transport = FanoutTransport::tcp;
  bool lean = true;  // subscribers ask for the lean stream (kCapLeanPose)
  // > 0: the server's threads run SCHED_FIFO at this priority while publishing (as `mimic run
  // --realtime` does), so a loaded machine's other processes do not preempt them, and the
  // receiving threads one below (they stand for viewers on other hosts: they read between
  // ticks instead of taking a core from one). Needs the privilege; without it the run goes on
  // at normal priority.
  int realtime_priority = 0;
  int sender_threads = 0;    // ServerOptions::fanout_threads (0: one per core, at most 4)
  int receiver_threads = 2;  // threads reading the subscribers' sockets, each its own share
  // Called once, just before the first tick of the timed window (tests: a fault injected while
  // the window runs).
  std::function<void()> on_window_start;
};

struct FanoutCapacity {
  FanoutOptions options;
  uint64_t streams = 0;                 // subscribers × avatars
  FanoutResult result;                  // frames, drops, lost (from sequence numbers), tick times
  double bytes_per_avatar_frame = 0;    // mean pose packet size the subscribers received
  double cpu_percent = 0;               // the server's threads' CPU time / wall time while publishing
  double cpu_us_per_tick = 0;           // the server's threads' CPU time per tick (less load-dependent than wall time)
  double receiver_cpu_us_per_tick = 0;  // the receiving threads' CPU time per tick
  double process_cpu_percent = 0;       // the whole process (server and receiving threads), of one core
  double load_average_1m = 0;           // the machine's, when the run ended
  // nats rows: the frame's time stamp (just before publishing) to its arrival at the relay,
  // the broker process's CPU, and the relay's fan-outs per published tick (the frames of a
  // tick may reach it in more than one batch).
  double publish_to_relay_ms_p50 = 0, publish_to_relay_ms_p99 = 0;
  double broker_cpu_percent = 0;
  double fanouts_per_tick = 0;
  // nats rows: frames accounted for only after the timed window, in the drain that follows it
  // (arrived late, or shown lost by a later one): with `received` and `lost`, every frame
  // published is counted once, however slow a loaded machine made the path.
  uint64_t settled_after_window = 0;
  bool realtime = false;   // the server's threads did run SCHED_FIFO
  int sender_threads = 1;  // threads sharing a tick's writes (Server::fanout_threads)
  int receiver_threads = 1;
};

Result<FanoutCapacity> measure_fanout_capacity(const FanoutOptions& options);

}  // namespace mimic::bench
