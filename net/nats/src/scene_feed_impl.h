// NatsSceneFeed's state, shared by its two halves: scene_feed.cpp (the broker side: the
// client's callbacks and the watcher thread) and scene_feed_serve.cpp (the server thread: what
// viewers see). Internal to net/.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "mimic/net/frame_codec.h"
#include "mimic/net/nats.h"
#include "nats_connection.h"

namespace mimic::net {

class Server;

struct NatsSceneFeed::Impl {
  using Clock = std::chrono::steady_clock;
  static constexpr int kTickPeriod_ms = 250;               // liveness checks and mesh requests
  static constexpr int64_t kRewatchSettle_us = 2'000'000;  // a reconnect's consumer reset is done by then
  static constexpr size_t kMaxQueuedFrames = 1 << 16;
  static constexpr size_t kMaxQueuedMeshes = 64;
  // Sequence continuity (apply_frame): a frame more than kMaxSeqStep from the avatar's newest
  // is a jump, taken only once kJumpFrames frames continue it, and, unless the avatar's frames
  // had stopped for kJumpQuiet before it, only after kJumpHold with no frame in step meanwhile.
  // A publisher back from an outage or restarted is followed; a stream far ahead injected
  // beside a live one is refused (it would freeze the avatar for viewers, who take only
  // sequences newer than the newest they have).
  static constexpr int32_t kMaxSeqStep = 256;
  static constexpr int kJumpFrames = 3;
  static constexpr std::chrono::milliseconds kJumpQuiet{500}, kJumpHold{300};

  NatsOptions opt;
  Server* server = nullptr;
  nats_detail::Connection conn;
  natsSubscription* sub = nullptr;         // mimic.S.poses.*
  natsSubscription* status_sub = nullptr;  // mimic.S.status.*

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
    bool mesh = false;        // a mesh frame or topology of LOD `lod`, else a pose frame
    uint8_t lod = 0;
  };
  struct Heartbeat {
    std::vector<std::string> keys;
    std::vector<int8_t> mesh_lods;  // per key: the LOD its mesh frames are offered at, or -1
    int period_ms = 1000;
  };
  std::mutex queue_mutex;
  std::vector<ModelEvent> models_in;
  std::vector<Frame> frames_in, meshes_in;
  std::vector<Heartbeat> heartbeats_in;
  bool pump_scheduled = false;

  // Server thread only.
  // Keyed by the bucket key "P.K": publisher token P (the subject token its frames, heartbeats
  // and mesh frames come on, which broker permissions tie to that publisher's user) and avatar
  // key K. A frame on another publisher's subject naming K finds nothing.
  struct Known {
    bool shown = false;  // served (added to the server), once its publisher showed life
    uint16_t id = 0;     // on the server, while shown
    uint32_t revision = 0;
    uint16_t dof_count = 0;
    uint64_t packet_hash = 0;  // of the packet as in the bucket: a put again unchanged is no update
    size_t packet_size = 0;
    std::string name, model_bytes;
    // Sequence continuity (kMaxSeqStep): the newest accepted and when, and a jump being confirmed.
    bool has_seq = false;
    uint32_t seq = 0, jump_last = 0;
    int jump_frames = 0;
    Clock::time_point seq_at{}, jump_since{};
    Clock::time_point alive_at{};             // its publisher's last heartbeat naming it, or its last frame
    Clock::time_point put_at{};               // its last put in the bucket (a live publisher's come every TTL/3)
    int period_ms = 1000;                     // its publisher's heartbeat period
    int8_t mesh_lod = -1;                     // the LOD its publisher offers mesh frames at (heartbeat)
    std::array<uint32_t, 8> mesh_vertices{};  // per LOD: the topology set on the server (0: none)
  };
  std::map<std::string, Known> avatars;
  // Avatar key K -> how many publishers' keys P.K end in it: a frame naming K on a publisher's
  // subject that does not own it is counted as foreign.
  std::map<std::string, int, std::less<>> key_owners;
  // Heartbeats naming keys whose model has not come yet: it is shown at once when it does.
  struct Heard {
    Clock::time_point at;
    int period_ms = 1000;
    int8_t mesh_lod = -1;
  };
  std::map<std::string, Heard> heard;
  bool was_down = false;
  rig::Pose scratch;
  MeshTopology scratch_topology;
  std::vector<glm::vec3> scratch_positions;
  std::vector<ModelEvent> models_work;
  std::vector<Frame> frames_work, meshes_work;
  std::vector<Heartbeat> heartbeats_work;
  std::vector<std::string> pass_keys;

