#include <utility>

#include "mimic/net/server.h"

#include <algorithm>
#include <boost/asio.hpp>
#include <chrono>
#include <cstring>
#include <map>
#include <random>
#include <unordered_map>

namespace mimic::net {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using udp = asio::ip::udp;
using Clock = std::chrono::steady_clock;

uint64_t wall_clock_us() {
  return static_cast<uint64_t>(std::chrono::duration_cast<std::chrono::microseconds>(
                                   std::chrono::system_clock::now().time_since_epoch())
                                   .count());
}

Result<std::pair<std::string, uint16_t>> split_host_port(const std::string& text) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size())
    return fail(Errc::invalid_argument, "expected ADDR:PORT, got '" + text + "'");
  std::string host = text.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  const std::string port_text = text.substr(colon + 1);
  char* end = nullptr;
  const long port = std::strtol(port_text.c_str(), &end, 10);
  if (*end != '\0' || port < 0 || port > 65535)
    return fail(Errc::invalid_argument, "bad port '" + port_text + "' in '" + text + "'");
  return std::make_pair(host, static_cast<uint16_t>(port));
}

namespace {

constexpr int kMaxLods = 8;
constexpr size_t kMaxAvatarsPerPublisher = 16;
constexpr size_t kMaxAvatars = 4096;

bool secrets_equal(const std::string& a, const std::string& b) {
  // Constant time in the secret's length, so timing does not leak a prefix.
  unsigned diff = a.size() == b.size() ? 0u : 1u;
  for (size_t i = 0; i < b.size(); ++i) diff |= unsigned(uint8_t(i < a.size() ? a[i] : 0) ^ uint8_t(b[i]));
  return diff == 0;
}

}  // namespace

struct Session;

struct MeshSlot {
  std::vector<uint8_t> topology;  // encoded packet
  std::vector<uint8_t> frame;     // latest encoded mesh frame
  size_t frame_size = 0;
  uint32_t sequence = 0;
};

struct Avatar {
  bool live = false;
  uint16_t id = 0;
  std::string name;
  uint16_t dof_count = 0;
  uint32_t revision = 0;
  std::vector<uint8_t> model_packet;  // encoded once, copied to every joiner
  std::array<uint8_t, kMaxDatagramBytes> pose{};
  size_t pose_size = 0;
  uint32_t sequence = 0;
  bool has_pose = false;
  Session* owner = nullptr;     // remote publisher, or nullptr for a local avatar
  uint64_t owner_token = 0;     // to re-attach on resume
  Clock::time_point orphaned_at{};
  bool orphaned = false;
  std::array<MeshSlot, kMaxLods> mesh;
};

struct ResumeRecord {
  Role role = Role::subscriber;
  Clock::time_point expires;
  std::map<uint16_t, uint32_t> models_known;  // subscriber: avatar -> revision delivered
  std::map<uint8_t, uint16_t> slots;          // publisher: slot -> avatar
};

struct ServerImpl {
  ServerOptions opt;
  asio::io_context io{1};
  tcp::acceptor acceptor{io};
  asio::steady_timer housekeeping{io};
  bool loopback = true;
  // Pose frames as datagrams: subscribers register their address with their session token.
  udp::socket udp_sock{io};
  bool udp_on = false;
  std::array<uint8_t, kMaxDatagramBytes> udp_in{};
  udp::endpoint udp_from;
  std::unordered_map<uint64_t, Session*> udp_sessions;  // session token -> subscriber asking for UDP
  ServerStats stats;
  std::vector<Avatar> avatars;  // index = avatar id; 0 unused
  std::vector<std::shared_ptr<Session>> sessions;
  std::unordered_map<uint64_t, ResumeRecord> resume;
  std::mt19937_64 rng;
  uint32_t next_session_id = 1;
  // Model revisions are unique across the server's life, so an avatar id reused after a removal
  // never looks like a model a resuming subscriber already holds.
  uint32_t next_revision = 1;
  std::array<uint8_t, 512> scratch{};

  void start_accept();
  void start_udp_receive();
  void on_datagram(std::span<const uint8_t> datagram);
  uint32_t capabilities() const { return udp_on ? kServerCapabilities : kServerCapabilities & ~uint32_t(kCapUdpPose); }
  void schedule_housekeeping();
  void remove_session(Session* s);
  Avatar* avatar(uint16_t id) {
    return id < avatars.size() && avatars[id].live ? &avatars[id] : nullptr;
  }
  Result<uint16_t> new_avatar(const std::string& name, uint16_t dof_count, std::string model_bytes,
                              Session* owner);
  void update_model(Avatar& a, const AvatarModel& m);
  void drop_avatar(uint16_t id);
  Reject accept_pose(Avatar& a, std::span<const uint8_t> packet);
  Reject accept_mesh(Avatar& a, uint8_t lod, std::span<const uint8_t> packet);
  void fan_out_pose(uint16_t id);
  bool batching = false;  // between begin_batch and end_batch: mark, flush once at the end
  uint64_t new_token() {
    uint64_t t = 0;
    while (t == 0 || resume.count(t)) t = rng();
    return t;
  }
};

