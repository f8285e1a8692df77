// The fan-out bench through a broker: the bench publishes its walking avatars with NatsPublisher
// (as `mimic run --nats` does) into a real nats-server it starts on a free loopback port, a relay
// in this process (a Server fed by NatsSceneFeed on its own thread, as `mimic relay`) serves the
// swarm of subscribers over TCP. Same columns as the direct rows; the tick is the relay's
// fan-out, and the publish-to-relay latency comes from the relay's feed.
#include <sched.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "fanout/swarm.h"
#include "mimic/net/frame_codec.h"
#include "mimic/bench/loopback_bench.h"
#include "mimic/core/thread_priority.h"
#include "mimic/net/nats.h"
#include "mimic/net/server.h"

extern char** environ;

namespace mimic::bench {

using namespace mimic::net;  // the harness drives the product's servers and clients

namespace {

std::string find_nats_server() {
  std::vector<std::string> dirs;
  if (const char* path = std::getenv("PATH")) {
    std::stringstream ss(path);
    for (std::string d; std::getline(ss, d, ':');)
      if (!d.empty()) dirs.push_back(d);
  }
  for (const char* d : {"/usr/sbin", "/usr/local/bin", "/usr/bin"}) dirs.push_back(d);
  for (const auto& d : dirs) {
    const std::string p = d + "/nats-server";
    if (::access(p.c_str(), X_OK) == 0) return p;
  }
  return {};
}

}  // namespace

Status fanout_nats_available() {
  if (find_nats_server().empty())
    return fail(Errc::not_found, "nats-server is not installed (not on PATH, /usr/sbin or /usr/local/bin)");
  return {};
}

namespace fanout {
namespace {

// CPU time (user + system) of another process so far.
double cpu_seconds_of(pid_t pid) {
  clockid_t clock{};
  timespec t{};
  if (clock_getcpuclockid(pid, &clock) != 0 || clock_gettime(clock, &t) != 0) return 0;
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// One nats-server with JetStream (the relay keeps the models in its key-value bucket) on a port
// it picks itself, which it writes to a ports file once it listens; in a temporary directory
// removed afterwards.
class Broker {
 public:
  ~Broker() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    std::error_code ec;
    if (!dir_.empty()) std::filesystem::remove_all(dir_, ec);
  }
  Status start() {
    const std::string bin = find_nats_server();
    char tmpl[] = "/tmp/mimic-bench-nats-XXXXXX";
    if (bin.empty() || !::mkdtemp(tmpl)) return fail(Errc::io_error, "fan-out nats: cannot set up nats-server");
    dir_ = tmpl;
    std::ofstream(dir_ + "/nats.conf") << "host: 127.0.0.1\nport: -1\nports_file_dir: \"" << dir_
                                       << "\"\njetstream { store_dir: \"" << dir_ << "/js\" }\n";
    std::vector<std::string> args = {bin, "-c", dir_ + "/nats.conf", "-l", dir_ + "/nats.log"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, bin.c_str(), nullptr, nullptr, argv.data(), environ) != 0)
      return fail(Errc::io_error, "fan-out nats: cannot start " + bin);
    // {"nats":["nats://127.0.0.1:PORT"]}
    const auto deadline = Clock::now() + std::chrono::seconds(10);
    while (Clock::now() < deadline) {
      std::error_code ec;
      for (const auto& e : std::filesystem::directory_iterator(dir_, ec)) {
        if (e.path().extension() != ".ports") continue;
        std::ifstream f(e.path());
        const std::string text((std::istreambuf_iterator<char>(f)), {});
        const size_t at = text.find("nats://"), end = text.find('"', at);
        if (at != std::string::npos && end != std::string::npos) {
          url_ = text.substr(at, end - at);
          return {};
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return fail(Errc::timeout, "fan-out nats: nats-server did not come up (log: " + dir_ + "/nats.log)");
  }
  const std::string& url() const { return url_; }
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  std::string url_;
  std::string dir_;
};

// Runs `fn` on the relay's thread and waits for its result.
template <class F>
auto on_server(Server& srv, F fn) {
  auto p = std::make_shared<std::promise<decltype(fn())>>();
  auto result = p->get_future();
  srv.dispatch([p, fn] { p->set_value(fn()); });
  return result.get();
}

// Realtime: every thread on the path, the broker's included; the receivers (started next) put
// themselves one below.
void realtime_path(pid_t broker, int priority) {
  if (priority <= 0) return;
  set_process_threads_fifo(broker, priority);
  set_process_threads_fifo(::getpid(), priority);
}

}  // namespace

Result<FanoutCapacity> measure_nats(const FanoutOptions& o) {
  if (auto st = fanout_nats_available(); !st) return tl::unexpected(st.error());
  raise_fd_limit(size_t(o.subscribers) * 2 + 256);
  Broker broker;
  if (auto st = broker.start(); !st) return tl::unexpected(st.error());

  auto relay = Server::create(server_options(o, false));
  if (!relay) return tl::unexpected(relay.error());
  Server& srv = **relay;
  NatsOptions nopt;
  nopt.servers = broker.url();
  nopt.scene = "fanout_bench";
  nopt.name = "bench-relay";
  auto feed = NatsSceneFeed::create(nopt, srv);
  if (!feed) return tl::unexpected(feed.error());
  std::thread relay_thread([&] { srv.run(); });
  struct StopRelay {
    Server& srv;
    std::thread& t;
    std::unique_ptr<NatsSceneFeed>& feed;
    ~StopRelay() {
      srv.stop();
      if (t.joinable()) t.join();
      feed.reset();  // while the relay's server is not running
    }
  } stop_relay{srv, relay_thread, *feed};
  nopt.name = "bench-pub";
  auto publisher = NatsPublisher::create(nopt);
  if (!publisher) return tl::unexpected(publisher.error());

  auto walkers = Walkers::make();
  if (!walkers) return tl::unexpected(walkers.error());
  std::vector<int> index;
  for (int a = 0; a < o.avatars; ++a) {
    auto i = (*publisher)->add_avatar(walkers->name(a), walkers->dof_count(), walkers->model_bytes());
    if (!i) return tl::unexpected(i.error());
    index.push_back(*i);
  }
  // The relay has every model (from the bucket) before the viewers join.
  const auto models_deadline = Clock::now() + std::chrono::seconds(30);
  while (on_server(srv, [&] { return srv.stats().avatars; }) < uint64_t(o.avatars) && Clock::now() < models_deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  if (on_server(srv, [&] { return srv.stats().avatars; }) < uint64_t(o.avatars))
    return fail(Errc::timeout, "fan-out nats: the relay did not get every model from the broker");

  Swarm swarm;
  const ServerAccess access{[](Clock::duration d) {
                              std::this_thread::sleep_for(std::max(d, Clock::duration(std::chrono::microseconds(200))));
                            },
                            [&] { return on_server(srv, [&] { return srv.stats(); }); }};
  if (auto st = swarm.join(o, srv.port(), false, access); !st) return tl::unexpected(st.error());
  realtime_path(broker.pid(), o.realtime_priority);
  swarm.start_receiving(o);

  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / o.rate_hz));
  Measured m;
  m.ticks = std::max(1, int(o.seconds * o.rate_hz));
  swarm.start_counting();
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  m.realtime = o.realtime_priority > 0 && set_thread_fifo(o.realtime_priority);
  const uint64_t dropped_before = on_server(srv, [&] { return srv.stats().frames_dropped; });
  const uint64_t fanouts_before = on_server(srv, [&] { return srv.fanout_times().count; });
  const auto link_before = (*publisher)->stats().frames_dropped + (*feed)->stats().frames_dropped;
  const uint64_t relay_frames_before = (*feed)->stats().frames;
  if (o.on_window_start) o.on_window_start();
  const double rcpu0 = swarm.receivers_cpu_s(), pcpu0 = process_cpu_s(), bcpu0 = cpu_seconds_of(broker.pid());
  const auto start = Clock::now();
  for (int k = 1; k <= m.ticks; ++k) {
    const auto due = start + period * (k - 1);
    std::this_thread::sleep_until(due);
    if (Clock::now() - due > period) m.late_ticks++;
    (*publisher)->begin_tick();  // as mimic run --nats does: a tick of frames in one message
    for (int a = 0; a < o.avatars; ++a)
      (*publisher)->publish_pose(index[size_t(a)], walkers->frame(a, k, o.rate_hz, uint16_t(a + 1)));
    (*publisher)->end_tick();
  }
  m.elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
  m.receivers_cpu_s = swarm.receivers_cpu_s() - rcpu0;
  m.process_cpu_s = process_cpu_s() - pcpu0;
  m.server_cpu_s = std::max(0.0, m.process_cpu_s - m.receivers_cpu_s);  // publisher, relay and their clients
  const double broker_cpu_s = cpu_seconds_of(broker.pid()) - bcpu0;
  if (m.realtime) set_thread_fifo(0);
  const uint64_t expected = uint64_t(o.subscribers) * uint64_t(o.avatars) * uint64_t(m.ticks);
  // Everything the row says comes from the timed window: what arrived by its end (with a few
  // ticks' grace for the frames in flight), the relay's fan-out times and rate in it. A relay
  // that fell behind catches up afterwards, and counting that made such a row say "kept up".
  const auto window_end = Clock::now() + std::max(3 * period, Clock::duration(std::chrono::milliseconds(50)));
  while (swarm.frames() < expected && Clock::now() < window_end)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  m.frames_received = int64_t(swarm.frames());
  m.lost = int64_t(swarm.lost());
  const auto times = on_server(srv, [&] { return srv.fanout_times(); });
  const NatsLinkStats relay_link = (*feed)->stats();
  m.dropped = on_server(srv, [&] { return srv.stats().frames_dropped; }) - dropped_before +
              (*publisher)->stats().frames_dropped + relay_link.frames_dropped - link_before;
  // Then the rest drains before the subscribers stop (counted apart from the window).
  const auto drain_deadline = Clock::now() + std::chrono::seconds(10);
  while (swarm.frames() < expected && Clock::now() < drain_deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  swarm.stop();
  const uint64_t settled = swarm.frames() + swarm.lost() - uint64_t(m.frames_received + m.lost);
  if (o.realtime_priority > 0) set_process_threads_fifo(::getpid(), 0);

  m.sender_threads = srv.fanout_threads();
  FanoutCapacity cap = capacity_row(o, swarm, m);
  FanoutResult& r = cap.result;
  r.tick_p50_us = times.p50_us;
  r.tick_p99_us = times.p99_us;
  // The rate the relay fanned ticks out at over the window, not the rate they were published at.
  const double relay_ticks = double(relay_link.frames - relay_frames_before) / double(std::max(o.avatars, 1));
  r.achieved_rate_hz = std::min(r.achieved_rate_hz, relay_ticks / std::max(m.elapsed_s, 1e-9));
  r.kept_up = r.frames_received >= r.frames_expected && r.lost == 0 && r.frames_dropped == 0 &&
              r.achieved_rate_hz >= 0.99 * o.rate_hz && r.tick_p50_us <= 1e6 / o.rate_hz;
  cap.publish_to_relay_ms_p50 = relay_link.latency_ms_p50;
  cap.publish_to_relay_ms_p99 = relay_link.latency_ms_p99;
  cap.broker_cpu_percent = 100.0 * broker_cpu_s / std::max(m.elapsed_s, 1e-9);
  cap.fanouts_per_tick = double(times.count - fanouts_before) / double(m.ticks);
  cap.settled_after_window = settled;
  return cap;
}

}  // namespace fanout

}  // namespace mimic::bench
