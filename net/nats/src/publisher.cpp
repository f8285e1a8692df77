// NatsPublisher: pose frames (a tick of them per message) and mesh frames on core NATS from a
// sender thread; models latest-wins in
// the scene's KV bucket and the status heartbeat from a housekeeping thread (models put again
// after every reconnect and every third of the bucket's TTL); relays' mesh requests arrive on
// the client's own thread.
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <random>
#include <thread>
#include <utility>
#include <vector>

#include "mimic/net/frame_codec.h"
#include "mimic/net/nats.h"
#include "nats_connection.h"

namespace mimic::net {

using nats_detail::describe;
using nats_detail::monotonic_us;

using nats_detail::subject_token;

namespace {

// A topology (the largest mesh message, hundreds of KB at LOD 0) goes out on a relay's ask, at
// most kTopologyBurst times at once and then once per kTopologyRefill_us per avatar, however
// many asks come: a few two-byte requests cannot make the publisher put megabytes on the
// broker. Relays that join together share one (they all subscribe to the subject).
constexpr double kTopologyBurst = 2;
constexpr int64_t kTopologyRefill_us = 5'000'000;

}  // namespace

struct NatsPublisher::Impl {
  NatsOptions opt;
  nats_detail::Connection conn;
  uint32_t incarnation = 0;  // model revision field: tells relays a publisher restarted

  // Mesh frames of one avatar at the LOD it is deformed at, sent only while relays ask.
  struct Mesh {
    Impl* owner = nullptr;
    uint8_t lod = 0;
    std::string subject, want_subject;
    std::vector<uint8_t> topology;  // encoded once at setup
    std::mutex m;
    std::vector<uint8_t> frame;  // sized at setup: publish_mesh never allocates
    size_t size = 0;
    bool dirty = false;
    std::atomic<int64_t> wanted_until_us{0};
    std::atomic<int64_t> next_due_us{0};
    std::atomic<bool> topology_asked{false};
    double topology_tokens = kTopologyBurst;  // sender thread
    int64_t topology_tokens_at_us = 0;
    natsSubscription* want_sub = nullptr;
  };
  struct Slot {
    std::string key, owned, avatar_name;  // owned: the bucket key P.K
    uint64_t key_value = 0;
    std::vector<uint8_t> model_packet;
    // The frame of the tick in progress (the publishing thread's alone until end_tick).
    std::array<uint8_t, kMaxDatagramBytes> staged{};
    size_t staged_size = 0;
    bool is_staged = false;
    // The newest committed frame, waiting for the sender (guarded by frames_mutex).
    std::array<uint8_t, kMaxDatagramBytes> frame{};
    size_t size = 0;
    bool dirty = false;
    std::unique_ptr<Mesh> mesh;
  };
  std::vector<std::unique_ptr<Slot>> slots;
  std::mutex slots_mutex;             // the vector itself (grows at setup while the threads run)
  std::vector<uint8_t> mesh_scratch;  // sender thread; sized at setup under slots_mutex
  // A tick's frames are committed together and taken together, so one message carries them
  // all: held for memcpy by either side, never across I/O.
  std::mutex frames_mutex;
  bool in_tick = false;        // publishing thread: between begin_tick and end_tick
  std::vector<Slot*> staged;   // publishing thread; capacity reserved by add_avatar
  std::vector<uint8_t> batch;  // sender thread; sized by add_avatar for every avatar
  std::string poses_subject;

  std::atomic<uint32_t> wake{0};
  std::atomic<bool> stopping{false};
  std::atomic<bool> models_dirty{true};
  std::atomic<uint64_t> frames{0}, dropped{0}, models{0}, model_failures{0}, mesh_frames{0}, mesh_requests{0},
      topologies{0}, topologies_refused{0};
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

  void wake_sender() {
    wake.store(1, std::memory_order_release);
    wake.notify_one();
  }

  // A relay wants this avatar's mesh (client thread).
  static void on_mesh_want(natsConnection*, natsSubscription*, natsMsg* msg, void* closure) {
    auto* mesh = static_cast<Mesh*>(closure);
    const auto* d = reinterpret_cast<const uint8_t*>(natsMsg_GetData(msg));
    if (natsMsg_GetDataLength(msg) == int(nats_detail::kMeshWantBytes) && d[0] == mesh->lod) {
      mesh->owner->mesh_requests++;
      mesh->wanted_until_us.store(monotonic_us() + nats_detail::kMeshWantTimeout_us, std::memory_order_relaxed);
      if (d[1] & nats_detail::kMeshWantTopology) {
        mesh->topology_asked = true;
        mesh->owner->wake_sender();
      }
    }
    natsMsg_Destroy(msg);
  }

