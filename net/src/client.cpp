#include <utility>

#include "mimic/net/client.h"

#include <algorithm>
#include <array>
#include <boost/asio.hpp>
#include <cstring>
#include <optional>

#include "mimic/net/nats.h"
#include "mimic/net/server.h"
#include "nats/embedded_relay.h"

namespace mimic::net {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using udp = asio::ip::udp;
using Clock = std::chrono::steady_clock;

namespace {
constexpr size_t kMaxSlots = 16;

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}
}  // namespace

struct PublishedAvatar {
  bool live = false;
  std::string name;
  uint16_t dof_count = 0;
  std::vector<uint8_t> model_packet;
  std::array<uint8_t, kMaxDatagramBytes> pose{};
  size_t pose_size = 0;
  bool pending = false;
};

struct Client::Impl {
  // A scene on a NATS broker is served to this client by a relay of its own (destroyed after
  // everything below it).
  std::shared_ptr<nats_detail::EmbeddedRelay> embedded_relay;
  Client* owner = nullptr;
  ClientOptions opt;
  asio::io_context io{1};
  std::optional<tcp::socket> sock;
  tcp::endpoint endpoint;
  PacketReader reader{kMaxPacketBytes};
  bool connected = false;
  bool handshake_done = false;
  std::optional<Error> fatal;   // the session is over for good
  bool dropped = false;         // connection lost; may resume
  SessionToken token;
  uint32_t caps = 0;
  uint64_t generation = 0;      // handlers of an old socket ignore themselves
  ClientStats stats;
  std::map<uint16_t, RemoteAvatar> avatars;
  std::array<PublishedAvatar, kMaxSlots> published;
  avatar::Pose scratch_pose;
  MeshTopology scratch_topology;

  std::vector<uint8_t> out, control;
  bool writing = false;

  // Pose frames as datagrams: one socket for the client's life, registered with the session
  // token (again after every resume, and every second to keep NAT mappings open).
  std::optional<udp::socket> usock;
  std::array<uint8_t, kMaxDatagramBytes> uin{};
  udp::endpoint ufrom;
  bool udp_ready = false;
  uint64_t udp_nonce = 0;  // the server's last answer: echoed to prove we receive at this address
  asio::steady_timer udp_timer{io};
  // A session that says nothing is closed by the server's idle timeout; a PING every 2 s keeps a
  // quiet subscriber (or a publisher whose source is silent) alive.
  asio::steady_timer keepalive_timer{io};
  void keepalive();
  // The latest datagram frame of each avatar whose model is still on its way (bounded).
  std::map<uint16_t, std::vector<uint8_t>> early;
  static constexpr size_t kMaxEarly = 64;
  void start_udp();
  void register_udp();
  void udp_receive();
  void on_pose(std::span<const uint8_t> p, uint64_t now_us, bool datagram);

  asio::steady_timer retry_timer{io};
  asio::steady_timer handshake_timer{io};
  bool connecting = false;             // a connection attempt (TCP or handshake) is under way
  int failures = 0;                    // consecutive failed attempts
  std::optional<Error> connect_error;  // why the last attempt failed

  void start_connection();
  void connect_failed(Errc code, std::string message);
  void schedule_retry();
  void read();
  void on_packet(std::span<const uint8_t> p);
  void queue_control(std::span<const uint8_t> bytes) { control.insert(control.end(), bytes.begin(), bytes.end()); }
  void flush();
  void lose_connection() {
    if (!connected && !connecting) return;
    connected = false;
    connecting = false;
    dropped = true;
    udp_ready = false;  // the server forgets the address with the session; registered again after WELCOME
    ++generation;
    boost::system::error_code ec;
    if (sock) sock->close(ec);
    writing = false;
    handshake_timer.cancel();
    schedule_retry();
  }
  void end(Errc code, std::string message) {
    if (!fatal) fatal = Error{code, std::move(message)};
    lose_connection();
  }
  Status status() const {
    if (fatal) return tl::unexpected(*fatal);
    return {};
  }
};

