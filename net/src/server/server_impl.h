// The scene server's internals, shared by its parts (one idea per file):
//   session.cpp          a connection's life: read loop, rate limit, dispatch, refusal, close
//   handshake.cpp        HELLO: versions, secret, tokens, resume, the scene for a joiner
//   publishing.cpp       what publishers bring: avatars, model revisions, pose and mesh frames
//   fan_out.cpp          what subscribers get: control queue (latest model wins), frame slots, writes
//   fan_out_pool.cpp     the threads that share a tick's writes
//   udp_registration.cpp pose frames as datagrams: echoed-nonce registration, expiry
//   limits.cpp           accepting connections: per-address limits, deadlines, housekeeping
//   secure_random.cpp    tokens and nonces from the OS's CSPRNG
//   ../server.cpp        the public Server API
#pragma once

#include <utility>  // before Asio, which uses std::exchange without including it

#include <array>
#include <boost/asio.hpp>
#include <chrono>
#include <sys/uio.h>
#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "mimic/net/frame_codec.h"
#include "mimic/net/pose_stream.h"
#include "mimic/net/server.h"
#include "server/fan_out_pool.h"

namespace mimic::net {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using udp = asio::ip::udp;
using Clock = std::chrono::steady_clock;

inline constexpr int kMaxLods = 8;
inline constexpr size_t kMaxAvatarsPerPublisher = 16;
inline constexpr size_t kMaxAvatars = 4096;

inline Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

struct Session;

// An encoded packet shared by every session that queues it (a model revision is encoded once and
// never copied per subscriber).
using SharedBytes = std::shared_ptr<const std::vector<uint8_t>>;

struct MeshSlot {
  SharedBytes topology;        // encoded packet, shared by the writes that carry it
  SharedBytes topology_uv;     // the same with its texture section (kCapMeshUv), or null
  std::vector<uint8_t> frame;  // latest encoded mesh frame, sized for the topology
  size_t frame_size = 0;
  size_t frame_capacity = 0;  // mesh_packet_bytes of the topology's vertex count
  uint32_t sequence = 0;
};

struct Avatar {
  bool live = false;
  uint16_t id = 0;
  std::string name;
  uint16_t dof_count = 0;
  uint32_t revision = 0;
  SharedBytes model_packet;  // this revision, encoded once
  std::array<uint8_t, kMaxDatagramBytes> pose{};
  size_t pose_size = 0;
  uint32_t sequence = 0;
  bool has_pose = false;
  // The lean stream of this avatar: its delta frame encoded once per frame, its key frame at
  // most once, both shared by every subscriber (lean_ok: the skeleton fits the lean stream).
  LeanPoseEncoder lean;
  bool lean_ok = false;
  Session* owner = nullptr;  // remote publisher, or nullptr for a local avatar
  SessionToken owner_token;  // to re-attach on resume
  Clock::time_point orphaned_at{};
  bool orphaned = false;
  std::array<MeshSlot, kMaxLods> mesh;
};

struct ResumeRecord {
  Role role = Role::subscriber;
  Clock::time_point expires;
  std::map<uint8_t, uint16_t> slots;  // publisher: slot -> avatar
};

// A queued control packet. `model_of` names the avatar of a model packet: a newer revision of the
// same avatar replaces it in the queue (latest wins), a removal drops it.
struct ControlItem {
  SharedBytes bytes;
  uint16_t model_of = 0;
};

// Datagrams of one fan-out, sent with sendmmsg when it ends. They point into the avatars' frame
// buffers, so a batch goes out before any of those is overwritten (accept_pose). A datagram is
// one or more frames (several only for lean subscribers: one datagram per subscriber per tick),
// each a piece pointing at the shared frame buffer.
struct UdpPiece {
  const uint8_t* bytes = nullptr;
  size_t size = 0;
};
struct UdpOut {
  size_t first_piece = 0, pieces = 0, size = 0, frames = 0;
  udp::endpoint to;
};

// One piece of a session's gather write, and what to do with it if the kernel does not take it:
// control packets (shared) wait for an asynchronous write; frames not sent at all go back to
// their pending slot (latest wins: the newest frame goes when the socket takes more); only the
// rest of a frame the kernel took part of is copied.
struct OutPiece {
  enum Kind : uint8_t { shared, pose, mesh, tail } kind = shared;
  uint16_t avatar = 0;
  uint32_t lean_sent_before = 0;  // pose: the receiver's lean reference before this frame
};

// What one thread of a fan-out owns: its counters (added to ServerStats when they are read), its
// datagrams, and the subscribers whose write the kernel did not take whole (finished by the
// server's thread, which alone starts asynchronous writes and closes sessions). Lane 0 is the
// server's own thread.
struct FanoutLane {
  uint64_t frames_out = 0, bytes_out = 0, frames_dropped = 0;
  uint64_t lean_keys_out = 0, lean_deltas_out = 0, udp_frames_out = 0, udp_send_calls = 0, mesh_frames_out = 0;
  std::vector<UdpOut> udp_batch;
  std::vector<UdpPiece> udp_pieces;
  std::vector<uint8_t> udp_scratch;  // mmsghdr and iovec arrays (reused)
  // The gather write being attempted, one subscriber at a time (reused: stays in the cache).
  std::vector<iovec> iov;
  std::vector<OutPiece> pieces;  // by iov entry
  // Subscribers whose write the kernel did not take whole: what is left of it is in the
  // session's out_buffers (or nothing: wait until the socket takes more).
  struct Unfinished {
    Session* session = nullptr;
    int error = 0;  // errno of a failed write (the session is closed), 0 if only partial
  };
  std::vector<Unfinished> unfinished;
  // The subscribers this lane writes, [begin, end) of ServerImpl::ready.
  size_t begin = 0, end = 0;

