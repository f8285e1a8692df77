// One UDP datagram with a forged source address and port, written through a raw IP socket, as an
// attacker on the path (or on the host, with CAP_NET_RAW) would send it. Tests that need it skip
// when the system refuses the raw socket (not root), saying so.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/ip.h>
#include <netinet/udp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

namespace mimic::test {

class ForgedUdp {
 public:
  ForgedUdp() : fd_(::socket(AF_INET, SOCK_RAW, IPPROTO_RAW)) {}
  ~ForgedUdp() {
    if (fd_ >= 0) ::close(fd_);
  }
  ForgedUdp(const ForgedUdp&) = delete;
  ForgedUdp& operator=(const ForgedUdp&) = delete;
  bool ok() const { return fd_ >= 0; }

  // `from` and `to` as "a.b.c.d"; the kernel fills in the IP checksum and length (IP_HDRINCL),
  // the UDP checksum is left 0 (allowed over IPv4).
  bool send(const char* from, uint16_t from_port, const char* to, uint16_t to_port, std::span<const uint8_t> payload) {
    std::vector<uint8_t> packet(sizeof(iphdr) + sizeof(udphdr) + payload.size());
    iphdr ip{};
    ip.version = 4;
    ip.ihl = 5;
    ip.ttl = 64;
    ip.protocol = IPPROTO_UDP;
    ip.tot_len = htons(static_cast<uint16_t>(packet.size()));
    ::inet_pton(AF_INET, from, &ip.saddr);
    ::inet_pton(AF_INET, to, &ip.daddr);
    udphdr udp{};
    udp.source = htons(from_port);
    udp.dest = htons(to_port);
    udp.len = htons(static_cast<uint16_t>(sizeof(udphdr) + payload.size()));
    std::memcpy(packet.data(), &ip, sizeof ip);
    std::memcpy(packet.data() + sizeof ip, &udp, sizeof udp);
    std::memcpy(packet.data() + sizeof ip + sizeof udp, payload.data(), payload.size());
    sockaddr_in dst{};
    dst.sin_family = AF_INET;
    dst.sin_addr.s_addr = ip.daddr;
    return ::sendto(fd_, packet.data(), packet.size(), 0, reinterpret_cast<const sockaddr*>(&dst), sizeof dst) ==
           static_cast<ssize_t>(packet.size());
  }

 private:
  int fd_ = -1;
};

}  // namespace mimic::test
