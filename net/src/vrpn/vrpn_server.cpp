#include "mimic/net/vrpn_server.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <vector>

#include "mimic/rig/transform.h"
#include "mimic/core/host_port.h"
#include "mimic/net/frame_codec.h"  // wall_clock_us
#include "mimic/net/vrpn_wire.h"

namespace mimic::net {

namespace {

constexpr int kMaxClients = 16;
constexpr size_t kInBytes = 64 * 1024;    // a client's unparsed input; longer messages close it
constexpr size_t kOutBytes = 512 * 1024;  // a client's unsent TCP bytes
constexpr size_t kMaxRemoteIds = 2000;    // VRPN's vrpn_CONNECTION_MAX_SENDERS and _TYPES
constexpr size_t kMaxSamplesPerAvatar = 64;
constexpr double kConnectTimeout_s = 5.0;

enum LocalType : int32_t { kPosQuat = 0, kPing = 1, kPong = 2, kTypeCount = 3 };
constexpr const char* kTypeNames[kTypeCount] = {"vrpn_Tracker Pos_Quat", "vrpn_Base ping_message",
                                                "vrpn_Base pong_message"};

double wall_s() { return double(wall_clock_us()) * 1e-6; }
double mono_s() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

bool set_nonblocking(int fd) {
  const int fl = ::fcntl(fd, F_GETFL, 0);
  return fl >= 0 && ::fcntl(fd, F_SETFL, fl | O_NONBLOCK) == 0;
}

// "<host> <port>" as VRPN's request: host of letters, digits and dots, port 1024-65535.
bool parse_lob(std::string_view msg, uint16_t& port) {
  const size_t sp = msg.find(' ');
  if (sp == 0 || sp == std::string_view::npos || sp > 199) return false;
  for (size_t i = 0; i < sp; ++i) {
    const char c = msg[i];
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '.')) return false;
  }
  long p = 0;
  size_t i = sp + 1, digits = 0;
  for (; i < msg.size() && msg[i] >= '0' && msg[i] <= '9' && digits < 6; ++i, ++digits) p = p * 10 + (msg[i] - '0');
  if (digits == 0 || p < 1024 || p > 65535) return false;
  port = static_cast<uint16_t>(p);
  return true;
}

}  // namespace

struct VrpnServer::Impl {
  struct Client {
    enum class State { free, connecting, cookie, connected };
    State state = State::free;
    int fd = -1;
    bool tcp_only = false;
    sockaddr_in peer{};
    uint16_t lob_port = 0;  // the client's TCP port it asked us to call (0: it connected to us)
    double since_s = 0;
    bool udp = false;
    sockaddr_in udp_to{};
    std::vector<uint8_t> in, out;
    size_t in_len = 0, out_begin = 0, out_end = 0;
    std::vector<int16_t> remote_sender;  // the client's sender id -> ours, -1 unknown
    std::vector<int8_t> remote_type;     // the client's type id -> ours, -1 unknown
    uint32_t tcp_seq = 0, udp_seq = 0;
  };
  struct Avatar {
    rig::Skeleton skeleton;
    std::vector<rig::RigidTransform> world_from_joint;
  };

  int tcp_listen = -1, udp_listen = -1, udp_data = -1;
  sockaddr_in bound{};
  uint16_t data_port = 0;
  std::vector<std::string> senders;  // Avatar<i> = 2i, Sensors<i> = 2i + 1
  std::vector<Avatar> avatars;
  std::array<Client, kMaxClients> clients;
  std::vector<uint8_t> frame;  // this frame's reports, sequence words patched per client
  size_t frame_len = 0;
  std::array<uint8_t, vrpn::kUdpDatagramBytes> datagram{};
  VrpnServerStats stats;

  ~Impl() {
    for (auto& c : clients)
      if (c.fd >= 0) ::close(c.fd);
    for (int fd : {tcp_listen, udp_listen, udp_data})
      if (fd >= 0) ::close(fd);
  }

  int connected_clients() const {
    int n = 0;
    for (const auto& c : clients) n += c.state == Client::State::connected;
    return n;
  }

  Client* free_slot() {
    for (auto& c : clients)
      if (c.state == Client::State::free) return &c;
    return nullptr;
  }

  void open_slot(Client& c, int fd, const sockaddr_in& peer, uint16_t lob_port, Client::State state) {
    c.state = state;
    c.fd = fd;
    c.tcp_only = lob_port == 0;
    c.peer = peer;
    c.lob_port = lob_port;
    c.since_s = mono_s();
    c.udp = false;
    c.in_len = c.out_begin = c.out_end = 0;
    std::fill(c.remote_sender.begin(), c.remote_sender.end(), int16_t(-1));
    std::fill(c.remote_type.begin(), c.remote_type.end(), int8_t(-1));
    c.tcp_seq = c.udp_seq = 0;
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    if (state == Client::State::cookie) queue_cookie(c);
  }

