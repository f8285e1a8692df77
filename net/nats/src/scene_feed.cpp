// NatsSceneFeed: one subscription to a scene's pose frames, one to its publishers' heartbeats,
// one watcher of its model bucket, and a subscription per mesh LOD some viewer wants; what
// arrives is validated and handed to the Server on its own thread (scene_feed_serve.cpp).
#include <chrono>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "mimic/net/server.h"
#include "scene_feed_impl.h"

namespace mimic::net {

using nats_detail::describe;
using nats_detail::monotonic_us;

namespace {

// mimic.<scene>.mesh.<P>.<K>.<lod>: the owned key P.K and the LOD.
bool subject_key(const char* subject, size_t scene_size, std::string& key, uint8_t& lod) {
  const std::string_view s(subject);
  const size_t a = 6 + scene_size + 6;  // "mimic." + scene + ".mesh."
  if (s.size() < a + 2 || s[s.size() - 2] != '.' || s.back() < '0' || s.back() > '7') return false;
  const std::string_view owned = s.substr(a, s.size() - 2 - a);
  if (!nats_detail::is_owned_key(owned)) return false;
  key.assign(owned);
  lod = uint8_t(s.back() - '0');
  return true;
}

}  // namespace

void NatsSceneFeed::Impl::schedule_pump_locked() {
  if (pump_scheduled) return;
  pump_scheduled = true;
  server->dispatch([this, alive = alive] {
    if (*alive) pump();
  });
}

// A mesh frame or topology, queued for the server thread (client thread).
void NatsSceneFeed::Impl::queue_mesh(natsMsg* msg) {
  Frame frame;
  frame.mesh = true;
  if (subject_key(natsMsg_GetSubject(msg), opt.scene.size(), frame.key, frame.lod)) {
    const auto* data = reinterpret_cast<const uint8_t*>(natsMsg_GetData(msg));
    frame.packet.assign(data, data + natsMsg_GetDataLength(msg));
    frame.arrival_us = wall_clock_us();
    std::lock_guard lock(queue_mutex);
    // Mesh frames are large: only a few wait (latest wins on the server anyway).
    if (meshes_in.size() < kMaxQueuedMeshes) {
      meshes_in.push_back(std::move(frame));
      schedule_pump_locked();
    } else {
      dropped++;
    }
  }
  natsMsg_Destroy(msg);
}

// A publisher's tick of pose frames: queued together, so the server thread takes the tick in
// one pass and fans it out once (client thread). Entries are checked as far as framing goes;
// the frames themselves are decoded on the server thread.
void NatsSceneFeed::Impl::on_poses_msg(natsConnection*, natsSubscription*, natsMsg* msg, void* self) {
  auto* f = static_cast<Impl*>(self);
  const auto* data = reinterpret_cast<const uint8_t*>(natsMsg_GetData(msg));
  const size_t size = size_t(std::max(0, natsMsg_GetDataLength(msg)));
  const uint64_t arrival_us = wall_clock_us();
  // The publisher is the subject's (its user may publish there alone): its avatars only.
  const std::string prefix = std::string(nats_detail::last_token(natsMsg_GetSubject(msg))) + ".";
  std::vector<Frame> tick;
  bool malformed = false;
  for (size_t at = 0; at < size;) {
    Header h;
    const size_t packet_at = at + nats_detail::kPosesKeyBytes;
    if (packet_at + kHeaderBytes > size ||
        decode_header(std::span<const uint8_t>(data + packet_at, size - packet_at), h) != Reject::ok ||
        h.type != MsgType::pose || packet_at + kHeaderBytes + h.payload_bytes > size) {
      malformed = true;  // the rest cannot be framed
      break;
    }
    Frame frame;
    frame.key = prefix + nats_detail::avatar_key_text(nats_detail::read_poses_key(data + at));
    frame.packet.assign(data + packet_at, data + packet_at + kHeaderBytes + h.payload_bytes);
    frame.arrival_us = arrival_us;
    tick.push_back(std::move(frame));
    at = packet_at + kHeaderBytes + h.payload_bytes;
  }
  natsMsg_Destroy(msg);
  if (malformed) f->rejected++;
  if (tick.empty()) return;
  std::lock_guard lock(f->queue_mutex);
  if (f->frames_in.size() + tick.size() <= kMaxQueuedFrames) {
    f->frames_in.insert(f->frames_in.end(), std::make_move_iterator(tick.begin()), std::make_move_iterator(tick.end()));
    f->schedule_pump_locked();
  } else {
    f->dropped += tick.size();
  }
}

void NatsSceneFeed::Impl::on_mesh_msg(natsConnection*, natsSubscription*, natsMsg* msg, void* self) {
  static_cast<Impl*>(self)->queue_mesh(msg);
}

void NatsSceneFeed::Impl::on_status_msg(natsConnection*, natsSubscription*, natsMsg* msg, void* self) {
  auto* f = static_cast<Impl*>(self);
  // {"publisher":..., "period_ms":P, "avatars":["<key>", ...], "mesh_lods":[L or -1, ...], ...}:
  // anything else is ignored.
  const auto j =
      nlohmann::json::parse(std::string_view(natsMsg_GetData(msg), size_t(natsMsg_GetDataLength(msg))), nullptr, false);
  // Keys of the subject's publisher only (see on_poses_msg).
  const std::string prefix = std::string(nats_detail::last_token(natsMsg_GetSubject(msg))) + ".";
  natsMsg_Destroy(msg);
  Heartbeat hb;
  if (j.is_object() && j.contains("avatars") && j["avatars"].is_array()) {
    if (auto p = j.find("period_ms"); p != j.end() && p->is_number_integer())
      hb.period_ms = std::clamp(p->get<int>(), 100, 60000);
    const auto& keys = j["avatars"];
    const auto lods = j.find("mesh_lods");
    const bool with_lods = lods != j.end() && lods->is_array() && lods->size() == keys.size();
    for (size_t i = 0; i < keys.size() && hb.keys.size() < 4096; ++i) {
      if (!keys[i].is_string() || keys[i].get_ref<const std::string&>().size() != 16) continue;
      hb.keys.push_back(prefix + keys[i].get<std::string>());
      const auto& lod = with_lods ? (*lods)[i] : nlohmann::json();
      hb.mesh_lods.push_back(
          lod.is_number_integer() && lod.get<int>() >= 0 && lod.get<int>() < 8 ? int8_t(lod.get<int>()) : int8_t(-1));
    }
  }
  if (hb.keys.empty()) return;
  std::lock_guard lock(f->queue_mutex);
  if (f->heartbeats_in.size() < 4096) {
    f->heartbeats_in.push_back(std::move(hb));
    f->schedule_pump_locked();
  }
}

// The watcher thread's other duty, four times a second: the server thread checks liveness and
// which mesh LODs its viewers want; here the mesh subscriptions follow and requests go out.
void NatsSceneFeed::Impl::tick() {
  server->dispatch([this, alive = alive] {
    if (*alive) housekeeping();
  });
  std::vector<MeshWant> want;
  {
    std::lock_guard lock(wants_mutex);
    want = wants;
  }
  for (auto it = mesh_subs.begin(); it != mesh_subs.end();) {
    const bool still = std::any_of(want.begin(), want.end(), [&](const MeshWant& w) {
      return w.key == it->first.first && w.lod == it->first.second;
    });
    if (still) {
      ++it;
      continue;
    }
    natsSubscription_Unsubscribe(it->second.sub);
    retired_subs.push_back(it->second.sub);
    it = mesh_subs.erase(it);
  }
  if (!conn.connected()) return;
  destroy_retired();
  const int64_t now = monotonic_us();
  for (const MeshWant& w : want) {
    auto [it, fresh] = mesh_subs.try_emplace({w.key, w.lod});
    if (fresh) {
      const std::string subject = nats_detail::mesh_subject(opt.scene, w.key, w.lod);
      if (natsStatus s = natsConnection_Subscribe(&it->second.sub, conn.get(), subject.c_str(), on_mesh_msg, this);
          s != NATS_OK) {
        set_error("subscribe " + subject + ": " + describe(s));
        mesh_subs.erase(it);
        continue;
      }
    }
    // Repeated while wanted (the publisher stops after three periods without); at every tick
    // while the topology is missing (a request may beat the subscription to a cluster node).
    if (!fresh && !w.need_topology && now - it->second.last_request_us < nats_detail::kMeshWantPeriod_ms * 1000)
      continue;
    const uint8_t request[nats_detail::kMeshWantBytes] = {
        w.lod, w.need_topology ? nats_detail::kMeshWantTopology : uint8_t(0)};
    const std::string subject = nats_detail::mesh_want_subject(opt.scene, w.key);
    if (natsConnection_Publish(conn.get(), subject.c_str(), request, int(sizeof request)) == NATS_OK) {
      it->second.last_request_us = now;
      mesh_requests++;
    }
  }
}

// libnats (3.4) looks a subscription up and then uses it without holding it: one destroyed
// right after its unsubscribe can be written to, freed, by the connection's reading thread. The
// reading thread handles the server's answer to a flush only after every message before it, so
// once a flush sent after the unsubscribes has come back, nothing can reach them. A flush that
// fails (the link went down) leaves them for a later tick, or for ~Impl after the close.
void NatsSceneFeed::Impl::destroy_retired() {
  if (retired_subs.empty() || natsConnection_FlushTimeout(conn.get(), 500) != NATS_OK) return;
  for (natsSubscription* r : retired_subs) natsSubscription_Destroy(r);
  retired_subs.clear();
}

void NatsSceneFeed::Impl::watch_loop() {
  jsCtx* js = nullptr;
  kvStore* kv = nullptr;
  kvWatcher* w = nullptr;
  // A watch is stopped and parked with its handles (see `parked`); handles that never made a
  // watch (no bucket yet) hold no subscription and go at once.
  auto reset = [&] {
    if (w) {
      kvWatcher_Stop(w);
      parked.push_back({js, kv, w});
    } else {
      if (kv) kvStore_Destroy(kv);
      if (js) jsCtx_Destroy(js);
    }
    w = nullptr;
    kv = nullptr;
    js = nullptr;
  };
  const std::string bucket = nats_detail::bucket_name(opt.scene);
  // Keys only (the models themselves are kept once, on the server thread): this watch's view,
  // to spot deletions on rewatch.
  std::set<std::string> seen, current;
  int64_t next_tick = 0, rewatch_at = 0;
  while (!stopping) {
    const int64_t now = monotonic_us();
    if (now >= next_tick) {
      next_tick = now + kTickPeriod_ms * 1000;
      tick();
    }
    // After a reconnect libnats resets the watch's ordered consumer on a thread of its own:
    // the old watch is stopped once that has settled, not while it runs, and parked (see `parked`).
    if (rewatch.exchange(false) && rewatch_at == 0) rewatch_at = w ? now + kRewatchSettle_us : now;
    if (rewatch_at > 0 && now >= rewatch_at) {
      rewatch_at = 0;
      reset();
      current.clear();
    }
    if (!w) {
      if (!conn.connected()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        continue;
      }
      jsOptions jo;
      jsOptions_Init(&jo);
      jo.Wait = 2000;
      natsStatus s = natsConnection_JetStream(&js, conn.get(), &jo);
      if (s == NATS_OK) s = js_KeyValue(&kv, js, bucket.c_str());
      if (s == NATS_OK) s = kvStore_WatchAll(&w, kv, nullptr);
      if (kvStatus* st = nullptr; s == NATS_OK && kvStore_Status(&st, kv) == NATS_OK) {
        bucket_ttl_ns = kvStatus_TTL(st);
        kvStatus_Destroy(st);
      }
      if (s != NATS_OK) {
        // No publisher has created the bucket yet, or the cluster is electing a leader.
        model_failures++;
        set_error("model bucket " + bucket + ": " + describe(s));
        reset();
        std::this_thread::sleep_for(std::chrono::milliseconds(kTickPeriod_ms));
        continue;
      }
    }
    kvEntry* e = nullptr;
    const natsStatus s = kvWatcher_Next(&e, w, kTickPeriod_ms);
    if (s == NATS_TIMEOUT) continue;
    if (s != NATS_OK) {
      set_error("model watch: " + describe(s));
      rewatch = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));  // it fails at once until rewatched
      continue;
    }
    if (!e) {
      // The initial values are all in: keys held before this watch and absent now were
      // deleted (or expired) while we were not watching.
      std::lock_guard lock(queue_mutex);
      for (const auto& key : seen)
        if (!current.count(key)) models_in.push_back({key, true, {}});
      seen = current;
      schedule_pump_locked();
      continue;
    }
    ModelEvent ev;
    ev.key = kvEntry_Key(e);
    ev.removed = kvEntry_Operation(e) != kvOp_Put;
    if (!nats_detail::is_owned_key(ev.key)) {
      models_refused++;  // not a publisher's P.K: nobody's frames could ever name it
      kvEntry_Destroy(e);
      continue;
    }
    // Not even copied when too large: a put replaced the key's model in the bucket, so the
    // model the relay had under it leaves too.
    if (!ev.removed && size_t(kvEntry_ValueLen(e)) > kHeaderBytes + 14 + kMaxNameBytes + opt.max_model_bytes) {
      models_refused++;
      ev.removed = true;
    }
    if (!ev.removed) {
      const auto* v = static_cast<const uint8_t*>(kvEntry_Value(e));
      ev.packet.assign(v, v + kvEntry_ValueLen(e));
      current.insert(ev.key);
      seen.insert(ev.key);
    } else {
      current.erase(ev.key);
      seen.erase(ev.key);
    }
    kvEntry_Destroy(e);
    std::lock_guard lock(queue_mutex);
    models_in.push_back(std::move(ev));
    schedule_pump_locked();
  }
  // The last watch is not even stopped here: its consumer may be resetting; closing the
  // connection ends that first (~Impl).
  if (w || kv || js) parked.push_back({js, kv, w});
}

