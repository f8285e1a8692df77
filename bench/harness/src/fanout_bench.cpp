// Fan-out capacity of one server process: many real subscriber sockets over loopback (the
// swarm, fanout/swarm.h), local avatars published at 90 Hz by the bench's thread, which drives
// the server; `lost` counted from every frame's sequence number. The broker rows are in
// fanout/nats_row.cpp.
#include <algorithm>
#include <chrono>
#include <thread>
#include <vector>

#include "fanout/swarm.h"
#include "mimic/bench/loopback_bench.h"
#include "mimic/core/thread_priority.h"
#include "mimic/net/server.h"

namespace mimic::bench {

using namespace mimic::net;  // the harness drives the product's servers and clients

namespace fanout {
Result<FanoutCapacity> measure_nats(const FanoutOptions& o);
}

const char* fanout_transport_name(FanoutTransport t) {
  switch (t) {
    case FanoutTransport::udp: return "udp";
    case FanoutTransport::nats: return "nats";
    case FanoutTransport::tcp: break;
  }
  return "tcp";
}

Result<FanoutCapacity> measure_fanout_capacity(const FanoutOptions& o) {
  using namespace fanout;
  if (o.subscribers < 1 || o.avatars < 1 || o.rate_hz <= 0 || o.seconds <= 0)
    return fail(Errc::invalid_argument, "fan-out: subscribers, avatars, rate and seconds must be positive");
  if (o.transport == FanoutTransport::nats) return measure_nats(o);
  const bool udp = o.transport == FanoutTransport::udp;
  raise_fd_limit(size_t(o.subscribers) * (udp ? 3 : 2) + 256);

  auto server = Server::create(server_options(o, udp));
  if (!server) return tl::unexpected(server.error());
  Server& srv = **server;
  if (udp && !srv.udp()) return fail(Errc::io_error, "fan-out: the server could not bind its UDP socket");

  auto walkers = Walkers::make();
  if (!walkers) return tl::unexpected(walkers.error());
  std::vector<uint16_t> ids;
  for (int a = 0; a < o.avatars; ++a) {
    auto id = srv.add_avatar(walkers->name(a), walkers->dof_count(), walkers->model_bytes());
    if (!id) return tl::unexpected(id.error());
    ids.push_back(*id);
  }

  Swarm swarm;
  const ServerAccess access{[&](Clock::duration d) { d.count() ? srv.run_until(Clock::now() + d) : srv.poll(); },
                            [&] { return srv.stats(); }};
  if (auto st = swarm.join(o, srv.port(), udp, access); !st) return tl::unexpected(st.error());
  swarm.start_receiving(o);

  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / o.rate_hz));
  Measured m;
  m.ticks = std::max(1, int(o.seconds * o.rate_hz));
  m.tick_us.reserve(size_t(m.ticks));
  // The avatars have no frame yet: sequences start at 1 with the first tick.
  srv.run_until(Clock::now() + std::chrono::milliseconds(100));
  swarm.start_counting();
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  m.realtime = o.realtime_priority > 0 && set_thread_fifo(o.realtime_priority);
  const uint64_t dropped_before = srv.stats().frames_dropped;
  const double rcpu0 = swarm.receivers_cpu_s(), pcpu0 = process_cpu_s();
  const auto start = Clock::now();
  for (int k = 1; k <= m.ticks; ++k) {
    const auto due = start + period * (k - 1);
    srv.run_until(due);
    const auto t0 = Clock::now();
    if (t0 - due > period) m.late_ticks++;
    srv.begin_batch();
    for (int a = 0; a < o.avatars; ++a)
      srv.publish_pose(ids[size_t(a)], walkers->frame(a, k, o.rate_hz, ids[size_t(a)]));
    srv.end_batch();
    m.tick_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  m.elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
  m.receivers_cpu_s = swarm.receivers_cpu_s() - rcpu0;
  m.process_cpu_s = process_cpu_s() - pcpu0;
  m.server_cpu_s = std::max(0.0, m.process_cpu_s - m.receivers_cpu_s);  // the server's threads
  if (m.realtime) set_thread_fifo(0);
  const uint64_t expected = uint64_t(o.subscribers) * uint64_t(o.avatars) * uint64_t(m.ticks);
  const auto drain_deadline = Clock::now() + std::chrono::seconds(10);
  while (swarm.frames() < expected && Clock::now() < drain_deadline)
    srv.run_until(Clock::now() + std::chrono::milliseconds(5));
  srv.run_until(Clock::now() + std::chrono::milliseconds(50));
  swarm.stop();
  m.dropped = srv.stats().frames_dropped - dropped_before;
  m.sender_threads = srv.fanout_threads();
  return capacity_row(o, swarm, m);
}

}  // namespace mimic::bench
