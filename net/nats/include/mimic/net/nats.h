// Scale-out through a NATS broker (docs/scaling.md): publishers put every avatar of a scene on
// the broker, edge relays take the scene from it once and serve their local viewers with
// Mimic's own protocol (a net::Server fed from the broker as the pipeline feeds it local
// avatars).
//
// Subjects and keys of scene S (a name of [A-Za-z0-9_-], at most 64 bytes), publisher P (its
// name as a subject token) and avatar key K:
//   mimic.S.poses.P           pose frames, core NATS (no persistence): one message per tick of
//                             publisher P, each avatar's key (8 bytes) and POSE packet
//                             (frame_codec.h, encode_pose), so a relay fans a tick out once
//   mimic.S.mesh.P.K.L        mesh frames of LOD L (encode_mesh) and, when asked, the mesh
//                             topology (encode_mesh_topology); only while a relay asks
//   mimic.S.want.P.K          a relay's request for mesh frames: u8 LOD, u8 flags (bit 0: send
//                             the topology); repeated every second while it wants them
//   mimic.S.status.P          a publisher's status heartbeat, JSON, once a second: relays
//                             remove the avatars it names after missed heartbeats
//   KV bucket mimic_S, key P.K: the avatar's model packet (encode_avatar_model: name, DOF
//                             count, body model bytes), latest wins, history 1, put again
//                             while the publisher lives, expiring (the bucket's TTL) once it
//                             has stopped
// Everything a publisher writes carries P, so broker permissions can give each publisher's
// user its own subjects and keys alone (config/nats/, docs/security.md, The broker); a relay takes
// the frames, heartbeats and mesh frames on P's subjects for P's keys only (another
// publisher's K named there is counted as foreign and dropped).
// K is nats_avatar_key(publisher, avatar): 16 hex digits of a 64-bit hash, the same on every
// start of a publisher with the same names.
//
// Threading: the broker's client runs its own threads. NatsPublisher::publish_pose (the
// realtime loop) copies the frame into a per-avatar slot, and end_tick wakes a sender thread:
// it never waits for the broker. NatsSceneFeed hands what arrives to its Server through
// Server::dispatch, so the Server stays driven by one thread.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>

#include "mimic/core/result.h"
#include "mimic/net/frame_codec.h"

namespace mimic::net {

class Server;

struct NatsOptions {
  std::string servers;  // "nats://HOST:PORT[,nats://HOST:PORT...]"
  std::string scene = "default";
  std::string name = "mimic";  // publisher name (part of every avatar key) and connection name
  // Credentials: user + password, or a token. From the environment (nats_credentials_from_env),
  // never from the command line.
  std::string user, password, token;
  // One connect attempt (TCP, INFO, CONNECT/PONG) to one server; a failover to the next server
  // of the list waits at most this for a node that does not answer (a refused connection
  // fails at once).
  double connect_timeout_s = 1.0;
  int reconnect_wait_ms = 250;  // after every server of the list failed once; never gives up
  bool randomize = true;        // try the servers in random order (spreads clients over a cluster)
  int kv_replicas = 0;          // copies of the model bucket; 0: 3 when 3+ servers are given, else 1
  // Publisher: its status heartbeat period. Relay: an avatar whose publisher has sent neither a
  // heartbeat nor a frame for `missed_heartbeats` periods (the publisher's own) leaves the scene.
  int heartbeat_ms = 1000;
  int missed_heartbeats = 3;
  // Publisher, when it creates the bucket: a model not put again for this long leaves it (the
  // publisher puts its models again every third of it, so only a dead publisher's expire).
  // 0: models never expire.
  double model_ttl_s = 60;
  // Publisher: mesh frames per avatar per second at most, while a relay asks for them.
  double mesh_max_hz = 30;
  // Relay: a model whose body model is larger is refused (counted in models_refused), and so is
  // one that would take the models it keeps past max_scene_model_bytes.
  size_t max_model_bytes = kMaxModelBytes;
  size_t max_scene_model_bytes = size_t(128) << 20;
};

// Bounds of the options above, checked by NatsPublisher::create and the command line.
inline constexpr double kMinModelTtl_s = 3, kMaxModelTtl_s = 86400;
inline constexpr double kMinMeshHz = 1, kMaxMeshHz = 240;
Status check_nats_options(const NatsOptions& options);

// Fills user/password/token from MIMIC_NATS_USER, MIMIC_NATS_PASSWORD, MIMIC_NATS_TOKEN.
void nats_credentials_from_env(NatsOptions& options);

// "nats://..." (or "tls://..."): a broker address rather than HOST:PORT.
bool is_nats_url(std::string_view text);
// A viewer's target "nats://HOST:PORT[,nats://HOST:PORT...][/SCENE]" -> servers and scene
// ("default" when absent).
struct NatsTarget {
  std::string servers, scene;
};
Result<NatsTarget> parse_nats_target(std::string_view text);
Status check_scene_name(std::string_view scene);

// Broker addresses as shown to people and in logs: without the USER:PASSWORD@ an address may carry.
std::string nats_display_servers(std::string_view servers);

// Stable avatar key: 16 lowercase hex digits of FNV-1a 64 over "publisher/avatar".
std::string nats_avatar_key(std::string_view publisher, std::string_view avatar);

struct NatsLinkStats {
  bool connected = false;
  uint64_t disconnects = 0;
  uint64_t reconnects = 0;
  uint64_t frames = 0;          // pose frames published / received
  uint64_t frames_dropped = 0;  // publisher: not connected, or overwritten before sending
  uint64_t models = 0;          // model puts (publisher) / model updates applied (relay)
  uint64_t model_failures = 0;  // puts or watches that failed (retried)
  uint64_t rejected = 0;        // relay: malformed or unknown frames and models from the broker
  uint64_t avatars = 0;         // relay: avatars of the scene being served
  uint64_t early_frames = 0;    // relay: frames of an avatar whose model had not arrived
  uint64_t mesh_frames = 0;     // mesh frames published / received
  uint64_t mesh_requests = 0;   // publisher: mesh_want messages received; relay: sent
  uint64_t expired = 0;         // relay: avatars removed after their publisher's missed heartbeats
  uint64_t held = 0;            // relay: models in the bucket whose publisher shows no sign of life
  // Relay, refused and counted: frames far ahead of (or behind) an avatar's newest that did not
  // prove to be its publisher's stream (NatsSceneFeed), models too large, over the scene's
  // budget or under a key that is not P.K, and frames, heartbeats or mesh frames naming an
  // avatar key that the publisher of their subject does not own.
  uint64_t seq_jumps_refused = 0;
  uint64_t models_refused = 0;
  uint64_t foreign = 0;
  uint64_t model_bytes = 0;  // relay: body model bytes it keeps (shown and held)
  // Publisher: topologies sent on relays' asks, and asks beyond the topology rate bound.
  uint64_t topologies = 0, topologies_refused = 0;
  // Relay: the frame's time stamp (capture time, publisher's wall clock) to its arrival at the
  // relay, over the last 4096 frames. With clocks in step (one host, or NTP), this is
  // publish-to-relay plus whatever the publisher spent between capture and publish.
  double latency_ms_p50 = 0, latency_ms_p99 = 0;
  std::string last_error;
};

// The broker link's state, cheap enough for a status line on the realtime loop: atomics kept
// by the client's callbacks (never the client's own lock, which its reconnect thread holds
// through a connect attempt).
struct NatsLinkState {
  bool connected = false;
  uint64_t disconnects = 0;  // times the link went down since start
  double down_s = 0;         // while down: for how long
  double last_outage_s = 0;  // the last outage's length, once the link came back
};
// " | nats up", " | nats up (2 outages, last 0.031 s)", " | nats DOWN 1.2 s" into `out`
// (snprintf: no allocation). Returns the characters written.
int format_nats_state(const NatsLinkState& s, char* out, size_t size) noexcept;

class NatsPublisher {
 public:
  // Fails on a bad address or scene, or when the broker refuses the credentials. A broker
  // that cannot be reached is not an error: the publisher connects when it comes up.
  static Result<std::unique_ptr<NatsPublisher>> create(const NatsOptions& options);
  ~NatsPublisher();  // removes this publisher's models from the bucket, then closes
  NatsPublisher(const NatsPublisher&) = delete;
  NatsPublisher& operator=(const NatsPublisher&) = delete;