// Reconnection is asynchronous: the realtime loop that drives the client never waits for it.
void Client::Impl::start_connection() {
  ++generation;
  const uint64_t gen = generation;
  sock.emplace(io);
  reader = PacketReader(kMaxPacketBytes);
  out.clear();
  control.clear();
  writing = false;
  handshake_done = false;
  connecting = true;
  handshake_timer.expires_after(seconds(opt.connect_timeout_s));
  handshake_timer.async_wait([this, gen](const boost::system::error_code& ec) {
    if (ec || gen != generation || handshake_done) return;
    connect_failed(Errc::timeout, "no answer from " + opt.connect + " in time");
  });
  sock->async_connect(endpoint, [this, gen](const boost::system::error_code& ec) {
    if (gen != generation) return;
    if (ec) {
      connect_failed(Errc::io_error, "cannot connect to " + opt.connect + ": " + ec.message());
      return;
    }
    boost::system::error_code ignore;
    sock->set_option(tcp::no_delay(true), ignore);
    connected = true;
    Hello h;
    h.role = opt.role;
    h.name = opt.name.substr(0, kMaxNameBytes);
    h.secret = opt.secret;
    h.mesh_lod = opt.mesh_lod;
    h.capabilities = kCapPose | kCapResume | (opt.mesh_lod != kNoMesh ? uint32_t(kCapMesh) : 0u) |
                     (opt.udp && opt.role == Role::subscriber ? uint32_t(kCapUdpPose) : 0u) |
                     (opt.lean && opt.role == Role::subscriber ? uint32_t(kCapLeanPose) : 0u);
    h.resume_token = token;
    std::array<uint8_t, kMaxHelloBytes> buf{};
    queue_control(std::span<const uint8_t>(buf.data(), encode_hello(h, buf)));
    flush();
    read();
  });
}

void Client::Impl::connect_failed(Errc code, std::string message) {
  connect_error = Error{code, std::move(message)};
  failures++;
  connected = true;  // so lose_connection tears the attempt down
  lose_connection();
}

void Client::Impl::schedule_retry() {
  if (!opt.reconnect || token.empty() || fatal) return;
  // The first retry at once (a dropped connection usually comes straight back), then backing off.
  retry_timer.expires_after(failures == 0 ? std::chrono::milliseconds(0) : std::chrono::milliseconds(250));
  retry_timer.async_wait([this](const boost::system::error_code& ec) {
    if (ec || !dropped || fatal || connecting) return;
    stats.reconnects++;
    start_connection();
  });
}

void Client::Impl::read() {
  const uint64_t gen = generation;
  auto space = reader.write_space(16 * 1024);
  sock->async_read_some(asio::buffer(space.data(), space.size()),
                        [this, gen](const boost::system::error_code& ec, size_t n) {
                          if (gen != generation) return;
                          if (ec) {
                            lose_connection();
                            return;
                          }
                          stats.bytes_in += n;
                          reader.commit(n);
                          for (;;) {
                            std::span<const uint8_t> p;
                            const Reject e = reader.next(p);
                            if (e != Reject::ok) {
                              stats.rejected++;
                              end(Errc::parse_error, std::string("bad stream from server: ") + reject_name(e));
                              return;
                            }
                            if (p.empty()) break;
                            on_packet(p);
                            if (gen != generation) return;
                          }
                          read();
                        });
}

