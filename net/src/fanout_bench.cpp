// Fan-out capacity of one server process: many real subscriber sockets over loopback, read by
// one thread with epoll, `lost` counted from every frame's sequence number.
#include <arpa/inet.h>
#include <pthread.h>
#include <sched.h>
#include <netinet/in.h>
#include <sys/epoll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <thread>
#include <vector>

#include "mimic/avatar/motion.h"
#include "mimic/net/loopback_bench.h"
#include "mimic/net/pose_stream.h"
#include "mimic/net/server.h"

namespace mimic::net {

namespace {

using Clock = std::chrono::steady_clock;

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * double(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

double process_cpu_s() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// Every subscriber needs a TCP socket (and a UDP one), the server one per session.
void raise_fd_limit(size_t wanted) {
  rlimit r{};
  if (getrlimit(RLIMIT_NOFILE, &r) != 0 || r.rlim_cur >= wanted) return;
  r.rlim_cur = std::min<rlim_t>(r.rlim_max, wanted);
  setrlimit(RLIMIT_NOFILE, &r);
}

bool set_fifo(int priority) {
  sched_param p{};
  p.sched_priority = priority;
  return pthread_setschedparam(pthread_self(), priority > 0 ? SCHED_FIFO : SCHED_OTHER, &p) == 0;
}

struct Sub {
  int fd = -1;   // TCP session
  int ufd = -1;  // UDP socket (udp transport)
  PacketReader reader{kMaxPacketBytes, 8192};
  std::vector<uint32_t> last;  // by avatar id: last sequence seen
  SessionToken token;
  bool welcomed = false;
  uint64_t nonce = 0;
  bool registered = false;
};

struct Counts {
  uint64_t frames = 0, bytes = 0, lost = 0;
};

// A pose frame (either kind): its sequence against the last one of its avatar.
void count_frame(Sub& s, std::span<const uint8_t> p, Counts& c) {
  const bool lean = p[2] == uint8_t(MsgType::pose_delta);
  if (!lean && p[2] != uint8_t(MsgType::pose)) return;
  const uint16_t a = pose_avatar(p);
  const uint32_t seq = lean ? lean_pose_sequence(p) : pose_sequence(p);
  if (a < s.last.size()) {
    if (s.last[a] != 0 && seq > s.last[a] + 1) c.lost += seq - s.last[a] - 1;
    s.last[a] = std::max(s.last[a], seq);
  }
  c.frames++;
  c.bytes += p.size();
}

void drain_tcp(Sub& s, Counts& c) {
  for (;;) {
    auto space = s.reader.write_space(16384);
    const ssize_t got = ::recv(s.fd, space.data(), space.size(), MSG_DONTWAIT);
    if (got <= 0) return;
    s.reader.commit(size_t(got));
    for (;;) {
      std::span<const uint8_t> p;
      if (s.reader.next(p) != Reject::ok || p.empty()) break;
      if (p[2] == uint8_t(MsgType::welcome)) {
        Welcome w;
        if (decode_welcome(p, w) == Reject::ok) {
          s.token = w.session_token;
          s.welcomed = true;
        }
        continue;
      }
      count_frame(s, p, c);
    }
    if (size_t(got) < space.size()) return;
  }
}

void drain_udp(Sub& s, Counts& c) {
  std::array<uint8_t, kMaxDatagramBytes> buf;
  for (;;) {
    const ssize_t got = ::recv(s.ufd, buf.data(), buf.size(), MSG_DONTWAIT);
    if (got <= 0) return;
    const std::span<const uint8_t> d(buf.data(), size_t(got));
    Header h;
    if (decode_header(d, h) != Reject::ok) continue;
    if (h.type == MsgType::udp_register) {
      UdpRegister r;
      if (decode_udp_register(d, r) != Reject::ok || !(r.token == s.token)) continue;
      if (r.nonce != 0 && r.nonce == s.nonce) {
        s.registered = true;
      } else {
        s.nonce = r.nonce;  // a challenge: echo it
        std::array<uint8_t, kUdpRegisterBytes> out{};
        ::send(s.ufd, out.data(), encode_udp_register({s.token, s.nonce}, out), MSG_DONTWAIT);
      }
      continue;
    }
    // Lean frames of several avatars share a datagram, back to back.
    for (size_t at = 0; at < d.size();) {
      const auto rest = d.subspan(at);
      Header ph;
      if (decode_header(rest, ph) != Reject::ok || rest.size() < kHeaderBytes + ph.payload_bytes) break;
      count_frame(s, rest.first(kHeaderBytes + ph.payload_bytes), c);
      at += kHeaderBytes + ph.payload_bytes;
    }
  }
}

}  // namespace

const char* fanout_transport_name(FanoutTransport t) { return t == FanoutTransport::udp ? "udp" : "tcp"; }

Result<FanoutCapacity> measure_fanout_capacity(const FanoutOptions& o) {
  if (o.subscribers < 1 || o.avatars < 1 || o.rate_hz <= 0 || o.seconds <= 0)
    return fail(Errc::invalid_argument, "fan-out: subscribers, avatars, rate and seconds must be positive");
  const bool udp = o.transport == FanoutTransport::udp;
  raise_fd_limit(size_t(o.subscribers) * (udp ? 3 : 2) + 256);

  ServerOptions opt;
  opt.max_sessions = size_t(o.subscribers) + 16;
  opt.max_sessions_per_address = opt.max_sessions;  // every subscriber is on this host
  opt.max_packets_per_s = 1e9;
  opt.udp = udp;
  opt.udp_registration_timeout_s = 3600;  // the bench's subscribers register once
  opt.idle_timeout_s = 0;
  auto server = Server::create(opt);
  if (!server) return tl::unexpected(server.error());
  Server& srv = **server;
  if (udp && !srv.udp()) return fail(Errc::io_error, "fan-out: the server could not bind its UDP socket");

  auto skeleton = avatar::Skeleton::build(avatar::default_skeleton_desc());
  if (!skeleton) return tl::unexpected(skeleton.error());
  auto walk = avatar::make_builtin_motion("walk", *skeleton);
  if (!walk) return tl::unexpected(walk.error());
  const uint16_t dofs = uint16_t(skeleton->dof_count());
  std::vector<uint16_t> ids;
  for (int a = 0; a < o.avatars; ++a) {
    auto id = srv.add_avatar("walker" + std::to_string(a), dofs, std::string(4000, 'b'));
    if (!id) return tl::unexpected(id.error());
    ids.push_back(*id);
  }

  std::vector<Sub> subs(static_cast<size_t>(o.subscribers));
  Hello hello;
  hello.name = "bench";
  hello.capabilities = kCapPose | (o.lean ? uint32_t(kCapLeanPose) : 0u) | (udp ? uint32_t(kCapUdpPose) : 0u);
  std::vector<uint8_t> hello_bytes(kMaxHelloBytes);
  hello_bytes.resize(encode_hello(hello, hello_bytes));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(srv.port());
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  auto close_all = [&] {
    for (auto& t : subs) {
      if (t.fd >= 0) ::close(t.fd);
      if (t.ufd >= 0) ::close(t.ufd);
      t.fd = t.ufd = -1;
    }
  };
  for (size_t i = 0; i < subs.size(); ++i) {
    auto& s = subs[i];
    s.fd = ::socket(AF_INET, SOCK_STREAM, 0);
    if (s.fd < 0 || ::connect(s.fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      close_all();
      return fail(Errc::io_error, "subscriber " + std::to_string(i) + " could not connect (file descriptors?)");
    }
    ::send(s.fd, hello_bytes.data(), hello_bytes.size(), MSG_NOSIGNAL);
    s.last.assign(ids.back() + 1u, 0);
    if (i % 64 == 0) srv.poll();  // keep the accept queue short
  }
  const auto join_deadline = Clock::now() + std::chrono::seconds(60);
  while (srv.stats().subscribers < uint64_t(o.subscribers) && Clock::now() < join_deadline)
    srv.run_until(Clock::now() + std::chrono::milliseconds(5));
  if (srv.stats().subscribers < uint64_t(o.subscribers)) {
    close_all();
    return fail(Errc::timeout, "fan-out: not every subscriber joined");
  }
  Counts setup;  // frames sent on joining are not part of the measurement
  if (udp) {
    // Each subscriber registers its own UDP socket: token, then the echoed nonce.
    for (auto& s : subs) {
      const auto until = Clock::now() + std::chrono::seconds(5);
      while (!s.welcomed && Clock::now() < until) {
        srv.poll();
        drain_tcp(s, setup);
      }
      if (!s.welcomed) {
        close_all();
        return fail(Errc::timeout, "fan-out: no WELCOME");
      }
      s.ufd = ::socket(AF_INET, SOCK_DGRAM, 0);
      if (s.ufd < 0 || ::connect(s.ufd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
        close_all();
        return fail(Errc::io_error, "fan-out: UDP socket (file descriptors?)");
      }
      std::array<uint8_t, kUdpRegisterBytes> out{};
      ::send(s.ufd, out.data(), encode_udp_register({s.token, 0}, out), MSG_DONTWAIT);
    }
    // A burst of registrations overflows the server's socket buffer: whoever has no answer
    // yet sends again every 100 ms, as clients do every 250 ms.
    const auto reg_deadline = Clock::now() + std::chrono::seconds(60);
    auto resend_at = Clock::now() + std::chrono::milliseconds(100);
    while (srv.stats().udp_registered < uint64_t(o.subscribers) && Clock::now() < reg_deadline) {
      srv.run_until(Clock::now() + std::chrono::milliseconds(2));
      const bool resend = Clock::now() >= resend_at;
      if (resend) resend_at = Clock::now() + std::chrono::milliseconds(100);
      for (auto& s : subs) {
        if (s.registered) continue;
        drain_udp(s, setup);
        if (resend && !s.registered) {
          std::array<uint8_t, kUdpRegisterBytes> out{};
          ::send(s.ufd, out.data(), encode_udp_register({s.token, s.nonce}, out), MSG_DONTWAIT);
        }
      }
    }
    if (srv.stats().udp_registered < uint64_t(o.subscribers)) {
      close_all();
      return fail(Errc::timeout, "fan-out: not every subscriber registered its UDP address");
    }
  }
  srv.run_until(Clock::now() + std::chrono::milliseconds(200));  // models delivered

  const int ep = ::epoll_create1(0);
  for (size_t i = 0; i < subs.size(); ++i) {
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.u64 = i * 2;
    ::epoll_ctl(ep, EPOLL_CTL_ADD, subs[i].fd, &ev);
    if (udp) {
      ev.data.u64 = i * 2 + 1;
      ::epoll_ctl(ep, EPOLL_CTL_ADD, subs[i].ufd, &ev);
    }
  }
  // Frames before the first tick (the latest pose sent on joining) reset the counts.
  std::atomic<bool> counting{false}, stop{false};
  std::atomic<uint64_t> frames{0}, bytes{0}, lost{0};
  std::thread reader([&] {
    if (o.realtime_priority > 0) set_fifo(o.realtime_priority);
    std::vector<epoll_event> events(512);
    Counts c;
    bool was_counting = false;
    while (!stop) {
      const int n = ::epoll_wait(ep, events.data(), int(events.size()), 20);
      if (!was_counting && counting) {
        c = {};
        was_counting = true;
      }
      for (int e = 0; e < n; ++e) {
        const uint64_t tag = events[size_t(e)].data.u64;
        Sub& s = subs[tag / 2];
        if (tag % 2) drain_udp(s, c);
        else drain_tcp(s, c);
      }
      frames = c.frames;
      bytes = c.bytes;
      lost = c.lost;
    }
  });

  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / o.rate_hz));
  const int ticks = std::max(1, int(o.seconds * o.rate_hz));
  std::vector<double> tick_us;
  tick_us.reserve(size_t(ticks));
  std::vector<uint8_t> packet(pose_packet_bytes(dofs));
  avatar::Pose pose = skeleton->zero_pose();
  // The avatars have no frame yet: sequences start at 1 with the first tick.
  srv.run_until(Clock::now() + std::chrono::milliseconds(100));
  counting = true;
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  uint64_t late = 0;
  const bool realtime = o.realtime_priority > 0 && set_fifo(o.realtime_priority);
  const uint64_t dropped_before = srv.stats().frames_dropped;
  const double cpu0 = thread_cpu_s(), pcpu0 = process_cpu_s();
  const auto start = Clock::now();
  for (int k = 1; k <= ticks; ++k) {
    const auto due = start + period * (k - 1);
    srv.run_until(due);
    const auto t0 = Clock::now();
    if (t0 - due > period) late++;
    srv.begin_batch();
    for (int a = 0; a < o.avatars; ++a) {
      (*walk)->sample(double(k) / o.rate_hz + 0.37 * a, pose);
      encode_pose({ids[size_t(a)], 0, uint32_t(k), wall_clock_us()}, pose, packet);
      srv.publish_pose(ids[size_t(a)], packet);
    }
    srv.end_batch();
    tick_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  const double elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
  const double cpu_s = thread_cpu_s() - cpu0, pcpu_s = process_cpu_s() - pcpu0;
  if (realtime) set_fifo(0);
  const uint64_t expected = uint64_t(o.subscribers) * uint64_t(o.avatars) * uint64_t(ticks);
  const auto drain_deadline = Clock::now() + std::chrono::seconds(5);
  while (frames < expected && Clock::now() < drain_deadline) srv.run_until(Clock::now() + std::chrono::milliseconds(5));
  srv.run_until(Clock::now() + std::chrono::milliseconds(50));
  stop = true;
  reader.join();
  ::close(ep);
  close_all();

  FanoutCapacity cap;
  cap.options = o;
  cap.realtime = realtime;
  cap.streams = uint64_t(o.subscribers) * uint64_t(o.avatars);
  FanoutResult& r = cap.result;
  r.subscribers = o.subscribers;
  r.avatars = o.avatars;
  r.rate_hz = o.rate_hz;
  r.seconds = double(ticks) / o.rate_hz;
  r.frames_expected = expected;
  r.frames_received = frames;
  r.frames_dropped = srv.stats().frames_dropped - dropped_before;
  r.lost = lost;
  r.tick_p50_us = percentile(tick_us, 0.50);
  r.tick_p99_us = percentile(tick_us, 0.99);
  r.late_ticks = late;
  r.achieved_rate_hz = double(ticks) / std::max(elapsed_s, 1e-9);
  // Lost frames are the ones a subscriber never saw (a sequence gap); frames the server had to
  // drop for a slow subscriber show there too.
  r.kept_up = r.frames_received >= expected && r.lost == 0 && r.frames_dropped == 0 &&
              r.achieved_rate_hz >= 0.99 * o.rate_hz;
  cap.bytes_per_avatar_frame = frames ? double(bytes) / double(frames) : 0;
  cap.cpu_percent = 100.0 * cpu_s / std::max(elapsed_s, 1e-9);
  cap.cpu_us_per_tick = 1e6 * cpu_s / double(ticks);
  cap.process_cpu_percent = 100.0 * pcpu_s / std::max(elapsed_s, 1e-9);
  double load[1] = {0};
  if (getloadavg(load, 1) == 1) cap.load_average_1m = load[0];
  return cap;
}

}  // namespace mimic::net
