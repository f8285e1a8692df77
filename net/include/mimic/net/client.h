// Client side of the scene protocol: a subscriber that receives every avatar's body model and
// latest pose frames (and mesh frames at a chosen LOD), or a publisher that brings avatars of
// its own into a scene hosted elsewhere (the remote source of a second Mimic).
//
// A client is driven by the thread that calls run_until/poll; callbacks run there. When the
// connection drops, the client reconnects and resumes its session (same token: a subscriber
// is not sent models it already holds; a publisher keeps its avatar ids and sequence numbers).
// Any cut of an established session is followed by a reconnection: a dropped connection, the
// server's goodbye, or a REJECT (e.g. its idle timeout after this process was stopped); only
// refusals another try cannot change (bad secret, no common version, a publisher's malformed
// input) end the session for good. A
// subscriber that was not driven for a while (stopped, busy) drops what its sockets buffered
// meanwhile and resumes, so it shows the newest frames rather than replaying old ones.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "mimic/core/result.h"
#include "mimic/net/frame_codec.h"
#include "mimic/net/pose_stream.h"

namespace mimic::net {

struct ClientOptions {
  // HOST:PORT of a Mimic server or relay. (A scene on a NATS broker is joined through a relay:
  // open_scene_connection in mimic/net/scene_connection.h, or `mimic relay`; docs/scaling.md.)
  std::string connect = "127.0.0.1:7777";
  Role role = Role::subscriber;
  std::string name = "mimic";
  std::string secret;          // publishers, when the server asks for one
  uint8_t mesh_lod = kNoMesh;  // subscribers: also receive mesh frames at this LOD
  // Subscribers: pose frames as UDP datagrams when the server offers them (models, meshes and
  // control stay on TCP; until the address is registered, frames keep coming over TCP).
  bool udp = false;
  bool reconnect = true;  // reconnect and resume after a dropped connection
  // Subscribers: the lean pose stream (key and delta frames, ~60 bytes instead of ~150) when the
  // server offers it, at the server's precision (coarser than POSE frames: docs/protocol.md).
  bool lean = false;
  double connect_timeout_s = 3.0;
  // Subscribers: not driven (run_until/poll) for this long, the client takes what its sockets
  // hold as stale, drops it and resumes the session to get the newest frames (0: never).
  double stall_resync_s = 1.0;
};

struct RemoteAvatar {
  uint16_t id = 0;
  std::string name;
  uint16_t dof_count = 0;
  uint32_t revision = 0;
  std::string model_bytes;
  bool has_pose = false;
  PoseHeader last;  // of the latest pose frame
  rig::Pose pose;   // dequantised
  uint64_t frames = 0;
  uint64_t lost = 0;  // sequence gaps (frames superseded before they reached us)
  // Mesh frames, when asked for.
  std::vector<uint32_t> mesh_indices;
  std::vector<glm::vec3> mesh_positions_m;
  // The topology's texture section (MeshTopology), when the server sends one: empty otherwise.
  std::vector<uint32_t> mesh_uv_source, mesh_uv_indices;
  std::vector<glm::vec2> mesh_uvs;
  uint64_t mesh_topologies = 0;  // topologies received: a change means the buffers change shape
  uint32_t mesh_vertex_count = 0;
  uint64_t mesh_frames = 0;
  MeshFrameHeader mesh_last;   // of the latest mesh frame (its LOD, sequence, time)
  LeanPoseState lean;          // the lean stream's reference frames of this avatar
  bool key_requested = false;  // a KEY_REQUEST is out and no key has come yet
  // The same avatar (same name, DOF count and model) came back after it left the scene (removed,
  // or the scene came back as a new session after a cut; within 10 minutes): its last frame
  // then. Its first frame here counts the frames in between as lost (when the sequence moved
  // forward by no more than its capture times allow: a restarted publisher carries nothing).
  bool carried = false;
  uint32_t carried_sequence = 0;
  uint64_t carried_time_us = 0;
};

struct ClientStats {
  uint64_t frames = 0;        // pose frames received
  uint64_t lost = 0;          // sum of sequence gaps
  uint64_t out_of_order = 0;  // frames not newer than the last one (dropped)
  uint64_t model_bytes = 0;   // bytes of model packets received
  uint64_t models = 0;
  uint64_t frame_bytes = 0;  // bytes of pose packets received
  uint64_t mesh_frames = 0;
  uint64_t mesh_bytes = 0;
  uint64_t bytes_in = 0;
  uint64_t reconnects = 0;
  uint64_t resumed = 0;
  uint64_t rejected = 0;           // malformed packets from the server
  uint64_t wrong_dof_count = 0;    // pose frames whose DOF count is not their model's (refused)
  uint64_t udp_frames = 0;         // pose frames that came as datagrams (also in frames)
  uint64_t udp_early = 0;          // datagram frames of an avatar whose model had not arrived
  uint64_t lean_keys = 0;          // lean stream: key frames applied (also in frames)
  uint64_t lean_unreferenced = 0;  // lean stream: deltas whose reference frame we lack (dropped)
  uint64_t key_requests = 0;       // KEY_REQUESTs sent after such a delta
  // Cuts (subscribers and publishers) and what they cost.
  uint64_t cuts = 0;             // established sessions that lost their connection, any cause
  uint64_t stall_resyncs = 0;    // of them: this side stalled, buffered frames dropped to resume
  uint64_t stale_datagrams = 0;  // datagrams dropped as stale on such a resync
  uint64_t outages = 0;          // cuts after which frames flowed again
  double outage_s = 0;           // time without frames over those: last frame before to first after
  double outage_max_s = 0;
  uint64_t lost_across_sessions = 0;  // part of `lost`: frames missed while an avatar was gone and came back
};

class Client {
 public:
  // Connects and completes the handshake (blocking, up to connect_timeout_s).
  static Result<std::unique_ptr<Client>> connect(const ClientOptions& options);
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  // Subscriber callbacks.
  std::function<void(const RemoteAvatar&)> on_model;
  std::function<void(const RemoteAvatar&, uint64_t receive_time_us)> on_pose;
  std::function<void(uint16_t avatar)> on_removed;
  std::function<void(const RemoteAvatar&)> on_mesh;
  // The connection of an established session was cut (`why` is printable: peers' words escaped);
  // the client is reconnecting.
  std::function<void(const std::string& why)> on_cut;
  // The first pose frame after a cut: `outage_s` since the last frame before it, `lost` frames
  // missed by sequence so far since the cut.
  std::function<void(double outage_s, uint64_t lost)> on_back;