void Client::Impl::on_packet(std::span<const uint8_t> p) {
  const auto type = static_cast<MsgType>(p[2]);
  const uint64_t now_us = wall_clock_us();
  switch (type) {
    case MsgType::welcome: {
      Welcome w;
      if (decode_welcome(p, w) != Reject::ok) break;
      const bool was_resume = !token.empty();
      token = w.session_token;
      caps = w.capabilities;
      handshake_done = true;
      connecting = false;
      dropped = false;
      failures = 0;
      handshake_timer.cancel();
      if (w.resumed) stats.resumed++;
      // The server did not know us (it restarted, or the grace period ran out): the scene
      // arrives afresh, so forget the old one.
      if (was_resume && !w.resumed && opt.role == Role::subscriber) avatars.clear();
      // A publisher whose session was not kept brings its avatars again.
      if (opt.role == Role::publisher && (!w.resumed || !was_resume)) {
        for (auto& a : published)
          if (a.live) queue_control(a.model_packet);
      }
      for (auto& a : published)
        if (a.live && a.pose_size) a.pending = true;
      flush();
      udp_ready = false;  // a new session (or a resumed one on a new server) learns the address anew
      udp_nonce = 0;
      if (caps & kCapUdpPose) start_udp();
      keepalive();
      return;
    }
    case MsgType::reject: {
      RejectMsg r;
      if (decode_reject(p, r) == Reject::ok) {
        // The message is the server's text: shown escaped, it cannot drive the terminal.
        end(Errc::disconnected, std::string("server refused the session: ") + reject_name(r.reason) + " (" +
                                    printable(r.message) + ")");
        return;
      }
      break;
    }
    case MsgType::bye: end(Errc::disconnected, "server said goodbye"); return;
    case MsgType::avatar_model: {
      AvatarModel m;
      if (decode_avatar_model(p, m) != Reject::ok) break;
      auto& a = avatars[m.avatar];
      const bool same = a.id == m.avatar && a.revision == m.revision;
      a.id = m.avatar;
      a.name = m.name;
      a.dof_count = m.dof_count;
      a.revision = m.revision;
      a.model_bytes = std::move(m.model_bytes);
      if (!same) {
        a.has_pose = false;
        a.lean.valid = false;  // frames after a new model start from a key frame
        a.key_requested = false;
      }
      stats.models++;
      stats.model_bytes += p.size();
      if (owner->on_model) owner->on_model(a);
      if (auto e = early.find(m.avatar); e != early.end()) {
        const std::vector<uint8_t> frame = std::move(e->second);
        early.erase(e);
        on_pose(frame, now_us, true);
      }
      return;
    }
    case MsgType::scene: {
      std::vector<SceneEntry> scene;
      if (decode_scene(p, scene) != Reject::ok) break;
      for (auto it = avatars.begin(); it != avatars.end();) {
        const bool listed = std::any_of(scene.begin(), scene.end(), [&](const SceneEntry& e) { return e.avatar == it->first; });
        if (listed) {
          ++it;
          continue;
        }
        const uint16_t gone = it->first;
        it = avatars.erase(it);
        if (owner->on_removed) owner->on_removed(gone);
      }
      return;
    }
    case MsgType::avatar_removed: {
      uint16_t id = 0;
      if (decode_avatar_removed(p, id) != Reject::ok) break;
      avatars.erase(id);
      if (owner->on_removed) owner->on_removed(id);
      return;
    }
    case MsgType::pose:
    case MsgType::pose_delta: on_pose(p, now_us, false); return;
    case MsgType::mesh_topology: {
      if (decode_mesh_topology(p, scratch_topology) != Reject::ok) break;
      auto it = avatars.find(scratch_topology.avatar);
      if (it == avatars.end()) break;
      it->second.mesh_indices = scratch_topology.indices;
      it->second.mesh_vertex_count = scratch_topology.vertex_count;
      return;
    }
    case MsgType::mesh: {
      auto it = avatars.find(pose_avatar(p));
      if (it == avatars.end()) break;
      // A frame draws with its topology's indices: one of another vertex count (or before any
      // topology) would index past its positions.
      if (it->second.mesh_indices.empty() || p.size() != mesh_packet_bytes(it->second.mesh_vertex_count)) break;
      if (decode_mesh(p, it->second.mesh_last, it->second.mesh_positions_m) != Reject::ok) break;
      it->second.mesh_frames++;
      stats.mesh_frames++;
      stats.mesh_bytes += p.size();
      if (owner->on_mesh) owner->on_mesh(it->second);
      return;
    }
    default: break;
  }
  stats.rejected++;
}

