// What bounds the server's sessions: the total and per-address session limits at accept, the
// handshake deadline (session.cpp arms it), the idle timeout, and the housekeeping that expires
// resume records, orphaned avatars and UDP registrations.
#include <algorithm>

#include "server/secure_random.h"
#include "server/server_impl.h"

namespace mimic::net {

void ServerImpl::start_accept() {
  acceptor.async_accept([this](const boost::system::error_code& ec, tcp::socket sock) {
    if (ec == asio::error::operation_aborted || !acceptor.is_open()) return;
    if (ec) {
      // Out of descriptors or kernel memory: the connection stays in the backlog and the next
      // accept() fails the same way at once. Retrying at once would spin the event loop; wait,
      // longer each time, until a descriptor is freed.
      stats.accept_errors++;
      accept_backoff_ms = std::clamp(accept_backoff_ms * 2, 10, 500);
      accept_timer.expires_after(std::chrono::milliseconds(accept_backoff_ms));
      accept_timer.async_wait([this](const boost::system::error_code& tec) {
        if (!tec) start_accept();
      });
      return;
    }
    accept_backoff_ms = 0;
    try {
      on_accept(std::move(sock));
    } catch (const std::bad_alloc&) {
      stats.sessions_out_of_memory++;  // the socket closes with its handler; the server goes on
    }
    start_accept();
  });
}

void ServerImpl::on_accept(tcp::socket sock) {
  stats.sessions_accepted++;
  boost::system::error_code ignore;
  sock.set_option(tcp::no_delay(true), ignore);
  sock.non_blocking(true, ignore);  // flush() writes directly when the kernel has room
  if (opt.send_buffer_bytes > 0) sock.set_option(asio::socket_base::send_buffer_size(opt.send_buffer_bytes), ignore);
  auto s = std::make_shared<Session>(*this, std::move(sock));
  s->id = new_session_id();
  if (sessions.size() >= opt.max_sessions) {
    s->count(Reject::server_full);
    s->refuse(Reject::server_full, "server full");
    return;
  }
  // One host cannot take every slot: idle connections from one address stop at its limit.
  size_t& from_here = sessions_per_address[s->peer_address];
  if (from_here >= opt.max_sessions_per_address) {
    if (from_here == 0) sessions_per_address.erase(s->peer_address);
    s->count(Reject::too_many_sessions);
    stats.sessions_refused_per_address++;
    s->refuse(Reject::too_many_sessions, "too many sessions from this address");
    return;
  }
  ++from_here;
  s->counted_per_address = true;
  sessions.push_back(s);
  stats.sessions_open = sessions.size();
  reserve_fanout();
  s->start();
}

void ServerImpl::schedule_housekeeping() {
  housekeeping.expires_after(std::chrono::milliseconds(opt.housekeeping_period_ms));
  housekeeping.async_wait([this](const boost::system::error_code& ec) {
    if (ec) return;
    const auto now = Clock::now();
    for (auto it = resume.begin(); it != resume.end();) {
      if (it->second.expires <= now)
        it = resume.erase(it);
      else
        ++it;
    }
    const auto grace = seconds(opt.resume_grace_s);
    for (auto& a : avatars)
      if (a.live && a.orphaned && now - a.orphaned_at >= grace) drop_avatar(a.id);
    // A session that has said nothing for the idle timeout is gone or hostile (clients send a
    // PING when they have nothing else to say).
    if (opt.idle_timeout_s > 0) {
      const auto idle = seconds(opt.idle_timeout_s);
      for (auto& s : std::vector<std::shared_ptr<Session>>(sessions)) {
        if (s->closed || !s->active || now - s->last_heard < idle) continue;
        s->count(Reject::timeout);
        stats.sessions_timed_out++;
        s->refuse(Reject::timeout, "idle for too long");
      }
    }
    expire_udp_registrations(now);
    expire_secret_failures(now);
    schedule_housekeeping();
  });
}

// Client ids (WELCOME) are random, so one id says nothing of how many came before or of the next.
uint32_t ServerImpl::new_session_id() const {
  for (;;) {
    const auto id = static_cast<uint32_t>(secure_random_u64());
    if (id == 0) continue;
    if (std::none_of(sessions.begin(), sessions.end(), [id](const auto& s) { return s->id == id; })) return id;
  }
}

void ServerImpl::remove_session(Session* s) {
  auto it = std::find_if(sessions.begin(), sessions.end(), [s](const auto& p) { return p.get() == s; });
  if (it != sessions.end()) sessions.erase(it);
  stats.sessions_open = sessions.size();
}

}  // namespace mimic::net
