// NatsSceneFeed on the server thread: what the broker brought, checked, becomes what the
// server's viewers see. An avatar is served once its publisher shows life (a heartbeat naming
// it, or one of its frames) and leaves after `missed_heartbeats` of its publisher's periods
// without any; mesh frames go to the viewers that asked for their LOD.
#include <algorithm>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "mimic/net/server.h"
#include "scene_feed_impl.h"

namespace mimic::net {

void NatsSceneFeed::Impl::pump() {
  const auto now = Clock::now();
  {
    std::lock_guard lock(queue_mutex);
    pump_scheduled = false;
    models_work.swap(models_in);
    frames_work.swap(frames_in);
    meshes_work.swap(meshes_in);
    heartbeats_work.swap(heartbeats_in);
  }
  for (auto& e : models_work) apply_model(e);
  models_work.clear();
  for (const auto& hb : heartbeats_work) apply_heartbeat(hb, now);
  heartbeats_work.clear();
  // One frame per avatar per pass: a second frame of the same avatar would overwrite the
  // first in every subscriber's pending slot before its write could complete (latest wins),
  // so the rest waits for the next pass, after the server has run its writes.
  size_t used = 0;
  pass_keys.clear();
  // Heartbeats and models alone are no fan-out (nor counted as one in fanout_times).
  if (frames_work.empty() && meshes_work.empty()) return;
  server->begin_batch();
  for (; used < frames_work.size(); ++used) {
    Frame& f = frames_work[used];
    if (std::find(pass_keys.begin(), pass_keys.end(), f.key) != pass_keys.end()) break;
    pass_keys.push_back(f.key);
    apply_frame(f, now);
  }
  for (auto& m : meshes_work) apply_mesh(m);
  server->end_batch();
  meshes_work.clear();
  if (used < frames_work.size()) {
    std::lock_guard lock(queue_mutex);
    frames_in.insert(frames_in.begin(), std::make_move_iterator(frames_work.begin() + long(used)),
                     std::make_move_iterator(frames_work.end()));
    schedule_pump_locked();
  }
  frames_work.clear();
}

bool NatsSceneFeed::Impl::alive_at(const Known& k, Clock::time_point now) const {
  return k.alive_at != Clock::time_point{} &&
         now - k.alive_at <= std::chrono::milliseconds(int64_t(k.period_ms) * opt.missed_heartbeats);
}

bool NatsSceneFeed::Impl::show(Known& k) {
  if (k.shown) return true;
  auto id = server->add_avatar(k.name, k.dof_count, k.model_bytes);
  if (!id) {
    rejected++;
    set_error("avatar " + printable(k.name) + ": " + id.error().what());
    return false;
  }
  k.id = *id;
  k.shown = true;
  k.mesh_vertices = {};
  k.has_seq = false;
  avatar_count++;
  return true;
}

void NatsSceneFeed::Impl::hide(Known& k) {
  if (!k.shown) return;
  server->remove_avatar(k.id);
  k.shown = false;
  k.mesh_vertices = {};
  avatar_count--;
}

namespace {
uint64_t fnv1a(std::span<const uint8_t> bytes) {
  uint64_t h = 14695981039346656037ull;
  for (uint8_t b : bytes) {
    h ^= b;
    h *= 1099511628211ull;
  }
  return h;
}
}  // namespace

// An avatar leaves the relay: its model's memory goes back (to the system too, once enough
// has been freed; a relay flooded with models and then emptied shrinks again).
void NatsSceneFeed::Impl::forget(std::map<std::string, Known>::iterator it) {
  hide(it->second);
  model_bytes_held -= it->second.model_bytes.size();
  model_bytes_freed += it->second.model_bytes.size();
  if (auto o = key_owners.find(std::string_view(it->first).substr(it->first.size() - 16));
      o != key_owners.end() && --o->second == 0)
    key_owners.erase(o);
  avatars.erase(it);
}

void NatsSceneFeed::Impl::apply_model(ModelEvent& e) {
  auto it = avatars.find(e.key);
  if (e.removed) {
    if (it != avatars.end()) forget(it);
    return;
  }
  const uint64_t hash = fnv1a(e.packet);
  if (it != avatars.end() && it->second.packet_hash == hash && it->second.packet_size == e.packet.size()) {
    it->second.put_at = Clock::now();  // put again unchanged: only its age starts over
    return;
  }
  AvatarModel m;
  if (decode_avatar_model(e.packet, m) != Reject::ok) {
    rejected++;
    return;
  }
  // Bounded: one model's size, and all the relay keeps (a flood of models under a publisher's
  // keys is refused past the budget, not held).
  const size_t before = it == avatars.end() ? 0 : it->second.model_bytes.size();
  if (m.model_bytes.size() > opt.max_model_bytes ||
      model_bytes_held - before + m.model_bytes.size() > opt.max_scene_model_bytes) {
    models_refused++;
    return;
  }
  model_bytes_held += m.model_bytes.size();
  model_bytes_held -= before;
  if (it == avatars.end()) {
    Known& k = avatars[e.key];
    key_owners[e.key.substr(e.key.size() - 16)]++;
    k.put_at = Clock::now();
    k.revision = m.revision;
    k.dof_count = m.dof_count;
    k.name = std::move(m.name);
    k.model_bytes = std::move(m.model_bytes);
    k.packet_hash = hash;
    k.packet_size = e.packet.size();
    // Its publisher's heartbeat may have come first.
    if (auto h = heard.find(e.key); h != heard.end()) {
      k.alive_at = h->second.at;
      k.period_ms = h->second.period_ms;
      k.mesh_lod = h->second.mesh_lod;
      heard.erase(h);
    }
    models++;
    // A model whose publisher shows no life (a crashed one's, until the bucket's TTL takes it)
    // waits for a heartbeat or a frame rather than appearing and vanishing.
    if (alive_at(k, Clock::now())) show(k);
    return;
  }
  // A new model, or its publisher restarted (sequence numbers start again).
  Known& k = it->second;
  k.put_at = Clock::now();
  k.revision = m.revision;
  k.dof_count = m.dof_count;
  k.model_bytes = std::move(m.model_bytes);
  model_bytes_freed += before;
  k.packet_hash = hash;
  k.packet_size = e.packet.size();
  k.mesh_vertices = {};  // its mesh may differ too: asked for again
  k.has_seq = false;     // the server forgets the avatar's sequence with its model
  models++;
  if (k.shown)
    if (auto st = server->update_avatar_model(k.id, k.dof_count, k.model_bytes); !st) rejected++;
}

void NatsSceneFeed::Impl::apply_heartbeat(const Heartbeat& hb, Clock::time_point now) {
  for (size_t i = 0; i < hb.keys.size(); ++i) {
    const int8_t lod = i < hb.mesh_lods.size() ? hb.mesh_lods[i] : int8_t(-1);
    auto it = avatars.find(hb.keys[i]);
    if (it == avatars.end()) {
      if (heard.size() < 65536) heard[hb.keys[i]] = {now, hb.period_ms, lod};
      continue;
    }
    it->second.alive_at = now;
    it->second.period_ms = hb.period_ms;
    it->second.mesh_lod = lod;
    show(it->second);
  }
}

void NatsSceneFeed::Impl::apply_frame(Frame& f, Clock::time_point now) {
  auto it = avatars.find(f.key);
  PoseHeader h;
  // Whatever came through the broker is checked as a remote publisher's frame would be.
  if (it == avatars.end()) {
    // Another publisher's avatar named on this one's subject, or its model has not arrived yet
    // (or it has left).
    if (key_owners.count(std::string_view(f.key).substr(f.key.size() - 16)))
      foreign++;
    else
      early++;
    return;
  }
  Known& k = it->second;
  if (decode_pose(f.packet, h, scratch) != Reject::ok || scratch.dof_rad.size() != k.dof_count) {
    rejected++;
    return;
  }
  if (!show(k)) return;
  bool reset = false;
  if (!sequence_ok(k, h.sequence, now, reset)) return;
  k.alive_at = now;  // a frame is a sign of life as good as a heartbeat
  // A stream confirmed behind the newest: the server (and its viewers) forget the old sequence.
  if (reset && !server->update_avatar_model(k.id, k.dof_count, k.model_bytes)) rejected++;
  if (server->publish_pose(k.id, f.packet) == Reject::ok) {
    frames++;
    std::lock_guard lock(latency_mutex);
    latency_ms[latency_next++ % latency_ms.size()] = float(double(int64_t(f.arrival_us - h.time_us)) * 1e-3);
  } else {
    rejected++;
  }
}

bool NatsSceneFeed::Impl::sequence_ok(Known& k, uint32_t seq, Clock::time_point now, bool& reset) {
  reset = false;
  const int32_t d = int32_t(seq - k.seq);
  if (!k.has_seq || (d > 0 && d <= kMaxSeqStep)) {
    k.has_seq = true;
    k.seq = seq;
    k.seq_at = now;
    k.jump_frames = 0;
    return true;
  }
  // A duplicate or a late frame: the server refuses it as out of order.
  if (d <= 0 && d >= -kMaxSeqStep) return true;
  // A jump: a candidate stream, followed while its frames continue it.
  const int32_t step = int32_t(seq - k.jump_last);
  if (k.jump_frames > 0 && step > 0 && step <= kMaxSeqStep) {
    k.jump_frames++;
  } else {
    k.jump_frames = 1;
    k.jump_since = now;
  }
  k.jump_last = seq;
  const bool stopped_before = k.jump_since - k.seq_at >= kJumpQuiet;
  if (k.jump_frames >= kJumpFrames && (stopped_before || now - k.jump_since >= kJumpHold)) {
    reset = d < 0;
    k.seq = seq;
    k.seq_at = now;
    k.jump_frames = 0;
    return true;
  }
  seq_jumps_refused++;
  return false;
}

void NatsSceneFeed::Impl::apply_mesh(Frame& f) {
  auto it = avatars.find(f.key);
  if (it == avatars.end() || !it->second.shown) {
    early++;
    return;
  }
  Known& k = it->second;
  Header header;
  if (decode_header(f.packet, header) != Reject::ok) {
    rejected++;
    return;
  }
  if (header.type == MsgType::mesh_topology) {
    if (decode_mesh_topology(f.packet, scratch_topology) != Reject::ok || scratch_topology.lod != f.lod) {
      rejected++;
      return;
    }
    scratch_topology.avatar = k.id;
    if (!server->set_mesh_topology(scratch_topology)) {
      rejected++;
      return;
    }
    k.mesh_vertices[f.lod] = scratch_topology.vertex_count;
    return;
  }
  MeshFrameHeader mh;
  if (header.type != MsgType::mesh || decode_mesh(f.packet, mh, scratch_positions) != Reject::ok || mh.lod != f.lod) {
    rejected++;
    return;
  }
  // Before its topology (or after a new model, until the new one comes): nothing to draw it on.
  if (k.mesh_vertices[f.lod] != scratch_positions.size()) {
    early++;
    return;
  }
  if (server->publish_mesh(k.id, f.lod, f.packet) == Reject::ok)
    mesh_frames++;
  else
    rejected++;
}

void NatsSceneFeed::Impl::housekeeping() {
  const auto now = Clock::now();
  uint64_t waiting = 0;
  if (!conn.connected()) {
    // Cut off from the broker, nobody's heartbeat can come: no verdicts until we hear again.
    was_down = true;
  } else {
    if (was_down) {
      for (auto& [key, k] : avatars)
        if (k.shown) k.alive_at = now;  // a fresh period of grace after our own outage
      was_down = false;
    }
    for (auto& [key, k] : avatars)
      if (k.shown && !alive_at(k, now)) {
        hide(k);
        expired++;
      }
    // A held model older than the bucket's TTL has left the bucket (expiry sends no event).
    if (const int64_t ttl_ns = bucket_ttl_ns; ttl_ns > 0)
      for (auto it = avatars.begin(); it != avatars.end();) {
        const auto next = std::next(it);
        if (!it->second.shown && now - it->second.put_at > std::chrono::nanoseconds(ttl_ns) + std::chrono::seconds(1))
          forget(it);
        it = next;
      }
    std::erase_if(heard, [&](const auto& h) {
      return now - h.second.at > std::chrono::milliseconds(int64_t(h.second.period_ms) * opt.missed_heartbeats);
    });
  }
  std::vector<MeshWant> want;
  const Known* any_shown = nullptr;
  for (const auto& [key, k] : avatars) {
    if (!k.shown)
      waiting++;
    else if (!any_shown)
      any_shown = &k;
  }
  held = waiting;
#if defined(__GLIBC__)
  // Freed models sit in the allocator's free lists otherwise (many of them small enough not to
  // be mapped on their own): given back once a few MB have gone.
  if (model_bytes_freed > (size_t(8) << 20)) {
    malloc_trim(0);
    model_bytes_freed = 0;
  }
#endif
  // A viewer's mesh LOD covers every avatar of the scene: one question to the server.
  const uint8_t lods = any_shown ? server->mesh_lods_wanted(any_shown->id) : 0;
  // Asked only of publishers that offer that LOD (their heartbeat says which).
  for (const auto& [key, k] : avatars)
    if (k.shown && k.mesh_lod >= 0 && (lods & (1u << k.mesh_lod)))
      want.push_back({key, uint8_t(k.mesh_lod), k.mesh_vertices[size_t(k.mesh_lod)] == 0});
  std::lock_guard lock(wants_mutex);
  wants.swap(want);
}

void NatsSceneFeed::Impl::latency_percentiles(double& p50, double& p99) const {
  std::lock_guard lock(latency_mutex);
  std::vector<float> v(latency_ms.begin(),
                       latency_ms.begin() + long(std::min<uint64_t>(latency_next, latency_ms.size())));
  if (v.empty()) return;
  auto at = [&v](double q) {
    const size_t k = std::min(v.size() - 1, size_t(q * double(v.size() - 1) + 0.5));
    std::nth_element(v.begin(), v.begin() + long(k), v.end());
    return double(v[k]);
  };
  p50 = at(0.5);
  p99 = at(0.99);
}

}  // namespace mimic::net
