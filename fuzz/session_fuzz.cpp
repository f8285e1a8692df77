// libFuzzer entry point for the server's session state machine: a real Server on loopback, driven
// by a script decoded from the input — connections opened and closed, raw or well-formed bytes
// sent on them (HELLO with any role, capabilities and resume token; models, poses, pings, BYE),
// UDP registrations carrying tokens and nonces the server handed out, floods. Everything the
// server answers is read back so handshakes, resumes and registrations really progress.
// Invariants: no sanitizer report, and the server's counters stay consistent.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <vector>

#include "mimic/net/frame_codec.h"
#include "mimic/net/server.h"

namespace {

using namespace mimic::net;

// The input, read as a script; reads past the end give zeros.
struct Script {
  const uint8_t* data;
  size_t size, pos = 0;
  bool done() const { return pos >= size; }
  uint8_t u8() { return pos < size ? data[pos++] : 0; }
  std::vector<uint8_t> bytes(size_t n) {
    std::vector<uint8_t> b;
    while (n-- && pos < size) b.push_back(data[pos++]);
    return b;
  }
};

struct Conn {
  int fd = -1;
  PacketReader reader{kMaxPacketBytes};
};

Server& server() {
  static std::unique_ptr<Server> s = [] {
    ServerOptions o;
    o.max_sessions = 24;
    o.max_sessions_per_address = 16;
    o.max_packets_per_s = 200;  // floods are reachable within one input
    o.max_control_backlog_bytes = 64 * 1024;
    o.max_model_bytes_held = 256 * 1024;
    o.max_mesh_bytes = 1u << 20;  // topologies within a frame's size still meet the total bound
    auto r = Server::create(o);
    if (!r) std::abort();
    (void)(*r)->add_avatar("local", 4, std::string(64, 'm'));
    return std::move(*r);
  }();
  return *s;
}

sockaddr_in server_address() {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(server().port());
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  return a;
}

void pump(std::vector<Conn>& conns, std::vector<SessionToken>& tokens) {
  server().poll();
  for (auto& c : conns) {
    if (c.fd < 0) continue;
    for (;;) {
      auto space = c.reader.write_space(4096);
      const ssize_t n = ::recv(c.fd, space.data(), space.size(), MSG_DONTWAIT);
      if (n <= 0) break;
      c.reader.commit(size_t(n));
    }
    for (;;) {
      std::span<const uint8_t> p;
      if (c.reader.next(p) != Reject::ok || p.empty()) break;
      Welcome w;
      if (decode_welcome(p, w) == Reject::ok && !w.session_token.empty() && tokens.size() < 16)
        tokens.push_back(w.session_token);
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Server& srv = server();
  Script in{data, size};
  std::vector<Conn> conns;
  std::vector<SessionToken> tokens;
  uint64_t last_nonce = 0;
  const int udp = ::socket(AF_INET, SOCK_DGRAM, 0);
  const sockaddr_in to = server_address();
  ::connect(udp, reinterpret_cast<const sockaddr*>(&to), sizeof to);
  for (int step = 0; step < 64 && !in.done(); ++step) {
    const uint8_t op = in.u8();
    const size_t which = conns.empty() ? 0 : in.u8() % conns.size();
    std::vector<uint8_t> out(kMaxHelloBytes + 1200);
    size_t n = 0;
    switch (op % 11) {
      case 0: {  // a new connection
        if (conns.size() >= 8) break;
        Conn c;
        c.fd = ::socket(AF_INET, SOCK_STREAM, 0);
        if (::connect(c.fd, reinterpret_cast<const sockaddr*>(&to), sizeof to) != 0) {
          ::close(c.fd);
          break;
        }
        conns.push_back(std::move(c));
        break;
      }
      case 1: {  // raw bytes
        const auto b = in.bytes(in.u8());
        if (!conns.empty() && conns[which].fd >= 0) (void)::send(conns[which].fd, b.data(), b.size(), MSG_NOSIGNAL);
        break;
      }
      case 2: {  // a well-formed HELLO, maybe resuming a token seen
        Hello h;
        const uint8_t f = in.u8();
        h.role = (f & 1) ? Role::publisher : Role::subscriber;
        h.capabilities = in.u8();
        h.mesh_lod = (f & 2) ? in.u8() % 9 : kNoMesh;
        if ((f & 4) && !tokens.empty()) h.resume_token = tokens[in.u8() % tokens.size()];
        h.name = (f & 8) ? "\x1b[2J" : "fuzz";
        n = encode_hello(h, out);
        break;
      }
      case 3: {  // a model on a slot
        AvatarModel m{uint16_t(in.u8() % 20), 0, uint16_t(in.u8() % 8), "m", std::string(in.u8() * 16u, 'x')};
        out.resize(avatar_model_packet_bytes(m));
        n = encode_avatar_model(m, out);
        break;
      }
      case 4: {  // a pose on a slot
        mimic::rig::Pose p;
        p.dof_rad.assign(in.u8() % 8, 0.1f);
        PoseHeader ph{uint16_t(in.u8() % 20), 0, uint32_t(in.u8()), 0};
        n = encode_pose(ph, p, out);
        break;
      }
      case 5: n = (in.u8() & 1) ? encode_ping(out) : encode_bye(out); break;
      case 6: {  // UDP registration with a token seen, echoing the last nonce or not
        if (tokens.empty()) break;
        UdpRegister r{tokens[in.u8() % tokens.size()], (in.u8() & 1) ? last_nonce : in.u8()};
        std::array<uint8_t, kUdpRegisterBytes> b{};
        (void)::send(udp, b.data(), encode_udp_register(r, b), 0);
        server().poll();
        UdpRegister answer;
        std::array<uint8_t, 1500> got{};
        const ssize_t k = ::recv(udp, got.data(), got.size(), MSG_DONTWAIT);
        if (k > 0 && decode_udp_register(std::span<const uint8_t>(got.data(), size_t(k)), answer) == Reject::ok)
          last_nonce = answer.nonce;
        break;
      }
      case 7: {  // close a connection, cleanly or not
        if (conns.empty() || conns[which].fd < 0) break;
        ::close(conns[which].fd);
        conns[which].fd = -1;
        break;
      }
      case 9: {  // a mesh topology whose counts come from the input: vertices up to 2^32 - 1,
                 // indices claimed vs carried
        const uint32_t high = in.u8(), shift = in.u8() % 25u, low = in.u8();
        const uint32_t vertices = high << shift | low;
        const uint32_t claimed = in.u8();
        const uint32_t carried = (in.u8() & 1) ? claimed : in.u8();
        out.assign(kHeaderBytes + 11 + 4 * size_t(carried), 0);
        size_t at = 0;
        auto put = [&](uint64_t v, int k) {
          for (int i = 0; i < k; ++i) out[at++] = uint8_t(v >> (8 * i));
        };
        put(kMagic, 1);
        put(kProtocolVersion, 1);
        put(uint8_t(MsgType::mesh_topology), 1);
        put(0, 1);
        put(out.size() - kHeaderBytes, 4);
        put(in.u8() % 20, 2);  // slot
        put(in.u8() % 10, 1);  // LOD, sometimes past the last
        put(vertices, 4);
        put(claimed, 4);
        for (uint32_t i = 0; i < carried; ++i) put(in.u8() % (uint64_t(vertices) + 1), 4);
        n = out.size();
        break;
      }
      case 10: {  // a mesh frame whose vertex count may not be its topology's
        std::vector<glm::vec3> p(size_t(in.u8()) * 8, glm::vec3(0.25f));
        if (p.size() > 1) p[1] = glm::vec3(1.0f);
        MeshFrameHeader mh{uint16_t(in.u8() % 20), uint8_t(in.u8() % 10), uint32_t(in.u8()), 0};
        out.resize(mesh_packet_bytes(p.size()));
        n = encode_mesh(mh, p, out);
        break;
      }
      case 8: {  // a burst of pings (flood)
        std::vector<uint8_t> burst;
        for (int i = 0; i < 300; ++i) {
          std::array<uint8_t, kHeaderBytes> b{};
          burst.insert(burst.end(), b.begin(), b.begin() + long(encode_ping(b)));
        }
        if (!conns.empty() && conns[which].fd >= 0)
          (void)::send(conns[which].fd, burst.data(), burst.size(), MSG_NOSIGNAL);
        break;
      }
    }
    if (n > 0 && !conns.empty() && conns[which].fd >= 0) (void)::send(conns[which].fd, out.data(), n, MSG_NOSIGNAL);
    pump(conns, tokens);
  }
  for (auto& c : conns)
    if (c.fd >= 0) ::close(c.fd);
  ::close(udp);
  // Let the server see every close, then check its books.
  for (int i = 0; i < 2000 && srv.stats().sessions_open > 0; ++i) {
    srv.poll();
    if (srv.stats().sessions_open > 0) ::usleep(50);
  }
  const ServerStats& s = srv.stats();
  if (s.sessions_open != 0) std::abort();
  if (s.publishers != 0 || s.subscribers != 0) std::abort();
  if (s.model_bytes_held > 2 * 256 * 1024 + 4096 && s.avatars <= 1) std::abort();
  if (s.mesh_bytes_held > (1u << 20)) std::abort();
  return 0;
}
