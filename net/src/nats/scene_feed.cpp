#if MIMIC_WITH_NATS
// NatsSceneFeed: one subscription to a scene's pose frames and one watcher of its model
// bucket; what arrives is validated and handed to the Server on its own thread.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <map>
#include <thread>
#include <vector>

#include "mimic/net/frame_codec.h"
#include "mimic/net/nats.h"
#include "mimic/net/server.h"
#include "nats/nats_connection.h"

namespace mimic::net {

using nats_detail::describe;

struct NatsSceneFeed::Impl {
  NatsOptions opt;
  Server* server = nullptr;
  nats_detail::Connection conn;
  natsSubscription* sub = nullptr;

  // From the client's threads to the server thread.
  struct ModelEvent {
    std::string key;
    bool removed = false;
    std::vector<uint8_t> packet;
  };
  struct Frame {
    std::string key;
    std::vector<uint8_t> packet;
    uint64_t arrival_us = 0;  // wall clock as the client handed it over
  };
  mutable std::mutex latency_mutex;
  std::vector<float> latency_ms = std::vector<float>(4096);
  uint64_t latency_next = 0;
  std::mutex queue_mutex;
  std::vector<ModelEvent> models_in;
  std::vector<Frame> frames_in;
  bool pump_scheduled = false;
  static constexpr size_t kMaxQueuedFrames = 1 << 16;

  // Server thread only.
  struct Known {
    uint16_t id = 0;
    uint32_t revision = 0;
    uint16_t dof_count = 0;
    std::vector<uint8_t> packet;
  };
  std::map<std::string, Known> avatars;
  avatar::Pose scratch;
  std::vector<ModelEvent> models_work;
  std::vector<Frame> frames_work;
  std::vector<std::string> pass_keys;
  std::atomic<uint64_t> frames{0}, dropped{0}, early{0}, models{0}, model_failures{0}, rejected{0}, avatar_count{0};

  std::thread watcher;
  std::atomic<bool> stopping{false};
  std::atomic<bool> rewatch{true};
  mutable std::mutex error_mutex;
  std::string last_error;
  std::shared_ptr<std::atomic<bool>> alive = std::make_shared<std::atomic<bool>>(true);

  void set_error(std::string e) {
    std::lock_guard lock(error_mutex);
    last_error = std::move(e);
  }

  // Caller holds queue_mutex.
  void schedule_pump_locked() {
    if (pump_scheduled) return;
    pump_scheduled = true;
    server->dispatch([this, alive = alive] {
      if (*alive) pump();
    });
  }

  static void on_msg(natsConnection*, natsSubscription*, natsMsg* msg, void* self) {
    auto* f = static_cast<Impl*>(self);
    // mimic.<scene>.<key>.pose: the key is the third token.
    const std::string subject = natsMsg_GetSubject(msg);
    const size_t a = subject.find('.', 6) + 1, b = subject.rfind('.');
    if (a > 0 && b > a) {
      const auto* data = reinterpret_cast<const uint8_t*>(natsMsg_GetData(msg));
      std::lock_guard lock(f->queue_mutex);
      if (f->frames_in.size() < kMaxQueuedFrames) {
        f->frames_in.push_back(
            {subject.substr(a, b - a), std::vector<uint8_t>(data, data + natsMsg_GetDataLength(msg)), wall_clock_us()});
        f->schedule_pump_locked();
      } else {
        f->dropped++;
      }
    }
    natsMsg_Destroy(msg);
  }

  void pump() {
    {
      std::lock_guard lock(queue_mutex);
      pump_scheduled = false;
      models_work.swap(models_in);
      frames_work.swap(frames_in);
    }
    for (auto& e : models_work) apply_model(e);
    models_work.clear();
    // One frame per avatar per pass: a second frame of the same avatar would overwrite the
    // first in every subscriber's pending slot before its write could complete (latest wins),
    // so the rest waits for the next pass, after the server has run its writes.
    size_t used = 0;
    pass_keys.clear();
    server->begin_batch();
    for (; used < frames_work.size(); ++used) {
      Frame& f = frames_work[used];
      if (std::find(pass_keys.begin(), pass_keys.end(), f.key) != pass_keys.end()) break;
      pass_keys.push_back(f.key);
      apply_frame(f);
    }
    server->end_batch();
    if (used < frames_work.size()) {
      std::lock_guard lock(queue_mutex);
      frames_in.insert(frames_in.begin(), std::make_move_iterator(frames_work.begin() + long(used)),
                       std::make_move_iterator(frames_work.end()));
      schedule_pump_locked();
    }
    frames_work.clear();
  }