struct Session : std::enable_shared_from_this<Session> {
  ServerImpl& srv;
  tcp::socket sock;
  asio::steady_timer hello_timer;
  PacketReader reader{kMaxHelloBytes};
  uint32_t id = 0;
  bool active = false;  // HELLO accepted
  bool closed = false;
  Role role = Role::subscriber;
  std::string name;
  uint32_t caps = 0;
  uint8_t mesh_lod = kNoMesh;
  uint64_t token = 0;
  bool udp_ready = false;  // pose frames go to udp_peer
  udp::endpoint udp_peer;

  // Outgoing: one write in flight (out), control packets queued behind it (control, never
  // dropped), and one pending frame slot per avatar (latest wins).
  std::vector<uint8_t> out;
  std::vector<uint8_t> control;
  std::vector<uint16_t> pending;        // avatars with a pose frame waiting
  std::vector<uint8_t> pending_flag;    // by avatar id
  std::vector<uint16_t> pending_mesh;
  std::vector<uint8_t> pending_mesh_flag;
  std::vector<uint8_t> topology_sent;   // by avatar id, for mesh subscribers
  bool writing = false;

  // Inbound
  std::map<uint8_t, uint16_t> slots;     // publisher slot -> avatar id
  std::map<uint16_t, uint32_t> models_known;  // subscriber: avatar -> revision delivered
  double tokens = 0;
  Clock::time_point last_refill;
  avatar::Pose scratch_pose;
  std::vector<glm::vec3> scratch_mesh;
  MeshTopology scratch_topology;

  uint64_t frames_out = 0, frames_dropped = 0, rejected = 0;

  Session(ServerImpl& s, tcp::socket socket)
      : srv(s), sock(std::move(socket)), hello_timer(s.io) {
    out.reserve(64 * 1024);
    control.reserve(4 * 1024);
    scratch_pose.dof_rad.reserve(kMaxPoseDofs);
  }