void Client::Impl::on_pose(std::span<const uint8_t> p, uint64_t now_us, bool datagram) {
  PoseHeader h;
  const bool lean = p[2] == uint8_t(MsgType::pose_delta);
  if (!lean && decode_pose(p, h, scratch_pose) != Reject::ok) {
    stats.rejected++;
    return;
  }
  if (lean) {
    h.avatar = pose_avatar(p);
    h.sequence = lean_pose_sequence(p);
  }
  auto it = avatars.find(h.avatar);
  if (it == avatars.end()) {
    if (!datagram) {
      stats.rejected++;
      return;
    }
    // A datagram may overtake the model it belongs to: kept until the model arrives.
    stats.udp_early++;
    auto e = early.find(h.avatar);
    if (e == early.end() && early.size() < kMaxEarly) e = early.emplace(h.avatar, std::vector<uint8_t>{}).first;
    auto sequence_of = [](std::span<const uint8_t> q) {
      return q[2] == uint8_t(MsgType::pose_delta) ? lean_pose_sequence(q) : pose_sequence(q);
    };
    if (e != early.end() && (e->second.empty() || static_cast<int32_t>(h.sequence - sequence_of(e->second)) > 0))
      e->second.assign(p.begin(), p.end());
    return;
  }
  auto& a = it->second;
  if (lean) {
    // The reference rule: a delta applies only on top of the frame right before it; without
    // it, drop the delta and ask once for a key frame (docs/protocol.md).
    const Reject e = decode_lean_pose(p, a.lean, h, scratch_pose);
    if (e == Reject::unexpected) {
      stats.lean_unreferenced++;
      if (!a.key_requested && (caps & kCapLeanPose)) {
        std::array<uint8_t, 16> buf{};
        queue_control(std::span<const uint8_t>(buf.data(), encode_key_request(a.id, buf)));
        flush();
        a.key_requested = true;
        stats.key_requests++;
      }
      return;
    }
    if (e == Reject::out_of_order) {
      stats.out_of_order++;
      return;
    }
    if (e != Reject::ok) {
      stats.rejected++;
      return;
    }
    if (lean_pose_is_key(p)) {
      stats.lean_keys++;
      a.key_requested = false;
    }
  }
  // A frame that does not fit the model would animate the wrong joints (docs/protocol.md).
  if (scratch_pose.dof_rad.size() != a.dof_count) {
    stats.rejected++;
    stats.wrong_dof_count++;
    return;
  }
  if (a.has_pose) {
    const int32_t step = static_cast<int32_t>(h.sequence - a.last.sequence);
    if (step <= 0) {
      stats.out_of_order++;
      return;
    }
    a.lost += uint64_t(step - 1);
    stats.lost += uint64_t(step - 1);
  }
  a.last = h;
  std::swap(a.pose, scratch_pose);
  a.has_pose = true;
  a.frames++;
  stats.frames++;
  stats.frame_bytes += p.size();
  if (datagram) stats.udp_frames++;
  if (owner->on_pose) owner->on_pose(a, now_us);
}

void Client::Impl::start_udp() {
  if (!usock) {
    const udp::endpoint server(endpoint.address(), endpoint.port());
    boost::system::error_code ec;
    usock.emplace(io);
    usock->open(server.protocol(), ec);
    // Connected: the kernel passes up datagrams from the server's address and port only.
    if (!ec) usock->connect(server, ec);
    if (ec) {
      usock.reset();
      return;  // frames keep coming over TCP
    }
    udp_receive();
  }
  register_udp();
}

void Client::Impl::register_udp() {
  if (!usock || token.empty() || fatal) return;
  std::array<uint8_t, kUdpRegisterBytes> buf{};
  boost::system::error_code ec;
  usock->send(asio::buffer(buf.data(), encode_udp_register({token, udp_nonce}, buf)), 0, ec);
  // Until the server answers, again in 250 ms; then once a second.
  udp_timer.expires_after(udp_ready ? std::chrono::milliseconds(1000) : std::chrono::milliseconds(250));
  udp_timer.async_wait([this](const boost::system::error_code& e) {
    if (!e) register_udp();
  });
}

void Client::Impl::keepalive() {
  keepalive_timer.expires_after(std::chrono::seconds(2));
  const uint64_t gen = generation;
  keepalive_timer.async_wait([this, gen](const boost::system::error_code& ec) {
    if (ec || gen != generation || !connected || fatal) return;
    std::array<uint8_t, kHeaderBytes> buf{};
    queue_control(std::span<const uint8_t>(buf.data(), encode_ping(buf)));
    flush();
    keepalive();
  });
}