NatsSceneFeed::Impl::~Impl() {
  stopping = true;
  if (watcher.joinable()) watcher.join();
  // Drain: the callbacks in progress finish before this object goes away.
  std::vector<natsSubscription*> subs = {sub, status_sub};
  for (auto& [key, m] : mesh_subs) subs.push_back(m.sub);
  for (natsSubscription* s : subs) {
    if (!s) continue;
    if (natsSubscription_Drain(s) == NATS_OK)
      natsSubscription_WaitForDrainCompletion(s, 2000);
    else
      natsSubscription_Unsubscribe(s);
  }
  conn.close();
  for (natsSubscription* s : subs)
    if (s) natsSubscription_Destroy(s);
  for (natsSubscription* s : retired_subs) natsSubscription_Destroy(s);
  for (const ParkedWatch& p : parked) {
    if (p.watch) kvWatcher_Destroy(p.watch);
    if (p.kv) kvStore_Destroy(p.kv);
    if (p.js) jsCtx_Destroy(p.js);
  }
  *alive = false;
}

Result<std::unique_ptr<NatsSceneFeed>> NatsSceneFeed::create(const NatsOptions& options, Server& server) {
  if (auto st = check_nats_options(options); !st) return tl::unexpected(st.error());
  auto impl = std::make_unique<Impl>();
  impl->opt = options;
  impl->server = &server;
  Impl* p = impl.get();
  // After a reconnect (possibly to another node) the model watch starts over: it delivers
  // every current model again, and anything missed meanwhile.
  p->conn.on_reconnected = [p] { p->rewatch = true; };
  if (auto st = impl->conn.open(options); !st) return tl::unexpected(st.error());
  // Subscriptions are kept across reconnects by the client (and set up on the first connect
  // when the broker was down at start).
  const std::string poses = nats_detail::poses_subject(options.scene, "*");
  if (natsStatus s = natsConnection_Subscribe(&impl->sub, impl->conn.get(), poses.c_str(), Impl::on_poses_msg, p);
      s != NATS_OK)
    return fail(Errc::io_error, "subscribe " + poses + ": " + describe(s));
  // Pose frames are small and frequent: let many wait rather than dropping them in the client.
  natsSubscription_SetPendingLimits(impl->sub, 1 << 16, 64 << 20);
  const std::string status = nats_detail::status_subject(options.scene, "*");
  if (natsStatus s =
          natsConnection_Subscribe(&impl->status_sub, impl->conn.get(), status.c_str(), Impl::on_status_msg, p);
      s != NATS_OK)
    return fail(Errc::io_error, "subscribe " + status + ": " + describe(s));
  impl->watcher = std::thread([p] { p->watch_loop(); });
  return std::unique_ptr<NatsSceneFeed>(new NatsSceneFeed(std::move(impl)));
}

NatsSceneFeed::NatsSceneFeed(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
NatsSceneFeed::~NatsSceneFeed() = default;

bool NatsSceneFeed::connected() const { return impl_->conn.connected(); }
NatsLinkState NatsSceneFeed::link_state() const noexcept { return impl_->conn.state(); }
std::string NatsSceneFeed::connected_url() const { return impl_->conn.connected_url(); }

NatsLinkStats NatsSceneFeed::stats() const {
  NatsLinkStats s = nats_detail::common_link_stats(*impl_);
  s.rejected = impl_->rejected;
  s.early_frames = impl_->early;
  s.expired = impl_->expired;
  s.held = impl_->held;
  s.seq_jumps_refused = impl_->seq_jumps_refused;
  s.models_refused = impl_->models_refused;
  s.foreign = impl_->foreign;
  s.model_bytes = impl_->model_bytes_held;
  impl_->latency_percentiles(s.latency_ms_p50, s.latency_ms_p99);
  s.avatars = impl_->avatar_count;
  std::lock_guard lock(impl_->error_mutex);
  s.last_error = impl_->last_error.empty() ? impl_->conn.last_error() : impl_->last_error;
  return s;
}

}  // namespace mimic::net