  void start() {
    tokens = srv.opt.max_packets_per_s;
    last_refill = Clock::now();
    hello_timer.expires_after(std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(srv.opt.hello_timeout_s)));
    hello_timer.async_wait([self = shared_from_this()](const boost::system::error_code& ec) {
      if (ec || self->closed || self->active) return;
      self->count(Reject::timeout);
      self->refuse(Reject::timeout, "no HELLO in time");
    });
    read();
  }

  void read() {
    if (closed) return;
    auto space = reader.write_space(4096);
    sock.async_read_some(asio::buffer(space.data(), space.size()),
                         [self = shared_from_this()](const boost::system::error_code& ec, size_t n) {
                           self->on_read(ec, n);
                         });
  }

  void on_read(const boost::system::error_code& ec, size_t n) {
    if (closed) return;
    if (ec) {
      close(false);
      return;
    }
    srv.stats.bytes_in += n;
    reader.commit(n);
    for (;;) {
      std::span<const uint8_t> packet;
      const Reject e = reader.next(packet);
      if (e != Reject::ok) {
        // The stream cannot be resynchronised: count it and end this session only.
        count(e);
        srv.stats.sessions_closed_for_input++;
        refuse(e, "bad stream");
        return;
      }
      if (packet.empty()) break;
      srv.stats.packets_in++;
      if (!rate_ok()) continue;
      handle(packet);
      if (closed) return;
    }
    read();
  }

  // Token bucket: one second of burst; far over the limit means a flood, and the session ends.
  bool rate_ok() {
    const auto now = Clock::now();
    const double dt = std::chrono::duration<double>(now - last_refill).count();
    last_refill = now;
    const double rate = srv.opt.max_packets_per_s;
    tokens = std::min(rate, tokens + dt * rate);
    if (tokens >= 1.0) {
      tokens -= 1.0;
      return true;
    }
    count(Reject::flood);
    tokens -= 1.0;
    if (tokens < -4 * rate) {
      srv.stats.sessions_closed_for_input++;
      refuse(Reject::flood, "packet flood");
    }
    return false;
  }

  void count(Reject e) {
    srv.stats.rejected[static_cast<size_t>(e)]++;
    rejected++;
  }

  void handle(std::span<const uint8_t> packet) {
    const auto type = static_cast<MsgType>(packet[2]);
    if (!active) {
      if (type != MsgType::hello) {
        count(Reject::unexpected);
        srv.stats.sessions_closed_for_input++;
        refuse(Reject::unexpected, "HELLO expected first");
        return;
      }
      on_hello(packet);
      return;
    }
    Reject e = Reject::ok;
    switch (type) {
      case MsgType::bye:
        forget_token();
        close(true);
        return;
      case MsgType::avatar_model: e = role == Role::publisher ? on_model(packet) : Reject::unexpected; break;
      case MsgType::pose: e = role == Role::publisher ? on_pose(packet) : Reject::unexpected; break;
      case MsgType::mesh_topology:
        e = role == Role::publisher ? on_mesh_topology(packet) : Reject::unexpected;
        break;
      case MsgType::mesh: e = role == Role::publisher ? on_mesh(packet) : Reject::unexpected; break;
      default: e = Reject::unexpected; break;
    }
    if (e == Reject::ok) return;
    count(e);
    // A broken message means a broken peer; order and role slips are only dropped.
    if (e != Reject::out_of_order && e != Reject::unexpected) {
      srv.stats.sessions_closed_for_input++;
      refuse(e, "bad packet");
    }
  }

  void on_hello(std::span<const uint8_t> packet) {
    Hello h;
    if (const Reject e = decode_hello(packet, h); e != Reject::ok) {
      count(e);
      srv.stats.sessions_closed_for_input++;
      refuse(e, "bad HELLO");
      return;
    }
    if (h.max_version < kMinProtocolVersion || h.min_version > kProtocolVersion) {
      count(Reject::unsupported_version);
      refuse(Reject::unsupported_version, "server speaks versions 1..1");
      return;
    }
    if (h.role == Role::publisher && !srv.opt.secret.empty() && !secrets_equal(h.secret, srv.opt.secret)) {
      count(Reject::unauthorized);
      refuse(Reject::unauthorized, "publishers must present the shared secret");
      return;
    }
    hello_timer.cancel();
    role = h.role;
    name = h.name;
    caps = h.capabilities & srv.capabilities();
    if (h.role != Role::subscriber) caps &= ~uint32_t(kCapUdpPose);
    mesh_lod = (caps & kCapMesh) && h.mesh_lod < kMaxLods ? h.mesh_lod : kNoMesh;
    active = true;
    bool resumed = false;
    if (h.resume_token != 0) {
      auto it = srv.resume.find(h.resume_token);
      if (it != srv.resume.end() && it->second.role == role) {
        resumed = true;
        token = h.resume_token;
        if (role == Role::subscriber) models_known = std::move(it->second.models_known);
        else reattach(it->second.slots);
        srv.resume.erase(it);
        srv.stats.resumed++;
      }
    }
    // The token also authenticates the UDP address a subscriber registers.
    if (!resumed) token = (caps & (kCapResume | kCapUdpPose)) ? srv.new_token() : 0;
    if (caps & kCapUdpPose) srv.udp_sessions[token] = this;
    // Any larger packet is a model or mesh, which only publishers send.
    reader.set_max_packet_bytes(role == Role::publisher ? kMaxPacketBytes : kMaxHelloBytes);
    if (role == Role::publisher) srv.stats.publishers++;
    else srv.stats.subscribers++;

    Welcome w;
    w.capabilities = caps;
    w.session_token = token;
    w.client_id = id;
    w.resumed = resumed;
    std::array<uint8_t, 64> buf{};
    queue_control(std::span<const uint8_t>(buf.data(), encode_welcome(w, buf)));
    if (role == Role::subscriber) {
      // The scene as it is now: a resumed subscriber drops avatars that left while it was away
      // (their removal may have been queued on the dead connection).
      std::vector<SceneEntry> scene;
      for (const auto& a : srv.avatars)
        if (a.live) scene.push_back({a.id, a.revision});
      for (auto it = models_known.begin(); it != models_known.end();)
        it = srv.avatar(it->first) ? std::next(it) : models_known.erase(it);
      std::vector<uint8_t> scene_packet(scene_packet_bytes(scene.size()));
      queue_control(std::span<const uint8_t>(scene_packet.data(), encode_scene(scene, scene_packet)));
      // Late joiner: every model it does not hold yet, then every latest pose, at once.
      for (auto& a : srv.avatars) {
        if (!a.live) continue;
        ensure_slot(a.id);
        send_model(a);
        mark_pose(a.id);
      }
    }
    flush();
  }

  void reattach(const std::map<uint8_t, uint16_t>& old_slots) {
    for (const auto& [slot, avatar_id] : old_slots) {
      Avatar* a = srv.avatar(avatar_id);
      if (!a || !a->orphaned) continue;
      a->owner = this;
      a->orphaned = false;
      slots[slot] = avatar_id;
    }
  }

  void send_model(Avatar& a) {
    auto it = models_known.find(a.id);
    if (it != models_known.end() && it->second == a.revision) return;
    queue_control(a.model_packet);
    models_known[a.id] = a.revision;
    srv.stats.model_bytes_out += a.model_packet.size();
  }

  Reject on_model(std::span<const uint8_t> packet) {
    AvatarModel m;
    if (const Reject e = decode_avatar_model(packet, m); e != Reject::ok) return e;
    const uint8_t slot = static_cast<uint8_t>(m.avatar);
    if (m.avatar > 255) return Reject::malformed;
    if (auto it = slots.find(slot); it != slots.end()) {
      if (Avatar* a = srv.avatar(it->second)) {
        srv.update_model(*a, m);
        return Reject::ok;
      }
    }
    if (slots.size() >= kMaxAvatarsPerPublisher) return Reject::unexpected;
    auto new_id = srv.new_avatar(m.name, m.dof_count, std::move(m.model_bytes), this);
    if (!new_id) return Reject::unexpected;
    slots[slot] = *new_id;
    srv.avatars[*new_id].owner_token = token;
    return Reject::ok;
  }

  Avatar* slot_avatar(uint16_t slot) {
    auto it = slots.find(static_cast<uint8_t>(slot));
    if (slot > 255 || it == slots.end()) return nullptr;
    return srv.avatar(it->second);
  }

  Reject on_pose(std::span<const uint8_t> packet) {
    PoseHeader h;
    // Validate every field before the bytes reach anyone else.
    if (const Reject e = decode_pose(packet, h, scratch_pose); e != Reject::ok) return e;
    Avatar* a = slot_avatar(h.avatar);
    if (!a) return Reject::unexpected;
    if (scratch_pose.dof_rad.size() != a->dof_count) return Reject::malformed;
    return srv.accept_pose(*a, packet);
  }

  Reject on_mesh_topology(std::span<const uint8_t> packet) {
    if (const Reject e = decode_mesh_topology(packet, scratch_topology); e != Reject::ok) return e;
    Avatar* a = slot_avatar(scratch_topology.avatar);
    if (!a || scratch_topology.lod >= kMaxLods) return Reject::unexpected;
    scratch_topology.avatar = a->id;
    auto& slot = a->mesh[scratch_topology.lod];
    slot.topology.resize(mesh_topology_packet_bytes(scratch_topology.indices.size()));
    encode_mesh_topology(scratch_topology, slot.topology);
    slot.frame_size = 0;
    slot.sequence = 0;
    for (auto& s : srv.sessions) s->topology_changed(a->id, scratch_topology.lod);
    return Reject::ok;
  }

  Reject on_mesh(std::span<const uint8_t> packet) {
    MeshFrameHeader h;
    if (const Reject e = decode_mesh(packet, h, scratch_mesh); e != Reject::ok) return e;
    Avatar* a = slot_avatar(h.avatar);
    if (!a || h.lod >= kMaxLods) return Reject::unexpected;
    return srv.accept_mesh(*a, h.lod, packet);
  }

  // ---- outgoing ----

  void queue_control(std::span<const uint8_t> bytes) {
    if (control.size() + bytes.size() > srv.opt.max_control_backlog_bytes) {
      srv.stats.sessions_closed_slow++;
      close(false);
      return;
    }
    control.insert(control.end(), bytes.begin(), bytes.end());
  }

  void ensure_slot(uint16_t avatar_id) {
    if (pending_flag.size() <= avatar_id) {
      pending_flag.resize(avatar_id + 1u, 0);
      pending_mesh_flag.resize(avatar_id + 1u, 0);
      topology_sent.resize(avatar_id + 1u, 0);
    }
  }

  void mark_pose(uint16_t avatar_id) {
    if (avatar_id >= pending_flag.size()) return;  // sized when the avatar was announced
    if (pending_flag[avatar_id]) {
      frames_dropped++;
      srv.stats.frames_dropped++;
      return;
    }
    pending_flag[avatar_id] = 1;
    pending.push_back(avatar_id);
  }

  void topology_changed(uint16_t avatar_id, uint8_t lod) {
    if (!active || role != Role::subscriber || lod != mesh_lod) return;
    ensure_slot(avatar_id);
    topology_sent[avatar_id] = 0;
  }

  void mark_mesh(uint16_t avatar_id) {
    if (avatar_id >= pending_mesh_flag.size()) return;
    if (pending_mesh_flag[avatar_id]) return;
    pending_mesh_flag[avatar_id] = 1;
    pending_mesh.push_back(avatar_id);
  }

  // Pose frames as datagrams: one per frame, at once, even while a model is still being
  // written on the stream; a full socket buffer drops the frame (latest wins anyway).
  void send_poses_udp() {
    for (uint16_t aid : pending) {
      pending_flag[aid] = 0;
      const Avatar* a = srv.avatar(aid);
      if (!a || !a->has_pose) continue;
      boost::system::error_code ec;
      srv.udp_sock.send_to(asio::buffer(a->pose.data(), a->pose_size), udp_peer, 0, ec);
      if (ec) {
        frames_dropped++;
        srv.stats.frames_dropped++;
        continue;
      }
      srv.stats.udp_frames_out++;
      srv.stats.bytes_out += a->pose_size;
      frames_out++;
      srv.stats.frames_out++;
    }
    pending.clear();
  }

  void flush() {
    if (closed || !active) return;
    if (udp_ready) send_poses_udp();
    if (writing) return;
    out.clear();
    out.insert(out.end(), control.begin(), control.end());
    control.clear();
    for (uint16_t aid : pending) {
      pending_flag[aid] = 0;
      const Avatar* a = srv.avatar(aid);
      if (!a || !a->has_pose) continue;
      out.insert(out.end(), a->pose.begin(), a->pose.begin() + static_cast<long>(a->pose_size));
      frames_out++;
      srv.stats.frames_out++;
    }
    pending.clear();
    for (uint16_t aid : pending_mesh) {
      pending_mesh_flag[aid] = 0;
      const Avatar* a = srv.avatar(aid);
      if (!a || mesh_lod >= kMaxLods) continue;
      const auto& m = a->mesh[mesh_lod];
      if (m.topology.empty() || m.frame_size == 0) continue;
      if (!topology_sent[aid]) {
        out.insert(out.end(), m.topology.begin(), m.topology.end());
        topology_sent[aid] = 1;
      }
      out.insert(out.end(), m.frame.begin(), m.frame.begin() + static_cast<long>(m.frame_size));
      srv.stats.mesh_frames_out++;
    }
    pending_mesh.clear();
    if (out.empty()) return;
    srv.stats.bytes_out += out.size();
    // Try the kernel first: on a healthy connection the whole batch fits the socket buffer and
    // no asynchronous operation (or completion handler) is needed at all.
    boost::system::error_code write_ec;
    const size_t sent = sock.write_some(asio::buffer(out), write_ec);
    if (write_ec && write_ec != asio::error::would_block && write_ec != asio::error::try_again) {
      close(false);
      return;
    }
    if (!write_ec && sent == out.size()) return;
    const size_t done = write_ec ? 0 : sent;
    writing = true;
    asio::async_write(sock, asio::buffer(out.data() + done, out.size() - done),
                      [self = shared_from_this()](const boost::system::error_code& ec, size_t) {
                        self->writing = false;
                        if (ec) {
                          self->close(false);
                          return;
                        }
                        self->flush();
                      });
  }

  // Sends REJECT, then closes once it is written (or at once if the peer is not reading).
  void refuse(Reject reason, const char* message) {
    if (closed) return;
    RejectMsg m;
    m.reason = reason;
    m.message = message;
    std::array<uint8_t, 300> buf{};
    const size_t n = encode_reject(m, buf);
    boost::system::error_code ec;
    sock.non_blocking(true, ec);
    sock.write_some(asio::buffer(buf.data(), n), ec);
    close(false);
  }

  void forget_token() {
    if (token) srv.resume.erase(token);
    token = 0;
  }

  void close(bool clean) {
    if (closed) return;
    closed = true;
    boost::system::error_code ec;
    hello_timer.cancel();
    sock.shutdown(tcp::socket::shutdown_both, ec);
    sock.close(ec);
    if (active) {
      if (role == Role::publisher) srv.stats.publishers--;
      else srv.stats.subscribers--;
    }
    const auto now = Clock::now();
    const auto grace = std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(srv.opt.resume_grace_s));
    if (auto it = srv.udp_sessions.find(token); token != 0 && it != srv.udp_sessions.end() && it->second == this)
      srv.udp_sessions.erase(it);
    if (active && !clean && token != 0 && (caps & kCapResume)) {
      ResumeRecord r;
      r.role = role;
      r.expires = now + grace;
      r.models_known = models_known;
      r.slots = slots;
      srv.resume[token] = std::move(r);
    }
    // A publisher's avatars outlive a dropped connection for the grace period (it may resume);
    // a clean BYE removes them at once.
    for (const auto& [slot, avatar_id] : slots) {
      Avatar* a = srv.avatar(avatar_id);
      if (!a) continue;
      if (clean || token == 0) {
        srv.drop_avatar(avatar_id);
      } else {
        a->owner = nullptr;
        a->orphaned = true;
        a->orphaned_at = now;
      }
    }
    slots.clear();
    asio::post(srv.io, [self = shared_from_this()] { self->srv.remove_session(self.get()); });
  }
};

