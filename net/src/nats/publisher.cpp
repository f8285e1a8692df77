#if MIMIC_WITH_NATS
// NatsPublisher: pose frames on core NATS from a sender thread, models latest-wins in the
// scene's KV bucket from a housekeeping thread (put again after every reconnect).
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <random>
#include <thread>
#include <vector>

#include "mimic/net/frame_codec.h"
#include "mimic/net/nats.h"
#include "nats/nats_connection.h"

namespace mimic::net {

using nats_detail::describe;

namespace {

// A token for subjects: the publisher name with anything but [A-Za-z0-9_-] as '_'.
std::string subject_token(const std::string& name) {
  std::string s = name.empty() ? "mimic" : name.substr(0, 64);
  for (char& c : s)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-')) c = '_';
  return s;
}

}  // namespace

struct NatsPublisher::Impl {
  NatsOptions opt;
  nats_detail::Connection conn;
  uint32_t incarnation = 0;  // model revision field: tells relays a publisher restarted

  struct Slot {
    std::string key, subject, avatar_name;
    std::vector<uint8_t> model_packet;
    std::mutex m;
    std::array<uint8_t, kMaxDatagramBytes> frame{};
    size_t size = 0;
    bool dirty = false;
  };
  std::vector<std::unique_ptr<Slot>> slots;
  std::mutex slots_mutex;  // the vector itself (grows at setup while the threads run)

  std::atomic<uint32_t> wake{0};
  std::atomic<bool> stopping{false};
  std::atomic<bool> models_dirty{true};
  std::atomic<uint64_t> frames{0}, dropped{0}, models{0}, model_failures{0};
  std::thread sender, housekeeper;
  std::mutex hk_mutex;
  std::condition_variable hk_cv;
  mutable std::mutex error_mutex;
  std::string last_error;

  jsCtx* js = nullptr;
  kvStore* kv = nullptr;

  void set_error(std::string e) {
    std::lock_guard lock(error_mutex);
    last_error = std::move(e);
  }

  void send_loop() {
    std::array<uint8_t, kMaxDatagramBytes> buf{};
    while (!stopping) {
      wake.wait(0, std::memory_order_acquire);
      wake.store(0, std::memory_order_release);
      std::lock_guard slots_lock(slots_mutex);
      for (auto& s : slots) {
        size_t n = 0;
        {
          std::lock_guard lock(s->m);
          if (!s->dirty) continue;
          n = s->size;
          std::memcpy(buf.data(), s->frame.data(), n);
          s->dirty = false;
        }
        // Not connected: the frame is dropped, not queued; after an outage viewers get the
        // newest frames, not a backlog.
        if (conn.connected() && natsConnection_Publish(conn.get(), s->subject.c_str(), buf.data(), int(n)) == NATS_OK)
          frames++;
        else
          dropped++;
      }
    }
  }

  bool ensure_bucket() {
    if (kv) return true;
    if (!js) {
      jsOptions jo;
      jsOptions_Init(&jo);
      jo.Wait = 2000;
      if (natsStatus s = natsConnection_JetStream(&js, conn.get(), &jo); s != NATS_OK) {
        set_error("JetStream: " + describe(s));
        return false;
      }
    }
    const std::string bucket = nats_detail::bucket_name(opt.scene);
    if (js_KeyValue(&kv, js, bucket.c_str()) == NATS_OK) return true;
    kvConfig cfg;
    kvConfig_Init(&cfg);
    cfg.Bucket = bucket.c_str();
    cfg.History = 1;  // latest wins
    // Copies on three nodes when a cluster is given, so losing one node loses no model.
    int replicas = opt.kv_replicas;
    if (replicas <= 0) replicas = std::count(opt.servers.begin(), opt.servers.end(), ',') >= 2 ? 3 : 1;
    cfg.Replicas = replicas;
    if (natsStatus s = js_CreateKeyValue(&kv, js, &cfg); s != NATS_OK) {
      kv = nullptr;
      set_error("model bucket " + bucket + ": " + describe(s));
      return false;
    }
    return true;
  }

  void put_models() {
    if (!ensure_bucket()) {
      // E.g. a cluster still electing its JetStream leader: try again on the next round.
      model_failures++;
      models_dirty = true;
      return;
    }
    std::lock_guard lock(slots_mutex);
    for (auto& s : slots) {
      uint64_t rev = 0;
      if (natsStatus st = kvStore_Put(&rev, kv, s->key.c_str(), s->model_packet.data(), int(s->model_packet.size()));
          st != NATS_OK) {
        model_failures++;
        set_error("model put: " + describe(st));
        models_dirty = true;
        return;
      }
      models++;
    }
  }

  void publish_status() {
    std::string json = "{\"publisher\":\"" + subject_token(opt.name) + "\",\"frames\":" + std::to_string(frames.load()) +
                       ",\"dropped\":" + std::to_string(dropped.load()) + ",\"avatars\":[";
    {
      std::lock_guard lock(slots_mutex);
      for (size_t i = 0; i < slots.size(); ++i)
        json += (i ? ",\"" : "\"") + slots[i]->key + "\"";
    }
    json += "]}";
    const std::string subject = "mimic." + opt.scene + ".status." + subject_token(opt.name);
    natsConnection_PublishString(conn.get(), subject.c_str(), json.c_str());
  }