  void close_client(Client& c) {
    if (c.fd >= 0) ::close(c.fd);
    if (c.state == Client::State::connected) stats.clients--;
    c.fd = -1;
    c.state = Client::State::free;
  }

  bool queue(Client& c, std::span<const uint8_t> bytes) {
    if (c.out_begin > 0 && c.out_end + bytes.size() > c.out.size()) {
      std::memmove(c.out.data(), c.out.data() + c.out_begin, c.out_end - c.out_begin);
      c.out_end -= c.out_begin;
      c.out_begin = 0;
    }
    if (c.out_end + bytes.size() > c.out.size()) return false;
    std::memcpy(c.out.data() + c.out_end, bytes.data(), bytes.size());
    c.out_end += bytes.size();
    return true;
  }

  void queue_cookie(Client& c) {
    std::array<uint8_t, vrpn::kCookieBytes> cookie{};
    vrpn::write_cookie(cookie);
    queue(c, cookie);
  }

  // A system or control message on the client's TCP stream.
  bool queue_message(Client& c, int32_t sender, int32_t type, std::span<const uint8_t> payload) {
    std::array<uint8_t, vrpn::kHeaderBytes + 256> buf{};
    const size_t n =
        vrpn::write_message(buf, vrpn::timestamp_from_seconds(wall_s()), sender, type, c.tcp_seq++, payload);
    return n > 0 && queue(c, std::span<const uint8_t>(buf.data(), n));
  }