void ServerImpl::start_accept() {
  acceptor.async_accept([this](const boost::system::error_code& ec, tcp::socket sock) {
    if (ec) {
      if (ec != asio::error::operation_aborted) start_accept();
      return;
    }
    stats.sessions_accepted++;
    boost::system::error_code ignore;
    sock.set_option(tcp::no_delay(true), ignore);
    sock.non_blocking(true, ignore);  // flush() writes directly when the kernel has room
    if (opt.send_buffer_bytes > 0) sock.set_option(asio::socket_base::send_buffer_size(opt.send_buffer_bytes), ignore);
    auto s = std::make_shared<Session>(*this, std::move(sock));
    s->id = next_session_id++;
    if (sessions.size() >= opt.max_sessions) {
      s->count(Reject::server_full);
      s->refuse(Reject::server_full, "server full");
    } else {
      sessions.push_back(s);
      stats.sessions_open = sessions.size();
      s->start();
    }
    start_accept();
  });
}

void ServerImpl::start_udp_receive() {
  udp_sock.async_receive_from(asio::buffer(udp_in), udp_from, [this](const boost::system::error_code& ec, size_t n) {
    if (ec) {
      if (ec != asio::error::operation_aborted && udp_sock.is_open()) start_udp_receive();
      return;
    }
    on_datagram(std::span<const uint8_t>(udp_in.data(), n));
    start_udp_receive();
  });
}

