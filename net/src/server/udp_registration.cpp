// Pose frames as datagrams. A subscriber's address is registered only after it proved it receives
// what is sent there (return routability): the server answers a registration from a new address
// with a fresh nonce, and frames go to that address once a registration from it echoes the nonce.
// A spoofed source address never sees the nonce, so it never gets frames; the answer is the same
// size as the request, so the socket cannot amplify. By default the address must also be on the
// TCP peer's host. A registration that is not refreshed in time expires (frames go back to TCP).
#include "server/secure_random.h"
#include "server/server_impl.h"

namespace mimic::net {

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

namespace {

// A datagram whose source is the server's own port on this host: nobody but the server sends
// from there, so it is forged, and answering it would make the server answer itself for ever.
bool from_own_port(const udp::endpoint& from, const udp::endpoint& local) {
  if (from.port() != local.port()) return false;
  return from.address() == local.address() || from.address().is_loopback() || local.address().is_unspecified();
}

}  // namespace

void ServerImpl::on_datagram(std::span<const uint8_t> datagram) {
  stats.udp_datagrams_in++;
  stats.bytes_in += datagram.size();
  if (from_own_port(udp_from, udp_local)) {
    stats.udp_own_address++;
    return;
  }
  UdpRegister reg;
  Reject e = decode_udp_register(datagram, reg);
  Session* s = nullptr;
  if (e == Reject::ok) {
    auto it = udp_sessions.find(reg.token);
    if (reg.token.empty() || it == udp_sessions.end() || it->second->closed)
      e = Reject::unauthorized;
    else
      s = it->second;
  }
  if (e == Reject::ok && !opt.udp_from_any_address && udp_from.address() != s->peer_address) {
    stats.udp_wrong_address++;
    e = Reject::unauthorized;
  }
  if (e != Reject::ok) {
    stats.rejected[static_cast<size_t>(e)]++;
    return;
  }
  const auto now = Clock::now();
  // Answers per session are rate limited: whatever sends registrations (a retrying client, a
  // forged source, another server answering), this socket answers a bounded number.
  const double rate = opt.udp_answers_per_s;
  const double dt = std::chrono::duration<double>(now - s->udp_answer_refill).count();
  s->udp_answer_refill = now;
  s->udp_answer_tokens = std::min(rate, s->udp_answer_tokens + dt * rate);
  if (s->udp_answer_tokens < 1.0) {
    stats.udp_answers_limited++;
    return;
  }
  s->udp_answer_tokens -= 1.0;
  UdpRegister answer;
  answer.token = reg.token;
  if (s->udp_ready && udp_from == s->udp_peer && reg.nonce == s->udp_nonce) {
    s->udp_refreshed = now;  // a refresh from the registered address
    answer.nonce = s->udp_nonce;
  } else if (s->pending_nonce != 0 && udp_from == s->pending_peer && reg.nonce == s->pending_nonce) {
    // The candidate address echoed its nonce: it receives what is sent there. Frames move to it.
    if (!s->udp_ready) stats.udp_registered++;
    s->udp_ready = true;
    s->udp_peer = udp_from;
    s->udp_nonce = s->pending_nonce;
    s->udp_refreshed = now;
    s->pending_nonce = 0;
    answer.nonce = s->udp_nonce;
  } else {
    // A new address (or a stale nonce): challenge it. The same address keeps its nonce until it
    // echoes, so retries before the answer arrives do not race.
    if (s->pending_nonce == 0 || udp_from != s->pending_peer) {
      do s->pending_nonce = secure_random_u64();
      while (s->pending_nonce == 0);
      s->pending_peer = udp_from;
    }
    stats.udp_challenges++;
    answer.nonce = s->pending_nonce;
  }
  std::array<uint8_t, kUdpRegisterBytes> buf{};
  boost::system::error_code ignore;
  udp_sock.send_to(asio::buffer(buf.data(), encode_udp_register(answer, buf)), udp_from, 0, ignore);
}

void ServerImpl::expire_udp_registrations(Clock::time_point now) {
  const auto limit = seconds(opt.udp_registration_timeout_s);
  for (auto& s : sessions) {
    if (!s->udp_ready || now - s->udp_refreshed < limit) continue;
    s->udp_ready = false;
    stats.udp_expired++;
  }
}

}  // namespace mimic::net
