#include "mimic/bench/loopback_bench.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "mimic/core/percentile.h"
#include "mimic/net/client.h"
#include "mimic/net/server.h"

namespace mimic::bench {

using namespace mimic::net;  // the harness drives the product's servers and clients

namespace {

using Clock = std::chrono::steady_clock;

double us_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::micro>(b - a).count();
}

rig::Pose test_pose(uint16_t dofs, uint32_t k) {
  rig::Pose p;
  p.root_position_m = {0, 0.9f, 0.001f * float(k % 1000)};
  p.dof_rad.assign(dofs, 0.0f);
  for (uint16_t i = 0; i < dofs; ++i) p.dof_rad[i] = 0.5f * std::sin(0.01f * float(k) + float(i));
  return p;
}

}  // namespace

Result<LatencyResult> measure_loopback_latency(int frames, uint16_t dof_count, bool udp) {
  auto server = Server::create({});
  if (!server) return tl::unexpected(server.error());
  Server& srv = **server;
  auto id = srv.add_avatar("bench", dof_count, std::string(4000, 'b'));
  if (!id) return tl::unexpected(id.error());
  // The client connects while the server is serviced from a helper thread, then both are
  // driven from here.
  std::atomic<bool> connecting{true};
  std::thread helper([&] {
    while (connecting) srv.run_until(Clock::now() + std::chrono::milliseconds(1));
  });
  ClientOptions o;
  o.connect = srv.endpoint();
  o.udp = udp;
  auto client = Client::connect(o);
  connecting = false;
  helper.join();
  if (!client) return tl::unexpected(client.error());
  Client& c = **client;
  if (udp) {
    const auto give_up = Clock::now() + std::chrono::seconds(2);
    while (!c.udp_active() && Clock::now() < give_up) {
      srv.poll();
      (void)c.poll();
    }
    if (!c.udp_active()) return fail(Errc::timeout, "the server did not register the UDP address");
  }
  uint32_t got_seq = 0;
  Clock::time_point got_at;
  c.on_pose = [&](const RemoteAvatar& a, uint64_t) {
    got_seq = a.last.sequence;
    got_at = Clock::now();
  };
  std::vector<uint8_t> packet(pose_packet_bytes(dof_count));
  std::vector<double> samples;
  samples.reserve(size_t(frames));
  for (int k = 1; k <= frames + 50; ++k) {
    const rig::Pose pose = test_pose(dof_count, uint32_t(k));
    encode_pose({*id, 0, uint32_t(k), wall_clock_us()}, pose, packet);
    const auto t0 = Clock::now();
    srv.publish_pose(*id, packet);
    const auto give_up = t0 + std::chrono::milliseconds(200);
    while (got_seq != uint32_t(k) && Clock::now() < give_up) {
      srv.poll();
      (void)c.poll();
    }
    if (got_seq != uint32_t(k)) return fail(Errc::timeout, "frame " + std::to_string(k) + " never arrived");
    if (k > 50) samples.push_back(us_between(t0, got_at));  // the first frames warm caches up
  }
  LatencyResult r;
  r.samples = samples.size();
  r.p50_us = percentile_in_place(samples, 0.50);
  r.p99_us = percentile_in_place(samples, 0.99);
  r.max_us = samples.empty() ? 0 : *std::max_element(samples.begin(), samples.end());
  return r;
}

namespace {

// Subscribers as bare TCP sockets read by one epoll thread: they split the stream and count
// POSE frames and sequence gaps without decoding poses, so what is measured is the server's work.
class RawSubscribers {
 public:
  ~RawSubscribers() {
    stop();
    for (auto& s : subs_)
      if (s.fd >= 0) ::close(s.fd);
    if (ep_ >= 0) ::close(ep_);
  }