// The only datagram a client sends: its session token, from the address its pose frames should
// go to. Anything else is counted and dropped; only a known token gets an answer (the same 16
// bytes), so the socket cannot be used to reflect traffic at a third party.
void ServerImpl::on_datagram(std::span<const uint8_t> datagram) {
  stats.udp_datagrams_in++;
  stats.bytes_in += datagram.size();
  uint64_t token = 0;
  Reject e = decode_udp_register(datagram, token);
  Session* s = nullptr;
  if (e == Reject::ok) {
    auto it = udp_sessions.find(token);
    if (it == udp_sessions.end() || it->second->closed) e = Reject::unauthorized;
    else s = it->second;
  }
  if (e != Reject::ok) {
    stats.rejected[static_cast<size_t>(e)]++;
    return;
  }
  if (!s->udp_ready || s->udp_peer != udp_from) {
    if (!s->udp_ready) stats.udp_registered++;
    s->udp_ready = true;
    s->udp_peer = udp_from;  // also after a NAT rebinding
  }
  std::array<uint8_t, kUdpRegisterBytes> ack{};
  boost::system::error_code ignore;
  udp_sock.send_to(asio::buffer(ack.data(), encode_udp_register(token, ack)), udp_from, 0, ignore);
}

void ServerImpl::schedule_housekeeping() {
  housekeeping.expires_after(std::chrono::milliseconds(250));
  housekeeping.async_wait([this](const boost::system::error_code& ec) {
    if (ec) return;
    const auto now = Clock::now();
    for (auto it = resume.begin(); it != resume.end();) {
      if (it->second.expires <= now) it = resume.erase(it);
      else ++it;
    }
    const auto grace = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(opt.resume_grace_s));
    for (auto& a : avatars)
      if (a.live && a.orphaned && now - a.orphaned_at >= grace) drop_avatar(a.id);
    schedule_housekeeping();
  });
}