  // Setup, before the loop: an avatar and its model packet bytes are put in the bucket (now
  // or once connected). Returns the index publish_pose takes.
  Result<int> add_avatar(const std::string& avatar_name, uint16_t dof_count, std::string model_bytes);
  // Realtime: an encoded pose frame of avatar `index` (copied; latest wins). Never allocates,
  // throws or waits for the broker. Between begin_tick() and end_tick() frames are held and
  // go out together at end_tick(), in one message (relays fan a tick out once); outside, each
  // goes at once.
  void publish_pose(int index, std::span<const uint8_t> packet) noexcept;
  void begin_tick() noexcept;
  void end_tick() noexcept;
  // Setup: avatar `index` is deformed at `topology.lod`; its mesh frames go out on
  // mimic.S.<key>.mesh.<lod> while relays ask for them (and the topology when they ask for it).
  Status add_mesh(int index, const MeshTopology& topology);
  // Realtime: a relay asked for this avatar's mesh within the last three seconds and the rate
  // bound (mesh_max_hz) lets a frame go now. Never allocates, throws or waits.
  bool mesh_wanted(int index) const noexcept;
  // Realtime: an encoded mesh frame of avatar `index` at its LOD (copied; latest wins).
  void publish_mesh(int index, std::span<const uint8_t> packet) noexcept;

  bool connected() const;
  NatsLinkState link_state() const noexcept;
  std::string connected_url() const;  // the broker node in use, empty when not connected
  NatsLinkStats stats() const;
  std::string key(int index) const;

  struct Impl;

 private:
  explicit NatsPublisher(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The relay side: subscribes once to a scene and feeds `server` (add_avatar, publish_pose,
// update_avatar_model, remove_avatar, mesh topologies and frames) on the server's own thread.
// An avatar is served once its publisher shows a sign of life (a heartbeat or a frame), and
// leaves after `missed_heartbeats` of its publisher's periods without one; mesh frames of a LOD
// are asked from the publisher while a viewer of the server wants them. `server` must outlive
// it, and the feed is destroyed while the server is not running (or from the server's thread).
class NatsSceneFeed {
 public:
  static Result<std::unique_ptr<NatsSceneFeed>> create(const NatsOptions& options, Server& server);
  ~NatsSceneFeed();
  NatsSceneFeed(const NatsSceneFeed&) = delete;
  NatsSceneFeed& operator=(const NatsSceneFeed&) = delete;

  bool connected() const;
  NatsLinkState link_state() const noexcept;
  std::string connected_url() const;
  NatsLinkStats stats() const;

  struct Impl;

 private:
  explicit NatsSceneFeed(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::net