  void add_to(ServerStats& s);
};

struct ServerImpl {
  ServerOptions opt;
  asio::io_context io{1};
  tcp::acceptor acceptor{io};
  asio::steady_timer accept_timer{io};  // the wait after a failed accept()
  int accept_backoff_ms = 0;
  asio::steady_timer housekeeping{io};
  bool loopback = true;
  // Pose frames as datagrams: subscribers register an address with their session token.
  udp::socket udp_sock{io};
  bool udp_on = false;
  std::array<uint8_t, kMaxDatagramBytes> udp_in{};
  udp::endpoint udp_from;
  udp::endpoint udp_local;  // the UDP socket's own address: datagrams "from" it are forged
  // Publisher HELLOs with a wrong secret, by address: the next is not checked before `until`.
  struct SecretFailures {
    int count = 0;
    Clock::time_point until;
  };
  std::map<asio::ip::address, SecretFailures> secret_failures;
  std::unordered_map<SessionToken, Session*, SessionTokenHash> udp_sessions;  // subscribers asking for UDP
  ServerStats stats;
  // Bytes of model packets alive (current revisions, and older ones still being written); the
  // deleter of every SharedBytes made by make_model_packet counts them down.
  std::shared_ptr<uint64_t> model_bytes_held = std::make_shared<uint64_t>(0);
  std::vector<Avatar> avatars;  // index = avatar id; 0 unused
  std::vector<std::shared_ptr<Session>> sessions;
  std::map<asio::ip::address, size_t> sessions_per_address;
  std::unordered_map<SessionToken, ResumeRecord, SessionTokenHash> resume;
  // Model revisions are unique across the server's life, so an avatar id reused after a removal
  // never looks like a model a resuming subscriber already holds.
  uint32_t next_revision = 1;
  bool batching = false;     // between begin_batch and end_batch: mark, flush once at the end
  bool fanning_out = false;  // in flush_subscribers: datagrams wait for its end
  // Fan-out threads: lanes[0] is the server's thread, the others the pool's workers.
  std::vector<FanoutLane> lanes = std::vector<FanoutLane>(1);
  FanoutPool pool;
  int fanout_threads = 1;               // opt.fanout_threads resolved
  std::vector<Session*> ready;          // subscribers with only pose frames to write this tick
  std::vector<Session*> rest;           // everyone else flush()es on the server's thread
  std::array<float, 4096> fanout_us{};  // the last fan-outs' wall times (Server::fanout_times)
  uint64_t fanouts = 0;
  // Asynchronous writes (and waits for a full socket), and closes after a failed write, wanted
  // outside the event loop, e.g. by the realtime loop's fan-out: done by the next poll()/run*(),
  // where Asio recycles their memory, so that a fan-out never allocates.
  std::vector<std::shared_ptr<Session>> deferred;
  // Bytes of a frame of every live avatar at most (pose, and mesh per LOD): what a session's
  // copy of an unfinished write is sized for (reserve_fanout).
  size_t frame_bytes_bound = 0;
  std::array<size_t, kMaxLods> mesh_bytes_bound{};
  std::array<size_t, kMaxLods> mesh_frame_largest{};
  // Frame buffers sized by every avatar's topologies (bounded by opt.max_mesh_bytes).
  size_t mesh_bytes_held = 0;