void ServerImpl::remove_session(Session* s) {
  auto it = std::find_if(sessions.begin(), sessions.end(), [s](const auto& p) { return p.get() == s; });
  if (it != sessions.end()) sessions.erase(it);
  stats.sessions_open = sessions.size();
}

Result<uint16_t> ServerImpl::new_avatar(const std::string& name, uint16_t dof_count,
                                          std::string model_bytes, Session* owner) {
  if (dof_count > kMaxPoseDofs) return fail(Errc::out_of_range, "too many DOFs for a pose frame");
  if (model_bytes.size() > kMaxModelBytes) return fail(Errc::out_of_range, "body model too large");
  uint16_t id = 0;
  for (uint16_t i = 1; i < avatars.size(); ++i)
    if (!avatars[i].live) {
      id = i;
      break;
    }
  if (id == 0) {
    if (avatars.size() >= kMaxAvatars) return fail(Errc::out_of_range, "too many avatars");
    if (avatars.empty()) avatars.emplace_back();
    id = static_cast<uint16_t>(avatars.size());
    avatars.emplace_back();
  }
  Avatar& a = avatars[id];
  a = Avatar{};
  a.live = true;
  a.id = id;
  a.name = name.substr(0, kMaxNameBytes);
  a.dof_count = dof_count;
  a.owner = owner;
  AvatarModel m;
  m.avatar = id;
  m.dof_count = dof_count;
  m.name = a.name;
  m.model_bytes = std::move(model_bytes);
  update_model(a, m);
  stats.avatars++;
  return id;
}

