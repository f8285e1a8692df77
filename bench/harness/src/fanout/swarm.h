// The fan-out bench's viewers: real subscriber sockets over loopback (a TCP session each, and a
// registered UDP socket each for UDP), read by a few threads with epoll, every frame's sequence
// number checked so that `lost` counts what a viewer never saw. Shared by the direct rows (the
// bench's thread drives the server) and the broker rows (a relay on its own thread).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <thread>
#include <vector>

#include "mimic/rig/motion.h"
#include "mimic/core/result.h"
#include "mimic/bench/loopback_bench.h"
#include "mimic/net/server.h"

namespace mimic::bench::fanout {

using Clock = std::chrono::steady_clock;

double process_cpu_s();
void raise_fd_limit(size_t wanted);
// A server that takes `subscribers` sessions from this host, frames as datagrams when `udp`.
net::ServerOptions server_options(const FanoutOptions& o, bool udp);

// How the swarm waits while the server works: the direct rows run the server on the calling
// thread, a relay runs on its own (then `stats` must ask its thread).
struct ServerAccess {
  std::function<void(Clock::duration)> wait;
  std::function<net::ServerStats()> stats;
};

class Swarm {
 public:
  Swarm();
  ~Swarm();
  Swarm(const Swarm&) = delete;
  Swarm& operator=(const Swarm&) = delete;

  // Connects `o.subscribers` subscribers to the server on `port` (lean as `o.lean`, frames as
  // datagrams when `udp`) and waits until all joined (and registered their UDP address).
  Status join(const FanoutOptions& o, uint16_t port, bool udp, const ServerAccess& server);
  // Receiving threads (o.receiver_threads), SCHED_FIFO one below o.realtime_priority if set.
  void start_receiving(const FanoutOptions& o);
  // From now on frames count (what arrived before, e.g. on joining, does not).
  void start_counting();
  void stop();
  int receiver_threads() const { return int(receivers_.size()); }
  double receivers_cpu_s() const;  // CPU time of the receiving threads so far
  uint64_t frames() const;
  uint64_t bytes() const;
  uint64_t lost() const;

  struct Sub;
  struct Receiver;

 private:
  void receive(Receiver& rx, int realtime_priority);
  std::vector<Sub> subs_;
  std::vector<std::unique_ptr<Receiver>> receivers_;
  std::atomic<bool> counting_{false}, stop_{false};
};

// The bench's avatars: the built-in walk on the default skeleton, each avatar a phase apart,
// with a 4,000-byte body model.
class Walkers {
 public:
  static Result<Walkers> make();
  uint16_t dof_count() const { return uint16_t(skeleton_.dof_count()); }
  std::string name(int avatar) const { return "walker" + std::to_string(avatar); }
  std::string model_bytes() const { return std::string(4000, 'b'); }
  // Avatar `avatar`'s POSE frame of tick `tick` (its sequence), time-stamped now, with `id` in
  // its avatar field. Valid until the next call.
  std::span<const uint8_t> frame(int avatar, int tick, double rate_hz, uint16_t id);

 private:
  rig::Skeleton skeleton_;
  std::shared_ptr<rig::Motion> walk_;
  rig::Pose pose_;
  std::vector<uint8_t> packet_;
};

// Fills the columns every row shares from what was measured.
struct Measured {
  int ticks = 0;
  double elapsed_s = 0;
  std::vector<double> tick_us;
  uint64_t late_ticks = 0;
  uint64_t dropped = 0;     // latest-wins drops at the server (or relay)
  double server_cpu_s = 0;  // the server's (relay's) threads
  double receivers_cpu_s = 0;
  double process_cpu_s = 0;
  bool realtime = false;
  int sender_threads = 1;
  // When set (>= 0): what the subscribers had received, and lost, by the end of the timed
  // window, instead of everything counted up to stop().
  int64_t frames_received = -1, lost = -1;
};
FanoutCapacity capacity_row(const FanoutOptions& o, const Swarm& swarm, const Measured& m);

}  // namespace mimic::bench::fanout
