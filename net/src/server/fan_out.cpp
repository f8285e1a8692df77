// What subscribers get, and how: a control queue where the newest model of an avatar replaces an
// older one still waiting (models are shared between sessions, never copied per subscriber), one
// pending frame slot per avatar (latest wins), one write in flight per session, datagrams for
// registered UDP subscribers. A tick's pose frames are written by a few threads (lanes), each
// subscriber by one of them.
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <climits>
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
  reserve_pieces();
}

// Models do not count against the control backlog: a queue holds at most one per avatar (a newer
// revision replaces the one waiting) and each is the server's shared packet, not a copy, so what
// a stalled subscriber pins is bounded by the scene's models (max_model_bytes_held, and
// enforce_model_memory_cap for revisions a write in flight still holds). A joiner is sent the
// whole scene, however large, as fast as it reads.
void Session::queue_model(uint16_t avatar_id, const SharedBytes& packet) {
  if (closed) return;
  for (auto& c : control)
    if (c.model_of == avatar_id) {
      c.bytes = packet;
      return;
    }
  control.push_back({packet, avatar_id});
  reserve_pieces();
}

void Session::drop_queued_model(uint16_t avatar_id) {
  for (auto it = control.begin(); it != control.end(); ++it)
    if (it->model_of == avatar_id) {
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

namespace {

// Capacity for at least n, grown geometrically (called once per avatar or control packet).
template <class V>
void reserve_at_least(V& v, size_t n) {
  if (v.capacity() < n) v.reserve(std::max(n, 2 * v.capacity()));
}

}  // namespace

void Session::reserve_pieces() {
  // A write's pieces: its control packets, and per avatar a frame, a topology and a mesh frame.
  const size_t pieces = control.size() + 3 * pending_flag.size() + 1;
  reserve_at_least(srv.lanes[0].iov, pieces);  // the server's thread writes these
  reserve_at_least(srv.lanes[0].pieces, pieces);
  reserve_at_least(out_buffers, pieces);
  reserve_at_least(out_shared, pieces);
}

void Session::reserve_buffers() {
  try {
    reserve_at_least(pending, pending_flag.size());
    reserve_at_least(pending_mesh, pending_flag.size());
    reserve_pieces();
    // What the kernel did not take of a write is copied here: room for a frame of every avatar
    // and mesh frames at this session's LOD (at least the largest, at most a few MiB of them);
    // beyond it, frames wait in their slots. Not while a write in flight points into it: when
    // that write completes.
    size_t tail = std::max(kMaxDatagramBytes, srv.frame_bytes_bound);
    constexpr size_t kMeshTailBytes = 4u << 20;
    if (mesh_lod < kMaxLods)
      tail += std::max(srv.mesh_frame_largest[mesh_lod], std::min(srv.mesh_bytes_bound[mesh_lod], kMeshTailBytes));
    if (!writing && tail > out_tail.capacity()) out_tail.reserve(tail);
  } catch (const std::bad_alloc&) {
    // This subscriber's buffers could not grow: it goes, the scene and everyone else stay.
    srv.stats.sessions_out_of_memory++;
    fail();
  }
}

// The larger of a POSE frame and a lean key frame of `dofs` DOFs (which carries its values and
// the previous frame's, by groups of 4: a 4-bit width and at most 20 bits a value).
size_t frame_bytes_bound(uint16_t dofs) {
  const size_t groups = (4u + dofs + 3) / 4;
  const size_t lean_key = kHeaderBytes + 17 + 6 * 10 + (2 * groups * (4 + 4 * 20) + 7) / 8;
  return std::min(kMaxDatagramBytes, std::max(pose_packet_bytes(dofs), lean_key));
}

void ServerImpl::reserve_fanout() {
  const size_t n = sessions.size();
  reserve_at_least(ready, n);
  reserve_at_least(rest, n);
  reserve_at_least(deferred, n);  // a session waits there at most once
  size_t live = 0, udp_subscribers = 0;
  frame_bytes_bound = 0;
  mesh_bytes_bound.fill(0);
  mesh_frame_largest.fill(0);
  for (const auto& a : avatars) {
    if (!a.live) continue;
    live++;
    frame_bytes_bound += net::frame_bytes_bound(a.dof_count);
    for (size_t l = 0; l < size_t(kMaxLods); ++l) {
      mesh_bytes_bound[l] += a.mesh[l].frame_capacity;
      mesh_frame_largest[l] = std::max(mesh_frame_largest[l], a.mesh[l].frame_capacity);
    }
  }
  for (const auto& s : sessions) udp_subscribers += s->active && (s->caps & kCapUdpPose);
  // At most one datagram per frame (lean subscribers take a tick in one).
  const size_t datagrams = udp_subscribers * std::max<size_t>(live, 1);
  for (auto& lane : lanes) {
    reserve_at_least(lane.unfinished, n);
    reserve_at_least(lane.iov, avatars.size());  // the lanes' writes carry pose frames only
    reserve_at_least(lane.pieces, avatars.size());
    reserve_at_least(lane.udp_batch, datagrams);
    reserve_at_least(lane.udp_pieces, datagrams);
    reserve_at_least(lane.udp_scratch, std::min<size_t>(datagrams, 1024) * sizeof(mmsghdr) + datagrams * sizeof(iovec));
  }
  // The fan-out's threads, before a tick needs them.
  if (n >= opt.fanout_parallel_from) pool.prepare(fanout_threads);
}

std::span<const uint8_t> Session::frame_bytes(Avatar& a, FanoutLane& lane) {
  if (!(caps & kCapLeanPose) || !a.lean_ok || a.id >= lean_sent.size()) return {a.pose.data(), a.pose_size};
  // The reference rule (docs/protocol.md): a delta only to a receiver that was sent the frame
  // right before; anyone else (joined, skipped frames, asked for a key) gets the key frame.
  uint32_t& sent = lean_sent[a.id];
  const auto p = a.lean.packet_for(sent);
  sent = a.sequence;
  if (lean_pose_is_key(p))
    lane.lean_keys_out++;
  else
    lane.lean_deltas_out++;
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
  reserve_buffers();  // a larger mesh frame
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
void Session::send_poses_udp(FanoutLane& lane) {
  for (uint16_t aid : pending) {
    pending_flag[aid] = 0;
    Avatar* a = srv.avatar(aid);
    if (!a || !a->has_pose) continue;
    const auto bytes = frame_bytes(*a, lane);
    // Lean receivers take several frames per datagram (up to its size limit); others one.
    auto& batch = lane.udp_batch;
    const bool join = (caps & kCapLeanPose) && !batch.empty() && batch.back().to == udp_peer &&
                      batch.back().size + bytes.size() <= kMaxDatagramBytes &&
                      batch.back().first_piece + batch.back().pieces == lane.udp_pieces.size();
    if (!join) batch.push_back({lane.udp_pieces.size(), 0, 0, 0, udp_peer});
    lane.udp_pieces.push_back({bytes.data(), bytes.size()});
    batch.back().pieces++;
    batch.back().size += bytes.size();
    batch.back().frames++;
    frames_out++;
  }
  pending.clear();
}

void ServerImpl::send_udp_batch(FanoutLane& lane) {
  auto& udp_batch = lane.udp_batch;
  auto& udp_pieces = lane.udp_pieces;
  auto& udp_scratch = lane.udp_scratch;
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
    lane.udp_send_calls++;
    const size_t ok = sent > 0 ? size_t(sent) : 0;
    for (size_t i = 0; i < ok; ++i) {
      lane.udp_frames_out += udp_batch[begin + i].frames;
      lane.frames_out += udp_batch[begin + i].frames;
      lane.bytes_out += udp_batch[begin + i].size;
    }
    // The datagram after the last one sent failed (full buffer, unreachable): dropped.
    const size_t skip = ok < m ? 1 : 0;
    if (skip) lane.frames_dropped += udp_batch[begin + ok].frames;
    begin += ok + skip;
  }
  udp_batch.clear();
  udp_pieces.clear();
}

// The pending pose frames onto lane.iov, each with the lean reference its receiver had before
// (settle_write restores it for a frame the kernel did not take).
void Session::gather_poses(FanoutLane& lane) {
  for (uint16_t aid : pending) {
    pending_flag[aid] = 0;
    Avatar* a = srv.avatar(aid);
    if (!a || !a->has_pose) continue;
    const uint32_t before = aid < lean_sent.size() ? lean_sent[aid] : 0;
    const auto bytes = frame_bytes(*a, lane);
    lane.iov.push_back({const_cast<uint8_t*>(bytes.data()), bytes.size()});
    lane.pieces.push_back({OutPiece::pose, aid, before});
    frames_out++;
    lane.frames_out++;
  }
  pending.clear();
}

void Session::flush() {
  if (closed || failed || !active) return;
  if (udp_ready) {
    send_poses_udp(srv.lanes[0]);
    // One sendmmsg per fan-out (sent when it ends); any other flush sends its datagrams now.
    if (!srv.batching && !srv.fanning_out) srv.send_udp_batch();
  }
  if (writing) return;
  // One gather write: control packets from their shared buffers, frames from the avatars' own
  // buffers (encoded once for every subscriber), never copied.
  FanoutLane& lane = srv.lanes[0];
  out_shared.clear();
  lane.iov.clear();
  lane.pieces.clear();
  for (const auto& c : control) {
    lane.iov.push_back({const_cast<uint8_t*>(c.bytes->data()), c.bytes->size()});
    lane.pieces.push_back({OutPiece::shared, 0, 0});
    out_shared.push_back(c);
  }
  control.clear();
  control_bytes = 0;
  gather_poses(lane);
  for (uint16_t aid : pending_mesh) {
    pending_mesh_flag[aid] = 0;
    const Avatar* a = srv.avatar(aid);
    if (!a || mesh_lod >= kMaxLods) continue;
    const auto& m = a->mesh[mesh_lod];
    if (!m.topology || m.frame_size == 0) continue;
    if (!topology_sent[aid]) {
      const SharedBytes& topo = (caps & kCapMeshUv) && m.topology_uv ? m.topology_uv : m.topology;
      lane.iov.push_back({const_cast<uint8_t*>(topo->data()), topo->size()});
      lane.pieces.push_back({OutPiece::shared, aid, 0});
      out_shared.push_back({topo, 0});
      topology_sent[aid] = 1;
    }
    lane.iov.push_back({const_cast<uint8_t*>(m.frame.data()), m.frame_size});
    lane.pieces.push_back({OutPiece::mesh, aid, 0});
    lane.mesh_frames_out++;
  }
  pending_mesh.clear();
  if (lane.iov.empty()) return;
  int error = 0;
  if (send_now(lane, error))
    start_async();
  else if (error)
    fail();
}

// Straight to the kernel, without waiting: on a healthy connection the whole batch fits the
// socket buffer and no asynchronous operation (or completion handler) is needed at all. A large
// batch goes in calls of at most half the send buffer: a single call that fills it makes one
// segment of it on loopback (64 KiB MSS), which the receiver acknowledges only after its
// delayed-ACK timeout (40 ms), while two or more are acknowledged at once.
bool Session::send_now(FanoutLane& lane, int& error) {
  size_t total = 0;
  for (const iovec& v : lane.iov) total += v.iov_len;
  lane.bytes_out += total;
  const size_t call_bytes = std::max<size_t>(4096, size_t(std::max(srv.opt.send_buffer_bytes, 0)) / 2);
  size_t sent = 0;
  for (size_t first = 0; first < lane.iov.size();) {
    size_t end = first, bytes = 0;
    while (end < lane.iov.size() && end - first < IOV_MAX &&
           (end == first || bytes + lane.iov[end].iov_len <= call_bytes))
      bytes += lane.iov[end++].iov_len;
    msghdr m{};
    m.msg_iov = lane.iov.data() + first;
    m.msg_iovlen = end - first;
    const ssize_t n = ::sendmsg(sock.native_handle(), &m, MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n < 0) {
      if (errno != EAGAIN && errno != EWOULDBLOCK) {
        error = errno;
        return false;
      }
      break;
    }
    sent += size_t(n);
    if (size_t(n) < bytes) break;  // the kernel took what it could
    first = end;
  }
  if (sent == total) {
    out_shared.clear();
    return false;
  }
  return settle_write(sent, lane);
}

// What the kernel did not take of lane.iov goes to an asynchronous write: control packets
// from their shared buffers, frames copied (the next frame overwrites an avatar's buffer) into
// out_tail, which has room for a frame of every avatar. Frames beyond that room (only frames
// the kernel did not start) go back to their pending slot: the newest goes when the socket
// takes more, and a lean receiver's reference stays what it was sent.
bool Session::settle_write(size_t sent, FanoutLane& lane) {
  out_buffers.clear();
  out_tail.clear();
  size_t done = sent;
  for (size_t i = 0; i < lane.iov.size(); ++i) {
    const iovec& v = lane.iov[i];
    const OutPiece& p = lane.pieces[i];
    if (done >= v.iov_len) {
      done -= v.iov_len;
      continue;
    }
    const auto* bytes = static_cast<const uint8_t*>(v.iov_base) + done;
    const size_t rest = v.iov_len - done;
    const bool started = done > 0;
    done = 0;
    if (p.kind == OutPiece::shared) {
      out_buffers.emplace_back(bytes, rest);
      continue;
    }
    // Within the reserve, so out_tail never moves under the buffers pointing into it; the
    // frame the kernel took part of comes first and always fits (a frame is at most the
    // reserve's smallest size).
    if (started || out_tail.size() + rest <= out_tail.capacity()) {
      const size_t at = out_tail.size();
      out_tail.insert(out_tail.end(), bytes, bytes + rest);
      out_buffers.emplace_back(out_tail.data() + at, rest);
      continue;
    }
    lane.bytes_out -= v.iov_len;
    if (p.kind == OutPiece::pose) {
      if (p.avatar < lean_sent.size()) lean_sent[p.avatar] = p.lean_sent_before;
      if (!pending_flag[p.avatar]) {
        pending_flag[p.avatar] = 1;
        pending.push_back(p.avatar);
      }
      frames_out--;
      lane.frames_out--;
    } else if (p.kind == OutPiece::mesh) {
      if (!pending_mesh_flag[p.avatar]) {
        pending_mesh_flag[p.avatar] = 1;
        pending_mesh.push_back(p.avatar);
      }
      lane.mesh_frames_out--;
    }
  }
  if (out_buffers.empty()) out_shared.clear();
  return true;
}

void Session::start_async() {
  writing = true;
  // Asio allocates an operation for each asynchronous call, from memory it recycles only when
  // called on the event loop's own thread; from elsewhere (the realtime loop) it waits for the
  // next poll.
  if (srv.io.get_executor().running_in_this_thread())
    continue_async();
  else
    srv.deferred.push_back(shared_from_this());
}

// A connection that failed under a write. Closing it takes memory (its resume record, the
// event loop's clean-up), so it happens on the event loop: at once when called there, else (the
// realtime loop's fan-out) at the next poll; until then nothing more is written to it.
void Session::fail() {
  if (srv.io.get_executor().running_in_this_thread()) {
    close(false);
    return;
  }
  if (failed) return;
  failed = true;
  srv.deferred.push_back(shared_from_this());
}

void Session::continue_async() {
  if (failed) close(false);
  if (closed) {
    writing = false;
    return;
  }
  auto done = [self = shared_from_this()](const boost::system::error_code& ec, size_t = 0) {
    self->writing = false;
    self->out_shared.clear();
    self->reserve_buffers();  // what could not grow while the write was in flight
    if (ec) {
      self->close(false);
      return;
    }
    self->flush();
  };
  // Nothing but frames left (now pending again): wait until the socket takes more.
  if (out_buffers.empty())
    sock.async_wait(tcp::socket::wait_write, done);
  else
    asio::async_write(sock, out_buffers, done);
}

void ServerImpl::start_deferred() {
  for (auto& s : deferred) s->continue_async();
  deferred.clear();
}

// A write in flight still holding a model revision that is no longer its avatar's current one.
bool Session::pins_stale_model() const {
  if (!writing) return false;
  for (const auto& [p, model_of] : out_shared) {
    if (model_of == 0) continue;  // not a model
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

void Session::write_poses(FanoutLane& lane) {
  if (udp_ready) {
    send_poses_udp(lane);
    return;
  }
  lane.iov.clear();
  lane.pieces.clear();
  gather_poses(lane);
  if (lane.iov.empty()) return;
  // Straight from the avatars' buffers to the kernel, one system call per subscriber per tick.
  int error = 0;
  if (send_now(lane, error) || error) lane.unfinished.push_back({this, error});
}

// On the server's thread, after the lanes: a lane's write the kernel did not take whole.
void Session::finish_write(const FanoutLane::Unfinished& u) {
  if (closed) return;
  if (u.error) {
    fail();
    return;
  }
  start_async();
}

void ServerImpl::write_lane(FanoutLane& lane) {
  lane.unfinished.clear();
  for (size_t i = lane.begin; i < lane.end; ++i) ready[i]->write_poses(lane);
  send_udp_batch(lane);
}

void FanoutLane::add_to(ServerStats& s) {
  s.frames_out += frames_out;
  s.bytes_out += bytes_out;
  s.frames_dropped += frames_dropped;
  s.lean_keys_out += lean_keys_out;
  s.lean_deltas_out += lean_deltas_out;
  s.udp_frames_out += udp_frames_out;
  s.udp_send_calls += udp_send_calls;
  s.mesh_frames_out += mesh_frames_out;
  frames_out = bytes_out = frames_dropped = lean_keys_out = lean_deltas_out = udp_frames_out = udp_send_calls =
      mesh_frames_out = 0;
}

void ServerImpl::fold_lanes() {
  for (auto& lane : lanes) lane.add_to(stats);
}

// Every subscriber's pending frames go out: those with nothing but pose frames to send are shared
// between the lanes (contiguous runs, so each is written by one thread and its frames keep their
// order); the others, and everything that needs the event loop (asynchronous writes, closing),
// stay on the server's thread.
void ServerImpl::flush_subscribers() {
  const auto t0 = Clock::now();
  fanning_out = true;
  ready.clear();
  rest.clear();
  for (auto& s : sessions) {
    if (s->poses_only()) {
      if (!s->pending.empty()) ready.push_back(s.get());
    } else {
      rest.push_back(s.get());
    }
  }
  int n = 1;
  if (fanout_threads > 1 && ready.size() >= std::max<size_t>(opt.fanout_parallel_from, 2)) {
    n = int(std::min<size_t>(size_t(fanout_threads), ready.size()));
    // Lean key frames are encoded on first use: encode them now, so that the lanes only read
    // the avatars.
    for (auto& a : avatars)
      if (a.live && a.has_pose && a.lean_ok) a.lean.key();
  }
  n = std::min(n, int(lanes.size()));  // lanes are made with the server (reserve_fanout)
  for (int k = 0; k < n; ++k) {
    lanes[size_t(k)].begin = ready.size() * size_t(k) / size_t(n);
    lanes[size_t(k)].end = ready.size() * size_t(k + 1) / size_t(n);
  }
  const int ran = pool.run(
      n,
      [](void* self, int k) {
        static_cast<ServerImpl*>(self)->write_lane(static_cast<ServerImpl*>(self)->lanes[size_t(k)]);
      },
      this);
  // Lanes whose worker could not be started are written here.
  for (int k = ran; k < n; ++k) write_lane(lanes[size_t(k)]);
  if (ran > 1) stats.fanout_shared++;
  for (int k = 0; k < n; ++k)
    for (const auto& u : lanes[size_t(k)].unfinished) u.session->finish_write(u);
  for (Session* s : rest) s->flush();
  fanning_out = false;
  send_udp_batch();
  fanout_us[fanouts++ % fanout_us.size()] = std::chrono::duration<float, std::micro>(Clock::now() - t0).count();
}

void ServerImpl::fan_out_pose(uint16_t id) {
  for (auto& s : sessions)
    if (s->active && s->role == Role::subscriber) s->mark_pose(id);
  if (!batching) flush_subscribers();
}

}  // namespace mimic::net