void ServerImpl::update_model(Avatar& a, const AvatarModel& m) {
  AvatarModel copy = m;
  copy.avatar = a.id;
  copy.revision = a.revision = next_revision++;
  copy.name = a.name;
  a.dof_count = m.dof_count;
  a.model_packet.resize(avatar_model_packet_bytes(copy));
  encode_avatar_model(copy, a.model_packet);
  a.has_pose = false;  // old frames may not match the new model
  for (auto& s : sessions) {
    if (!s->active || s->role != Role::subscriber) continue;
    s->ensure_slot(a.id);
    s->send_model(a);
    s->flush();
  }
}

void ServerImpl::drop_avatar(uint16_t id) {
  Avatar* a = avatar(id);
  if (!a) return;
  a->live = false;
  stats.avatars--;
  std::array<uint8_t, 16> buf{};
  const size_t n = encode_avatar_removed(id, buf);
  for (auto& s : sessions) {
    if (!s->active || s->role != Role::subscriber) continue;
    s->models_known.erase(id);
    s->queue_control(std::span<const uint8_t>(buf.data(), n));
    s->flush();
  }
}

Reject ServerImpl::accept_pose(Avatar& a, std::span<const uint8_t> packet) {
  if (packet.size() > a.pose.size()) return Reject::oversized;
  const uint32_t seq = pose_sequence(packet);
  if (a.has_pose && static_cast<int32_t>(seq - a.sequence) <= 0) return Reject::out_of_order;
  std::memcpy(a.pose.data(), packet.data(), packet.size());
  a.pose_size = packet.size();
  set_pose_avatar(std::span<uint8_t>(a.pose.data(), a.pose_size), a.id);
  a.sequence = seq;
  a.has_pose = true;
  stats.frames_in++;
  fan_out_pose(a.id);
  return Reject::ok;
}

Reject ServerImpl::accept_mesh(Avatar& a, uint8_t lod, std::span<const uint8_t> packet) {
  auto& slot = a.mesh[lod];
  if (slot.topology.empty()) return Reject::unexpected;
  if (slot.frame.size() < packet.size()) slot.frame.resize(packet.size());
  std::memcpy(slot.frame.data(), packet.data(), packet.size());
  slot.frame_size = packet.size();
  set_pose_avatar(std::span<uint8_t>(slot.frame.data(), slot.frame_size), a.id);  // same offset
  for (auto& s : sessions) {
    if (!s->active || s->role != Role::subscriber || s->mesh_lod != lod) continue;
    s->mark_mesh(a.id);
    if (!batching) s->flush();
  }
  return Reject::ok;
}

void ServerImpl::fan_out_pose(uint16_t id) {
  for (auto& s : sessions) {
    if (!s->active || s->role != Role::subscriber) continue;
    s->mark_pose(id);
    if (!batching) s->flush();
  }
}

// ---- Server -----------------------------------------------------------------------------------

Server::Server(std::unique_ptr<ServerImpl> impl) : impl_(std::move(impl)) {}

Server::~Server() {
  if (!impl_) return;
  boost::system::error_code ec;
  impl_->acceptor.close(ec);
  impl_->udp_sock.close(ec);
  for (auto& s : std::vector<std::shared_ptr<Session>>(impl_->sessions)) s->close(true);
  impl_->housekeeping.cancel();
  impl_->io.restart();
  impl_->io.poll();
  impl_->sessions.clear();
}

Result<std::unique_ptr<Server>> Server::create(const ServerOptions& options) {
  auto hp = split_host_port(options.listen);
  if (!hp) return tl::unexpected(hp.error());
  auto impl = std::make_unique<ServerImpl>();
  impl->opt = options;
  boost::system::error_code ec;
  const auto addr = asio::ip::make_address(hp->first, ec);
  if (ec) return fail(Errc::invalid_argument, "bad listen address '" + hp->first + "': " + ec.message());
  impl->loopback = addr.is_loopback();
  if (!impl->loopback && options.secret.empty())
    return fail(Errc::invalid_argument,
                "serving on " + options.listen +
                    " exposes the scene beyond this machine: give publishers a shared secret (--secret)");
  const tcp::endpoint ep(addr, hp->second);
  impl->acceptor.open(ep.protocol(), ec);
  if (!ec) impl->acceptor.set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) impl->acceptor.bind(ep, ec);
  if (!ec) impl->acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) return fail(Errc::io_error, "cannot listen on " + options.listen + ": " + ec.message());
  if (options.udp) {
    // Same address and port as the listener. If another program holds the UDP port, the server
    // runs without it and does not offer the capability.
    const udp::endpoint uep(addr, impl->acceptor.local_endpoint().port());
    boost::system::error_code uec;
    impl->udp_sock.open(uep.protocol(), uec);
    if (!uec) impl->udp_sock.bind(uep, uec);
    if (!uec) impl->udp_sock.non_blocking(true, uec);
    impl->udp_on = !uec;
    if (uec) impl->udp_sock.close(uec);
  }
  impl->rng.seed(std::random_device{}() ^ (uint64_t(std::random_device{}()) << 32));
  impl->avatars.emplace_back();  // id 0 is never used
  impl->start_accept();
  if (impl->udp_on) impl->start_udp_receive();
  impl->schedule_housekeeping();
  return std::unique_ptr<Server>(new Server(std::move(impl)));
}