  // limits.cpp
  void start_accept();
  void on_accept(tcp::socket sock);
  void schedule_housekeeping();
  void remove_session(Session* s);
  void expire_secret_failures(Clock::time_point now);
  uint32_t new_session_id() const;
  // udp_registration.cpp
  void start_udp_receive();
  void on_datagram(std::span<const uint8_t> datagram);
  void expire_udp_registrations(Clock::time_point now);
  // handshake.cpp
  uint32_t capabilities() const { return udp_on ? kServerCapabilities : kServerCapabilities & ~uint32_t(kCapUdpPose); }
  SessionToken new_token() const;
  // publishing.cpp
  Avatar* avatar(uint16_t id) { return id < avatars.size() && avatars[id].live ? &avatars[id] : nullptr; }
  Result<uint16_t> new_avatar(const std::string& name, uint16_t dof_count, std::string model_bytes, Session* owner);
  void update_model(Avatar& a, const AvatarModel& m);
  // Whether the scene's current models stay within opt.max_model_bytes_held with a model packet
  // of `packet_bytes` in place of `replacing`'s (or added); counts a refusal.
  bool model_fits(size_t packet_bytes, const Avatar* replacing);
  void drop_avatar(uint16_t id);
  Reject accept_pose(Avatar& a, std::span<const uint8_t> packet);
  Reject accept_mesh(Avatar& a, uint8_t lod, std::span<const uint8_t> packet);
  // A new mesh topology of an avatar at t.lod: ok, oversized (more vertices than a frame holds)
  // or unavailable (over opt.max_mesh_bytes, or out of memory).
  Reject set_topology(Avatar& a, const MeshTopology& t);
  SharedBytes make_model_packet(const AvatarModel& m);
  // fan_out.cpp
  void fan_out_pose(uint16_t id);
  void flush_subscribers();
  void write_lane(FanoutLane& lane);
  void send_udp_batch(FanoutLane& lane);
  void send_udp_batch() { send_udp_batch(lanes[0]); }
  void fold_lanes();
  void enforce_model_memory_cap();
  // On the event loop, whenever sessions, avatars, UDP registrations or mesh topologies change:
  // sizes every buffer a fan-out fills, so that a fan-out itself never allocates.
  void reserve_fanout();
  void start_deferred();
};

// The most bytes a subscriber can be sent for one frame of an avatar with `dofs` DOFs.
size_t frame_bytes_bound(uint16_t dofs);

struct Session : std::enable_shared_from_this<Session> {
  ServerImpl& srv;
  tcp::socket sock;
  asio::ip::address peer_address;  // of the TCP connection
  asio::steady_timer hello_timer;
  PacketReader reader{kMaxHelloBytes};
  uint32_t id = 0;
  bool active = false;  // HELLO accepted
  bool closed = false;
  bool counted_per_address = false;
  Role role = Role::subscriber;
  std::string name;
  uint32_t caps = 0;
  uint8_t mesh_lod = kNoMesh;
  SessionToken token;
  Clock::time_point last_heard;  // any packet from the peer (idle timeout)

  // UDP: pose frames go to udp_peer once it echoed udp_nonce, until not refreshed in time. A
  // candidate address gets its own nonce (pending_*) and replaces udp_peer only when it echoes.
  bool udp_ready = false;
  udp::endpoint udp_peer;
  uint64_t udp_nonce = 0;
  Clock::time_point udp_refreshed;
  udp::endpoint pending_peer;
  uint64_t pending_nonce = 0;
  double udp_answer_tokens = 0;  // registration answers left (ServerOptions::udp_answers_per_s)
  Clock::time_point udp_answer_refill;

