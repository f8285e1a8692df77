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
#include "raw_peer.h"
#include "mimic/net/server.h"

namespace mimic::net::test {

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
  pump(
      clients, [] { return false; }, seconds);
}

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
  rig::Pose p;
  p.dof_rad.assign(dofs, 0.25f);
  Bytes b(kMaxDatagramBytes);
  b.resize(encode_pose({slot, 0, seq, wall_clock_us()}, p, b));
  return b;
}

}  // namespace mimic::net::test
