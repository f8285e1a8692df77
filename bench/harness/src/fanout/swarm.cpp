#include "fanout/swarm.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <pthread.h>
#include <sched.h>
#include <sys/epoll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdlib>

#include "mimic/core/thread_priority.h"
#include "mimic/core/percentile.h"
#include "mimic/net/frame_codec.h"
#include "mimic/net/pose_stream.h"

namespace mimic::bench::fanout {

using namespace mimic::net;  // the harness drives the product's servers and clients

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

ServerOptions server_options(const FanoutOptions& o, bool udp) {
  ServerOptions opt;
  opt.max_sessions = size_t(o.subscribers) + 16;
  opt.max_sessions_per_address = opt.max_sessions;  // every subscriber is on this host
  opt.max_packets_per_s = 1e9;
  opt.udp = udp;
  opt.udp_registration_timeout_s = 3600;  // the bench's subscribers register once
  opt.idle_timeout_s = 0;
  opt.fanout_threads = o.sender_threads;
  return opt;
}

struct Swarm::Sub {
  int fd = -1;   // TCP session
  int ufd = -1;  // UDP socket (udp transport)
  PacketReader reader{kMaxPacketBytes, 8192};
  std::vector<uint32_t> last;  // by avatar id: last sequence seen
  SessionToken token;
  bool welcomed = false;
  uint64_t nonce = 0;
  bool registered = false;
};

struct Swarm::Receiver {
  int ep = -1;
  size_t begin = 0, end = 0;  // its subscribers
  std::thread thread;
  std::atomic<uint64_t> frames{0}, bytes{0}, lost{0};
};

namespace {

using Sub = Swarm::Sub;

struct Counts {
  uint64_t frames = 0, bytes = 0, lost = 0;
};

// A pose frame (either kind): its sequence against the last one of its avatar.
void count_frame(Sub& s, std::span<const uint8_t> p, Counts& c) {
  const bool lean = p[2] == uint8_t(MsgType::pose_delta);
  if (!lean && p[2] != uint8_t(MsgType::pose)) return;
  const uint16_t a = pose_avatar(p);
  const uint32_t seq = lean ? lean_pose_sequence(p) : pose_sequence(p);
  if (a >= s.last.size()) s.last.resize(a + 1u, 0);
  if (s.last[a] != 0 && seq > s.last[a] + 1) c.lost += seq - s.last[a] - 1;
  s.last[a] = std::max(s.last[a], seq);
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

// Datagrams in batches: one recvmmsg takes what a tick brought (a lean subscriber gets one
// datagram per tick) and tells, by coming back short, that nothing is left.
struct UdpInbox {
  static constexpr size_t kBatch = 8;
  std::array<std::array<uint8_t, kMaxDatagramBytes>, kBatch> buf{};
  std::array<iovec, kBatch> iov{};
  std::array<mmsghdr, kBatch> msgs{};
};

void handle_datagram(Sub& s, std::span<const uint8_t> d, Counts& c) {
  Header h;
  if (decode_header(d, h) != Reject::ok) return;
  if (h.type == MsgType::udp_register) {
    UdpRegister r;
    if (decode_udp_register(d, r) != Reject::ok || !(r.token == s.token)) return;
    if (r.nonce != 0 && r.nonce == s.nonce) {
      s.registered = true;
    } else {
      s.nonce = r.nonce;  // a challenge: echo it
      std::array<uint8_t, kUdpRegisterBytes> out{};
      ::send(s.ufd, out.data(), encode_udp_register({s.token, s.nonce}, out), MSG_DONTWAIT);
    }
    return;
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

void drain_udp(Sub& s, Counts& c, UdpInbox& in) {
  for (;;) {
    for (size_t i = 0; i < UdpInbox::kBatch; ++i) {
      in.iov[i] = {in.buf[i].data(), in.buf[i].size()};
      in.msgs[i] = {};
      in.msgs[i].msg_hdr.msg_iov = &in.iov[i];
      in.msgs[i].msg_hdr.msg_iovlen = 1;
    }
    const int got = ::recvmmsg(s.ufd, in.msgs.data(), unsigned(UdpInbox::kBatch), MSG_DONTWAIT, nullptr);
    if (got <= 0) return;
    for (int i = 0; i < got; ++i) handle_datagram(s, {in.buf[size_t(i)].data(), in.msgs[size_t(i)].msg_len}, c);
    if (size_t(got) < UdpInbox::kBatch) return;
  }
}

}  // namespace

Swarm::Swarm() = default;

Swarm::~Swarm() {
  stop();
  for (auto& s : subs_) {
    if (s.fd >= 0) ::close(s.fd);
    if (s.ufd >= 0) ::close(s.ufd);
  }
}

Status Swarm::join(const FanoutOptions& o, uint16_t port, bool udp, const ServerAccess& server) {
  subs_.resize(static_cast<size_t>(o.subscribers));
  Hello hello;
  hello.name = "bench";
  hello.capabilities = kCapPose | (o.lean ? uint32_t(kCapLeanPose) : 0u) | (udp ? uint32_t(kCapUdpPose) : 0u);
  std::vector<uint8_t> hello_bytes(kMaxHelloBytes);
  hello_bytes.resize(encode_hello(hello, hello_bytes));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  for (size_t i = 0; i < subs_.size(); ++i) {
    auto& s = subs_[i];
    s.fd = ::socket(AF_INET, SOCK_STREAM, 0);
    if (s.fd < 0 || ::connect(s.fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0)
      return fail(Errc::io_error, "subscriber " + std::to_string(i) + " could not connect (file descriptors?)");
    ::send(s.fd, hello_bytes.data(), hello_bytes.size(), MSG_NOSIGNAL);
    if (i % 64 == 0) server.wait(Clock::duration::zero());  // keep the accept queue short
  }
  const auto join_deadline = Clock::now() + std::chrono::seconds(60);
  while (server.stats().subscribers < uint64_t(o.subscribers) && Clock::now() < join_deadline)
    server.wait(std::chrono::milliseconds(5));
  if (server.stats().subscribers < uint64_t(o.subscribers))
    return fail(Errc::timeout, "fan-out: not every subscriber joined");
  Counts setup;  // frames sent on joining are not part of the measurement
  auto inbox = std::make_unique<UdpInbox>();
  if (udp) {
    // Each subscriber registers its own UDP socket: token, then the echoed nonce.
    for (auto& s : subs_) {
      const auto until = Clock::now() + std::chrono::seconds(5);
      while (!s.welcomed && Clock::now() < until) {
        server.wait(Clock::duration::zero());
        drain_tcp(s, setup);
      }
      if (!s.welcomed) return fail(Errc::timeout, "fan-out: no WELCOME");
      s.ufd = ::socket(AF_INET, SOCK_DGRAM, 0);
      if (s.ufd < 0 || ::connect(s.ufd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0)
        return fail(Errc::io_error, "fan-out: UDP socket (file descriptors?)");
      std::array<uint8_t, kUdpRegisterBytes> out{};
      ::send(s.ufd, out.data(), encode_udp_register({s.token, 0}, out), MSG_DONTWAIT);
    }
    // A burst of registrations overflows the server's socket buffer: whoever has no answer
    // yet sends again every 100 ms, as clients do every 250 ms.
    const auto reg_deadline = Clock::now() + std::chrono::seconds(60);
    auto resend_at = Clock::now() + std::chrono::milliseconds(100);
    while (server.stats().udp_registered < uint64_t(o.subscribers) && Clock::now() < reg_deadline) {
      server.wait(std::chrono::milliseconds(2));
      const bool resend = Clock::now() >= resend_at;
      if (resend) resend_at = Clock::now() + std::chrono::milliseconds(100);
      for (auto& s : subs_) {
        if (s.registered) continue;
        drain_udp(s, setup, *inbox);
        if (resend && !s.registered) {
          std::array<uint8_t, kUdpRegisterBytes> out{};
          ::send(s.ufd, out.data(), encode_udp_register({s.token, s.nonce}, out), MSG_DONTWAIT);
        }
      }
    }
    if (server.stats().udp_registered < uint64_t(o.subscribers))
      return fail(Errc::timeout, "fan-out: not every subscriber registered its UDP address");
  }
  server.wait(std::chrono::milliseconds(200));  // models delivered
  return {};
}

void Swarm::start_receiving(const FanoutOptions& o) {
  const size_t n = size_t(std::clamp(o.receiver_threads, 1, std::max(1, int(subs_.size()))));
  for (size_t r = 0; r < n; ++r) {
    auto rx = std::make_unique<Receiver>();
    rx->ep = ::epoll_create1(0);
    rx->begin = subs_.size() * r / n;
    rx->end = subs_.size() * (r + 1) / n;
    for (size_t i = rx->begin; i < rx->end; ++i) {
      epoll_event ev{};
      ev.events = EPOLLIN;
      ev.data.u64 = i * 2;
      ::epoll_ctl(rx->ep, EPOLL_CTL_ADD, subs_[i].fd, &ev);
      if (subs_[i].ufd >= 0) {
        ev.data.u64 = i * 2 + 1;
        ::epoll_ctl(rx->ep, EPOLL_CTL_ADD, subs_[i].ufd, &ev);
      }
    }
    receivers_.push_back(std::move(rx));
  }
  for (auto& rx : receivers_)
    rx->thread = std::thread([this, r = rx.get(), p = o.realtime_priority] { receive(*r, p); });
}

// Below the server's priority: the receivers stand for viewers on other hosts, so they read
// between ticks instead of taking a core from a tick.
void Swarm::receive(Receiver& rx, int realtime_priority) {
  if (realtime_priority > 0) set_thread_fifo(std::max(1, realtime_priority - 1));
  std::vector<epoll_event> events(512);
  auto in = std::make_unique<UdpInbox>();
  Counts c;
  bool was_counting = false;
  while (!stop_) {
    const int n = ::epoll_wait(rx.ep, events.data(), int(events.size()), 20);
    if (!was_counting && counting_) {
      c = {};
      was_counting = true;
    }
    for (int e = 0; e < n; ++e) {
      const uint64_t tag = events[size_t(e)].data.u64;
      Sub& s = subs_[tag / 2];
      if (tag % 2)
        drain_udp(s, c, *in);
      else
        drain_tcp(s, c);
    }
    rx.frames = c.frames;
    rx.bytes = c.bytes;
    rx.lost = c.lost;
  }
}

void Swarm::start_counting() { counting_ = true; }

void Swarm::stop() {
  stop_ = true;
  for (auto& rx : receivers_) {
    if (rx->thread.joinable()) rx->thread.join();
    if (rx->ep >= 0) ::close(rx->ep);
    rx->ep = -1;
  }
}

double Swarm::receivers_cpu_s() const {
  double t = 0;
  for (const auto& rx : receivers_) {
    clockid_t id{};
    timespec ts{};
    if (!rx->thread.joinable()) continue;
    if (pthread_getcpuclockid(const_cast<std::thread&>(rx->thread).native_handle(), &id) == 0 &&
        clock_gettime(id, &ts) == 0)
      t += double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
  }
  return t;
}

uint64_t Swarm::frames() const {
  uint64_t n = 0;
  for (const auto& rx : receivers_) n += rx->frames;
  return n;
}
uint64_t Swarm::bytes() const {
  uint64_t n = 0;
  for (const auto& rx : receivers_) n += rx->bytes;
  return n;
}
uint64_t Swarm::lost() const {
  uint64_t n = 0;
  for (const auto& rx : receivers_) n += rx->lost;
  return n;
}

Result<Walkers> Walkers::make() {
  auto skeleton = rig::Skeleton::build(rig::default_skeleton_desc());
  if (!skeleton) return tl::unexpected(skeleton.error());
  auto walk = rig::make_builtin_motion("walk", *skeleton);
  if (!walk) return tl::unexpected(walk.error());
  Walkers w;
  w.skeleton_ = std::move(*skeleton);
  w.walk_ = std::move(*walk);
  w.pose_ = w.skeleton_.zero_pose();
  w.packet_.resize(pose_packet_bytes(w.dof_count()));
  return w;
}

std::span<const uint8_t> Walkers::frame(int avatar, int tick, double rate_hz, uint16_t id) {
  walk_->sample(double(tick) / rate_hz + 0.37 * avatar, pose_);
  encode_pose({id, 0, uint32_t(tick), wall_clock_us()}, pose_, packet_);
  return packet_;
}

FanoutCapacity capacity_row(const FanoutOptions& o, const Swarm& swarm, const Measured& m) {
  FanoutCapacity cap;
  cap.options = o;
  cap.realtime = m.realtime;
  cap.sender_threads = m.sender_threads;
  cap.receiver_threads = swarm.receiver_threads();
  cap.streams = uint64_t(o.subscribers) * uint64_t(o.avatars);
  FanoutResult& r = cap.result;
  r.subscribers = o.subscribers;
  r.avatars = o.avatars;
  r.rate_hz = o.rate_hz;
  r.seconds = double(m.ticks) / o.rate_hz;
  r.frames_expected = cap.streams * uint64_t(m.ticks);
  r.frames_received = m.frames_received >= 0 ? uint64_t(m.frames_received) : swarm.frames();
  r.frames_dropped = m.dropped;
  r.lost = m.lost >= 0 ? uint64_t(m.lost) : swarm.lost();
  std::vector<double> tick_us = m.tick_us;
  r.tick_p50_us = percentile_in_place(tick_us, 0.50);
  r.tick_p99_us = percentile_in_place(tick_us, 0.99);
  r.late_ticks = m.late_ticks;
  r.achieved_rate_hz = double(m.ticks) / std::max(m.elapsed_s, 1e-9);
  // Lost frames are the ones a subscriber never saw (a sequence gap); frames the server had to
  // drop for a slow subscriber show there too.
  r.kept_up = r.frames_received >= r.frames_expected && r.lost == 0 && r.frames_dropped == 0 &&
              r.achieved_rate_hz >= 0.99 * o.rate_hz;
  cap.bytes_per_avatar_frame = r.frames_received ? double(swarm.bytes()) / double(r.frames_received) : 0;
  const double elapsed = std::max(m.elapsed_s, 1e-9);
  cap.cpu_percent = 100.0 * m.server_cpu_s / elapsed;
  cap.cpu_us_per_tick = 1e6 * m.server_cpu_s / double(m.ticks);
  cap.receiver_cpu_us_per_tick = 1e6 * m.receivers_cpu_s / double(m.ticks);
  cap.process_cpu_percent = 100.0 * m.process_cpu_s / elapsed;
  double load[1] = {0};
  if (getloadavg(load, 1) == 1) cap.load_average_1m = load[0];
  return cap;
}

}  // namespace mimic::bench::fanout