void Client::Impl::udp_receive() {
  usock->async_receive(asio::buffer(uin), [this](const boost::system::error_code& ec, size_t n) {
    if (ec) {
      if (ec == asio::error::operation_aborted || !usock || !usock->is_open()) return;
      udp_receive();  // e.g. ICMP port unreachable while the server restarts
      return;
    }
    stats.bytes_in += n;
    const std::span<const uint8_t> d(uin.data(), n);
    Header h;
    UdpRegister echoed;
    if (decode_header(d, h) != Reject::ok || n < kHeaderBytes + h.payload_bytes ||
        (n != kHeaderBytes + h.payload_bytes && h.type != MsgType::pose_delta)) {
      stats.rejected++;
    } else if (h.type == MsgType::pose) {
      on_pose(d, wall_clock_us(), true);
    } else if (h.type == MsgType::pose_delta) {
      // Lean frames of several avatars may share a datagram, back to back.
      const uint64_t now = wall_clock_us();
      for (size_t at = 0; at < n;) {
        const auto rest = d.subspan(at);
        Header ph;
        if (decode_header(rest, ph) != Reject::ok || ph.type != MsgType::pose_delta ||
            rest.size() < kHeaderBytes + ph.payload_bytes) {
          stats.rejected++;
          break;
        }
        on_pose(rest.first(kHeaderBytes + ph.payload_bytes), now, true);
        at += kHeaderBytes + ph.payload_bytes;
      }
    } else if (h.type == MsgType::udp_register && decode_udp_register(d, echoed) == Reject::ok && echoed.token == token) {
      if (echoed.nonce != 0 && echoed.nonce == udp_nonce) {
        udp_ready = true;  // the server has seen us echo its nonce from this address
      } else {
        // A challenge: echo the nonce at once (the server sends frames here only after that).
        udp_ready = false;
        udp_nonce = echoed.nonce;
        std::array<uint8_t, kUdpRegisterBytes> buf{};
        boost::system::error_code ignore;
        usock->send(asio::buffer(buf.data(), encode_udp_register({token, udp_nonce}, buf)), 0, ignore);
      }
    } else {
      stats.rejected++;
    }
    udp_receive();
  });
}

void Client::Impl::flush() {
  if (writing || !connected) return;
  out.clear();
  out.insert(out.end(), control.begin(), control.end());
  control.clear();
  if (handshake_done) {
    for (auto& a : published) {
      if (!a.live || !a.pending) continue;
      a.pending = false;
      out.insert(out.end(), a.pose.begin(), a.pose.begin() + static_cast<long>(a.pose_size));
    }
  }
  if (out.empty()) return;
  writing = true;
  const uint64_t gen = generation;
  asio::async_write(*sock, asio::buffer(out), [this, gen](const boost::system::error_code& ec, size_t) {
    if (gen != generation) return;
    writing = false;
    if (ec) {
      lose_connection();
      return;
    }
    flush();
  });
}

Client::Client(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) { impl_->owner = this; }

Client::~Client() {
  if (!impl_) return;
  if (!impl_->fatal) impl_->fatal = Error{Errc::disconnected, "closed"};  // no reconnection now
  impl_->lose_connection();
  impl_->retry_timer.cancel();
  impl_->udp_timer.cancel();
  impl_->keepalive_timer.cancel();
  if (impl_->usock) {
    boost::system::error_code ec;
    impl_->usock->close(ec);
  }
  impl_->io.restart();
  impl_->io.poll();
}

Result<std::unique_ptr<Client>> Client::connect(const ClientOptions& options) {
  if (is_nats_url(options.connect)) {
    if (options.role != Role::subscriber)
      return fail(Errc::invalid_argument, "publishing into a NATS scene is mimic run --nats, not a client");
    auto relay = nats_detail::EmbeddedRelay::start(options.connect, options.udp);
    if (!relay) return tl::unexpected(relay.error());
    ClientOptions local = options;
    local.connect = (*relay)->endpoint();
    auto c = connect(local);
    if (c) (*c)->impl_->embedded_relay = std::move(*relay);
    return c;
  }
  auto hp = split_host_port(options.connect);
  if (!hp) return tl::unexpected(hp.error());
  auto impl = std::make_unique<Impl>();
  impl->opt = options;
  boost::system::error_code ec;
  auto addr = asio::ip::make_address(hp->first, ec);
  if (ec) {
    tcp::resolver resolver(impl->io);
    auto results = resolver.resolve(hp->first, std::to_string(hp->second), ec);
    if (ec || results.empty()) return fail(Errc::not_found, "cannot resolve '" + hp->first + "'");
    addr = results.begin()->endpoint().address();
  }
  impl->endpoint = tcp::endpoint(addr, hp->second);
  impl->out.reserve(16 * 1024);
  impl->control.reserve(4 * 1024);
  impl->scratch_pose.dof_rad.reserve(kMaxPoseDofs);
  std::unique_ptr<Client> client(new Client(std::move(impl)));
  Impl& d = *client->impl_;
  d.start_connection();
  const auto deadline = Clock::now() + seconds(options.connect_timeout_s) + std::chrono::milliseconds(100);
  while (!d.handshake_done && !d.fatal && !d.connect_error && Clock::now() < deadline) {
    if (d.io.stopped()) d.io.restart();
    d.io.run_one_until(deadline);
  }
  if (d.fatal) return tl::unexpected(*d.fatal);
  if (d.connect_error) return tl::unexpected(*d.connect_error);
  if (!d.handshake_done) return fail(Errc::timeout, "no answer from " + options.connect);
  return client;
}

