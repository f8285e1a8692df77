// The Mimic wire protocol, version 2 (docs/protocol.md): pure encoders and decoders, no I/O.
//
// Every packet is an 8-byte header (magic 'M', version, type, flags, u32 little-endian payload
// length) followed by its payload. Encoders write into caller-owned buffers and return the
// packet size (0 when the buffer is too small); they never allocate. Decoders validate every
// field against the payload length and report why a packet was refused as a `Reject` code
// (counted by the server), never by throwing; decoding a pose into a Pose whose dof_rad already
// has the right size does not allocate.
//
// Units: metres, radians, microseconds. Frames: +Y up, the body faces +Z, left is +X.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/rig/skeleton.h"

namespace mimic::net {

inline constexpr uint8_t kMagic = 'M';
// Version 2: 128-bit session tokens and UDP registration by echoed nonce (version 1 had 64-bit
// tokens and registered any address that presented one).
inline constexpr uint8_t kProtocolVersion = 2;  // the only version this build speaks
inline constexpr uint8_t kMinProtocolVersion = 2;
inline constexpr size_t kHeaderBytes = 8;

// Size limits (whole packet, header included).
inline constexpr size_t kMaxDatagramBytes = 1200;  // pose packets always fit one datagram
inline constexpr size_t kMaxHelloBytes = 512;
inline constexpr size_t kMaxModelBytes = 1u << 20;  // opaque body model payload
inline constexpr size_t kMaxMeshBytes = 8u << 20;   // mesh topology / mesh frame
inline constexpr size_t kMaxPacketBytes = kMaxMeshBytes + 64;
inline constexpr size_t kMaxNameBytes = 64;
inline constexpr size_t kMaxSecretBytes = 128;
inline constexpr size_t kPoseFixedBytes = kHeaderBytes + 38;  // + 2 bytes per DOF
inline constexpr size_t kMaxPoseDofs = (kMaxDatagramBytes - kPoseFixedBytes) / 2;
inline constexpr uint16_t kNoMesh = 0xFF;
// The most vertices a mesh frame of kMaxMeshBytes can carry (6 bytes each after a 36-byte
// header). A topology's vertex count is bounded by it: receivers size every frame buffer of that
// avatar and LOD from the count, before any frame arrives.
inline constexpr uint32_t kMaxMeshVertices = (kMaxMeshBytes - kHeaderBytes - 36) / 6;

enum class MsgType : uint8_t {
  hello = 1,            // client -> server: versions, role, capabilities, resume token, secret
  welcome = 2,          // server -> client: chosen version, agreed capabilities, session token
  reject = 3,           // server -> client: why the session was refused (then the server closes)
  bye = 4,              // either way: clean leave (the session cannot be resumed)
  udp_register = 5,     // over UDP, client -> server: session token and the last nonce it got;
                        // server -> client: the same token and the nonce to echo (docs/protocol.md)
  ping = 6,             // client -> server: keep-alive of an otherwise silent session
  key_request = 7,      // subscriber -> server (kCapLeanPose): u16 avatar; its next frame goes as a key
  avatar_model = 10,    // publisher -> server (avatar = publisher's slot) and server -> subscriber
  avatar_removed = 11,  // server -> subscriber
  scene = 12,           // server -> subscriber after WELCOME: every live avatar (id, revision)
  pose = 20,            // quantised joint values; one datagram
  pose_delta = 21,      // server -> subscriber with kCapLeanPose: key or delta frame (pose_stream.h)
  mesh_topology = 30,   // fixed index array of one avatar at one LOD
  mesh = 31,            // vertex positions at that LOD
};

enum class Role : uint8_t { publisher = 1, subscriber = 2 };

enum Capability : uint32_t {
  kCapPose = 1u << 0,      // pose frames (always on in v1)
  kCapMesh = 1u << 1,      // mesh topology + mesh frames at a chosen LOD
  kCapResume = 1u << 2,    // the session token may be presented again after a disconnect
  kCapUdpPose = 1u << 3,   // subscribers: pose frames as UDP datagrams (docs/protocol.md)
  kCapLeanPose = 1u << 4,  // subscribers: POSE_DELTA key and delta frames instead of POSE
  kCapMeshUv = 1u << 5,    // MESH_TOPOLOGY may carry texture coordinates (its texture section)
};
inline constexpr uint32_t kServerCapabilities =
    kCapPose | kCapMesh | kCapResume | kCapUdpPose | kCapLeanPose | kCapMeshUv;

// A session token: 128 bits from the OS's CSPRNG, all zero for "none". Equality takes the same
// time whatever the bytes, so a guess learns nothing from how fast it was refused.
inline constexpr size_t kTokenBytes = 16;
struct SessionToken {
  std::array<uint8_t, kTokenBytes> bytes{};
  bool empty() const noexcept;
  friend bool operator==(const SessionToken& a, const SessionToken& b) noexcept;
};
struct SessionTokenHash {
  size_t operator()(const SessionToken& t) const noexcept;
};

// UDP_REGISTER in both directions: the client sends its token and the nonce it last received
// (0 at first); the server answers with the token and the nonce the address must echo. Equal
// nonces in the answer mean the address is registered.
struct UdpRegister {
  SessionToken token;
  uint64_t nonce = 0;
};
inline constexpr size_t kUdpRegisterBytes = kHeaderBytes + kTokenBytes + 8;

// Why a packet or a session was refused. Numeric values are on the wire (REJECT) and stable.
enum class Reject : uint16_t {
  ok = 0,
  truncated = 1,  // shorter than its header or its fields say
  bad_magic = 2,
  unknown_version = 3,  // header version this build does not speak
  unknown_type = 4,
  oversized = 5,            // longer than the type's limit
  malformed = 6,            // a field out of range (bad lengths, zero quaternion, trailing bytes)
  out_of_order = 7,         // sequence number not newer than the last one accepted
  unsupported_version = 8,  // no common version in HELLO
  unauthorized = 9,         // publisher without the shared secret
  unexpected = 10,          // valid packet in the wrong state or role
  flood = 11,               // over the session's packet rate
  server_full = 12,
  timeout = 13,            // no HELLO in time, or silent for longer than the idle timeout
  too_many_sessions = 14,  // over the per-address session limit
  unavailable = 15,        // asks for what this server does not offer (a mesh LOD it does not serve)
};
inline constexpr int kRejectCount = 16;
const char* reject_name(Reject r) noexcept;

struct Header {
  uint8_t version = kProtocolVersion;
  MsgType type = MsgType::hello;
  uint8_t flags = 0;
  uint32_t payload_bytes = 0;
};

// Largest packet (header included) accepted for a message type; 0 for unknown types.
size_t max_packet_bytes(uint8_t type) noexcept;

// Checks magic, version and the type's size limit from the first kHeaderBytes of `bytes`.
Reject decode_header(std::span<const uint8_t> bytes, Header& out) noexcept;

// ---- messages ---------------------------------------------------------------------------------

struct Hello {
  uint8_t min_version = kMinProtocolVersion;
  uint8_t max_version = kProtocolVersion;
  Role role = Role::subscriber;
  uint8_t mesh_lod = kNoMesh;  // subscribers: mesh frames at this LOD, or kNoMesh
  uint32_t capabilities = kCapPose | kCapResume;
  SessionToken resume_token;  // empty: a new session
  std::string name;           // for logs, ≤ kMaxNameBytes, no control characters
  std::string secret;         // publishers on a non-loopback server, ≤ kMaxSecretBytes
};

struct Welcome {
  uint8_t version = kProtocolVersion;
  uint32_t capabilities = 0;  // client's ∩ server's
  SessionToken session_token;
  uint32_t client_id = 0;
  bool resumed = false;
};

struct RejectMsg {
  Reject reason = Reject::ok;
  uint8_t server_min_version = kMinProtocolVersion;
  uint8_t server_max_version = kProtocolVersion;
  std::string message;
};

// The body model travels as opaque bytes from the avatar module; `dof_count` lets a receiver
// check pose frames against it without parsing the model.
struct AvatarModel {
  uint16_t avatar = 0;
  uint32_t revision = 0;
  uint16_t dof_count = 0;
  std::string name;
  std::string model_bytes;
};

// Pose frame fields besides the pose itself.
struct PoseHeader {
  uint16_t avatar = 0;
  uint16_t flags = 0;     // kPoseStale when the source had no fresh data
  uint32_t sequence = 0;  // per avatar, +1 per frame
  uint64_t time_us = 0;   // capture time, publisher's wall clock (µs since the Unix epoch)
};
inline constexpr uint16_t kPoseStale = 1u << 0;

// The avatars present when a subscriber (re)joins: a resuming subscriber drops any avatar it
// holds that is not listed (it may have missed the removal while away).
struct SceneEntry {
  uint16_t avatar = 0;
  uint32_t revision = 0;
};
inline constexpr size_t kMaxSceneBytes = 64 * 1024;

struct MeshTopology {
  MeshTopology() = default;
  // The plain topology (no texture section), as written before texture coordinates.
  MeshTopology(uint16_t avatar_id, uint8_t lod_, uint32_t vertices, std::vector<uint32_t> triangles)
      : avatar(avatar_id), lod(lod_), vertex_count(vertices), indices(std::move(triangles)) {}
  uint16_t avatar = 0;
  uint8_t lod = 0;
  uint32_t vertex_count = 0;
  std::vector<uint32_t> indices;  // 3 per triangle, each < vertex_count
  // Texture coordinates, only between peers that agreed kCapMeshUv: empty, or the skin with its
  // seams split (a vertex where u wraps or two parts meet has a coordinate on each side). Per
  // textured vertex the skin vertex it copies (< vertex_count) and its (u, v) in [0, 1]; then
  // the same triangles, in the same order, over the textured vertices
  // (uv_source[uv_indices[i]] == indices[i]).
  std::vector<uint32_t> uv_source;
  std::vector<glm::vec2> uvs;
  std::vector<uint32_t> uv_indices;
};

struct MeshFrameHeader {
  uint16_t avatar = 0;
  uint8_t lod = 0;
  uint32_t sequence = 0;
  uint64_t time_us = 0;
};

// Quantisation steps (the round-trip tolerances).
inline constexpr float kRootPositionStep_m = 1e-5f;              // ±21 km range
inline constexpr float kAngleStep_rad = 3.14159265f / 32767.0f;  // angles wrap into [-π, π]
inline constexpr float kQuatStep = 1.0f / 32767.0f;

// Pose packet size for a skeleton with `dof_count` DOFs (150 bytes for the default skeleton).
constexpr size_t pose_packet_bytes(size_t dof_count) { return kPoseFixedBytes + 2 * dof_count; }

// Encoders: packet size written into `out`, or 0 if `out` is too small or a field is too long.
size_t encode_hello(const Hello& m, std::span<uint8_t> out) noexcept;
size_t encode_welcome(const Welcome& m, std::span<uint8_t> out) noexcept;
size_t encode_reject(const RejectMsg& m, std::span<uint8_t> out) noexcept;
size_t encode_bye(std::span<uint8_t> out) noexcept;
size_t encode_avatar_model(const AvatarModel& m, std::span<uint8_t> out) noexcept;
size_t encode_avatar_removed(uint16_t avatar, std::span<uint8_t> out) noexcept;
size_t encode_udp_register(const UdpRegister& m, std::span<uint8_t> out) noexcept;
size_t encode_ping(std::span<uint8_t> out) noexcept;
size_t encode_key_request(uint16_t avatar, std::span<uint8_t> out) noexcept;
size_t encode_scene(std::span<const SceneEntry> entries, std::span<uint8_t> out) noexcept;
// Also 0 when pose.dof_rad.size() > kMaxPoseDofs.
size_t encode_pose(const PoseHeader& h, const rig::Pose& pose, std::span<uint8_t> out) noexcept;
size_t encode_mesh_topology(const MeshTopology& m, std::span<uint8_t> out) noexcept;
// For receivers that agreed kCapMeshUv: the texture section follows the indices (when m.uvs is
// not empty); 0 also when the texture fields disagree in size.
size_t encode_mesh_topology_with_uvs(const MeshTopology& m, std::span<uint8_t> out) noexcept;
// Positions are quantised to 16 bits per axis inside their bounding box.
size_t encode_mesh(const MeshFrameHeader& h, std::span<const glm::vec3> positions_m, std::span<uint8_t> out) noexcept;

inline size_t mesh_packet_bytes(size_t vertex_count) { return kHeaderBytes + 36 + 6 * vertex_count; }
// `uv_count` textured vertices (0: no texture section).
inline size_t mesh_topology_packet_bytes(size_t index_count, size_t uv_count = 0) {
  return kHeaderBytes + 11 + 4 * index_count + (uv_count ? 4 + 12 * uv_count + 4 * index_count : 0);
}
inline size_t scene_packet_bytes(size_t entries) { return kHeaderBytes + 2 + 6 * entries; }
inline size_t avatar_model_packet_bytes(const AvatarModel& m) {
  return kHeaderBytes + 14 + m.name.size() + m.model_bytes.size();
}

// Decoders take a whole packet (header included, as returned by PacketReader).
Reject decode_hello(std::span<const uint8_t> packet, Hello& out);
Reject decode_welcome(std::span<const uint8_t> packet, Welcome& out);
Reject decode_reject(std::span<const uint8_t> packet, RejectMsg& out);
Reject decode_avatar_model(std::span<const uint8_t> packet, AvatarModel& out);
Reject decode_avatar_removed(std::span<const uint8_t> packet, uint16_t& avatar) noexcept;
Reject decode_udp_register(std::span<const uint8_t> packet, UdpRegister& out) noexcept;
Reject decode_key_request(std::span<const uint8_t> packet, uint16_t& avatar) noexcept;
Reject decode_scene(std::span<const uint8_t> packet, std::vector<SceneEntry>& out);
// `out.dof_rad` is resized to the packet's DOF count (no allocation when it already fits).
Reject decode_pose(std::span<const uint8_t> packet, PoseHeader& header, rig::Pose& out);
// Takes the texture section when the packet has one (out's texture fields are cleared otherwise).
Reject decode_mesh_topology(std::span<const uint8_t> packet, MeshTopology& out);
Reject decode_mesh(std::span<const uint8_t> packet, MeshFrameHeader& header, std::vector<glm::vec3>& positions_m);

// Names (publishers', avatars') are shown in terminals and logs: a name that is not valid UTF-8
// or holds a control, bidi or invisible format character (mimic::is_safe_name) makes the HELLO
// or model carrying it malformed.
bool name_is_printable(std::string_view name) noexcept;
// `text` safe to print whatever a peer sent (mimic::terminal_safe: controls, bidi and invisible
// characters as \uXXXX, bytes that are not UTF-8 as \xNN, a backslash doubled).
std::string printable(std::string_view text);

// Reads the avatar id of a pose packet and rewrites it in place (the server re-stamps a
// publisher's slot with the scene-wide avatar id without re-encoding).
uint16_t pose_avatar(std::span<const uint8_t> packet) noexcept;
void set_pose_avatar(std::span<uint8_t> packet, uint16_t avatar) noexcept;
uint32_t pose_sequence(std::span<const uint8_t> packet) noexcept;

// Splits a byte stream (TCP) into packets. The header is validated as soon as it arrives, so
// an oversized or foreign packet is refused before its body is buffered.
class PacketReader {
 public:
  // `max_packet_bytes` caps any packet on top of the per-type limit (e.g. before HELLO).
  explicit PacketReader(size_t max_packet_bytes = kMaxPacketBytes, size_t initial_capacity = 4096);

  void set_max_packet_bytes(size_t n) { max_packet_ = n; }

  // Free space to read into (at least `min_bytes`, growing the buffer if needed) and the
  // number of bytes actually written there.
  std::span<uint8_t> write_space(size_t min_bytes = 1024);
  void commit(size_t n) { end_ += n; }

  // The next complete packet, valid until the next call. Returns Reject::ok with an empty
  // span when more bytes are needed; any other value means the stream is unusable (the
  // caller closes it): this reader does not resynchronise.
  Reject next(std::span<const uint8_t>& packet);

  size_t buffered_bytes() const { return end_ - begin_; }

 private:
  std::vector<uint8_t> buf_;
  size_t begin_ = 0, end_ = 0;
  size_t max_packet_;
};

// Wall clock in µs since the Unix epoch: what pose and mesh frames carry as their capture time.
uint64_t wall_clock_us();

}  // namespace mimic::net