  void send_mesh(Mesh& mesh) {
    if (mesh.topology_asked.exchange(false, std::memory_order_relaxed)) {
      const int64_t now = monotonic_us();
      mesh.topology_tokens = std::min(
          kTopologyBurst, mesh.topology_tokens + double(now - mesh.topology_tokens_at_us) / double(kTopologyRefill_us));
      mesh.topology_tokens_at_us = now;
      if (mesh.topology_tokens < 1) {
        topologies_refused++;  // the relay asks again while it lacks it
      } else if (conn.connected()) {
        mesh.topology_tokens -= 1;
        if (natsStatus s = natsConnection_Publish(conn.get(), mesh.subject.c_str(), mesh.topology.data(),
                                                  int(mesh.topology.size()));
            s != NATS_OK)
          set_error("mesh topology: " + describe(s));
        else
          topologies++;
      }
    }
    size_t n = 0;
    {
      std::lock_guard lock(mesh.m);
      if (!mesh.dirty) return;
      n = mesh.size;
      std::memcpy(mesh_scratch.data(), mesh.frame.data(), n);
      mesh.dirty = false;
    }
    if (conn.connected() &&
        natsConnection_Publish(conn.get(), mesh.subject.c_str(), mesh_scratch.data(), int(n)) == NATS_OK)
      mesh_frames++;
  }

  // Publishing thread: a frame becomes the slot's newest for the sender (latest wins).
  void commit_locked(Slot& s, const uint8_t* bytes, size_t n) {
    if (s.dirty) dropped++;
    std::memcpy(s.frame.data(), bytes, n);
    s.size = n;
    s.dirty = true;
  }

  // Every avatar's newest frame, in one message (or more, each within the broker's payload
  // limit, for a publisher of thousands of avatars): a relay takes a tick in one piece, and
  // fans it out to its viewers once.
  void send_poses() {
    size_t n = 0, count = 0;
    {
      std::lock_guard lock(frames_mutex);
      for (auto& s : slots) {
        if (!s->dirty) continue;
        nats_detail::write_poses_key(s->key_value, batch.data() + n);
        std::memcpy(batch.data() + n + nats_detail::kPosesKeyBytes, s->frame.data(), s->size);
        n += nats_detail::kPosesKeyBytes + s->size;
        s->dirty = false;
        count++;
      }
    }
    if (count == 0) return;
    // Not connected: the frames are dropped, not queued; after an outage viewers get the
    // newest frames, not a backlog.
    if (!conn.connected()) {
      dropped += count;
      return;
    }
    const auto limit = size_t(std::clamp<int64_t>(natsConnection_GetMaxPayload(conn.get()), 4096, 1 << 20));
    for (size_t begin = 0; begin < n;) {
      // Whole entries up to the limit.
      size_t end = begin, entries = 0;
      while (end < n) {
        Header h;  // checked by publish_pose
        decode_header(std::span<const uint8_t>(batch.data() + end + nats_detail::kPosesKeyBytes, kHeaderBytes), h);
        const size_t entry = nats_detail::kPosesKeyBytes + kHeaderBytes + h.payload_bytes;
        if (end > begin && end + entry - begin > limit) break;
        end += entry;
        entries++;
      }
      if (natsConnection_Publish(conn.get(), poses_subject.c_str(), batch.data() + begin, int(end - begin)) == NATS_OK)
        frames += entries;
      else
        dropped += entries;
      begin = end;
    }
  }

  void send_loop() {
    while (!stopping) {
      wake.wait(0, std::memory_order_acquire);
      wake.store(0, std::memory_order_release);
      std::lock_guard slots_lock(slots_mutex);
      send_poses();
      for (auto& s : slots)
        if (s->mesh) send_mesh(*s->mesh);
    }
  }

