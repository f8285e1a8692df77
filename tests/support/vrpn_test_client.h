// A minimal VRPN client for tests, written from VRPN's documented wire format
// (Format_Of_Protocol.txt and vrpn_Connection.C's marshalling, version 07), independent of
// Mimic's server code: the 24-byte cookie, messages with a 24-byte big-endian header (length
// = 24 + payload, seconds, microseconds, sender, type, a sequence word) and payloads padded to
// 8 bytes, sender/type descriptions (-1/-2), the UDP description (-3), and vrpn_Tracker
// Pos_Quat payloads (i32 sensor, i32 pad, 3 + 4 big-endian f64).
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <bit>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace mimic::test::vrpn {

struct Report {
  std::string device;  // sender name
  int32_t sensor = 0;
  double pos[3] = {};
  double quat[4] = {};  // x y z w
  uint32_t seconds = 0, microseconds = 0;
  bool udp = false;
};

inline uint32_t be32(const uint8_t* p) {
  return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | uint32_t(p[3]);
}
inline double be_f64(const uint8_t* p) { return std::bit_cast<double>(uint64_t(be32(p)) << 32 | be32(p + 4)); }
inline void put32(std::vector<uint8_t>& out, uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out.push_back(uint8_t(v >> s));
}

class Client {
 public:
  ~Client() {
    for (int fd : {tcp_, udp_, listen_})
      if (fd >= 0) ::close(fd);
  }

  // "Avatar0@tcp://host:port": we connect to the server's TCP port.
  bool connect_tcp(uint16_t port) {
    tcp_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a = loopback(port);
    return ::connect(tcp_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 && start();
  }

  // "Avatar0@host:port": we listen, send "<our address> <our TCP port>" to the server's UDP
  // port, and the server calls us back. `between` runs while we wait (e.g. the server's poll).
  bool connect_lob(uint16_t port, const std::function<void()>& between, const char* request = nullptr,
                   double timeout_s = 3.0) {
    listen_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a = loopback(0);
    socklen_t len = sizeof a;
    if (::bind(listen_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(listen_, 1) != 0) return false;
    ::getsockname(listen_, reinterpret_cast<sockaddr*>(&a), &len);
    const std::string msg = request ? std::string(request) : "127.0.0.1 " + std::to_string(ntohs(a.sin_port));
    const int lob = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in to = loopback(port);
    ::sendto(lob, msg.c_str(), msg.size() + 1, 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
    ::close(lob);
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < until) {
      if (between) between();
      pollfd p{listen_, POLLIN, 0};
      if (::poll(&p, 1, 5) > 0) {
        tcp_ = ::accept(listen_, nullptr, nullptr);
        return tcp_ >= 0 && start();
      }
    }
    return false;
  }

  // Our cookie, then descriptions of the devices we ask for and of the ping/pong types, and,
  // if `offer_udp`, our UDP port for the server's reports.
  void handshake(const std::vector<std::string>& devices, bool offer_udp, const char* cookie = "vrpn: ver. 07.35") {
    std::vector<uint8_t> out(24, 0);
    std::memcpy(out.data(), cookie, std::strlen(cookie));
    out[16] = ' ';
    out[17] = ' ';
    out[18] = '0';
    if (offer_udp) {
      udp_ = ::socket(AF_INET, SOCK_DGRAM, 0);
      sockaddr_in a = loopback(0);
      socklen_t len = sizeof a;
      ::bind(udp_, reinterpret_cast<sockaddr*>(&a), sizeof a);
      ::getsockname(udp_, reinterpret_cast<sockaddr*>(&a), &len);
      message(out, int32_t(ntohs(a.sin_port)), -3, "127.0.0.1", 10);
    }
    for (size_t i = 0; i < devices.size(); ++i) description(out, int32_t(i), -1, devices[i]);
    description(out, 0, -2, "vrpn_Base ping_message");
    description(out, 1, -2, "vrpn_Base pong_message");
    devices_ = devices;
    write(out);
  }

  void ping(int32_t our_device) {
    std::vector<uint8_t> out;
    message(out, our_device, 0, nullptr, 0);
    write(out);
  }

  // Reads TCP and UDP until done() or the timeout, running `between` in the gaps.
  void pump(const std::function<void()>& between, double timeout_s, const std::function<bool()>& done) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    uint8_t buf[65536];
    while (!done() && std::chrono::steady_clock::now() < until && !closed) {
      if (between) between();
      pollfd p[2] = {{tcp_, POLLIN, 0}, {udp_, POLLIN, 0}};
      if (::poll(p, udp_ >= 0 ? 2 : 1, 2) <= 0) continue;
      if (p[0].revents) {
        const ssize_t n = ::recv(tcp_, buf, sizeof buf, 0);
        if (n <= 0) {
          closed = true;
          break;
        }
        stream_.insert(stream_.end(), buf, buf + n);
        size_t used = 0;
        if (server_cookie.empty() && stream_.size() >= 24) {
          server_cookie.assign(reinterpret_cast<const char*>(stream_.data()), 24);
          used = 24;
        }
        if (!server_cookie.empty()) used += decode(stream_.data() + used, stream_.size() - used, false);
        stream_.erase(stream_.begin(), stream_.begin() + long(used));
      }
      if (udp_ >= 0 && p[1].revents) {
        const ssize_t n = ::recv(udp_, buf, sizeof buf, 0);
        if (n > 0) {
          ++datagrams;
          max_datagram = std::max(max_datagram, size_t(n));
          if (decode(buf, size_t(n), true) != size_t(n)) ++bad_datagrams;
        }
      }
    }
  }

  std::string server_cookie;
  std::map<int32_t, std::string> senders, types;  // the server's ids
  int server_udp_port = 0;
  std::string server_udp_host;
  std::vector<Report> reports;
  int pongs = 0;
  size_t datagrams = 0, max_datagram = 0, bad_datagrams = 0;
  bool closed = false;

 private:
  static sockaddr_in loopback(uint16_t port) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(port);
    return a;
  }
  bool start() { return tcp_ >= 0; }
  void write(const std::vector<uint8_t>& b) { (void)!::send(tcp_, b.data(), b.size(), MSG_NOSIGNAL); }
  static void message(std::vector<uint8_t>& out, int32_t sender, int32_t type, const void* payload, size_t n) {
    put32(out, uint32_t(24 + n));
    put32(out, 0);
    put32(out, 0);
    put32(out, uint32_t(sender));
    put32(out, uint32_t(type));
    put32(out, 0);
    const auto* p = static_cast<const uint8_t*>(payload);
    if (n) out.insert(out.end(), p, p + n);
    while (out.size() % 8) out.push_back(0);
  }
  static void description(std::vector<uint8_t>& out, int32_t id, int32_t kind, const std::string& name) {
    std::vector<uint8_t> p;
    put32(p, uint32_t(name.size() + 1));
    p.resize(4 + name.size() + 1, 0);
    std::memcpy(p.data() + 4, name.data(), name.size());
    message(out, id, kind, p.data(), p.size());
  }
  // Decodes whole messages; returns the bytes used.
  size_t decode(const uint8_t* d, size_t n, bool udp) {
    size_t at = 0;
    while (n - at >= 24) {
      const uint32_t len = be32(d + at);
      if (len < 24) {
        closed = true;
        return at;
      }
      const size_t payload = len - 24, wire = 24 + ((payload + 7) & ~size_t(7));
      if (n - at < wire) break;
      const uint8_t* h = d + at;
      const auto sender = int32_t(be32(h + 12)), type = int32_t(be32(h + 16));
      const uint8_t* p = h + 24;
      if (type == -1 || type == -2) {
        const uint32_t k = be32(p);
        (type == -1 ? senders : types)[sender] = std::string(reinterpret_cast<const char*>(p + 4), k ? k - 1 : 0);
      } else if (type == -3) {
        server_udp_port = sender;
        server_udp_host.assign(reinterpret_cast<const char*>(p), strnlen(reinterpret_cast<const char*>(p), payload));
      } else if (type >= 0 && types.count(type)) {
        if (types[type] == "vrpn_Tracker Pos_Quat" && payload == 64) {
          Report r;
          r.device = senders.count(sender) ? senders[sender] : "?";
          r.sensor = int32_t(be32(p));
          for (int i = 0; i < 3; ++i) r.pos[i] = be_f64(p + 8 + 8 * i);
          for (int i = 0; i < 4; ++i) r.quat[i] = be_f64(p + 32 + 8 * i);
          r.seconds = be32(h + 4);
          r.microseconds = be32(h + 8);
          r.udp = udp;
          reports.push_back(r);
        } else if (types[type] == "vrpn_Base pong_message") {
          ++pongs;
        }
      }
      at += wire;
    }
    return at;
  }

  int tcp_ = -1, udp_ = -1, listen_ = -1;
  std::vector<uint8_t> stream_;
  std::vector<std::string> devices_;
};

}  // namespace mimic::test::vrpn