uint16_t Server::port() const { return impl_->acceptor.local_endpoint().port(); }
bool Server::udp() const { return impl_->udp_on; }

std::string Server::endpoint() const {
  const auto ep = impl_->acceptor.local_endpoint();
  return ep.address().to_string() + ":" + std::to_string(ep.port());
}

Result<uint16_t> Server::add_avatar(const std::string& name, uint16_t dof_count, std::string model_bytes) {
  return impl_->new_avatar(name, dof_count, std::move(model_bytes), nullptr);
}

void Server::remove_avatar(uint16_t avatar) { impl_->drop_avatar(avatar); }

Reject Server::publish_pose(uint16_t avatar, std::span<const uint8_t> packet) {
  Avatar* a = impl_->avatar(avatar);
  if (!a) return Reject::unexpected;
  Header h;
  if (const Reject e = decode_header(packet, h); e != Reject::ok) return e;
  if (h.type != MsgType::pose || packet.size() != pose_packet_bytes(a->dof_count)) return Reject::malformed;
  const Reject e = impl_->accept_pose(*a, packet);
  if (e != Reject::ok) impl_->stats.rejected[static_cast<size_t>(e)]++;
  return e;
}

uint8_t Server::mesh_lods_wanted(uint16_t avatar) const {
  uint8_t mask = 0;
  for (const auto& s : impl_->sessions)
    if (s->active && s->role == Role::subscriber && s->mesh_lod < kMaxLods) mask |= uint8_t(1u << s->mesh_lod);
  return impl_->avatar(avatar) ? mask : 0;
}

Status Server::set_mesh_topology(const MeshTopology& topology) {
  Avatar* a = impl_->avatar(topology.avatar);
  if (!a) return fail(Errc::not_found, "no avatar " + std::to_string(topology.avatar));
  if (topology.lod >= kMaxLods) return fail(Errc::out_of_range, "LOD must be below 8");
  auto& slot = a->mesh[topology.lod];
  slot.topology.resize(mesh_topology_packet_bytes(topology.indices.size()));
  if (encode_mesh_topology(topology, slot.topology) == 0) return fail(Errc::out_of_range, "mesh too large");
  slot.frame_size = 0;
  for (auto& s : impl_->sessions) s->topology_changed(a->id, topology.lod);
  return {};
}

Reject Server::publish_mesh(uint16_t avatar, uint8_t lod, std::span<const uint8_t> packet) {
  Avatar* a = impl_->avatar(avatar);
  if (!a || lod >= kMaxLods) return Reject::unexpected;
  return impl_->accept_mesh(*a, lod, packet);
}

void Server::run_until(std::chrono::steady_clock::time_point deadline) {
  if (impl_->io.stopped()) impl_->io.restart();
  impl_->io.run_until(deadline);
}

void Server::poll() {
  if (impl_->io.stopped()) impl_->io.restart();
  impl_->io.poll();
}

void Server::run() {
  if (impl_->io.stopped()) impl_->io.restart();
  auto guard = asio::make_work_guard(impl_->io);
  impl_->io.run();
}

void Server::stop() { impl_->io.stop(); }

void Server::begin_batch() { impl_->batching = true; }

void Server::end_batch() {
  impl_->batching = false;
  for (auto& s : impl_->sessions) s->flush();
}

void Server::dispatch(std::function<void()> fn) { asio::post(impl_->io, std::move(fn)); }

const ServerStats& Server::stats() const { return impl_->stats; }

std::vector<SessionInfo> Server::sessions() const {
  std::vector<SessionInfo> v;
  for (const auto& s : impl_->sessions) {
    if (!s->active) continue;
    v.push_back({s->id, s->role, s->name, s->frames_out, s->frames_dropped, s->rejected});
  }
  return v;
}

}  // namespace mimic::net
