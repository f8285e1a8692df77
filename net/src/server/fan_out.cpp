// What subscribers get, and how: a control queue where the newest model of an avatar replaces an
// older one still waiting (models are shared between sessions, never copied per subscriber), one
// pending frame slot per avatar (latest wins), one write in flight per session, datagrams for
// registered UDP subscribers.
#include <sys/socket.h>

#include <algorithm>
#include <cstring>

#include "server/server_impl.h"

namespace mimic::net {

void Session::send_model(Avatar& a) {
  auto it = models_known.find(a.id);
  if (it != models_known.end() && it->second == a.revision) return;
  queue_model(a.id, a.model_packet);
  models_known[a.id] = a.revision;
  // Frames after a new model start from a key frame.
  if (a.id < lean_sent.size()) lean_sent[a.id] = 0;
  srv.stats.model_bytes_out += a.model_packet->size();
}

void Session::queue_control(std::span<const uint8_t> bytes) {
  if (closed) return;
  if (control_bytes + bytes.size() > srv.opt.max_control_backlog_bytes) {
    srv.stats.sessions_closed_slow++;
    close(false);
    return;
  }
  control.push_back({std::make_shared<const std::vector<uint8_t>>(bytes.begin(), bytes.end()), 0});
  control_bytes += bytes.size();
}

void Session::queue_model(uint16_t avatar_id, const SharedBytes& packet) {
  if (closed) return;
  // Latest wins: a model of this avatar still waiting is replaced where it stands.
  for (auto& c : control)
    if (c.model_of == avatar_id) {
      control_bytes = control_bytes - c.bytes->size() + packet->size();
      c.bytes = packet;
      return;
    }
  if (control_bytes + packet->size() > srv.opt.max_control_backlog_bytes) {
    srv.stats.sessions_closed_slow++;
    close(false);
    return;
  }
  control.push_back({packet, avatar_id});
  control_bytes += packet->size();
}

void Session::drop_queued_model(uint16_t avatar_id) {
  for (auto it = control.begin(); it != control.end(); ++it)
    if (it->model_of == avatar_id) {
      control_bytes -= it->bytes->size();
      control.erase(it);
      return;
    }
}

void Session::ensure_slot(uint16_t avatar_id) {
  if (pending_flag.size() <= avatar_id) {
    pending_flag.resize(avatar_id + 1u, 0);
    pending_mesh_flag.resize(avatar_id + 1u, 0);
    topology_sent.resize(avatar_id + 1u, 0);
    lean_sent.resize(avatar_id + 1u, 0);
  }
}

std::span<const uint8_t> Session::frame_bytes(Avatar& a) {
  if (!(caps & kCapLeanPose) || !a.lean_ok || a.id >= lean_sent.size()) return {a.pose.data(), a.pose_size};
  // The reference rule (docs/protocol.md): a delta only to a receiver that was sent the frame
  // right before; anyone else (joined, skipped frames, asked for a key) gets the key frame.
  uint32_t& sent = lean_sent[a.id];
  const auto p = a.lean.packet_for(sent);
  sent = a.sequence;
  if (lean_pose_is_key(p)) srv.stats.lean_keys_out++;
  else srv.stats.lean_deltas_out++;
  return p;
}

void Session::on_key_request(std::span<const uint8_t> packet) {
  uint16_t avatar_id = 0;
  if (decode_key_request(packet, avatar_id) != Reject::ok) return;
  srv.stats.key_requests++;
  if (avatar_id < lean_sent.size()) lean_sent[avatar_id] = 0;
}

void Session::mark_pose(uint16_t avatar_id) {
  if (avatar_id >= pending_flag.size()) return;  // sized when the avatar was announced
  if (pending_flag[avatar_id]) {
    frames_dropped++;
    srv.stats.frames_dropped++;
    return;
  }
  pending_flag[avatar_id] = 1;
  pending.push_back(avatar_id);
}

void Session::topology_changed(uint16_t avatar_id, uint8_t lod) {
  if (!active || role != Role::subscriber || lod != mesh_lod) return;
  ensure_slot(avatar_id);
  topology_sent[avatar_id] = 0;
}

void Session::mark_mesh(uint16_t avatar_id) {
  if (avatar_id >= pending_mesh_flag.size()) return;
  if (pending_mesh_flag[avatar_id]) return;
  pending_mesh_flag[avatar_id] = 1;
  pending_mesh.push_back(avatar_id);
}

// Pose frames as datagrams: one per frame, at once, even while a model is still being written on
// the stream; queued for one sendmmsg per fan-out. A full socket buffer drops the frame (latest
// wins anyway; a lean receiver asks for a key).
void Session::send_poses_udp() {
  for (uint16_t aid : pending) {
    pending_flag[aid] = 0;
    Avatar* a = srv.avatar(aid);
    if (!a || !a->has_pose) continue;
    const auto bytes = frame_bytes(*a);
    // Lean receivers take several frames per datagram (up to its size limit); others one.
    auto& batch = srv.udp_batch;
    const bool join = (caps & kCapLeanPose) && !batch.empty() && batch.back().to == udp_peer &&
                      batch.back().size + bytes.size() <= kMaxDatagramBytes &&
                      batch.back().first_piece + batch.back().pieces == srv.udp_pieces.size();
    if (!join) batch.push_back({srv.udp_pieces.size(), 0, 0, 0, udp_peer});
    srv.udp_pieces.push_back({bytes.data(), bytes.size()});
    batch.back().pieces++;
    batch.back().size += bytes.size();
    batch.back().frames++;
    frames_out++;
  }
  pending.clear();
}

void ServerImpl::send_udp_batch() {
  if (udp_batch.empty()) return;
  constexpr size_t kChunk = 1024;
  const size_t n = std::min(udp_batch.size(), kChunk);
  udp_scratch.resize(n * sizeof(mmsghdr) + udp_pieces.size() * sizeof(iovec));
  auto* msgs = reinterpret_cast<mmsghdr*>(udp_scratch.data());
  auto* iov = reinterpret_cast<iovec*>(udp_scratch.data() + n * sizeof(mmsghdr));
  for (size_t i = 0; i < udp_pieces.size(); ++i) {
    iov[i].iov_base = const_cast<uint8_t*>(udp_pieces[i].bytes);
    iov[i].iov_len = udp_pieces[i].size;
  }
  const int fd = udp_sock.native_handle();
  for (size_t begin = 0; begin < udp_batch.size();) {
    const size_t m = std::min(kChunk, udp_batch.size() - begin);
    for (size_t i = 0; i < m; ++i) {
      UdpOut& d = udp_batch[begin + i];
      std::memset(&msgs[i], 0, sizeof(mmsghdr));
      msgs[i].msg_hdr.msg_name = d.to.data();
      msgs[i].msg_hdr.msg_namelen = socklen_t(d.to.size());
      msgs[i].msg_hdr.msg_iov = &iov[d.first_piece];
      msgs[i].msg_hdr.msg_iovlen = d.pieces;
    }
    const int sent = ::sendmmsg(fd, msgs, unsigned(m), MSG_DONTWAIT);
    stats.udp_send_calls++;
    const size_t ok = sent > 0 ? size_t(sent) : 0;
    for (size_t i = 0; i < ok; ++i) {
      stats.udp_frames_out += udp_batch[begin + i].frames;
      stats.frames_out += udp_batch[begin + i].frames;
      stats.bytes_out += udp_batch[begin + i].size;
    }
    // The datagram after the last one sent failed (full buffer, unreachable): dropped.
    const size_t skip = ok < m ? 1 : 0;
    if (skip) stats.frames_dropped += udp_batch[begin + ok].frames;
    begin += ok + skip;
  }
  udp_batch.clear();
  udp_pieces.clear();
}

void Session::flush() {
  if (closed || !active) return;
  if (udp_ready) {
    send_poses_udp();
    // One sendmmsg per fan-out (sent when it ends); any other flush sends its datagrams now.
    if (!srv.batching && !srv.fanning_out) srv.send_udp_batch();
  }
  if (writing) return;
  // One gather write: small packets and frames are copied into `out`, model packets are written
  // from the shared buffer itself. Segments record where each piece goes, in order.
  struct Segment {
    const uint8_t* shared = nullptr;  // nullptr: out[begin, begin + size)
    size_t begin = 0, size = 0;
    bool transient = false;  // in an avatar's frame buffer, valid until its next frame
  };
  std::array<Segment, 64> segs_inline;
  std::vector<Segment> segs_more;
  size_t nsegs = 0;
  auto add_segment = [&](Segment s) {
    if (nsegs < segs_inline.size()) segs_inline[nsegs] = s;
    else segs_more.push_back(s);
    ++nsegs;
  };
  auto segment = [&](size_t i) -> Segment& { return i < segs_inline.size() ? segs_inline[i] : segs_more[i - segs_inline.size()]; };
  auto add_out = [&](const uint8_t* p, size_t n) {
    const size_t begin = out.size();
    out.insert(out.end(), p, p + n);
    if (nsegs > 0 && segment(nsegs - 1).shared == nullptr) segment(nsegs - 1).size += n;
    else add_segment({nullptr, begin, n, false});
  };
  out.clear();
  out_shared.clear();
  for (const auto& c : control) {
    if (c.model_of != 0) {
      add_segment({c.bytes->data(), 0, c.bytes->size(), false});
      out_shared.push_back(c.bytes);
    } else {
      add_out(c.bytes->data(), c.bytes->size());
    }
  }
  control.clear();
  control_bytes = 0;
  // Frames are written from the avatar's own buffer (encoded once for every subscriber), not
  // copied; only if the write goes asynchronous is the rest copied (below).
  for (uint16_t aid : pending) {
    pending_flag[aid] = 0;
    Avatar* a = srv.avatar(aid);
    if (!a || !a->has_pose) continue;
    const auto bytes = frame_bytes(*a);
    add_segment({bytes.data(), 0, bytes.size(), true});
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
      add_out(m.topology.data(), m.topology.size());
      topology_sent[aid] = 1;
    }
    add_out(m.frame.data(), m.frame_size);
    srv.stats.mesh_frames_out++;
  }
  pending_mesh.clear();
  if (nsegs == 0) return;
  // `out` no longer grows: its pointers are stable for the write.
  out_buffers.clear();
  out_transient.clear();
  size_t total = 0;
  for (size_t i = 0; i < nsegs; ++i) {
    const Segment& s = segment(i);
    out_buffers.emplace_back(s.shared ? s.shared : out.data() + s.begin, s.size);
    out_transient.push_back(s.transient ? 1 : 0);
    total += s.size;
  }
  srv.stats.bytes_out += total;
  // Try the kernel first: on a healthy connection the whole batch fits the socket buffer and no
  // asynchronous operation (or completion handler) is needed at all.
  boost::system::error_code write_ec;
  const size_t sent = sock.write_some(out_buffers, write_ec);
  if (write_ec && write_ec != asio::error::would_block && write_ec != asio::error::try_again) {
    close(false);
    return;
  }
  if (!write_ec && sent == total) {
    out_shared.clear();
    return;
  }
  // Drop what the kernel took from the front of the buffer list.
  size_t done = write_ec ? 0 : sent;
  size_t first = 0;
  while (first < out_buffers.size() && done >= out_buffers[first].size()) done -= out_buffers[first++].size();
  out_buffers.erase(out_buffers.begin(), out_buffers.begin() + static_cast<long>(first));
  out_transient.erase(out_transient.begin(), out_transient.begin() + static_cast<long>(first));
  if (!out_buffers.empty()) out_buffers.front() += done;
  // Frames still unwritten point into avatar buffers the next tick overwrites: copy them.
  out_tail.clear();
  for (size_t i = 0; i < out_buffers.size(); ++i)
    if (out_transient[i]) {
      const auto* p = static_cast<const uint8_t*>(out_buffers[i].data());
      out_tail.insert(out_tail.end(), p, p + out_buffers[i].size());
    }
  for (size_t i = 0, at = 0; i < out_buffers.size(); ++i)
    if (out_transient[i]) {
      const size_t n = out_buffers[i].size();
      out_buffers[i] = asio::const_buffer(out_tail.data() + at, n);
      at += n;
    }
  writing = true;
  asio::async_write(sock, out_buffers, [self = shared_from_this()](const boost::system::error_code& ec, size_t) {
    self->writing = false;
    self->out_shared.clear();
    if (ec) {
      self->close(false);
      return;
    }
    self->flush();
  });
}

// A write in flight still holding a model revision that is no longer its avatar's current one.
bool Session::pins_stale_model() const {
  if (!writing) return false;
  for (const auto& p : out_shared) {
    bool current = false;
    for (const auto& a : srv.avatars)
      if (a.live && a.model_packet == p) current = true;
    if (!current) return true;
  }
  return false;
}

// Models are latest-wins, so the memory they take is one packet per avatar plus old revisions
// pinned by writes to stalled subscribers. Over the cap, those subscribers are the slow ones:
// they are disconnected (and may resume, fetching only the current revision).
void ServerImpl::enforce_model_memory_cap() {
  stats.model_bytes_held = *model_bytes_held;
  if (*model_bytes_held <= opt.max_model_bytes_held) return;
  for (auto& s : sessions) {
    if (s->closed || !s->pins_stale_model()) continue;
    stats.sessions_closed_slow++;
    s->close(false);
  }
}

void ServerImpl::fan_out_pose(uint16_t id) {
  fanning_out = true;
  for (auto& s : sessions) {
    if (!s->active || s->role != Role::subscriber) continue;
    s->mark_pose(id);
    if (!batching) s->flush();
  }
  fanning_out = false;
  if (!batching) send_udp_batch();
}

}  // namespace mimic::net