  // Publisher: announces an avatar (body model bytes are opaque here) and returns its slot.
  Result<uint8_t> add_avatar(const std::string& name, uint16_t dof_count, std::string model_bytes);
  // Sends a pose of an added avatar (sequence numbers and timestamps are the caller's). Latest
  // wins: if the previous frame is still being written, this one replaces any waiting frame.
  // Never allocates after the first call.
  Status publish_pose(uint8_t slot, const PoseHeader& header, const rig::Pose& pose);

  // Processes the network until `deadline`, or without blocking. An error means the session
  // ended for good (rejected, or the connection dropped and resuming is off). Reconnecting
  // after a drop happens in the background (at once, then every 250 ms) and never blocks.
  Status run_until(std::chrono::steady_clock::time_point deadline);
  Status poll();

  // Drops the TCP connection without BYE (as a network failure would); the next run_until
  // reconnects and resumes. For tests and tools.
  void drop_connection();
  // Clean leave: BYE, then close; the session cannot be resumed.
  void close();
  // Keeps `resource` alive as long as this client, released after the client's sockets are
  // closed: what serves it from inside this process (open_scene_connection's relay).
  void hold(std::shared_ptr<void> resource);

  bool connected() const;
  bool udp_active() const;  // the server has registered our UDP address
  SessionToken session_token() const;
  uint32_t negotiated_capabilities() const;
  const std::map<uint16_t, RemoteAvatar>& avatars() const;
  const ClientStats& stats() const;

 private:
  struct Impl;
  explicit Client(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::net
