// The client's link: pose frames (over the stream or as datagrams), UDP registration, keep-alive,
// the stall watch, and what a cut costs (outage time, frames lost across sessions).
#include <sys/socket.h>

#include <algorithm>
#include <array>
#include <utility>

#include <boost/asio.hpp>

#include "client_impl.h"
#include "mimic/net/frame_codec.h"  // wall_clock_us

namespace mimic::net {

namespace asio = boost::asio;
using namespace client_detail;

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
  // A datagram between sessions belongs to the old one (the server forgot our address with
  // it): stale, and it must not make us ask for a key frame before HELLO.
  if (datagram && !handshake_done) return;
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
      if (!a.key_requested && (caps & kCapLeanPose) && handshake_done) {
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
  } else if (a.carried) {
    count_carried_loss(a, h);
  }
  a.last = h;
  std::swap(a.pose, scratch_pose);
  a.has_pose = true;
  a.frames++;
  stats.frames++;
  stats.frame_bytes += p.size();
  if (datagram) stats.udp_frames++;
  frames_flow_again(Clock::now());
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
    if (resync_if_stalled()) {
      stats.stale_datagrams++;  // this one too: it waited through the stall
      udp_receive();
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
    } else if (h.type == MsgType::udp_register && decode_udp_register(d, echoed) == Reject::ok &&
               echoed.token == token) {
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

void Client::Impl::cut(std::string why) {
  const bool was_up = handshake_done && !fatal;
  lose_connection();
  if (was_up && opt.reconnect && owner->on_cut) owner->on_cut(why);
}

void Client::Impl::start_watch() {
  if (watching || opt.stall_resync_s <= 0 || !opt.reconnect) return;
  watching = true;
  watch_seen = Clock::now();
  watch_timer.expires_after(std::chrono::milliseconds(100));
  watch_timer.async_wait([this](const boost::system::error_code& ec) {
    if (!ec && !fatal) resync_if_stalled();
    watching = false;
    if (!ec && !fatal) start_watch();
  });
}

bool Client::Impl::resync_if_stalled() {
  if (!watching) return false;
  const auto now = Clock::now();
  const bool stalled = now - watch_seen > seconds(opt.stall_resync_s);
  watch_seen = now;
  if (!stalled || !handshake_done || fatal) return false;
  stats.stall_resyncs++;
  stats.stale_datagrams += drain_udp();
  // Closing the stream drops what the kernel holds for it; the resumed session starts from the
  // newest frame of each avatar (the skipped ones count as lost, by sequence).
  cut("this side stalled for more than " + std::to_string(opt.stall_resync_s).substr(0, 4) +
      " s: buffered frames dropped, resuming");
  return true;
}

size_t Client::Impl::drain_udp() {
  if (!usock) return 0;
  size_t n = 0;
  std::array<uint8_t, kMaxDatagramBytes> sink{};
  while (::recv(usock->native_handle(), sink.data(), sink.size(), MSG_DONTWAIT) >= 0) n++;
  early.clear();
  return n;
}

void Client::Impl::frames_flow_again(Clock::time_point now) {
  last_frame_at = now;
  if (!outage_from) return;
  const double outage_s = std::chrono::duration<double>(now - *outage_from).count();
  outage_from.reset();
  stats.outages++;
  stats.outage_s += outage_s;
  stats.outage_max_s = std::max(stats.outage_max_s, outage_s);
  if (owner->on_back) owner->on_back(outage_s, stats.lost - lost_at_cut);
}

void Client::Impl::remember_departed() {
  for (const auto& [id, a] : avatars) remember_departed(a);
}

// An avatar that left (removed, or its session ended): kept a while, so that if the same one
// comes back (its publisher reconnected, the server restarted) its frames go on from here.
void Client::Impl::remember_departed(const RemoteAvatar& a) {
  if (!a.has_pose && !a.carried) return;
  DepartedAvatar d;
  d.id = a.id;
  d.name = a.name;
  d.dof_count = a.dof_count;
  d.model_hash = std::hash<std::string>{}(a.model_bytes);
  d.sequence = a.has_pose ? a.last.sequence : a.carried_sequence;
  d.time_us = a.has_pose ? a.last.time_us : a.carried_time_us;
  d.left = Clock::now();
  // One entry per avatar (a newer record replaces the older), none older than kDepartedFor.
  std::erase_if(departed, [&](const DepartedAvatar& o) {
    return (o.id == d.id && o.name == d.name && o.model_hash == d.model_hash) || d.left - o.left > kDepartedFor;
  });
  if (departed.size() < kMaxDeparted) departed.push_back(std::move(d));
}

// The same avatar is the same name, DOF count and model bytes; the same id wins when several
// match, and an ambiguous match carries nothing (better no count than a wrong one).
void Client::Impl::carry_over(RemoteAvatar& a) {
  a.carried = false;
  if (departed.empty()) return;
  std::erase_if(departed, [now = Clock::now()](const DepartedAvatar& o) { return now - o.left > kDepartedFor; });
  const size_t hash = std::hash<std::string>{}(a.model_bytes);
  auto same = [&](const DepartedAvatar& d) {
    return d.name == a.name && d.dof_count == a.dof_count && d.model_hash == hash;
  };
  auto pick =
      std::find_if(departed.begin(), departed.end(), [&](const DepartedAvatar& d) { return same(d) && d.id == a.id; });
  if (pick == departed.end() && std::count_if(departed.begin(), departed.end(), same) == 1)
    pick = std::find_if(departed.begin(), departed.end(), same);
  if (pick == departed.end()) return;
  a.carried = true;
  a.carried_sequence = pick->sequence;
  a.carried_time_us = pick->time_us;
  departed.erase(pick);
}

// The first frame of an avatar after the scene came back anew: the frames between its last one
// before the cut and this one were lost, if this is the same publisher going on (its sequence
// moved forward, and by no more than its capture times allow at 2 kHz; a publisher that
// restarted counts from zero again and carries nothing).
void Client::Impl::count_carried_loss(RemoteAvatar& a, const PoseHeader& h) {
  a.carried = false;
  const int32_t step = static_cast<int32_t>(h.sequence - a.carried_sequence);
  if (step <= 0 || h.time_us <= a.carried_time_us) return;
  const double elapsed_s = double(h.time_us - a.carried_time_us) * 1e-6;
  if (double(step - 1) > elapsed_s * 2000.0 + 16.0) return;
  a.lost += uint64_t(step - 1);
  stats.lost += uint64_t(step - 1);
  stats.lost_across_sessions += uint64_t(step - 1);
}

}  // namespace mimic::net
