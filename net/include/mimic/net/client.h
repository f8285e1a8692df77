// Client side of the scene protocol: a subscriber that receives every avatar's body model and
// latest pose frames (and mesh frames at a chosen LOD), or a publisher that brings avatars of
// its own into a scene hosted elsewhere (the remote source of a second Mimic).
//
// A client is driven by the thread that calls run_until/poll; callbacks run there. When the
// connection drops, the client reconnects and resumes its session (same token: a subscriber
// is not sent models it already holds; a publisher keeps its avatar ids and sequence numbers).
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
  // HOST:PORT, or a scene on a NATS broker: nats://HOST:PORT[,nats://HOST:PORT...][/SCENE]
  // (served to this client by a relay inside its process; docs/scaling.md)
  std::string connect = "127.0.0.1:7777";
  Role role = Role::subscriber;
  std::string name = "mimic";
  std::string secret;              // publishers, when the server asks for one
  uint8_t mesh_lod = kNoMesh;      // subscribers: also receive mesh frames at this LOD
  // Subscribers: pose frames as UDP datagrams when the server offers them (models, meshes and
  // control stay on TCP; until the address is registered, frames keep coming over TCP).
  bool udp = false;
  bool reconnect = true;           // reconnect and resume after a dropped connection
  // Subscribers: the lean pose stream (key and delta frames, ~60 bytes instead of ~150) when the
  // server offers it, at the server's precision (coarser than POSE frames: docs/protocol.md).
  bool lean = false;
  double connect_timeout_s = 3.0;
};

struct RemoteAvatar {
  uint16_t id = 0;
  std::string name;
  uint16_t dof_count = 0;
  uint32_t revision = 0;
  std::string model_bytes;
  bool has_pose = false;
  PoseHeader last;                 // of the latest pose frame
  avatar::Pose pose;               // dequantised
  uint64_t frames = 0;
  uint64_t lost = 0;               // sequence gaps (frames superseded before they reached us)
  // Mesh frames, when asked for.
  std::vector<uint32_t> mesh_indices;
  std::vector<glm::vec3> mesh_positions_m;
  uint32_t mesh_vertex_count = 0;
  uint64_t mesh_frames = 0;
  MeshFrameHeader mesh_last;       // of the latest mesh frame (its LOD, sequence, time)
  LeanPoseState lean;              // the lean stream's reference frames of this avatar
  bool key_requested = false;      // a KEY_REQUEST is out and no key has come yet
};

struct ClientStats {
  uint64_t frames = 0;            // pose frames received
  uint64_t lost = 0;              // sum of sequence gaps
  uint64_t out_of_order = 0;      // frames not newer than the last one (dropped)
  uint64_t model_bytes = 0;       // bytes of model packets received
  uint64_t models = 0;
  uint64_t frame_bytes = 0;       // bytes of pose packets received
  uint64_t mesh_frames = 0;
  uint64_t mesh_bytes = 0;
  uint64_t bytes_in = 0;
  uint64_t reconnects = 0;
  uint64_t resumed = 0;
  uint64_t rejected = 0;          // malformed packets from the server
  uint64_t wrong_dof_count = 0;   // pose frames whose DOF count is not their model's (refused)
  uint64_t udp_frames = 0;        // pose frames that came as datagrams (also in frames)
  uint64_t udp_early = 0;         // datagram frames of an avatar whose model had not arrived
  uint64_t lean_keys = 0;         // lean stream: key frames applied (also in frames)
  uint64_t lean_unreferenced = 0; // lean stream: deltas whose reference frame we lack (dropped)
  uint64_t key_requests = 0;      // KEY_REQUESTs sent after such a delta
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

  // Publisher: announces an avatar (body model bytes are opaque here) and returns its slot.
  Result<uint8_t> add_avatar(const std::string& name, uint16_t dof_count, std::string model_bytes);
  // Sends a pose of an added avatar (sequence numbers and timestamps are the caller's). Latest
  // wins: if the previous frame is still being written, this one replaces any waiting frame.
  // Never allocates after the first call.
  Status publish_pose(uint8_t slot, const PoseHeader& header, const avatar::Pose& pose);

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
