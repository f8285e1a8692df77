#include "mimic/net/vrpn_client.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>

#include "mimic/core/host_port.h"
#include "mimic/net/vrpn_wire.h"

namespace mimic::net {

namespace {

constexpr size_t kMaxRemoteIds = 512;      // ids a server may describe; VRPN's own tables hold 2,000
constexpr size_t kMaxPayload = 64 * 1024;  // larger messages break the connection, as the server does
constexpr size_t kReportsPerDatagram = vrpn::kUdpDatagramBytes / vrpn::message_bytes(vrpn::kPosQuatBytes) + 1;
constexpr double kPingEvery_s = 1.0;  // vrpn_BaseClass's rate
constexpr double kLobEvery_s = 1.0;   // how often a call-back request is repeated

// Our senders: the button device first (if any), then the trackers; one message type, ping.
enum Local : int32_t { kPingType = 0 };
enum class Remote : int8_t { none, pos_quat, button_change, pong };
constexpr int16_t kNotOurs = -1, kButtons = -2;  // remote sender → tracker index, or these

void close_fd(int& fd) {
  if (fd >= 0) ::close(fd);
  fd = -1;
}

bool set_nonblocking(int fd) {
  const int flags = ::fcntl(fd, F_GETFL, 0);
  return flags >= 0 && ::fcntl(fd, F_SETFL, flags | O_NONBLOCK) == 0;
}

int socket_of(int type) {
  const int fd = ::socket(AF_INET, type | SOCK_CLOEXEC, 0);
  if (fd >= 0 && !set_nonblocking(fd)) {
    ::close(fd);
    return -1;
  }
  return fd;
}

uint16_t port_of(int fd) {
  sockaddr_in a{};
  socklen_t n = sizeof a;
  return ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n) == 0 ? ntohs(a.sin_port) : 0;
}

double unix_now_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace

std::string VrpnAddress::text() const {
  return device + "@" + (tcp_only ? "tcp://" : "") + host + ":" + std::to_string(port);
}

Result<VrpnAddress> parse_vrpn_address(std::string_view text) {
  const size_t at = text.find('@');
  if (at == std::string_view::npos || at == 0 || at + 1 == text.size())
    return fail(Errc::invalid_argument,
                "expected DEVICE@HOST[:PORT] or DEVICE@tcp://HOST[:PORT], got '" + std::string(text) + "'");
  VrpnAddress a;
  a.device = std::string(text.substr(0, at));
  if (a.device.size() + 1 > vrpn::kMaxNameBytes)
    return fail(Errc::invalid_argument, "VRPN device name longer than 99 bytes in '" + std::string(text) + "'");
  std::string_view where = text.substr(at + 1);
  if (where.rfind("tcp://", 0) == 0) {
    a.tcp_only = true;
    where.remove_prefix(6);
  }
  if (where.empty()) return fail(Errc::invalid_argument, "no host in '" + std::string(text) + "'");
  if (where.find(':') == std::string_view::npos || where.front() == '[') {
    a.host = std::string(where);
  } else {
    auto hp = split_host_port(where);
    if (!hp) return fail(Errc::invalid_argument, hp.error().message);
    a.host = hp->host;
    a.port = hp->port;
    if (a.port == 0) return fail(Errc::invalid_argument, "VRPN port 0 in '" + std::string(text) + "'");
  }
  return a;
}

const char* vrpn_link_name(VrpnLink link) {
  switch (link) {
    case VrpnLink::waiting: return "waiting";
    case VrpnLink::connecting: return "connecting";
    case VrpnLink::handshaking: return "handshaking";
    case VrpnLink::connected: return "connected";
  }
  return "?";
}

struct VrpnTrackerRemote::Impl {
  Options options;
  std::shared_ptr<const Clock> clock;
  sockaddr_in server{};  // TCP port = UDP port: VRPN serves both on one number
  VrpnLink link = VrpnLink::waiting;
  VrpnClientStats stats;
  std::string last_error;
  int listen_fd = -1, tcp_fd = -1, udp_fd = -1;
  double next_attempt_s = 0, last_lob_s = -1e9, last_ping_s = 0, last_heard_s = 0;
  std::array<int16_t, kMaxRemoteIds> remote_sender{};
  std::array<Remote, kMaxRemoteIds> remote_type{};
  std::array<uint8_t, vrpn::kHeaderBytes + kMaxPayload + 8> rx{};
  size_t rx_fill = 0;
  std::array<uint8_t, 16384> tx{};  // descriptions of up to 66 devices, then pings
  size_t tx_fill = 0;
  std::array<uint8_t, 2048> datagram{};
  char error_text[160] = {};

