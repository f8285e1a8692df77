// The scene server: publishers bring avatars (body model once, then pose frames), subscribers
// receive every avatar's model on join and its latest frames after. One TCP connection per
// client carries everything; a subscriber may ask for its pose frames as UDP datagrams instead,
// sent from the same port (docs/protocol.md explains both).
//
// Frames are latest-wins: each subscriber has one write in flight and one pending slot per
// avatar, so a slow or stalled subscriber overwrites (and counts) its own old frames and never
// delays anyone else. Models are latest-wins too: one shared packet per revision, only the
// newest per avatar queued for a subscriber, and a cap on what old revisions may pin. Hostile input (malformed,
// truncated, oversized, out-of-order packets, unknown versions, floods) is refused, counted in ServerStats and, where
// it breaks the stream, ends only that session.
//
// Threading: a Server is driven by one thread (run, run_until or poll) and every call except
// stop() and port() must come from that thread. Local avatars (the in-process pipeline) publish
// through publish_pose(), which never allocates or throws.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mimic/core/result.h"
#include "mimic/net/frame_codec.h"

namespace mimic::net {

struct ServerOptions {
  std::string listen = "127.0.0.1:0";  // ADDR:PORT; port 0 picks a free port
  // Publishers must present it. Required when `listen` is not a loopback address.
  std::string secret;
  size_t max_sessions = 4096;
  size_t max_sessions_per_address = 256;        // from one peer IP address (idle floods stop there)
  double hello_timeout_s = 2.0;                 // a connection that does not say HELLO in time is closed
  double idle_timeout_s = 10.0;                 // a session that sends nothing (not even PING) is closed; 0: never
  double resume_grace_s = 10.0;                 // how long a dropped session's token (and avatars) live
  double max_packets_per_s = 1000;              // per session, with one second of burst
  int send_buffer_bytes = 32 * 1024;            // kernel send buffer per session (bounds staleness)
  size_t max_control_backlog_bytes = 8u << 20;  // models/meshes queued for a stalled client
  // Model packets held in memory, all avatars and revisions; over it, subscribers whose stalled
  // writes pin old revisions are disconnected.
  // The current models of all avatars are bounded by it too: a model (or revision) that would
  // pass it is refused (ServerStats::models_refused).
  uint64_t max_model_bytes_held = 64u << 20;
  // Mesh frame buffers of all avatars and LODs, sized by their topologies: a topology that would
  // pass it is refused (ServerStats::mesh_topologies_refused).
  size_t max_mesh_bytes = 64u << 20;
  // Mesh LODs whose frames this server serves (bit i = LOD i): a subscriber asking for another
  // is refused with Reject::unavailable, naming these. All by default (remote publishers may
  // bring any); `mimic run` serves the LOD it deforms.
  uint8_t mesh_lods_served = 0xFF;
  bool udp = true;  // offer pose frames as UDP datagrams (a UDP socket on the same address and port)
  // UDP registrations must come from the TCP peer's IP address unless this is set (e.g. a
  // client whose UDP leaves through another interface or NAT than its TCP connection).
  bool udp_from_any_address = false;
  double udp_registration_timeout_s = 5.0;  // not refreshed for this long: frames back on TCP
  int housekeeping_period_ms = 250;         // timeouts are checked this often
  // UDP_REGISTER answers per session per second (registrations refresh about once a second):
  // beyond it registrations are dropped unanswered, so no datagram source can make the server
  // answer without bound.
  double udp_answers_per_s = 20;
  // A publisher HELLO with a wrong secret makes its address wait before the next is checked:
  // the wait starts here and doubles per failure, up to secret_backoff_max_s.
  double secret_backoff_s = 0.05;
  double secret_backoff_max_s = 10.0;
  // Network work done by one poll(): at most this many completions and this much time, so a
  // loop that interleaves frames with poll() keeps its rate whatever arrives (the rest waits for
  // the next poll).
  int poll_max_handlers = 256;
  int poll_budget_us = 2000;
  // The lean pose stream (subscribers with kCapLeanPose, docs/protocol.md): precision as a
  // power-of-two coarsening of the POSE frame's steps, and a key frame to everyone every this
  // many frames (0: only to joiners, after skipped frames and on request).
  uint8_t lean_pose_shift = 3;  // kDefaultPoseShift
  uint32_t lean_key_interval = 90;
  // A tick's writes to subscribers are shared by this many threads (the server's own and
  // fanout_threads - 1 workers; 0: one per core, at most 4), each subscriber written by one of
  // them; only ticks with at least `fanout_parallel_from` subscribers to write are shared (below
  // that, waking a worker costs more than it saves). Workers take the scheduling policy of the
  // thread that publishes (SCHED_FIFO under `mimic run --realtime`).
  int fanout_threads = 0;
  size_t fanout_parallel_from = 256;
};

struct ServerStats {
  uint64_t sessions_accepted = 0;
  uint64_t sessions_open = 0;
  uint64_t publishers = 0;
  uint64_t subscribers = 0;
  uint64_t resumed = 0;
  uint64_t avatars = 0;
  uint64_t packets_in = 0;
  uint64_t bytes_in = 0;
  uint64_t bytes_out = 0;
  uint64_t frames_in = 0;       // pose frames accepted from publishers (local or remote)
  uint64_t frames_out = 0;      // pose frames written to subscribers
  uint64_t frames_dropped = 0;  // latest-wins: overwritten before a subscriber could take them
  uint64_t mesh_frames_out = 0;
  uint64_t model_bytes_out = 0;
  uint64_t sessions_closed_for_input = 0;         // ended because of what the peer sent
  uint64_t sessions_closed_slow = 0;              // control backlog overflow, or pinning old models over the cap
  uint64_t sessions_timed_out = 0;                // no HELLO in time, or idle past the idle timeout
  uint64_t sessions_refused_per_address = 0;      // over max_sessions_per_address
  uint64_t model_bytes_held = 0;                  // model packets in memory (shared by all sessions)
  uint64_t udp_datagrams_in = 0;                  // received on the UDP socket, valid or not
  uint64_t udp_registered = 0;                    // registrations completed (the address echoed its nonce)
  uint64_t udp_challenges = 0;                    // nonces sent to addresses not (yet) registered
  uint64_t udp_wrong_address = 0;                 // registrations from another IP than the TCP peer's
  uint64_t udp_expired = 0;                       // registrations not refreshed in time
  uint64_t udp_frames_out = 0;                    // pose frames sent as datagrams (also in frames_out)
  uint64_t lean_keys_out = 0;                     // lean stream: key frames sent (also in frames_out)
  uint64_t lean_deltas_out = 0;                   // lean stream: delta frames sent (also in frames_out)
  uint64_t key_requests = 0;                      // KEY_REQUESTs from subscribers
  uint64_t udp_send_calls = 0;                    // sendmmsg calls (each sends a batch of datagrams)
  uint64_t fanout_shared = 0;                     // fan-outs whose writes several threads shared
  uint64_t models_refused = 0;                    // models over max_model_bytes_held
  uint64_t mesh_topologies_refused = 0;           // topologies over max_mesh_bytes (or out of memory)
  uint64_t mesh_bytes_held = 0;                   // mesh frame buffers sized by topologies
  uint64_t sessions_out_of_memory = 0;            // sessions dropped because memory for them ran out
  uint64_t udp_own_address = 0;                   // datagrams claiming the server's own address, ignored
  uint64_t udp_answers_limited = 0;               // registrations over udp_answers_per_s, unanswered
  uint64_t accept_errors = 0;                     // accept() failures (EMFILE, ENFILE, ...), retried later
  uint64_t secret_backoffs = 0;                   // publisher HELLOs refused while their address waits
  uint64_t poll_budget_hit = 0;                   // poll() calls that left work for the next one
  uint64_t max_sessions_effective = 0;            // max_sessions, lowered to what descriptors allow
  std::array<uint64_t, kRejectCount> rejected{};  // by Reject code