Result<uint8_t> Client::add_avatar(const std::string& name, uint16_t dof_count, std::string model_bytes) {
  auto& d = *impl_;
  if (d.opt.role != Role::publisher) return fail(Errc::invalid_argument, "only publishers add avatars");
  if (dof_count > kMaxPoseDofs) return fail(Errc::out_of_range, "too many DOFs for a pose frame");
  for (uint8_t slot = 0; slot < kMaxSlots; ++slot) {
    auto& a = d.published[slot];
    if (a.live) continue;
    AvatarModel m;
    m.avatar = slot;
    m.dof_count = dof_count;
    m.name = name.substr(0, kMaxNameBytes);
    m.model_bytes = std::move(model_bytes);
    a.model_packet.resize(avatar_model_packet_bytes(m));
    if (encode_avatar_model(m, a.model_packet) == 0) return fail(Errc::out_of_range, "body model too large");
    a.live = true;
    a.name = m.name;
    a.dof_count = dof_count;
    d.queue_control(a.model_packet);
    d.flush();
    return slot;
  }
  return fail(Errc::out_of_range, "a publisher carries at most 16 avatars");
}

Status Client::publish_pose(uint8_t slot, const PoseHeader& header, const avatar::Pose& pose) {
  auto& d = *impl_;
  if (slot >= kMaxSlots || !d.published[slot].live) return fail(Errc::not_found, "no such avatar slot");
  auto& a = d.published[slot];
  if (pose.dof_rad.size() != a.dof_count) return fail(Errc::invalid_argument, "pose has the wrong DOF count");
  PoseHeader h = header;
  h.avatar = slot;
  a.pose_size = encode_pose(h, pose, a.pose);
  a.pending = true;
  d.flush();
  return d.status();
}

Status Client::run_until(Clock::time_point deadline) {
  auto& d = *impl_;
  if (d.fatal) return d.status();
  if (d.dropped && !d.connecting && (!d.opt.reconnect || d.token.empty()))
    return fail(Errc::disconnected, "connection to " + d.opt.connect + " lost");
  while (Clock::now() < deadline && !d.fatal) {
    if (d.io.stopped()) d.io.restart();
    d.io.run_one_until(deadline);
  }
  return d.status();
}

Status Client::poll() {
  auto& d = *impl_;
  if (d.io.stopped()) d.io.restart();
  d.io.poll();
  return d.status();
}

void Client::drop_connection() { impl_->lose_connection(); }

void Client::close() {
  auto& d = *impl_;
  if (!d.connected) return;
  std::array<uint8_t, 16> buf{};
  const size_t n = encode_bye(buf);
  boost::system::error_code ec;
  // Whatever is still queued goes first; BYE is the last thing on the stream.
  asio::write(*d.sock, asio::buffer(d.control), ec);
  asio::write(*d.sock, asio::buffer(buf.data(), n), ec);
  d.token = SessionToken{};
  d.lose_connection();
  d.dropped = false;
  d.fatal = Error{Errc::disconnected, "closed"};
}

bool Client::connected() const { return impl_->connected; }
bool Client::udp_active() const { return impl_->udp_ready && impl_->connected; }
SessionToken Client::session_token() const { return impl_->token; }
uint32_t Client::negotiated_capabilities() const { return impl_->caps; }
const std::map<uint16_t, RemoteAvatar>& Client::avatars() const { return impl_->avatars; }
const ClientStats& Client::stats() const { return impl_->stats; }

}  // namespace mimic::net