  double now() const { return clock->now_s(); }

  void drop(const char* why) {
    // The reason is kept in a fixed buffer first: a failure inside poll() must not allocate on
    // every retry; the string is only rebuilt when the reason changes.
    if (std::strncmp(error_text, why, sizeof error_text) != 0) {
      std::snprintf(error_text, sizeof error_text, "%s", why);
      last_error = error_text;
    }
    if (link == VrpnLink::connected || link == VrpnLink::handshaking) ++stats.drops;
    close_fd(listen_fd);
    close_fd(tcp_fd);
    close_fd(udp_fd);
    link = VrpnLink::waiting;
    next_attempt_s = now() + options.retry_after_s;
  }

  void drop_errno(const char* what) {
    char text[160];
    std::snprintf(text, sizeof text, "%s: %s", what, std::strerror(errno));
    drop(text);
  }

  // The local address the server is reached from, for the call-back request and the UDP
  // description.
  bool local_address(in_addr& out) {
    const int probe = socket_of(SOCK_DGRAM);
    if (probe < 0) return false;
    sockaddr_in a{};
    socklen_t n = sizeof a;
    const bool ok = ::connect(probe, reinterpret_cast<const sockaddr*>(&server), sizeof server) == 0 &&
                    ::getsockname(probe, reinterpret_cast<sockaddr*>(&a), &n) == 0;
    ::close(probe);
    out = a.sin_addr;
    return ok;
  }

  bool bind_local(int fd, in_addr addr) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr = addr;
    return ::bind(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a) == 0;
  }

  void start_attempt() {
    in_addr local{};
    if (!local_address(local)) return drop_errno("no route to the VRPN server");
    rx_fill = tx_fill = 0;
    remote_sender.fill(kNotOurs);
    remote_type.fill(Remote::none);
    if (!options.tracker.tcp_only) {
      udp_fd = socket_of(SOCK_DGRAM);
      if (udp_fd < 0 || !bind_local(udp_fd, local)) return drop_errno("cannot open the UDP socket");
      listen_fd = socket_of(SOCK_STREAM);
      if (listen_fd < 0 || !bind_local(listen_fd, local) || ::listen(listen_fd, 1) != 0)
        return drop_errno("cannot listen for the server's call-back");
      last_lob_s = -1e9;
      link = VrpnLink::connecting;
      return;
    }
    tcp_fd = socket_of(SOCK_STREAM);
    if (tcp_fd < 0) return drop_errno("cannot open a TCP socket");
    if (::connect(tcp_fd, reinterpret_cast<const sockaddr*>(&server), sizeof server) != 0 && errno != EINPROGRESS)
      return drop_errno("cannot connect to the VRPN server");
    link = VrpnLink::connecting;
  }

