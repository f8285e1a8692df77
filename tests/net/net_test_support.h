// Loopback helpers for the net tests: a server on its own thread, raw TCP peers that speak
// (or abuse) the protocol byte by byte, and a pump that drives clients until a condition holds.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <future>
#include <memory>
#include <thread>
#include <vector>

#include "mimic/net/client.h"
#include "mimic/net/server.h"

namespace mimic::net::test {

using Bytes = std::vector<uint8_t>;
using Clock = std::chrono::steady_clock;

class ServerThread {
 public:
  explicit ServerThread(ServerOptions opt = {}) {
    auto s = Server::create(opt);
    if (!s) throw std::runtime_error(s.error().what());
    server_ = std::move(*s);
    thread_ = std::thread([this] { server_->run(); });
  }
  ~ServerThread() {
    server_->stop();
    thread_.join();
  }
  Server& server() { return *server_; }
  std::string endpoint() const { return "127.0.0.1:" + std::to_string(server_->port()); }
  uint16_t port() const { return server_->port(); }

  // Runs fn on the server thread and waits for its result.
  template <class F>
  auto call(F fn) {
    using R = decltype(fn());
    auto p = std::make_shared<std::promise<R>>();
    auto fut = p->get_future();
    server_->dispatch([p, fn] {
      if constexpr (std::is_void_v<R>) {
        fn();
        p->set_value();
      } else {
        p->set_value(fn());
      }
    });
    return fut.get();
  }
  ServerStats stats() {
    return call([this] { return server_->stats(); });
  }
  std::vector<SessionInfo> sessions() {
    return call([this] { return server_->sessions(); });
  }

 private:
  std::unique_ptr<Server> server_;
  std::thread thread_;
};

// Drives the clients until `done` or the timeout; true if `done` became true.
inline bool pump(std::vector<Client*> clients, const std::function<bool()>& done, double timeout_s = 5.0) {
  const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  while (Clock::now() < end) {
    for (Client* c : clients) (void)c->run_until(Clock::now() + std::chrono::microseconds(200));
    if (done()) return true;
  }
  return done();
}

inline void pump_for(std::vector<Client*> clients, double seconds) {
  pump(clients, [] { return false; }, seconds);
}

// A raw TCP peer on loopback.
class RawPeer {
 public:
  // `from`: the local address to connect from (any 127.x.y.z is this host too).
  explicit RawPeer(uint16_t port, int rcvbuf_bytes = 0, const char* from = nullptr) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    if (rcvbuf_bytes > 0) ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf_bytes, sizeof rcvbuf_bytes);
    if (from) {
      sockaddr_in l{};
      l.sin_family = AF_INET;
      ::inet_pton(AF_INET, from, &l.sin_addr);
      ::bind(fd_, reinterpret_cast<sockaddr*>(&l), sizeof l);
    }
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  }
  ~RawPeer() { ::close(fd_); }
  bool connected() const { return connected_; }

  bool send(const Bytes& b) { return send(b.data(), b.size()); }
  bool send(const void* p, size_t n) {
    return ::send(fd_, p, n, MSG_NOSIGNAL) == static_cast<ssize_t>(n);
  }
  // Bytes received within `timeout_s` (stops early at EOF: closed() turns true).
  Bytes read(double timeout_s, size_t want = 1) {
    Bytes out;
    const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
    while (Clock::now() < end && out.size() < want && !closed_) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 10) <= 0) continue;
      uint8_t buf[65536];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) {
        closed_ = true;
        break;
      }
      out.insert(out.end(), buf, buf + n);
    }
    return out;
  }
  // True if the server closed the connection within `timeout_s`.
  bool wait_closed(double timeout_s) {
    while (!closed_) {
      const Bytes b = read(timeout_s, SIZE_MAX);
      if (!closed_ && b.empty()) return false;
    }
    return true;
  }
  bool closed() const { return closed_; }
  // Everything that comes until nothing more does for `quiet_s` (a stalled peer reading at last).
  Bytes read_until_quiet(double quiet_s) {
    Bytes all;
    for (;;) {
      const Bytes b = read(quiet_s, 1 << 20);
      if (b.empty()) return all;
      all.insert(all.end(), b.begin(), b.end());
    }
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
  bool closed_ = false;
};

// A received byte stream into a reader, whose next() then gives its packets one by one.
inline void feed(PacketReader& r, const Bytes& bytes) {
  auto space = r.write_space(bytes.size());
  std::copy(bytes.begin(), bytes.end(), space.begin());
  r.commit(bytes.size());
}

inline Bytes hello_packet(Role role, const std::string& secret = "", uint8_t min_v = kMinProtocolVersion,
                          uint8_t max_v = kProtocolVersion) {
  Hello h;
  h.role = role;
  h.min_version = min_v;
  h.max_version = max_v;
  h.secret = secret;
  h.name = "raw";
  Bytes b(kMaxHelloBytes);
  b.resize(encode_hello(h, b));
  return b;
}

// Reads one whole packet from `peer` (empty if none came within `timeout_s`).
inline Bytes read_packet(RawPeer& peer, double timeout_s = 2.0) {
  Bytes got = peer.read(timeout_s, kHeaderBytes);
  Header h;
  if (got.size() < kHeaderBytes || decode_header(got, h) != Reject::ok) return {};
  if (got.size() < kHeaderBytes + h.payload_bytes) {
    const Bytes more = peer.read(timeout_s, kHeaderBytes + h.payload_bytes - got.size());
    got.insert(got.end(), more.begin(), more.end());
  }
  got.resize(std::min(got.size(), size_t(kHeaderBytes + h.payload_bytes)));
  return got;
}

inline Bytes model_packet(uint16_t slot, uint16_t dofs, size_t model_bytes) {
  AvatarModel m{slot, 0, dofs, "raw", std::string(model_bytes, 'm')};
  Bytes b(avatar_model_packet_bytes(m));
  encode_avatar_model(m, b);
  return b;
}

inline Bytes pose_packet(uint16_t slot, uint32_t seq, uint16_t dofs) {
  avatar::Pose p;
  p.dof_rad.assign(dofs, 0.25f);
  Bytes b(kMaxDatagramBytes);
  b.resize(encode_pose({slot, 0, seq, wall_clock_us()}, p, b));
  return b;
}

}  // namespace mimic::net::test