  // Server thread -> watcher thread: the mesh LODs the server's viewers want.
  struct MeshWant {
    std::string key;
    uint8_t lod = 0;
    bool need_topology = false;
  };
  std::mutex wants_mutex;
  std::vector<MeshWant> wants;
  // Watcher thread only: a subscription per wanted (key, LOD).
  struct MeshSub {
    natsSubscription* sub = nullptr;
    int64_t last_request_us = 0;
  };
  std::map<std::pair<std::string, uint8_t>, MeshSub> mesh_subs;

  std::atomic<uint64_t> frames{0}, dropped{0}, early{0}, models{0}, model_failures{0}, rejected{0}, avatar_count{0},
      mesh_frames{0}, mesh_requests{0}, expired{0}, held{0}, seq_jumps_refused{0}, models_refused{0}, foreign{0},
      model_bytes_held{0};
  size_t model_bytes_freed = 0;  // server thread: since the last malloc_trim
  mutable std::mutex latency_mutex;
  std::vector<float> latency_ms = std::vector<float>(4096);
  uint64_t latency_next = 0;

  std::thread watcher;
  std::atomic<bool> stopping{false};
  std::atomic<bool> rewatch{true};
  // Model watches stopped (at a rewatch, and the last one at stop), destroyed only after the
  // connection has closed. libnats (3.4) frees a subscription that its reading thread may still
  // be delivering to, and an ordered consumer reset (after a reconnect or missed heartbeats, on
  // a thread of its own) can leave the watch under a second id; either way, a watch destroyed
  // while the connection reads writes into freed memory. One is parked per rewatch, that is per
  // reconnect: a few hundred bytes each.
  struct ParkedWatch {
    jsCtx* js = nullptr;
    kvStore* kv = nullptr;
    kvWatcher* watch = nullptr;
  };
  std::vector<ParkedWatch> parked;  // watcher thread; ~Impl after it has joined
  // Mesh subscriptions no viewer wants any more: unsubscribed at once, destroyed once a flush
  // has shown the reading thread is past them (or after the connection has closed).
  std::vector<natsSubscription*> retired_subs;  // watcher thread
  void destroy_retired();
  std::atomic<int64_t> bucket_ttl_ns{0};  // the model bucket's TTL (0: none), read when watching
  mutable std::mutex error_mutex;
  std::string last_error;
  std::shared_ptr<std::atomic<bool>> alive = std::make_shared<std::atomic<bool>>(true);

  ~Impl();
  void set_error(std::string e) {
    std::lock_guard lock(error_mutex);
    last_error = std::move(e);
  }
  void latency_percentiles(double& p50, double& p99) const;

  // Broker side (scene_feed.cpp).
  static void on_poses_msg(natsConnection*, natsSubscription*, natsMsg* msg, void* self);
  static void on_mesh_msg(natsConnection*, natsSubscription*, natsMsg* msg, void* self);
  static void on_status_msg(natsConnection*, natsSubscription*, natsMsg* msg, void* self);
  void queue_mesh(natsMsg* msg);
  void schedule_pump_locked();  // caller holds queue_mutex
  void watch_loop();
  void tick();

  // Server thread (scene_feed_serve.cpp).
  void pump();
  void housekeeping();
  void apply_model(ModelEvent& e);
  void apply_heartbeat(const Heartbeat& hb, Clock::time_point now);
  void apply_frame(Frame& f, Clock::time_point now);
  void apply_mesh(Frame& f);
  bool show(Known& k);
  void hide(Known& k);
  bool alive_at(const Known& k, Clock::time_point now) const;
  bool sequence_ok(Known& k, uint32_t seq, Clock::time_point now, bool& reset);
  void forget(std::map<std::string, Known>::iterator it);
};

}  // namespace mimic::net
