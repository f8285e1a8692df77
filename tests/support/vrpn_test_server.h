// A minimal VRPN server for tests, written from VRPN's published protocol description
// (Format_Of_Protocol.txt: the cookie, 24-byte big-endian headers, payloads padded to 8 bytes,
// sender/type/UDP descriptions) and independent of Mimic's own server: it numbers its senders and
// types differently (senders from 3, types from 5), as any other VRPN server may, so a client
// must map them by name. Serves both ways VRPN clients connect (tcp:// and the UDP call-back
// request), answers pings, and sends vrpn_Tracker Pos_Quat reports and vrpn_Button Change
// messages — by UDP to a client that described its UDP port, on TCP otherwise. Runs on its own
// thread; the test calls send_* from its thread.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <bit>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "vrpn_test_client.h"  // be32, put32

namespace mimic::test::vrpn {

class Server {
 public:
  // Binds TCP and UDP on 127.0.0.1:`port` (0: a free one); `devices` are its tracker/button names.
  explicit Server(std::vector<std::string> devices, uint16_t port = 0) : devices_(std::move(devices)) {
    tcp_ = ::socket(AF_INET, SOCK_STREAM, 0);
    const int one = 1;
    ::setsockopt(tcp_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in a = loopback(port);
    ok_ = ::bind(tcp_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 && ::listen(tcp_, 8) == 0;
    socklen_t len = sizeof a;
    ::getsockname(tcp_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    udp_ = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in u = loopback(port_);
    ok_ = ok_ && ::bind(udp_, reinterpret_cast<sockaddr*>(&u), sizeof u) == 0;
    thread_ = std::thread([this] { run(); });
  }
  ~Server() {
    stop_ = true;
    thread_.join();
    for (auto& c : clients_) ::close(c.fd);
    ::close(tcp_);
    ::close(udp_);
  }
  bool ok() const { return ok_; }
  uint16_t port() const { return port_; }
  int handshakes() const { return handshakes_; }
  int pings() const { return pings_; }

  void send_pos_quat(const std::string& device, int32_t sensor, const double pos[3], const double quat_xyzw[4],
                     uint32_t seconds, uint32_t microseconds) {
    std::vector<uint8_t> p;
    put32(p, uint32_t(sensor));
    put32(p, 0);
    for (int i = 0; i < 3; ++i) put_f64(p, pos[i]);
    for (int i = 0; i < 4; ++i) put_f64(p, quat_xyzw[i]);
    send_all(sender_id(device), kPosQuat, p, seconds, microseconds);
  }
  void send_button(const std::string& device, int32_t button, bool pressed) {
    std::vector<uint8_t> p;
    put32(p, uint32_t(button));
    put32(p, pressed ? 1 : 0);
    send_all(sender_id(device), kButtonChange, p, 0, 0);
  }

 private:
  static constexpr int32_t kFirstSender = 3, kPosQuat = 5, kButtonChange = 6, kPing = 7, kPong = 8;
  struct Conn {
    int fd = -1;
    bool cookie = false;
    std::vector<uint8_t> in;
    sockaddr_in udp_to{};
    bool udp = false;
    std::vector<std::pair<int32_t, std::string>> their_types;
  };

  static sockaddr_in loopback(uint16_t port) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(port);
    return a;
  }
  static void put_f64(std::vector<uint8_t>& out, double v) {
    const uint64_t b = std::bit_cast<uint64_t>(v);
    put32(out, uint32_t(b >> 32));
    put32(out, uint32_t(b));
  }
  static void message(std::vector<uint8_t>& out, int32_t sender, int32_t type, const std::vector<uint8_t>& payload,
                      uint32_t s = 0, uint32_t us = 0) {
    put32(out, uint32_t(24 + payload.size()));
    put32(out, s);
    put32(out, us);
    put32(out, uint32_t(sender));
    put32(out, uint32_t(type));
    put32(out, 0);
    out.insert(out.end(), payload.begin(), payload.end());
    while (out.size() % 8) out.push_back(0);
  }
  static void description(std::vector<uint8_t>& out, int32_t id, int32_t kind, const std::string& name) {
    std::vector<uint8_t> p;
    put32(p, uint32_t(name.size() + 1));
    p.resize(4 + name.size() + 1, 0);
    std::memcpy(p.data() + 4, name.data(), name.size());
    message(out, id, kind, p);
  }
  int32_t sender_id(const std::string& device) const {
    for (size_t i = 0; i < devices_.size(); ++i)
      if (devices_[i] == device) return kFirstSender + int32_t(i);
    return -100;
  }

  void send_all(int32_t sender, int32_t type, const std::vector<uint8_t>& payload, uint32_t s, uint32_t us) {
    std::vector<uint8_t> m;
    message(m, sender, type, payload, s, us);
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto& c : clients_) {
      if (!c.cookie) continue;
      if (c.udp)
        ::sendto(udp_, m.data(), m.size(), 0, reinterpret_cast<sockaddr*>(&c.udp_to), sizeof c.udp_to);
      else
        (void)!::send(c.fd, m.data(), m.size(), MSG_NOSIGNAL);
    }
  }

  void greet(Conn& c) {
    std::vector<uint8_t> out(24, 0);
    std::memcpy(out.data(), "vrpn: ver. 07.35  0", 19);
    ::send(c.fd, out.data(), out.size(), MSG_NOSIGNAL);
  }

  void describe(Conn& c) {
    std::vector<uint8_t> out;
    for (size_t i = 0; i < devices_.size(); ++i) description(out, kFirstSender + int32_t(i), -1, devices_[i]);
    description(out, kPosQuat, -2, "vrpn_Tracker Pos_Quat");
    description(out, kButtonChange, -2, "vrpn_Button Change");
    description(out, kPing, -2, "vrpn_Base ping_message");
    description(out, kPong, -2, "vrpn_Base pong_message");
    ::send(c.fd, out.data(), out.size(), MSG_NOSIGNAL);
  }

  void read(Conn& c) {
    uint8_t buf[4096];
    const ssize_t n = ::recv(c.fd, buf, sizeof buf, MSG_DONTWAIT);
    if (n <= 0) {
      if (n == 0) {
        ::close(c.fd);
        c.fd = -1;
      }
      return;
    }
    c.in.insert(c.in.end(), buf, buf + n);
    if (!c.cookie) {
      if (c.in.size() < 24) return;
      if (std::memcmp(c.in.data(), "vrpn: ver. 07.", 14) != 0) {
        ::close(c.fd);
        c.fd = -1;
        return;
      }
      c.in.erase(c.in.begin(), c.in.begin() + 24);
      describe(c);
      c.cookie = true;
      ++handshakes_;
    }
    while (c.in.size() >= 24) {
      const uint32_t len = be32(c.in.data());
      const size_t wire = 24 + ((len - 24 + 7) & ~size_t(7));
      if (len < 24 || c.in.size() < wire) break;
      const int32_t sender = int32_t(be32(c.in.data() + 12)), type = int32_t(be32(c.in.data() + 16));
      const uint8_t* payload = c.in.data() + 24;
      if (type == -3 && sender > 0) {
        c.udp_to = loopback(uint16_t(sender));
        ::inet_pton(AF_INET, reinterpret_cast<const char*>(payload), &c.udp_to.sin_addr);
        c.udp = true;
      } else if (type == -2 && len - 24 > 4) {
        c.their_types.emplace_back(sender, std::string(reinterpret_cast<const char*>(payload + 4)));
      } else if (type >= 0) {
        for (const auto& [id, name] : c.their_types)
          if (id == type && name == "vrpn_Base ping_message") {
            ++pings_;
            std::vector<uint8_t> out;
            message(out, kFirstSender, kPong, {});
            ::send(c.fd, out.data(), out.size(), MSG_NOSIGNAL);
          }
      }
      c.in.erase(c.in.begin(), c.in.begin() + long(wire));
    }
  }

  void run() {
    while (!stop_) {
      std::vector<pollfd> fds = {{tcp_, POLLIN, 0}, {udp_, POLLIN, 0}};
      {
        std::lock_guard<std::mutex> lock(mutex_);
        for (auto& c : clients_) fds.push_back({c.fd, POLLIN, 0});
      }
      if (::poll(fds.data(), fds.size(), 5) <= 0) continue;
      std::lock_guard<std::mutex> lock(mutex_);
      if (fds[0].revents) {
        Conn c;
        c.fd = ::accept(tcp_, nullptr, nullptr);
        if (c.fd >= 0) greet(clients_.emplace_back(std::move(c)));
      }
      if (fds[1].revents) {  // a call-back request: "<address> <port>"
        char msg[200] = {};
        sockaddr_in from{};
        socklen_t len = sizeof from;
        if (::recvfrom(udp_, msg, sizeof msg - 1, 0, reinterpret_cast<sockaddr*>(&from), &len) > 0) {
          const char* space = std::strchr(msg, ' ');
          if (space) {
            Conn c;
            c.fd = ::socket(AF_INET, SOCK_STREAM, 0);
            sockaddr_in to = from;
            to.sin_port = htons(uint16_t(std::atoi(space + 1)));
            if (::connect(c.fd, reinterpret_cast<sockaddr*>(&to), sizeof to) == 0)
              greet(clients_.emplace_back(std::move(c)));
            else
              ::close(c.fd);
          }
        }
      }
      for (auto& c : clients_) read(c);
      std::erase_if(clients_, [](const Conn& c) { return c.fd < 0; });
    }
  }

  std::vector<std::string> devices_;
  int tcp_ = -1, udp_ = -1;
  uint16_t port_ = 0;
  bool ok_ = false;
  std::atomic<bool> stop_{false};
  std::atomic<int> handshakes_{0}, pings_{0};
  std::mutex mutex_;
  std::vector<Conn> clients_;
  std::thread thread_;
};

}  // namespace mimic::test::vrpn