  // After the cookies: where our UDP port is (unless the client came over TCP only), then the
  // names of our senders and message types, which the client maps onto its own ids.
  bool handshake(Client& c) {
    if (!c.tcp_only) {
      sockaddr_in local{};
      socklen_t len = sizeof local;
      char ip[INET_ADDRSTRLEN] = "127.0.0.1";
      if (::getsockname(c.fd, reinterpret_cast<sockaddr*>(&local), &len) == 0)
        ::inet_ntop(AF_INET, &local.sin_addr, ip, sizeof ip);
      const size_t n = std::strlen(ip) + 1;
      if (!queue_message(c, data_port, vrpn::kUdpDescription,
                         std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(ip), n)))
        return false;
    }
    std::array<uint8_t, 4 + vrpn::kMaxNameBytes> payload{};
    for (size_t i = 0; i < senders.size(); ++i) {
      const size_t n = vrpn::write_description(payload, senders[i]);
      if (!queue_message(c, int32_t(i), vrpn::kSenderDescription, std::span<const uint8_t>(payload.data(), n)))
        return false;
    }
    for (int32_t t = 0; t < kTypeCount; ++t) {
      const size_t n = vrpn::write_description(payload, kTypeNames[t]);
      if (!queue_message(c, t, vrpn::kTypeDescription, std::span<const uint8_t>(payload.data(), n))) return false;
    }
    return true;
  }

  void handle(Client& c, const vrpn::Message& m) {
    switch (m.type) {
      case vrpn::kSenderDescription:
      case vrpn::kTypeDescription: {
        if (m.sender < 0 || size_t(m.sender) >= kMaxRemoteIds) return;
        const std::string_view name = vrpn::description_name(m.payload);
        if (m.type == vrpn::kSenderDescription) {
          int16_t ours = -1;
          for (size_t i = 0; i < senders.size(); ++i)
            if (senders[i] == name) ours = int16_t(i);
          c.remote_sender[size_t(m.sender)] = ours;
        } else {
          int8_t ours = -1;
          for (int8_t t = 0; t < kTypeCount; ++t)
            if (name == kTypeNames[t]) ours = t;
          c.remote_type[size_t(m.sender)] = ours;
        }
        return;
      }
      case vrpn::kUdpDescription: {
        // The sender field is the client's UDP port, the payload its address.
        if (m.sender <= 0 || m.sender > 65535) return;
        char ip[64] = {};
        std::memcpy(ip, m.payload.data(), std::min(m.payload.size(), sizeof ip - 1));
        sockaddr_in to{};
        to.sin_family = AF_INET;
        to.sin_port = htons(uint16_t(m.sender));
        if (::inet_pton(AF_INET, ip, &to.sin_addr) != 1 || to.sin_addr.s_addr == htonl(INADDR_ANY))
          to.sin_addr = c.peer.sin_addr;
        c.udp_to = to;
        c.udp = true;
        return;
      }
      default:
        if (m.type < 0 || size_t(m.type) >= kMaxRemoteIds || m.sender < 0 || size_t(m.sender) >= kMaxRemoteIds) return;
        if (c.remote_type[size_t(m.type)] == kPing && c.remote_sender[size_t(m.sender)] >= 0) {
          if (queue_message(c, c.remote_sender[size_t(m.sender)], kPong, {})) stats.pongs++;
        }
        return;
    }
  }

  void accept_lobs() {
    for (int k = 0; k < 16; ++k) {
      char msg[200];
      sockaddr_in from{};
      socklen_t len = sizeof from;
      const ssize_t n =
          ::recvfrom(udp_listen, msg, sizeof msg - 1, MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&from), &len);
      if (n < 0) return;
      stats.lob_requests++;
      uint16_t port = 0;
      if (!parse_lob(std::string_view(msg, strnlen(msg, size_t(n))), port)) {
        stats.refused++;
        continue;
      }
      // Clients repeat the request until called back: one connection per (address, port).
      bool known = false;
      for (const auto& c : clients)
        known = known || (c.state != Client::State::free && c.lob_port == port &&
                          c.peer.sin_addr.s_addr == from.sin_addr.s_addr);
      if (known) continue;
      Client* c = free_slot();
      const int fd = c ? ::socket(AF_INET, SOCK_STREAM, 0) : -1;
      if (fd < 0 || !set_nonblocking(fd)) {
        if (fd >= 0) ::close(fd);
        stats.refused++;
        continue;
      }
      // Only the address the request came from is called back: the server cannot be told to
      // open connections to a third party.
      sockaddr_in to = from;
      to.sin_port = htons(port);
      if (::connect(fd, reinterpret_cast<const sockaddr*>(&to), sizeof to) != 0 && errno != EINPROGRESS) {
        ::close(fd);
        stats.refused++;
        continue;
      }
      open_slot(*c, fd, to, port, Client::State::connecting);
    }
  }

  void accept_tcp() {
    for (int k = 0; k < 16; ++k) {
      sockaddr_in from{};
      socklen_t len = sizeof from;
      const int fd = ::accept(tcp_listen, reinterpret_cast<sockaddr*>(&from), &len);
      if (fd < 0) return;
      Client* c = free_slot();
      if (!c || !set_nonblocking(fd)) {
        ::close(fd);
        stats.refused++;
        continue;
      }
      open_slot(*c, fd, from, 0, Client::State::cookie);
    }
  }

  void service(Client& c) {
    if (c.state == Client::State::connecting) {
      pollfd p{c.fd, POLLOUT, 0};
      if (::poll(&p, 1, 0) <= 0) {
        if (mono_s() - c.since_s > kConnectTimeout_s) close_client(c);
        return;
      }
      int err = 0;
      socklen_t len = sizeof err;
      if (::getsockopt(c.fd, SOL_SOCKET, SO_ERROR, &err, &len) != 0 || err != 0) {
        close_client(c);
        return;
      }
      c.state = Client::State::cookie;
      queue_cookie(c);
    }
    // Read what there is.
    for (;;) {
      if (c.in_len == c.in.size()) {
        close_client(c);  // a message longer than we accept
        return;
      }
      const ssize_t n = ::recv(c.fd, c.in.data() + c.in_len, c.in.size() - c.in_len, MSG_DONTWAIT);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
        close_client(c);
        return;
      }
      if (n < 0) break;
      c.in_len += size_t(n);
    }
    size_t used = 0;
    if (c.state == Client::State::cookie) {
      if (c.in_len < vrpn::kCookieBytes) {
        if (mono_s() - c.since_s > kConnectTimeout_s)
          close_client(c);
        else
          flush_tcp(c);
        return;
      }
      if (!vrpn::cookie_ok(std::span<const uint8_t, vrpn::kCookieBytes>(c.in.data(), vrpn::kCookieBytes))) {
        stats.refused++;
        close_client(c);
        return;
      }
      used = vrpn::kCookieBytes;
      c.state = Client::State::connected;
      stats.connections++;
      stats.clients++;
      if (!handshake(c)) {
        close_client(c);
        return;
      }
    }
    for (;;) {
      vrpn::Message m;
      const auto r = vrpn::parse_message(std::span<const uint8_t>(c.in.data() + used, c.in_len - used),
                                         kInBytes - vrpn::kHeaderBytes - 8, m);
      if (r == vrpn::Parse::bad) {
        close_client(c);
        return;
      }
      if (r == vrpn::Parse::need_more) break;
      handle(c, m);
      used += m.wire_bytes;
    }
    if (used > 0) {
      std::memmove(c.in.data(), c.in.data() + used, c.in_len - used);
      c.in_len -= used;
    }
    flush_tcp(c);
  }

  void flush_tcp(Client& c) {
    while (c.fd >= 0 && c.out_begin < c.out_end) {
      const ssize_t n = ::send(c.fd, c.out.data() + c.out_begin, c.out_end - c.out_begin, MSG_DONTWAIT | MSG_NOSIGNAL);
      if (n < 0) {
        if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) close_client(c);
        return;
      }
      c.out_begin += size_t(n);
    }
    if (c.out_begin == c.out_end) c.out_begin = c.out_end = 0;
  }

  void append_report(int32_t sender, double unix_time_s, int32_t sensor, const double p[3], const double q[4]) {
    if (frame_len + vrpn::message_bytes(vrpn::kPosQuatBytes) > frame.size()) return;
    std::array<uint8_t, vrpn::kPosQuatBytes> payload{};
    vrpn::write_pos_quat(payload, sensor, p, q);
    frame_len += vrpn::write_message(std::span<uint8_t>(frame.data() + frame_len, frame.size() - frame_len),
                                     vrpn::timestamp_from_seconds(unix_time_s), sender, kPosQuat, 0, payload);
  }

  void send_frame() {
    if (frame_len == 0) return;
    constexpr size_t kMsg = vrpn::message_bytes(vrpn::kPosQuatBytes);
    const size_t messages = frame_len / kMsg;
    for (auto& c : clients) {
      if (c.state != Client::State::connected) continue;
      if (c.udp) {
        // Whole messages per datagram, as VRPN packs its UDP buffer.
        size_t fill = 0;
        for (size_t i = 0; i < messages; ++i) {
          if (fill + kMsg > datagram.size()) {
            send_datagram(c, fill);
            fill = 0;
          }
          std::memcpy(datagram.data() + fill, frame.data() + i * kMsg, kMsg);
          vrpn::store_be32(datagram.data() + fill + 20, c.udp_seq++);
          fill += kMsg;
        }
        if (fill > 0) send_datagram(c, fill);
      } else {
        // Whole frames or nothing on the stream: a full buffer costs this client the frame.
        if (!queue(c, std::span<const uint8_t>(frame.data(), frame_len))) {
          stats.frames_dropped++;
          continue;
        }
        const size_t base = c.out_end - frame_len;
        for (size_t i = 0; i < messages; ++i) vrpn::store_be32(c.out.data() + base + i * kMsg + 20, c.tcp_seq++);
        flush_tcp(c);
      }
      stats.reports += messages;
    }
    frame_len = 0;
  }

  void send_datagram(Client& c, size_t bytes) {
    const ssize_t n = ::sendto(udp_data, datagram.data(), bytes, MSG_DONTWAIT | MSG_NOSIGNAL,
                               reinterpret_cast<const sockaddr*>(&c.udp_to), sizeof c.udp_to);
    if (n == ssize_t(bytes)) stats.udp_datagrams++;
  }
};