  // Lob mode: repeat the call-back request until the server connects to our listening port.
  void await_call_back() {
    if (now() - last_lob_s >= kLobEvery_s) {
      in_addr local{};
      if (!local_address(local)) return drop_errno("no route to the VRPN server");
      char ip[INET_ADDRSTRLEN] = {};
      ::inet_ntop(AF_INET, &local, ip, sizeof ip);
      char msg[64];
      const int n = std::snprintf(msg, sizeof msg, "%s %u", ip, unsigned(port_of(listen_fd)));
      // Lost or refused datagrams are retried at the next second, as VRPN's clients do.
      (void)::sendto(udp_fd, msg, size_t(n) + 1, MSG_NOSIGNAL, reinterpret_cast<const sockaddr*>(&server),
                     sizeof server);
      last_lob_s = now();
    }
    sockaddr_in peer{};
    socklen_t len = sizeof peer;
    const int fd = ::accept4(listen_fd, reinterpret_cast<sockaddr*>(&peer), &len, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;
    if (peer.sin_addr.s_addr != server.sin_addr.s_addr) {  // only the server we asked may call back
      ::close(fd);
      ++stats.malformed;
      return;
    }
    close_fd(listen_fd);
    tcp_fd = fd;
    begin_handshake();
  }

  void await_connect() {
    pollfd p{tcp_fd, POLLOUT, 0};
    if (::poll(&p, 1, 0) <= 0) return;
    int err = 0;
    socklen_t n = sizeof err;
    ::getsockopt(tcp_fd, SOL_SOCKET, SO_ERROR, &err, &n);
    if (err != 0) {
      errno = err;
      return drop_errno("cannot connect to the VRPN server");
    }
    begin_handshake();
  }

  void begin_handshake() {
    const int one = 1;
    ::setsockopt(tcp_fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    vrpn::write_cookie(std::span<uint8_t, vrpn::kCookieBytes>(tx.data(), vrpn::kCookieBytes));
    tx_fill = vrpn::kCookieBytes;
    link = VrpnLink::handshaking;
    last_heard_s = now();
  }

  bool queue(int32_t sender, int32_t type, std::span<const uint8_t> payload) {
    const size_t n = vrpn::write_message(std::span<uint8_t>(tx.data() + tx_fill, tx.size() - tx_fill),
                                         vrpn::timestamp_from_seconds(unix_now_s()), sender, type, 0, payload);
    tx_fill += n;
    return n > 0;
  }

  bool queue_description(int32_t id, int32_t kind, std::string_view name) {
    std::array<uint8_t, 4 + vrpn::kMaxNameBytes> payload{};
    const size_t n = vrpn::write_description(payload, name);
    return n > 0 && queue(id, kind, std::span<const uint8_t>(payload.data(), n));
  }

  // After the server's cookie: our UDP port (unless tcp://), then our senders and types.
  void finish_handshake() {
    bool ok = true;
    if (!options.tracker.tcp_only) {
      sockaddr_in a{};
      socklen_t n = sizeof a;
      ::getsockname(tcp_fd, reinterpret_cast<sockaddr*>(&a), &n);
      char ip[INET_ADDRSTRLEN] = {};
      ::inet_ntop(AF_INET, &a.sin_addr, ip, sizeof ip);
      ok &= queue(int32_t(port_of(udp_fd)), vrpn::kUdpDescription,
                  std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(ip), std::strlen(ip) + 1));
    }
    int32_t id = 0;
    ok &= queue_description(id++, vrpn::kSenderDescription, options.tracker.device);
    for (const std::string& name : options.more_trackers) ok &= queue_description(id++, vrpn::kSenderDescription, name);
    if (!options.button_device.empty()) ok &= queue_description(id++, vrpn::kSenderDescription, options.button_device);
    ok &= queue_description(kPingType, vrpn::kTypeDescription, "vrpn_Base ping_message");
    if (!ok) return drop("VRPN descriptions do not fit the send buffer");
    link = VrpnLink::connected;
    ++stats.connects;
    last_ping_s = now();
  }

  bool flush() {
    size_t sent = 0;
    while (sent < tx_fill) {
      const ssize_t n = ::send(tcp_fd, tx.data() + sent, tx_fill - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
      if (n <= 0) {
        drop_errno("the VRPN server's connection broke");
        return false;
      }
      sent += size_t(n);
    }
    std::memmove(tx.data(), tx.data() + sent, tx_fill - sent);
    tx_fill -= sent;
    return true;
  }

  void describe(const vrpn::Message& m) {
    if (m.sender < 0 || size_t(m.sender) >= kMaxRemoteIds) return;
    const std::string_view name = vrpn::description_name(m.payload);
    if (m.type == vrpn::kSenderDescription) {
      int16_t ours = kNotOurs;
      if (name == options.tracker.device) ours = 0;
      for (size_t i = 0; i < options.more_trackers.size(); ++i)
        if (name == options.more_trackers[i]) ours = int16_t(i + 1);
      if (!options.button_device.empty() && name == options.button_device) ours = kButtons;
      remote_sender[size_t(m.sender)] = ours;
    } else {
      remote_type[size_t(m.sender)] = name == "vrpn_Tracker Pos_Quat"    ? Remote::pos_quat
                                      : name == "vrpn_Button Change"     ? Remote::button_change
                                      : name == "vrpn_Base pong_message" ? Remote::pong
                                                                         : Remote::none;
    }
  }

  struct Out {
    std::span<VrpnReport> reports;
    size_t report_count = 0;
    std::span<VrpnButtonEvent> buttons;
    size_t button_count = 0;
    bool room() const { return reports.size() - report_count >= kReportsPerDatagram; }
  };

  void handle(const vrpn::Message& m, Out& out) {
    last_heard_s = now();
    if (m.type == vrpn::kSenderDescription || m.type == vrpn::kTypeDescription) return describe(m);
    if (m.type < 0 || size_t(m.type) >= kMaxRemoteIds || m.sender < 0 || size_t(m.sender) >= kMaxRemoteIds) return;
    const Remote type = remote_type[size_t(m.type)];
    const int16_t sender = remote_sender[size_t(m.sender)];
    if (type == Remote::pong) {
      ++stats.pongs;
    } else if (type == Remote::pos_quat && sender >= 0 && out.report_count < out.reports.size()) {
      VrpnReport& r = out.reports[out.report_count];
      r.device = sender;
      double p[3], q[4];
      if (!vrpn::read_pos_quat(m.payload, r.sensor, p, q)) {
        ++stats.malformed;
        return;
      }
      r.position = {p[0], p[1], p[2]};
      r.orientation = glm::dquat(q[3], q[0], q[1], q[2]);
      r.capture_unix_s = double(m.time.seconds) + 1e-6 * double(m.time.microseconds);
      r.received_s = last_heard_s;
      ++out.report_count;
      ++stats.reports;
    } else if (type == Remote::button_change && sender == kButtons && m.payload.size() == 8 &&
               out.button_count < out.buttons.size()) {
      out.buttons[out.button_count++] = {int32_t(vrpn::load_be32(m.payload.data())),
                                         vrpn::load_be32(m.payload.data() + 4) != 0, last_heard_s};
      ++stats.buttons;
    }
  }

  void read_tcp(Out& out) {
    while (out.room()) {
      vrpn::Message m;
      const auto parse = vrpn::parse_message(std::span<const uint8_t>(rx.data(), rx_fill), kMaxPayload, m);
      if (parse == vrpn::Parse::bad) return drop("a VRPN message with a bad length on TCP");
      if (parse == vrpn::Parse::ok) {
        handle(m, out);
        if (link != VrpnLink::connected) return;
        std::memmove(rx.data(), rx.data() + m.wire_bytes, rx_fill - m.wire_bytes);
        rx_fill -= m.wire_bytes;
        continue;
      }
      const ssize_t n = ::recv(tcp_fd, rx.data() + rx_fill, rx.size() - rx_fill, MSG_DONTWAIT);
      if (n == 0) return drop("the VRPN server closed the connection");
      if (n < 0) {
        if (errno != EAGAIN && errno != EWOULDBLOCK) drop_errno("the VRPN server's connection broke");
        return;
      }
      rx_fill += size_t(n);
    }
  }

  void read_udp(Out& out) {
    while (udp_fd >= 0 && out.room()) {
      sockaddr_in from{};
      socklen_t len = sizeof from;
      const ssize_t n =
          ::recvfrom(udp_fd, datagram.data(), datagram.size(), MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&from), &len);
      if (n < 0) return;
      if (from.sin_addr.s_addr != server.sin_addr.s_addr) {  // only the server's reports count
        ++stats.malformed;
        continue;
      }
      ++stats.udp_datagrams;
      std::span<const uint8_t> rest(datagram.data(), size_t(n));
      vrpn::Message m;
      while (!rest.empty()) {
        if (vrpn::parse_message(rest, vrpn::kUdpDatagramBytes, m) != vrpn::Parse::ok) {
          ++stats.malformed;
          break;
        }
        handle(m, out);
        rest = rest.subspan(m.wire_bytes);
      }
    }
  }

  void read_cookie() {
    while (rx_fill < vrpn::kCookieBytes) {
      const ssize_t n = ::recv(tcp_fd, rx.data() + rx_fill, vrpn::kCookieBytes - rx_fill, MSG_DONTWAIT);
      if (n == 0) return drop("the VRPN server closed the connection during the handshake");
      if (n < 0) {
        if (errno != EAGAIN && errno != EWOULDBLOCK) drop_errno("the VRPN handshake failed");
        return;
      }
      rx_fill += size_t(n);
    }
    if (!vrpn::cookie_ok(std::span<const uint8_t, vrpn::kCookieBytes>(rx.data(), vrpn::kCookieBytes)))
      return drop("not a VRPN 07 server (its cookie does not match)");
    rx_fill = 0;
    finish_handshake();
  }

  void keep_alive() {
    if (now() - last_ping_s >= kPingEvery_s) {
      if (queue(0, kPingType, {})) last_ping_s = now();  // from the tracker, as vrpn_Tracker_Remote pings
    }
  }
};

VrpnTrackerRemote::VrpnTrackerRemote(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

VrpnTrackerRemote::~VrpnTrackerRemote() {
  close_fd(impl_->listen_fd);
  close_fd(impl_->tcp_fd);
  close_fd(impl_->udp_fd);
}

Result<std::unique_ptr<VrpnTrackerRemote>> VrpnTrackerRemote::create(const Options& options,
                                                                     std::shared_ptr<const Clock> clock) {
  if (options.tracker.device.empty()) return fail(Errc::invalid_argument, "VRPN: no device name");
  if (options.button_device.size() + 1 > vrpn::kMaxNameBytes)
    return fail(Errc::invalid_argument, "VRPN: button device name longer than 99 bytes");
  if (options.more_trackers.size() > 64) return fail(Errc::invalid_argument, "VRPN: more than 65 tracker devices");
  for (const std::string& name : options.more_trackers)
    if (name.empty() || name.size() + 1 > vrpn::kMaxNameBytes)
      return fail(Errc::invalid_argument, "VRPN: a tracker device name must be 1-99 bytes");
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  const std::string port = std::to_string(options.tracker.port);
  if (const int rc = ::getaddrinfo(options.tracker.host.c_str(), port.c_str(), &hints, &found); rc != 0 || !found)
    return fail(Errc::not_found, "VRPN server " + options.tracker.host + ": " + ::gai_strerror(rc));
  auto impl = std::make_unique<Impl>();
  std::memcpy(&impl->server, found->ai_addr, sizeof impl->server);
  ::freeaddrinfo(found);
  impl->options = options;
  impl->clock = clock ? std::move(clock) : std::make_shared<SteadyClock>();
  impl->last_error.reserve(sizeof impl->error_text);
  return std::unique_ptr<VrpnTrackerRemote>(new VrpnTrackerRemote(std::move(impl)));
}

size_t VrpnTrackerRemote::poll(std::span<VrpnReport> reports, std::span<VrpnButtonEvent> buttons,
                               size_t& button_count) {
  Impl& d = *impl_;
  Impl::Out out{reports, 0, buttons, 0};
  switch (d.link) {
    case VrpnLink::waiting:
      if (d.now() >= d.next_attempt_s) d.start_attempt();
      break;
    case VrpnLink::connecting:
      if (d.options.tracker.tcp_only)
        d.await_connect();
      else
        d.await_call_back();
      break;
    case VrpnLink::handshaking:
      if (d.flush()) d.read_cookie();
      break;
    case VrpnLink::connected:
      d.keep_alive();
      if (!d.flush()) break;
      // TCP first: the descriptions that name the UDP reports' ids come on it.
      d.read_tcp(out);
      if (d.link == VrpnLink::connected) d.read_udp(out);
      if (d.link == VrpnLink::connected && d.now() - d.last_heard_s > d.options.silent_after_s)
        d.drop("the VRPN server went silent");
      break;
  }
  if (d.link == VrpnLink::handshaking && d.now() - d.last_heard_s > d.options.silent_after_s)
    d.drop("the VRPN server did not answer the handshake");
  button_count = out.button_count;
  return out.report_count;
}

VrpnLink VrpnTrackerRemote::link() const { return impl_->link; }
const VrpnClientStats& VrpnTrackerRemote::stats() const { return impl_->stats; }
const std::string& VrpnTrackerRemote::last_error() const { return impl_->last_error; }
const VrpnTrackerRemote::Options& VrpnTrackerRemote::options() const { return impl_->options; }
double VrpnTrackerRemote::last_heard_s() const { return impl_->last_heard_s; }

}  // namespace mimic::net
