// A raw TCP peer on loopback for tests that speak (or abuse) a protocol byte by byte: the net
// tests' hostile peers and the CLI attack suite's.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <vector>

namespace mimic::net::test {

using Bytes = std::vector<uint8_t>;
using Clock = std::chrono::steady_clock;

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
  bool send(const void* p, size_t n) { return ::send(fd_, p, n, MSG_NOSIGNAL) == static_cast<ssize_t>(n); }
  // Bytes received within `timeout_s` (stops early at EOF: closed() turns true).
  Bytes read(double timeout_s, size_t want = 1) {
    Bytes out;
    const auto end =
        Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
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

}  // namespace mimic::net::test