  void housekeeping_loop() {
    auto next_status = std::chrono::steady_clock::now();
    std::unique_lock lock(hk_mutex);
    while (!stopping) {
      hk_cv.wait_for(lock, std::chrono::milliseconds(100));
      if (stopping) break;
      if (!conn.connected()) continue;
      lock.unlock();
      if (models_dirty.exchange(false)) put_models();
      if (std::chrono::steady_clock::now() >= next_status) {
        publish_status();
        next_status = std::chrono::steady_clock::now() + std::chrono::seconds(1);
      }
      lock.lock();
    }
  }

  void stop_threads() {
    stopping = true;
    wake.store(1);
    wake.notify_one();
    hk_cv.notify_all();
    if (sender.joinable()) sender.join();
    if (housekeeper.joinable()) housekeeper.join();
  }

  ~Impl() {
    stop_threads();
    // A clean leave removes this publisher's avatars from the scene.
    if (conn.connected() && kv) {
      for (auto& s : slots) kvStore_Delete(kv, s->key.c_str());
      natsConnection_FlushTimeout(conn.get(), 1000);
    }
    if (kv) kvStore_Destroy(kv);
    if (js) jsCtx_Destroy(js);
    conn.close();
  }
};

Result<std::unique_ptr<NatsPublisher>> NatsPublisher::create(const NatsOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->opt = options;
  std::random_device rd;
  impl->incarnation = rd() | 1u;
  Impl* p = impl.get();
  p->conn.on_reconnected = [p] {
    // A broker that lost its store (or a first connect) gets the models again; relays ignore
    // unchanged ones.
    p->models_dirty = true;
    p->hk_cv.notify_all();
  };
  if (auto st = impl->conn.open(options); !st) return tl::unexpected(st.error());
  impl->sender = std::thread([p] { p->send_loop(); });
  impl->housekeeper = std::thread([p] { p->housekeeping_loop(); });
  return std::unique_ptr<NatsPublisher>(new NatsPublisher(std::move(impl)));
}

NatsPublisher::NatsPublisher(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
NatsPublisher::~NatsPublisher() = default;

Result<int> NatsPublisher::add_avatar(const std::string& avatar_name, uint16_t dof_count, std::string model_bytes) {
  if (dof_count > kMaxPoseDofs) return fail(Errc::out_of_range, "too many DOFs for a pose frame");
  auto slot = std::make_unique<Impl::Slot>();
  slot->avatar_name = avatar_name;
  slot->key = nats_avatar_key(impl_->opt.name, avatar_name);
  slot->subject = nats_detail::pose_subject(impl_->opt.scene, slot->key);
  AvatarModel m;
  m.revision = impl_->incarnation;
  m.dof_count = dof_count;
  m.name = (impl_->opt.name + "/" + avatar_name).substr(0, kMaxNameBytes);
  if (!name_is_printable(m.name)) return fail(Errc::invalid_argument, "avatar name has control characters");
  m.model_bytes = std::move(model_bytes);
  if (m.model_bytes.size() > kMaxModelBytes) return fail(Errc::out_of_range, "body model too large");
  slot->model_packet.resize(avatar_model_packet_bytes(m));
  if (encode_avatar_model(m, slot->model_packet) == 0) return fail(Errc::invalid_argument, "cannot encode the model");
  std::lock_guard lock(impl_->slots_mutex);
  impl_->slots.push_back(std::move(slot));
  impl_->models_dirty = true;
  impl_->hk_cv.notify_all();
  return int(impl_->slots.size() - 1);
}

void NatsPublisher::publish_pose(int index, std::span<const uint8_t> packet) noexcept {
  // The slots vector only grows at setup, before the loop publishes.
  if (index < 0 || size_t(index) >= impl_->slots.size() || packet.size() > kMaxDatagramBytes) return;
  Impl::Slot& s = *impl_->slots[size_t(index)];
  {
    std::lock_guard lock(s.m);  // held for a memcpy by either side, never across I/O
    if (s.dirty) impl_->dropped++;
    std::memcpy(s.frame.data(), packet.data(), packet.size());
    s.size = packet.size();
    s.dirty = true;
  }
  impl_->wake.store(1, std::memory_order_release);
  impl_->wake.notify_one();
}

bool NatsPublisher::connected() const { return impl_->conn.connected(); }
std::string NatsPublisher::connected_url() const { return impl_->conn.connected_url(); }

std::string NatsPublisher::key(int index) const {
  std::lock_guard lock(impl_->slots_mutex);
  return index >= 0 && size_t(index) < impl_->slots.size() ? impl_->slots[size_t(index)]->key : std::string();
}

NatsLinkStats NatsPublisher::stats() const {
  NatsLinkStats s;
  s.connected = impl_->conn.connected();
  s.disconnects = impl_->conn.disconnects();
  s.reconnects = impl_->conn.reconnects();
  s.frames = impl_->frames;
  s.frames_dropped = impl_->dropped;
  s.models = impl_->models;
  s.model_failures = impl_->model_failures;
  std::lock_guard lock(impl_->error_mutex);
  s.last_error = impl_->last_error.empty() ? impl_->conn.last_error() : impl_->last_error;
  return s;
}

}  // namespace mimic::net
#endif  // MIMIC_WITH_NATS