  // Drops the bucket handle after a failed put: a broker restarted with an empty store has no
  // bucket behind it any more ("no responders"), so the next round binds to it again or
  // creates it anew, and puts every model again.
  void forget_bucket() {
    if (kv) kvStore_Destroy(kv);
    kv = nullptr;
    if (js) jsCtx_Destroy(js);
    js = nullptr;
  }

  bool ensure_bucket() {
    if (kv) return true;
    if (!js) {
      jsOptions jo;
      jsOptions_Init(&jo);
      // Puts and bucket calls wait this long at most for JetStream (a cluster electing a
      // leader answers nothing); they run on the housekeeping thread only.
      jo.Wait = 1000;
      if (natsStatus s = natsConnection_JetStream(&js, conn.get(), &jo); s != NATS_OK) {
        set_error("JetStream: " + describe(s));
        return false;
      }
    }
    const std::string bucket = nats_detail::bucket_name(opt.scene);
    if (js_KeyValue(&kv, js, bucket.c_str()) == NATS_OK) return true;
    kv = nullptr;
    kvConfig cfg;
    kvConfig_Init(&cfg);
    cfg.Bucket = bucket.c_str();
    cfg.History = 1;  // latest wins
    // A dead publisher's models age out; live ones are put again well before (put_models).
    cfg.TTL = int64_t(opt.model_ttl_s * 1e9);  // nanoseconds, the stream's max_age
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

  // Housekeeping thread. The packets are copied out first: a put may wait a second for
  // JetStream, and the sender thread takes slots_mutex for every tick (holding it across the
  // puts stalled pose frames for as long as a put waited, on every failover that moved the
  // bucket's leader).
  void put_models() {
    if (!ensure_bucket()) {
      // E.g. a cluster still electing its JetStream leader: try again on the next round.
      model_failures++;
      models_dirty = true;
      return;
    }
    std::vector<std::pair<std::string, std::vector<uint8_t>>> todo;
    {
      std::lock_guard lock(slots_mutex);
      for (auto& s : slots) todo.emplace_back(s->owned, s->model_packet);
    }
    for (const auto& [key, packet] : todo) {
      if (stopping) return;
      uint64_t rev = 0;
      if (natsStatus st = kvStore_Put(&rev, kv, key.c_str(), packet.data(), int(packet.size())); st != NATS_OK) {
        model_failures++;
        set_error("model put: " + describe(st));
        forget_bucket();
        models_dirty = true;
        return;
      }
      models++;
    }
  }

  // The heartbeat: relays keep this publisher's avatars while it comes (docs/scaling.md).
  void publish_status() {
    // Appended piece by piece: GCC 12 warns falsely on "literal" + std::string (-Wrestrict).
    std::string json = "{\"publisher\":\"";
    json.append(subject_token(opt.name)).append("\",\"incarnation\":").append(std::to_string(incarnation));
    json.append(",\"period_ms\":").append(std::to_string(opt.heartbeat_ms));
    json.append(",\"frames\":").append(std::to_string(frames.load()));
    json.append(",\"dropped\":").append(std::to_string(dropped.load()));
    json.append(",\"mesh_frames\":").append(std::to_string(mesh_frames.load())).append(",\"avatars\":[");
    std::string lods;
    {
      std::lock_guard lock(slots_mutex);
      for (size_t i = 0; i < slots.size(); ++i) {
        json.append(i ? ",\"" : "\"").append(slots[i]->key).append("\"");
        lods.append(i ? "," : "").append(std::to_string(slots[i]->mesh ? int(slots[i]->mesh->lod) : -1));
      }
    }
    json.append("],\"mesh_lods\":[").append(lods).append("]}");
    const std::string subject = nats_detail::status_subject(opt.scene, subject_token(opt.name));
    natsConnection_PublishString(conn.get(), subject.c_str(), json.c_str());
  }

  void housekeeping_loop() {
    using C = std::chrono::steady_clock;
    auto next_status = C::now();
    // Models are put again every third of their TTL, so only a dead publisher's expire.
    const auto refresh = std::chrono::duration_cast<C::duration>(std::chrono::duration<double>(opt.model_ttl_s / 3));
    auto next_refresh = C::now() + refresh;
    auto next_put = C::now();
    std::unique_lock lock(hk_mutex);
    while (!stopping) {
      hk_cv.wait_for(lock, std::chrono::milliseconds(50));
      if (stopping) break;
      if (!conn.connected()) continue;
      lock.unlock();
      if (opt.model_ttl_s > 0 && C::now() >= next_refresh) {
        models_dirty = true;
        next_refresh = C::now() + refresh;
      }
      // The heartbeat first: a put may wait for JetStream, relays must not miss it meanwhile.
      if (C::now() >= next_status) {
        publish_status();
        next_status = C::now() + std::chrono::milliseconds(opt.heartbeat_ms);
      }
      if (C::now() >= next_put && models_dirty.exchange(false)) {
        put_models();
        // After a failed round, the next one a little later (not 20 times a second).
        if (models_dirty) next_put = C::now() + std::chrono::milliseconds(250);
      }
      lock.lock();
    }
  }

  void stop_threads() {
    stopping = true;
    wake_sender();
    hk_cv.notify_all();
    if (sender.joinable()) sender.join();
    if (housekeeper.joinable()) housekeeper.join();
  }

  ~Impl() {
    stop_threads();
    // Requests in delivery finish before the slots they point at go away.
    for (auto& s : slots) {
      if (!s->mesh || !s->mesh->want_sub) continue;
      natsSubscription* sub = s->mesh->want_sub;
      if (natsSubscription_Drain(sub) == NATS_OK)
        natsSubscription_WaitForDrainCompletion(sub, 2000);
      else
        natsSubscription_Unsubscribe(sub);
    }
    // A clean leave removes this publisher's avatars from the scene.
    if (conn.connected() && kv) {
      for (auto& s : slots) kvStore_Delete(kv, s->owned.c_str());
      natsConnection_FlushTimeout(conn.get(), 1000);
    }
    if (kv) kvStore_Destroy(kv);
    if (js) jsCtx_Destroy(js);
    conn.close();
    for (auto& s : slots)
      if (s->mesh && s->mesh->want_sub) natsSubscription_Destroy(s->mesh->want_sub);
  }
};

Result<std::unique_ptr<NatsPublisher>> NatsPublisher::create(const NatsOptions& options) {
  if (auto st = check_nats_options(options); !st) return tl::unexpected(st.error());
  auto impl = std::make_unique<Impl>();
  impl->opt = options;
  impl->poses_subject = nats_detail::poses_subject(options.scene, subject_token(options.name));
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
  slot->key_value = nats_detail::avatar_key_value(impl_->opt.name, avatar_name);
  slot->key = nats_detail::avatar_key_text(slot->key_value);
  slot->owned = nats_detail::owned_key(subject_token(impl_->opt.name), slot->key);
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
  // Room for a frame of every avatar: neither publish_pose nor the sender ever allocates.
  impl_->staged.reserve(impl_->slots.size());
  impl_->batch.resize(impl_->slots.size() * (nats_detail::kPosesKeyBytes + kMaxDatagramBytes));
  impl_->models_dirty = true;
  impl_->hk_cv.notify_all();
  return int(impl_->slots.size() - 1);
}

Status NatsPublisher::add_mesh(int index, const MeshTopology& topology) {
  std::lock_guard lock(impl_->slots_mutex);
  if (index < 0 || size_t(index) >= impl_->slots.size())
    return fail(Errc::not_found, "no avatar " + std::to_string(index));
  Impl::Slot& slot = *impl_->slots[size_t(index)];
  if (slot.mesh) return fail(Errc::invalid_argument, "the avatar's mesh is set already");
  if (topology.lod >= 8) return fail(Errc::out_of_range, "LOD must be below 8");
  auto mesh = std::make_unique<Impl::Mesh>();
  mesh->owner = impl_.get();
  mesh->lod = topology.lod;
  mesh->subject = nats_detail::mesh_subject(impl_->opt.scene, slot.owned, topology.lod);
  mesh->want_subject = nats_detail::mesh_want_subject(impl_->opt.scene, slot.owned);
  MeshTopology t = topology;
  t.avatar = 0;  // relays put their own id in
  mesh->topology.resize(mesh_topology_packet_bytes(t.indices.size()));
  if (encode_mesh_topology(t, mesh->topology) == 0) return fail(Errc::out_of_range, "mesh topology too large");
  mesh->frame.resize(mesh_packet_bytes(topology.vertex_count));
  if (impl_->mesh_scratch.size() < mesh->frame.size()) impl_->mesh_scratch.resize(mesh->frame.size());
  // Kept by the client across reconnects (and set up on the first connect after a failed start).
  if (natsStatus s = natsConnection_Subscribe(&mesh->want_sub, impl_->conn.get(), mesh->want_subject.c_str(),
                                              Impl::on_mesh_want, mesh.get());
      s != NATS_OK)
    return fail(Errc::io_error, "subscribe " + mesh->want_subject + ": " + describe(s));
  slot.mesh = std::move(mesh);
  return {};
}

void NatsPublisher::publish_pose(int index, std::span<const uint8_t> packet) noexcept {
  // The slots vector only grows at setup, before the loop publishes.
  if (index < 0 || size_t(index) >= impl_->slots.size() || packet.size() > kMaxDatagramBytes) return;
  Header h;
  if (decode_header(packet, h) != Reject::ok || h.type != MsgType::pose ||
      kHeaderBytes + h.payload_bytes != packet.size())
    return;
  Impl::Slot& s = *impl_->slots[size_t(index)];
  if (impl_->in_tick) {
    std::memcpy(s.staged.data(), packet.data(), packet.size());
    s.staged_size = packet.size();
    if (!s.is_staged) impl_->staged.push_back(&s);
    s.is_staged = true;
    return;
  }
  {
    std::lock_guard lock(impl_->frames_mutex);
    impl_->commit_locked(s, packet.data(), packet.size());
  }
  impl_->wake_sender();
}

void NatsPublisher::begin_tick() noexcept { impl_->in_tick = true; }

void NatsPublisher::end_tick() noexcept {
  impl_->in_tick = false;
  if (impl_->staged.empty()) return;
  {
    std::lock_guard lock(impl_->frames_mutex);
    for (Impl::Slot* s : impl_->staged) {
      impl_->commit_locked(*s, s->staged.data(), s->staged_size);
      s->is_staged = false;
    }
  }
  impl_->staged.clear();
  impl_->wake_sender();
}

bool NatsPublisher::mesh_wanted(int index) const noexcept {
  if (index < 0 || size_t(index) >= impl_->slots.size()) return false;
  const Impl::Mesh* m = impl_->slots[size_t(index)]->mesh.get();
  if (!m) return false;
  const int64_t now = monotonic_us();
  return now < m->wanted_until_us.load(std::memory_order_relaxed) &&
         now >= m->next_due_us.load(std::memory_order_relaxed);
}

void NatsPublisher::publish_mesh(int index, std::span<const uint8_t> packet) noexcept {
  if (index < 0 || size_t(index) >= impl_->slots.size()) return;
  Impl::Mesh* m = impl_->slots[size_t(index)]->mesh.get();
  if (!m || packet.size() > m->frame.size()) return;
  {
    std::lock_guard lock(m->m);
    std::memcpy(m->frame.data(), packet.data(), packet.size());
    m->size = packet.size();
    m->dirty = true;
  }
  // The next frame is due one period after this one's due time (so a loop faster than the
  // bound averages the bound), or a period from now after a pause.
  const auto period_us = int64_t(1e6 / impl_->opt.mesh_max_hz);
  const int64_t now = monotonic_us(), due = m->next_due_us.load(std::memory_order_relaxed);
  m->next_due_us.store(now - due > period_us ? now + period_us : due + period_us, std::memory_order_relaxed);
  impl_->wake_sender();
}

bool NatsPublisher::connected() const { return impl_->conn.connected(); }
NatsLinkState NatsPublisher::link_state() const noexcept { return impl_->conn.state(); }
std::string NatsPublisher::connected_url() const { return impl_->conn.connected_url(); }

std::string NatsPublisher::key(int index) const {
  std::lock_guard lock(impl_->slots_mutex);
  return index >= 0 && size_t(index) < impl_->slots.size() ? impl_->slots[size_t(index)]->key : std::string();
}

NatsLinkStats NatsPublisher::stats() const {
  NatsLinkStats s = nats_detail::common_link_stats(*impl_);
  s.topologies = impl_->topologies;
  s.topologies_refused = impl_->topologies_refused;
  std::lock_guard lock(impl_->error_mutex);
  s.last_error = impl_->last_error.empty() ? impl_->conn.last_error() : impl_->last_error;
  return s;
}

}  // namespace mimic::net