  void apply_model(ModelEvent& e) {
    auto it = avatars.find(e.key);
    if (e.removed) {
      if (it != avatars.end()) {
        server->remove_avatar(it->second.id);
        avatars.erase(it);
      }
      avatar_count = avatars.size();
      return;
    }
    if (it != avatars.end() && it->second.packet == e.packet) return;  // put again unchanged
    AvatarModel m;
    if (decode_avatar_model(e.packet, m) != Reject::ok) {
      rejected++;
      return;
    }
    if (it == avatars.end()) {
      auto id = server->add_avatar(m.name, m.dof_count, std::move(m.model_bytes));
      if (!id) {
        rejected++;
        set_error("avatar " + printable(m.name) + ": " + id.error().what());
        return;
      }
      avatars[e.key] = {*id, m.revision, m.dof_count, std::move(e.packet)};
    } else {
      // A new model, or its publisher restarted (sequence numbers start again).
      if (auto st = server->update_avatar_model(it->second.id, m.dof_count, std::move(m.model_bytes)); !st) {
        rejected++;
        return;
      }
      it->second.revision = m.revision;
      it->second.dof_count = m.dof_count;
      it->second.packet = std::move(e.packet);
    }
    models++;
    avatar_count = avatars.size();
  }

  void apply_frame(Frame& f) {
    auto it = avatars.find(f.key);
    PoseHeader h;
    // Whatever came through the broker is checked as a remote publisher's frame would be.
    if (it == avatars.end()) {
      early++;  // its model has not arrived yet (or it has left)
      return;
    }
    if (decode_pose(f.packet, h, scratch) != Reject::ok ||
        scratch.dof_rad.size() != it->second.dof_count) {
      rejected++;
      return;
    }
    if (server->publish_pose(it->second.id, f.packet) == Reject::ok) {
      frames++;
      std::lock_guard lock(latency_mutex);
      latency_ms[latency_next++ % latency_ms.size()] = float(double(int64_t(f.arrival_us - h.time_us)) * 1e-3);
    }
    else
      rejected++;
  }

  void watch_loop() {
    jsCtx* js = nullptr;
    kvStore* kv = nullptr;
    kvWatcher* w = nullptr;
    auto reset = [&] {
      if (w) kvWatcher_Destroy(w);
      if (kv) kvStore_Destroy(kv);
      if (js) jsCtx_Destroy(js);
      w = nullptr;
      kv = nullptr;
      js = nullptr;
    };
    const std::string bucket = nats_detail::bucket_name(opt.scene);
    std::map<std::string, std::vector<uint8_t>> seen;  // this watch's view, to spot deletions on rewatch
    std::map<std::string, std::vector<uint8_t>> current;
    while (!stopping) {
      if (rewatch.exchange(false)) {
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
        if (s != NATS_OK) {
          // No publisher has created the bucket yet, or the cluster is electing a leader.
          model_failures++;
          set_error("model bucket " + bucket + ": " + describe(s));
          reset();
          std::this_thread::sleep_for(std::chrono::milliseconds(250));
          continue;
        }
      }
      kvEntry* e = nullptr;
      const natsStatus s = kvWatcher_Next(&e, w, 200);
      if (s == NATS_TIMEOUT) continue;
      if (s != NATS_OK) {
        set_error("model watch: " + describe(s));
        rewatch = true;
        continue;
      }
      if (!e) {
        // The initial values are all in: keys held before this watch and absent now were
        // deleted while we were not watching.
        std::lock_guard lock(queue_mutex);
        for (const auto& [key, packet] : seen)
          if (!current.count(key)) models_in.push_back({key, true, {}});
        seen = current;
        schedule_pump_locked();
        continue;
      }
      ModelEvent ev;
      ev.key = kvEntry_Key(e);
      const kvOperation op = kvEntry_Operation(e);
      ev.removed = op != kvOp_Put;
      if (!ev.removed) {
        const auto* v = static_cast<const uint8_t*>(kvEntry_Value(e));
        ev.packet.assign(v, v + kvEntry_ValueLen(e));
        current[ev.key] = ev.packet;
        seen[ev.key] = ev.packet;
      } else {
        current.erase(ev.key);
        seen.erase(ev.key);
      }
      kvEntry_Destroy(e);
      std::lock_guard lock(queue_mutex);
      models_in.push_back(std::move(ev));
      schedule_pump_locked();
    }
    reset();
  }