VrpnServer::VrpnServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
VrpnServer::~VrpnServer() = default;

Result<std::unique_ptr<VrpnServer>> VrpnServer::create(const std::string& listen) {
  std::string text = listen;
  if (text.find(':') == std::string::npos) text = "127.0.0.1:" + text;
  auto hp = split_host_port(text);
  if (!hp) return tl::unexpected(hp.error());
  auto impl = std::make_unique<Impl>();
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(hp->port);
  const std::string host = hp->host == "localhost" ? "127.0.0.1" : hp->host;
  if (::inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1)
    return fail(Errc::invalid_argument, "VRPN: '" + hp->host + "' is not an IPv4 address");
  impl->tcp_listen = ::socket(AF_INET, SOCK_STREAM, 0);
  impl->udp_listen = ::socket(AF_INET, SOCK_DGRAM, 0);
  impl->udp_data = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (impl->tcp_listen < 0 || impl->udp_listen < 0 || impl->udp_data < 0)
    return fail(Errc::io_error, std::string("VRPN: cannot open sockets: ") + std::strerror(errno));
  const int one = 1;
  ::setsockopt(impl->tcp_listen, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (::bind(impl->tcp_listen, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0)
    return fail(Errc::io_error, "VRPN: cannot bind TCP " + text + ": " + std::strerror(errno));
  // Port 0: the TCP port the system picked is the UDP port too, as VRPN listens on both.
  socklen_t len = sizeof addr;
  ::getsockname(impl->tcp_listen, reinterpret_cast<sockaddr*>(&addr), &len);
  if (::bind(impl->udp_listen, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0)
    return fail(Errc::io_error,
                "VRPN: cannot bind UDP port " + std::to_string(ntohs(addr.sin_port)) + ": " + std::strerror(errno));
  if (::listen(impl->tcp_listen, 16) != 0 || !set_nonblocking(impl->tcp_listen) || !set_nonblocking(impl->udp_listen))
    return fail(Errc::io_error, std::string("VRPN: cannot listen: ") + std::strerror(errno));
  sockaddr_in data = addr;
  data.sin_port = 0;
  len = sizeof data;
  if (::bind(impl->udp_data, reinterpret_cast<const sockaddr*>(&data), sizeof data) != 0 ||
      ::getsockname(impl->udp_data, reinterpret_cast<sockaddr*>(&data), &len) != 0 || !set_nonblocking(impl->udp_data))
    return fail(Errc::io_error, std::string("VRPN: cannot open the UDP data socket: ") + std::strerror(errno));
  impl->bound = addr;
  impl->data_port = ntohs(data.sin_port);
  for (auto& c : impl->clients) {
    c.in.resize(kInBytes);
    c.out.resize(kOutBytes);
    c.remote_sender.assign(kMaxRemoteIds, -1);
    c.remote_type.assign(kMaxRemoteIds, -1);
  }
  return std::unique_ptr<VrpnServer>(new VrpnServer(std::move(impl)));
}

Status VrpnServer::add_avatar(const rig::Skeleton& skeleton) {
  const size_t i = impl_->avatars.size();
  if (i >= 256) return fail(Errc::out_of_range, "VRPN: at most 256 avatars");
  impl_->avatars.push_back({skeleton, std::vector<rig::RigidTransform>(size_t(skeleton.joint_count()))});
  impl_->senders.push_back("Avatar" + std::to_string(i));
  impl_->senders.push_back("Sensors" + std::to_string(i));
  impl_->frame.resize(impl_->frame.size() + (size_t(skeleton.joint_count()) + kMaxSamplesPerAvatar) *
                                                vrpn::message_bytes(vrpn::kPosQuatBytes));
  return {};
}

size_t VrpnServer::avatar_count() const { return impl_->avatars.size(); }
uint16_t VrpnServer::port() const { return ntohs(impl_->bound.sin_port); }
std::string VrpnServer::endpoint() const {
  char ip[INET_ADDRSTRLEN] = {};
  ::inet_ntop(AF_INET, &impl_->bound.sin_addr, ip, sizeof ip);
  return std::string(ip) + ":" + std::to_string(port());
}

void VrpnServer::poll() {
  impl_->accept_lobs();
  impl_->accept_tcp();
  // Whatever clients send to our UDP port is not needed: drain it.
  std::array<uint8_t, 2048> sink{};
  for (int k = 0; k < 64 && ::recv(impl_->udp_data, sink.data(), sink.size(), MSG_DONTWAIT) >= 0; ++k) {}
  for (auto& c : impl_->clients)
    if (c.state != Impl::Client::State::free) impl_->service(c);
}

void VrpnServer::send_pose(size_t avatar, const rig::Pose& pose, double unix_time_s) {
  if (avatar >= impl_->avatars.size() || impl_->stats.clients == 0) return;
  Impl::Avatar& a = impl_->avatars[avatar];
  rig::forward_kinematics(a.skeleton, pose, a.world_from_joint);
  for (size_t j = 0; j < a.world_from_joint.size(); ++j) {
    const auto& t = a.world_from_joint[j];
    const double p[3] = {t.translation.x, t.translation.y, t.translation.z};
    const double q[4] = {t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w};
    impl_->append_report(int32_t(2 * avatar), unix_time_s, int32_t(j), p, q);
  }
}

void VrpnServer::send_sample(size_t avatar, int32_t sensor, const glm::vec3& position_m, const glm::quat& orientation,
                             double unix_time_s) {
  if (avatar >= impl_->avatars.size() || impl_->stats.clients == 0) return;
  const double p[3] = {position_m.x, position_m.y, position_m.z};
  const double q[4] = {orientation.x, orientation.y, orientation.z, orientation.w};
  impl_->append_report(int32_t(2 * avatar + 1), unix_time_s, sensor, p, q);
}

void VrpnServer::flush() { impl_->send_frame(); }

VrpnServerStats VrpnServer::stats() const { return impl_->stats; }

}  // namespace mimic::net
