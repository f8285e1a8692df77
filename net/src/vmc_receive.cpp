#include "mimic/net/vmc_receive.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstring>

#include "mimic/core/clock.h"
#include "mimic/core/host_port.h"

namespace mimic::net {

Result<std::unique_ptr<VmcReceiver>> VmcReceiver::open(const std::string& host_port) {
  std::string host = "127.0.0.1", port_text = host_port;
  if (host_port.find(':') != std::string::npos) {
    auto hp = split_host_port(host_port);
    if (!hp) return tl::unexpected(hp.error());
    host = hp->host == "localhost" ? "127.0.0.1" : hp->host;
    port_text = std::to_string(hp->port);
  }
  char* end = nullptr;
  const long port = std::strtol(port_text.c_str(), &end, 10);
  if (port_text.empty() || *end != '\0' || port < 0 || port > 65535)
    return fail(Errc::invalid_argument, "expected [HOST:]PORT, got '" + host_port + "'");
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  if (::inet_pton(AF_INET, host.c_str(), &a.sin_addr) != 1)
    return fail(Errc::invalid_argument, "bad IPv4 address '" + host + "' in '" + host_port + "'");
  std::unique_ptr<VmcReceiver> r(new VmcReceiver());
  r->fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (r->fd_ < 0 || ::bind(r->fd_, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0)
    return fail(Errc::io_error, "cannot listen for OSC on " + host + ":" + port_text + ": " + std::strerror(errno));
  // A burst of bundles (VMC sends 2-3 a frame) waits here until the loop's next read.
  const int rcvbuf = 1 << 20;
  ::setsockopt(r->fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
  return r;
}

VmcReceiver::~VmcReceiver() {
  if (fd_ >= 0) ::close(fd_);
}

size_t VmcReceiver::poll(size_t max_datagrams) {
  size_t n = 0;
  const double now = steady_now_s();
  for (; n < max_datagrams; ++n) {
    const ssize_t got = ::recv(fd_, buffer_.data(), buffer_.size(), MSG_DONTWAIT | MSG_TRUNC);
    if (got < 0) return n;
    if (size_t(got) > buffer_.size()) {
      stats_.datagrams++;
      stats_.oversized++;
      continue;
    }
    apply_vmc_packet(std::span<const uint8_t>(buffer_.data(), size_t(got)), now, state_, stats_);
  }
  stats_.budget_hit++;
  return n;
}

uint16_t VmcReceiver::port() const {
  sockaddr_in a{};
  socklen_t len = sizeof a;
  ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
  return ntohs(a.sin_port);
}

std::string VmcReceiver::endpoint() const {
  sockaddr_in a{};
  socklen_t len = sizeof a;
  ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
  char ip[INET_ADDRSTRLEN] = {};
  ::inet_ntop(AF_INET, &a.sin_addr, ip, sizeof ip);
  return std::string(ip) + ":" + std::to_string(ntohs(a.sin_port));
}

}  // namespace mimic::net