  uint64_t rejected_total() const {
    uint64_t n = 0;
    for (auto v : rejected) n += v;
    return n;
  }
};

struct ServerImpl;  // internal

struct SessionInfo {
  uint32_t id = 0;
  Role role = Role::subscriber;
  std::string name;
  uint64_t frames_out = 0;
  uint64_t frames_dropped = 0;
  uint64_t rejected = 0;
  bool udp = false;  // pose frames go to a registered UDP address
};

class Server {
 public:
  static Result<std::unique_ptr<Server>> create(const ServerOptions& options);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  uint16_t port() const;
  bool udp() const;              // pose frames offered as UDP datagrams (ServerOptions::udp and the port was free)
  std::string endpoint() const;  // "127.0.0.1:7777"
  int fanout_threads() const;    // ServerOptions::fanout_threads, 0 resolved

  // Avatars published from this process. `model_bytes` is the serialised body model (opaque
  // here); pose frames must carry `dof_count` values.
  Result<uint16_t> add_avatar(const std::string& name, uint16_t dof_count, std::string model_bytes);
  void remove_avatar(uint16_t avatar);
  // A new body model (or DOF count) for a local avatar: subscribers get it at once, and its
  // pose frames start over (the next one is accepted whatever its sequence number), as when
  // the avatar's publisher restarted.
  Status update_avatar_model(uint16_t avatar, uint16_t dof_count, std::string model_bytes);
  // `packet` is an encoded pose frame (encode_pose); its avatar field is set to `avatar`. Packets
  // not newer than the last one are refused (out_of_order). Never allocates or throws.
  Reject publish_pose(uint16_t avatar, std::span<const uint8_t> packet);
  // Frames published between begin_batch() and end_batch() (one tick of several avatars) go to
  // each subscriber in one write instead of one per avatar.
  void begin_batch();
  void end_batch();
  // LODs (bit i = LOD i, i < 8) some subscriber wants mesh frames of for `avatar`.
  uint8_t mesh_lods_wanted(uint16_t avatar) const;
  Status set_mesh_topology(const MeshTopology& topology);
  // An encoded mesh frame (encode_mesh) for an avatar and LOD whose topology is set.
  Reject publish_mesh(uint16_t avatar, uint8_t lod, std::span<const uint8_t> packet);

  // Drive the network: until `deadline`, once without blocking, or until stop().
  void run_until(std::chrono::steady_clock::time_point deadline);
  void poll();
  void run();
  void stop();  // any thread
  // Runs `fn` on the thread driving the server (any thread may call; allocates: not for the
  // realtime loop). For setup, tools and tests.
  void dispatch(std::function<void()> fn);

  const ServerStats& stats() const;
  // Wall time of the last fan-outs (up to 4096; a fan-out is end_batch, or a frame published
  // outside a batch): from the first write to the last one handed to the kernel.
  struct FanoutTimes {
    double p50_us = 0, p99_us = 0;
    uint64_t count = 0;  // fan-outs since the server started
  };
  FanoutTimes fanout_times() const;
  std::vector<SessionInfo> sessions() const;

 private:
  explicit Server(std::unique_ptr<ServerImpl> impl);
  std::unique_ptr<ServerImpl> impl_;
};

}  // namespace mimic::net
