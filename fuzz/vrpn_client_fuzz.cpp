// libFuzzer entry point for the VRPN tracker remote (net/vrpn_client.h) against a hostile server:
// a loopback listener accepts the remote's tcp:// connection and writes the input as the server's
// side of the stream — a cookie (the first input byte picks a valid one, one with another
// version, or none: the input is the cookie), then descriptions, reports, pongs, bad lengths,
// anything — and closes. The remote is polled until it has consumed everything or dropped the
// server. Invariants: no sanitizer report; a report handed out has finite numbers; the remote
// never counts more reports than the bytes could hold.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include "mimic/net/vrpn_client.h"

namespace {

using namespace mimic::net;

int listener(uint16_t& port) {
  static int fd = -1;
  static uint16_t bound = 0;
  if (fd < 0) {
    fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd, 4) != 0) std::abort();
    socklen_t n = sizeof a;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n);
    bound = ntohs(a.sin_port);
  }
  port = bound;
  return fd;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  uint16_t port = 0;
  const int lfd = listener(port);
  VrpnTrackerRemote::Options o;
  o.tracker = *parse_vrpn_address("Tracker0@tcp://127.0.0.1:" + std::to_string(port));
  o.button_device = "Buttons0";
  o.silent_after_s = 0.05;
  o.retry_after_s = 3600;  // one connection per input
  auto remote = VrpnTrackerRemote::create(o);
  if (!remote) std::abort();
  std::array<VrpnReport, 32> reports;
  std::array<VrpnButtonEvent, 4> buttons;
  size_t nb = 0;
  (*remote)->poll(reports, buttons, nb);  // starts connecting
  const int server = ::accept(lfd, nullptr, nullptr);
  if (server < 0) std::abort();
  const uint8_t mode = data[0] % 3;
  if (mode != 2) {
    char cookie[24] = {};
    std::memcpy(cookie, mode == 0 ? "vrpn: ver. 07.35  0" : "vrpn: ver. 08.01  0", 19);
    (void)!::send(server, cookie, sizeof cookie, MSG_NOSIGNAL);
  }
  (void)!::send(server, data + 1, size - 1, MSG_NOSIGNAL);
  ::shutdown(server, SHUT_WR);
  uint64_t handed_out = 0;
  for (int k = 0; k < 400 && (*remote)->link() != VrpnLink::waiting; ++k) {
    const size_t n = (*remote)->poll(reports, buttons, nb);
    for (size_t i = 0; i < n; ++i) {
      const auto& r = reports[i];
      if (!std::isfinite(r.position.x) || !std::isfinite(r.orientation.w)) std::abort();
    }
    handed_out += n;
    if (n == 0) ::usleep(100);
  }
  if (handed_out > size / 88 + 1) std::abort();  // a report is 88 bytes on the wire
  ::close(server);
  return 0;
}