  ~Impl() {
    stopping = true;
    if (watcher.joinable()) watcher.join();
    if (sub) {
      // Drain: the callbacks in progress finish before this object goes away.
      if (natsSubscription_Drain(sub) == NATS_OK)
        natsSubscription_WaitForDrainCompletion(sub, 2000);
      else
        natsSubscription_Unsubscribe(sub);
      natsSubscription_Destroy(sub);
    }
    conn.close();
    *alive = false;
  }
};

Result<std::unique_ptr<NatsSceneFeed>> NatsSceneFeed::create(const NatsOptions& options, Server& server) {
  auto impl = std::make_unique<Impl>();
  impl->opt = options;
  impl->server = &server;
  Impl* p = impl.get();
  // After a reconnect (possibly to another node) the model watch starts over: it delivers
  // every current model again, and anything missed meanwhile.
  p->conn.on_reconnected = [p] { p->rewatch = true; };
  if (auto st = impl->conn.open(options); !st) return tl::unexpected(st.error());
  const std::string subject = "mimic." + options.scene + ".*.pose";
  // Subscriptions are kept across reconnects by the client (and set up on the first connect
  // when the broker was down at start).
  if (natsStatus s = natsConnection_Subscribe(&impl->sub, impl->conn.get(), subject.c_str(), Impl::on_msg, p);
      s != NATS_OK)
    return fail(Errc::io_error, "subscribe " + subject + ": " + describe(s));
  // Pose frames are small and frequent: let many wait rather than dropping them in the client.
  natsSubscription_SetPendingLimits(impl->sub, 1 << 16, 64 << 20);
  impl->watcher = std::thread([p] { p->watch_loop(); });
  return std::unique_ptr<NatsSceneFeed>(new NatsSceneFeed(std::move(impl)));
}

NatsSceneFeed::NatsSceneFeed(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
NatsSceneFeed::~NatsSceneFeed() = default;

bool NatsSceneFeed::connected() const { return impl_->conn.connected(); }
std::string NatsSceneFeed::connected_url() const { return impl_->conn.connected_url(); }

NatsLinkStats NatsSceneFeed::stats() const {
  NatsLinkStats s;
  s.connected = impl_->conn.connected();
  s.disconnects = impl_->conn.disconnects();
  s.reconnects = impl_->conn.reconnects();
  s.frames = impl_->frames;
  s.frames_dropped = impl_->dropped;
  s.models = impl_->models;
  s.model_failures = impl_->model_failures;
  s.rejected = impl_->rejected;
  s.early_frames = impl_->early;
  {
    std::lock_guard lock(impl_->latency_mutex);
    std::vector<float> v(impl_->latency_ms.begin(),
                         impl_->latency_ms.begin() + long(std::min<uint64_t>(impl_->latency_next, impl_->latency_ms.size())));
    if (!v.empty()) {
      auto at = [&v](double q) {
        const size_t k = std::min(v.size() - 1, size_t(q * double(v.size() - 1) + 0.5));
        std::nth_element(v.begin(), v.begin() + long(k), v.end());
        return double(v[k]);
      };
      s.latency_ms_p50 = at(0.5);
      s.latency_ms_p99 = at(0.99);
    }
  }
  s.avatars = impl_->avatar_count;
  std::lock_guard lock(impl_->error_mutex);
  s.last_error = impl_->last_error.empty() ? impl_->conn.last_error() : impl_->last_error;
  return s;
}

}  // namespace mimic::net
#endif  // MIMIC_WITH_NATS
