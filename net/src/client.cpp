#include <utility>

#include "mimic/net/client.h"

#include <algorithm>
#include <array>
#include <boost/asio.hpp>
#include <cstring>
#include <optional>

#include "client_impl.h"
#include "mimic/core/host_port.h"

namespace mimic::net {

namespace asio = boost::asio;
using namespace client_detail;

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
    // HELLO goes first: nothing queued while the connection was down (a key request, a PING)
    // belongs to this connection, and the server refuses anything before HELLO.
    control.clear();
    Hello h;
    h.role = opt.role;
    h.name = opt.name.substr(0, kMaxNameBytes);
    h.secret = opt.secret;
    h.mesh_lod = opt.mesh_lod;
    h.capabilities = kCapPose | kCapResume | (opt.mesh_lod != kNoMesh ? uint32_t(kCapMesh | kCapMeshUv) : 0u) |
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

void Client::Impl::lose_connection() {
  if (!connected && !connecting) return;
  // A session that was up is cut: whatever the cause, the client comes back (when it may).
  if (handshake_done && !fatal && !token.empty()) {
    // Sessions cut right after their WELCOME, twice in a row (a server that takes us and drops
    // us at once): back off instead of reconnecting at once, over and over.
    if (Clock::now() - welcome_at >= std::chrono::seconds(1))
      short_sessions = 0;
    else if (++short_sessions >= 2)
      failures++;
    stats.cuts++;
    if (!outage_from) {
      outage_from = last_frame_at == Clock::time_point{} ? Clock::now() : last_frame_at;
      lost_at_cut = stats.lost;
    }
  }
  connected = false;
  connecting = false;
  handshake_done = false;
  dropped = true;
  udp_ready = false;  // the server forgets the address with the session; registered again after WELCOME
  ++generation;
  boost::system::error_code ec;
  if (sock) sock->close(ec);
  writing = false;
  handshake_timer.cancel();
  schedule_retry();
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
  sock->async_read_some(
      asio::buffer(space.data(), space.size()), [this, gen](const boost::system::error_code& ec, size_t n) {
        if (gen != generation) return;
        if (ec) {
          cut(ec == asio::error::eof ? "the server closed the connection" : "connection lost: " + ec.message());
          return;
        }
        // Bytes that waited while this thread stalled are old: dropped, resumed.
        if (resync_if_stalled()) return;
        stats.bytes_in += n;
        reader.commit(n);
        for (;;) {
          std::span<const uint8_t> p;
          const Reject e = reader.next(p);
          if (e != Reject::ok) {
            stats.rejected++;
            const std::string why = std::string("bad stream from server: ") + reject_name(e);
            if (handshake_done)
              cut(why);
            else
              end(Errc::parse_error, why);
            return;
          }
          if (p.empty()) break;
          on_packet(p);
          if (gen != generation) return;
        }
        read();
      });
}

void Client::Impl::on_welcome(const Welcome& w) {
  const bool was_resume = !token.empty();
  token = w.session_token;
  caps = w.capabilities;
  handshake_done = true;
  welcome_at = Clock::now();
  connecting = false;
  dropped = false;
  failures = 0;
  handshake_timer.cancel();
  if (w.resumed) stats.resumed++;
  // The server did not know us (it restarted, or the grace period ran out): the scene
  // arrives afresh, so forget the old one.
  if (was_resume && !w.resumed && opt.role == Role::subscriber) {
    remember_departed();  // its frames to come are measured against the old ones
    std::vector<uint16_t> gone;
    for (const auto& entry : avatars) gone.push_back(entry.first);
    avatars.clear();
    early.clear();
    for (const uint16_t id : gone)
      if (owner->on_removed) owner->on_removed(id);
  }
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
  if (opt.role == Role::subscriber) start_watch();
}

void Client::Impl::on_reject(const RejectMsg& r) {
  // The message is the server's text: shown escaped, it cannot drive the terminal.
  const std::string why =
      std::string("server refused the session: ") + reject_name(r.reason) + " (" + printable(r.message) + ")";
  // Refusals that another try cannot change end the session: a bad secret, no common version,
  // a mesh LOD the server does not serve, and for a publisher what it sent (it would send it
  // again). Any other REJECT of a session we
  // had (the idle timeout after a stall, a full server while it restarts) is a cut like any other.
  const bool transient =
      r.reason == Reject::timeout || r.reason == Reject::server_full || r.reason == Reject::too_many_sessions;
  const bool final = r.reason == Reject::unauthorized || r.reason == Reject::unsupported_version ||
                     r.reason == Reject::unknown_version || r.reason == Reject::unavailable ||
                     (opt.role == Role::publisher && !transient);
  if (!final && opt.reconnect && !token.empty()) {
    if (!handshake_done) failures++;  // refused while coming back: try again, backing off
    cut(why);
    return;
  }
  end(Errc::disconnected, why);
}

void Client::Impl::on_packet(std::span<const uint8_t> p) {
  const auto type = static_cast<MsgType>(p[2]);
  const uint64_t now_us = wall_clock_us();
  switch (type) {
    case MsgType::welcome: {
      Welcome w;
      if (decode_welcome(p, w) != Reject::ok) break;
      on_welcome(w);
      return;
    }
    case MsgType::reject: {
      RejectMsg r;
      if (decode_reject(p, r) == Reject::ok) {
        on_reject(r);
        return;
      }
      break;
    }
    case MsgType::bye:
      // A server that stops says goodbye; one that starts again takes us back.
      if (handshake_done && opt.reconnect)
        cut("the server said goodbye");
      else
        end(Errc::disconnected, "server said goodbye");
      return;
    case MsgType::avatar_model: {
      AvatarModel m;
      if (decode_avatar_model(p, m) != Reject::ok) break;
      const auto had = avatars.find(m.avatar);
      // The same revision again: a resumed session is sent every model (docs/protocol.md).
      const bool same = had != avatars.end() && had->second.revision == m.revision;
      auto& a = avatars[m.avatar];
      a.id = m.avatar;
      a.name = m.name;
      a.dof_count = m.dof_count;
      a.revision = m.revision;
      a.model_bytes = std::move(m.model_bytes);
      if (!same) {
        a.has_pose = false;
        a.lean.valid = false;  // frames after a new model start from a key frame
        a.key_requested = false;
        carry_over(a);
      }
      stats.models++;
      stats.model_bytes += p.size();
      if (owner->on_model && !same) owner->on_model(a);
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
        const bool listed =
            std::any_of(scene.begin(), scene.end(), [&](const SceneEntry& e) { return e.avatar == it->first; });
        if (listed) {
          ++it;
          continue;
        }
        const uint16_t gone = it->first;
        remember_departed(it->second);
        it = avatars.erase(it);
        if (owner->on_removed) owner->on_removed(gone);
      }
      return;
    }
    case MsgType::avatar_removed: {
      uint16_t id = 0;
      if (decode_avatar_removed(p, id) != Reject::ok) break;
      if (auto it = avatars.find(id); it != avatars.end()) remember_departed(it->second);
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
      it->second.mesh_uv_source = scratch_topology.uv_source;
      it->second.mesh_uvs = scratch_topology.uvs;
      it->second.mesh_uv_indices = scratch_topology.uv_indices;
      it->second.mesh_topologies++;
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
  impl_->watch_timer.cancel();
  if (impl_->usock) {
    boost::system::error_code ec;
    impl_->usock->close(ec);
  }
  impl_->io.restart();
  impl_->io.poll();
}

Result<std::unique_ptr<Client>> Client::connect(const ClientOptions& options) {
  // A broker's scene is joined through a relay (open_scene_connection, mimic relay): the client
  // itself speaks Mimic's protocol over TCP and UDP only.
  // Not echoed: a broker address may carry USER:PASSWORD@.
  if (options.connect.find("://") != std::string::npos)
    return fail(Errc::invalid_argument,
                "a URL was given: a client connects to HOST:PORT of a Mimic server or relay (a broker's scene "
                "through a relay)");
  auto hp = split_host_port(options.connect);
  if (!hp) return tl::unexpected(hp.error());
  auto impl = std::make_unique<Impl>();
  impl->opt = options;
  boost::system::error_code ec;
  auto addr = asio::ip::make_address(hp->host, ec);
  if (ec) {
    tcp::resolver resolver(impl->io);
    auto results = resolver.resolve(hp->host, std::to_string(hp->port), ec);
    if (ec || results.empty()) return fail(Errc::not_found, "cannot resolve '" + hp->host + "'");
    addr = results.begin()->endpoint().address();
  }
  impl->endpoint = tcp::endpoint(addr, hp->port);
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

Status Client::publish_pose(uint8_t slot, const PoseHeader& header, const rig::Pose& pose) {
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

void Client::hold(std::shared_ptr<void> resource) { impl_->held.push_back(std::move(resource)); }

bool Client::connected() const { return impl_->connected; }
bool Client::udp_active() const { return impl_->udp_ready && impl_->connected; }
SessionToken Client::session_token() const { return impl_->token; }
uint32_t Client::negotiated_capabilities() const { return impl_->caps; }
const std::map<uint16_t, RemoteAvatar>& Client::avatars() const { return impl_->avatars; }
const ClientStats& Client::stats() const { return impl_->stats; }

}  // namespace mimic::net
