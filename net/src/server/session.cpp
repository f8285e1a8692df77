// A connection's life: the read loop, the packet rate limit, dispatch by state and role, refusal
// and close (with a resume record when the session may come back).
#include <algorithm>

#include "server/server_impl.h"

namespace mimic::net {

Session::Session(ServerImpl& s, tcp::socket socket) : srv(s), sock(std::move(socket)), hello_timer(s.io) {
  boost::system::error_code ec;
  const auto remote = sock.remote_endpoint(ec);
  if (!ec) peer_address = remote.address();
  scratch_pose.dof_rad.reserve(kMaxPoseDofs);
}

void Session::start() {
  tokens = srv.opt.max_packets_per_s;
  last_refill = last_heard = Clock::now();
  // The handshake deadline: HELLO must be complete in time, however slowly its bytes trickle.
  hello_timer.expires_after(seconds(srv.opt.hello_timeout_s));
  hello_timer.async_wait([self = shared_from_this()](const boost::system::error_code& ec) {
    if (ec || self->closed || self->active) return;
    self->count(Reject::timeout);
    self->srv.stats.sessions_timed_out++;
    self->refuse(Reject::timeout, "no HELLO in time");
  });
  read();
}

void Session::read() {
  if (closed) return;
  auto space = reader.write_space(4096);
  sock.async_read_some(
      asio::buffer(space.data(), space.size()),
      [self = shared_from_this()](const boost::system::error_code& ec, size_t n) { self->on_read(ec, n); });
}

void Session::on_read(const boost::system::error_code& ec, size_t n) {
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
    last_heard = Clock::now();
    if (!rate_ok()) {
      if (closed) return;  // a flood ends the session: nothing after it may be handled
      continue;
    }
    try {
      handle(packet);
    } catch (const std::bad_alloc&) {
      // What this peer asked for could not be allocated: it loses its session, nobody else
      // anything (an exception out of a handler would end the event loop and the process).
      srv.stats.sessions_out_of_memory++;
      close(false);
    }
    if (closed) return;
  }
  read();
}

// Token bucket: one second of burst; far over the limit means a flood, and the session ends.
bool Session::rate_ok() {
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

void Session::count(Reject e) {
  srv.stats.rejected[static_cast<size_t>(e)]++;
  rejected++;
}

void Session::handle(std::span<const uint8_t> packet) {
  // A closed session handles nothing: a HELLO here would register its token for UDP again after
  // close() took it out, and the session is freed right after.
  if (closed) return;
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
    case MsgType::ping: return;  // last_heard is all it is for
    case MsgType::key_request:
      if (role != Role::subscriber || !(caps & kCapLeanPose)) {
        e = Reject::unexpected;
        break;
      }
      on_key_request(packet);
      return;
    case MsgType::avatar_model: e = role == Role::publisher ? on_model(packet) : Reject::unexpected; break;
    case MsgType::pose: e = role == Role::publisher ? on_pose(packet) : Reject::unexpected; break;
    case MsgType::mesh_topology: e = role == Role::publisher ? on_mesh_topology(packet) : Reject::unexpected; break;
    case MsgType::mesh: e = role == Role::publisher ? on_mesh(packet) : Reject::unexpected; break;
    default: e = Reject::unexpected; break;
  }
  if (e == Reject::ok) return;
  count(e);
  // A broken message means a broken peer; order and role slips are only dropped.
  // Over one of the server's bounds (models, mesh memory) is not the peer's fault: only dropped.
  if (e != Reject::out_of_order && e != Reject::unexpected && e != Reject::unavailable) {
    srv.stats.sessions_closed_for_input++;
    refuse(e, "bad packet");
  }
}

// Sends REJECT, then closes once it is written (or at once if the peer is not reading).
void Session::refuse(Reject reason, const char* message) {
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

void Session::forget_token() {
  if (token.empty()) return;
  srv.resume.erase(token);
  // The token also keys this session's UDP registration: with the token gone, close() could no
  // longer find it, and a datagram would reach the freed session.
  if (auto it = srv.udp_sessions.find(token); it != srv.udp_sessions.end() && it->second == this)
    srv.udp_sessions.erase(it);
  token = SessionToken{};
}

void Session::close(bool clean) {
  if (closed) return;
  closed = true;
  boost::system::error_code ec;
  hello_timer.cancel();
  sock.shutdown(tcp::socket::shutdown_both, ec);
  sock.close(ec);
  if (active) {
    if (role == Role::publisher)
      srv.stats.publishers--;
    else
      srv.stats.subscribers--;
  }
  if (counted_per_address) {
    auto it = srv.sessions_per_address.find(peer_address);
    if (it != srv.sessions_per_address.end() && --it->second == 0) srv.sessions_per_address.erase(it);
    counted_per_address = false;
  }
  const auto now = Clock::now();
  if (auto it = srv.udp_sessions.find(token); !token.empty() && it != srv.udp_sessions.end() && it->second == this)
    srv.udp_sessions.erase(it);
  udp_ready = false;
  if (active && !clean && !token.empty() && (caps & kCapResume)) {
    ResumeRecord r;
    r.role = role;
    r.expires = now + seconds(srv.opt.resume_grace_s);
    r.slots = slots;
    srv.resume[token] = std::move(r);
  }
  // A publisher's avatars outlive a dropped connection for the grace period (it may resume);
  // a clean BYE removes them at once.
  for (const auto& [slot, avatar_id] : slots) {
    Avatar* a = srv.avatar(avatar_id);
    if (!a) continue;
    if (clean || token.empty()) {
      srv.drop_avatar(avatar_id);
    } else {
      a->owner = nullptr;
      a->orphaned = true;
      a->orphaned_at = now;
    }
  }
  slots.clear();
  // Queued models are not needed any more; the write in flight (if any) keeps its own until it
  // completes with an error.
  control.clear();
  control_bytes = 0;
  asio::post(srv.io, [self = shared_from_this()] { self->srv.remove_session(self.get()); });
}

}  // namespace mimic::net