  // Outgoing: one write in flight (control packets from their shared buffers, frames from the
  // avatars' buffers, as one gather write), control packets queued behind it (never dropped,
  // but a newer model replaces an older one of the same avatar), and one pending frame slot per
  // avatar (latest wins). Every vector here is sized on the event loop (ensure_slot,
  // reserve_buffers), never by a fan-out.
  std::vector<ControlItem> out_shared;          // packets of the write in flight (models marked), kept alive
  std::vector<asio::const_buffer> out_buffers;  // what an asynchronous write still has to send
  std::vector<ControlItem> control;
  size_t control_bytes = 0;
  std::vector<uint16_t> pending;      // avatars with a pose frame waiting
  std::vector<uint8_t> pending_flag;  // by avatar id
  std::vector<uint16_t> pending_mesh;
  std::vector<uint8_t> pending_mesh_flag;
  std::vector<uint8_t> topology_sent;  // by avatar id, for mesh subscribers
  // Lean stream: by avatar id, the sequence of the last frame this subscriber was sent (its
  // receiver's reference; 0: none, so the next frame goes as a key).
  std::vector<uint32_t> lean_sent;
  std::vector<uint8_t> out_tail;  // frames of a write the kernel did not take, copied
  bool writing = false;
  bool failed = false;  // a write failed off the event loop; it closes the session (fail())

  // Inbound
  std::map<uint8_t, uint16_t> slots;          // publisher slot -> avatar id
  std::map<uint16_t, uint32_t> models_known;  // subscriber: avatar -> revision queued this session
  double tokens = 0;
  Clock::time_point last_refill;
  rig::Pose scratch_pose;
  std::vector<glm::vec3> scratch_mesh;
  MeshTopology scratch_topology;

  uint64_t frames_out = 0, frames_dropped = 0, rejected = 0;

  Session(ServerImpl& s, tcp::socket socket);

  // session.cpp
  void start();
  void read();
  void on_read(const boost::system::error_code& ec, size_t n);
  bool rate_ok();
  void count(Reject e);
  void handle(std::span<const uint8_t> packet);
  void refuse(Reject reason, const char* message);
  void forget_token();
  void close(bool clean);
  // handshake.cpp
  void on_hello(std::span<const uint8_t> packet);
  bool secret_accepted(const std::string& secret);
  void reattach(const std::map<uint8_t, uint16_t>& old_slots);
  // publishing.cpp
  Reject on_model(std::span<const uint8_t> packet);
  Avatar* slot_avatar(uint16_t slot);
  Reject on_pose(std::span<const uint8_t> packet);
  Reject on_mesh_topology(std::span<const uint8_t> packet);
  Reject on_mesh(std::span<const uint8_t> packet);
  // fan_out.cpp
  void send_model(Avatar& a);
  void queue_control(std::span<const uint8_t> bytes);
  void queue_model(uint16_t avatar_id, const SharedBytes& packet);
  void drop_queued_model(uint16_t avatar_id);
  void ensure_slot(uint16_t avatar_id);
  void mark_pose(uint16_t avatar_id);
  // The bytes of an avatar's current frame for this subscriber (lean key or delta, or POSE).
  std::span<const uint8_t> frame_bytes(Avatar& a, FanoutLane& lane);
  void on_key_request(std::span<const uint8_t> packet);
  void topology_changed(uint16_t avatar_id, uint8_t lod);
  void mark_mesh(uint16_t avatar_id);
  void send_poses_udp(FanoutLane& lane);
  void gather_poses(FanoutLane& lane);
  // Sizes the outgoing buffers for the avatars and the control queue (event loop only).
  void reserve_buffers();
  void reserve_pieces();
  // lane.iov to the kernel at once; what it does not take is settled by settle_write. Returns
  // true when an asynchronous write (or a wait for room) must follow; `error` is set when the
  // connection failed.
  bool send_now(FanoutLane& lane, int& error);
  bool settle_write(size_t sent, FanoutLane& lane);
  // The asynchronous rest of a write: started now on the event loop, else by the next poll.
  void continue_async();
  void start_async();
  void fail();
  // Nothing but pose frames to send (no control packet, mesh frame or write in flight): what a
  // fan-out thread may write for it.
  bool poses_only() const {
    return active && !closed && !failed && role == Role::subscriber && !writing && control.empty() &&
           pending_mesh.empty();
  }
  // A fan-out thread's write of this subscriber's pending frames (poses_only()); anything the
  // kernel does not take goes to lane.unfinished.
  void write_poses(FanoutLane& lane);
  void finish_write(const FanoutLane::Unfinished& u);
  void flush();
  bool pins_stale_model() const;
};

}  // namespace mimic::net