  // Connects `count` subscribers (HELLO sent) to `srv` on loopback; `avatar_slots` bounds the
  // avatar ids whose sequences they follow.
  Status connect(Server& srv, int count, size_t avatar_slots) {
    Hello hello;
    hello.name = "bench";
    std::vector<uint8_t> hello_bytes(kMaxHelloBytes);
    hello_bytes.resize(encode_hello(hello, hello_bytes));
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(srv.port());
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ep_ = ::epoll_create1(0);
    subs_ = std::vector<Sub>(static_cast<size_t>(count));
    for (size_t i = 0; i < subs_.size(); ++i) {
      auto& s = subs_[i];
      s.fd = ::socket(AF_INET, SOCK_STREAM, 0);
      if (s.fd < 0 || ::connect(s.fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0)
        return fail(Errc::io_error, "subscriber " + std::to_string(i) + " could not connect (file descriptors?)");
      ::send(s.fd, hello_bytes.data(), hello_bytes.size(), MSG_NOSIGNAL);
      s.last.assign(avatar_slots, 0);
      epoll_event ev{};
      ev.events = EPOLLIN;
      ev.data.u64 = i;
      ::epoll_ctl(ep_, EPOLL_CTL_ADD, s.fd, &ev);
      if (i % 64 == 0) srv.poll();  // keep the accept queue short
    }
    return {};
  }

  void start_reading() {
    reader_ = std::thread([this] {
      std::vector<epoll_event> events(256);
      while (!stop_) {
        const int n = ::epoll_wait(ep_, events.data(), int(events.size()), 20);
        for (int e = 0; e < n; ++e) read_ready(subs_[events[size_t(e)].data.u64]);
      }
    });
  }

  void stop() {
    stop_ = true;
    if (reader_.joinable()) reader_.join();
  }

  uint64_t received() const { return received_; }
  uint64_t lost() const { return lost_; }

 private:
  struct Sub {
    int fd = -1;
    PacketReader reader{kMaxPacketBytes, 8192};
    std::vector<uint32_t> last;  // by avatar id
  };

  void read_ready(Sub& s) {
    auto space = s.reader.write_space(16384);
    const ssize_t got = ::recv(s.fd, space.data(), space.size(), MSG_DONTWAIT);
    if (got <= 0) return;
    s.reader.commit(size_t(got));
    for (;;) {
      std::span<const uint8_t> p;
      if (s.reader.next(p) != Reject::ok || p.empty()) break;
      if (p[2] != uint8_t(MsgType::pose)) continue;
      const uint16_t a = pose_avatar(p);
      const uint32_t seq = pose_sequence(p);
      if (a < s.last.size()) {
        if (seq > s.last[a] + 1) lost_ += seq - s.last[a] - 1;  // sequences start at 1
        s.last[a] = seq;
      }
      received_++;
    }
  }

  std::vector<Sub> subs_;
  int ep_ = -1;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> received_{0}, lost_{0};
  std::thread reader_;
};

}  // namespace

Result<FanoutResult> measure_fanout(int subscribers, int avatars, double rate_hz, double seconds) {
  ServerOptions opt;
  opt.max_sessions = size_t(subscribers) + 16;
  opt.max_sessions_per_address = opt.max_sessions;  // every subscriber is on this host
  opt.max_packets_per_s = 1e9;
  auto server = Server::create(opt);
  if (!server) return tl::unexpected(server.error());
  Server& srv = **server;
  const uint16_t dofs = 52;
  std::vector<uint16_t> ids;
  for (int a = 0; a < avatars; ++a) {
    auto id = srv.add_avatar("bench" + std::to_string(a), dofs, std::string(4000, 'b'));
    if (!id) return tl::unexpected(id.error());
    ids.push_back(*id);
  }
  RawSubscribers subs;
  if (auto st = subs.connect(srv, subscribers, ids.back() + 1u); !st) return tl::unexpected(st.error());
  subs.start_reading();
  const auto join_deadline = Clock::now() + std::chrono::seconds(30);
  while (srv.stats().subscribers < uint64_t(subscribers) && Clock::now() < join_deadline)
    srv.run_until(Clock::now() + std::chrono::milliseconds(5));
  srv.run_until(Clock::now() + std::chrono::milliseconds(200));  // models delivered

  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate_hz));
  const int ticks = std::max(1, int(seconds * rate_hz));
  std::vector<double> tick_us;
  tick_us.reserve(size_t(ticks));
  std::vector<uint8_t> packet(pose_packet_bytes(dofs));
  std::vector<rig::Pose> poses;
  for (int a = 0; a < avatars; ++a) poses.push_back(test_pose(dofs, uint32_t(a)));
  uint64_t late = 0;
  const auto start = Clock::now();
  for (int k = 1; k <= ticks; ++k) {
    const auto due = start + period * (k - 1);
    srv.run_until(due);
    const auto t0 = Clock::now();
    if (t0 - due > period) late++;
    srv.begin_batch();
    for (int a = 0; a < avatars; ++a) {
      encode_pose({ids[size_t(a)], 0, uint32_t(k), wall_clock_us()}, poses[size_t(a)], packet);
      srv.publish_pose(ids[size_t(a)], packet);
    }
    srv.end_batch();
    tick_us.push_back(us_between(t0, Clock::now()));
  }
  const double elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
  const uint64_t expected = uint64_t(subscribers) * uint64_t(avatars) * uint64_t(ticks);
  const auto drain_deadline = Clock::now() + std::chrono::seconds(5);
  while (subs.received() < expected && Clock::now() < drain_deadline)
    srv.run_until(Clock::now() + std::chrono::milliseconds(5));
  subs.stop();

  FanoutResult r;
  r.subscribers = subscribers;
  r.avatars = avatars;
  r.rate_hz = rate_hz;
  r.seconds = double(ticks) / rate_hz;
  r.frames_expected = expected;
  r.frames_received = subs.received();
  r.frames_dropped = srv.stats().frames_dropped;
  r.lost = subs.lost();
  r.tick_p50_us = percentile_in_place(tick_us, 0.50);
  r.tick_p99_us = percentile_in_place(tick_us, 0.99);
  r.late_ticks = late;
  // The last tick is due (ticks - 1) periods after the first and takes one more to send.
  r.achieved_rate_hz = double(ticks) / std::max(elapsed_s, 1e-9);
  r.kept_up =
      r.frames_received == expected && r.lost == 0 && r.frames_dropped == 0 && r.achieved_rate_hz >= 0.99 * rate_hz;
  return r;
}

}  // namespace mimic::bench
