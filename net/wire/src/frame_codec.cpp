#include "mimic/net/frame_codec.h"

#include "mimic/core/text.h"

#include <algorithm>
#include <chrono>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "frame_codec_bytes.h"

namespace mimic::net {

using namespace codec_detail;

uint64_t wall_clock_us() {
  return static_cast<uint64_t>(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
          .count());
}

bool SessionToken::empty() const noexcept {
  uint8_t any = 0;
  for (uint8_t b : bytes) any |= b;
  return any == 0;
}

bool operator==(const SessionToken& a, const SessionToken& b) noexcept {
  // Every byte is looked at whatever the first difference: no early exit to time.
  unsigned diff = 0;
  for (size_t i = 0; i < kTokenBytes; ++i) diff |= unsigned(a.bytes[i] ^ b.bytes[i]);
  return diff == 0;
}

size_t SessionTokenHash::operator()(const SessionToken& t) const noexcept {
  // The bytes are uniformly random already.
  uint64_t h = 0;
  std::memcpy(&h, t.bytes.data(), sizeof h);
  return static_cast<size_t>(h);
}

bool name_is_printable(std::string_view name) noexcept { return is_safe_name(name); }

std::string printable(std::string_view text) { return terminal_safe(text); }

const char* reject_name(Reject r) noexcept {
  switch (r) {
    case Reject::ok: return "ok";
    case Reject::truncated: return "truncated";
    case Reject::bad_magic: return "bad_magic";
    case Reject::unknown_version: return "unknown_version";
    case Reject::unknown_type: return "unknown_type";
    case Reject::oversized: return "oversized";
    case Reject::malformed: return "malformed";
    case Reject::out_of_order: return "out_of_order";
    case Reject::unsupported_version: return "unsupported_version";
    case Reject::unauthorized: return "unauthorized";
    case Reject::unexpected: return "unexpected";
    case Reject::flood: return "flood";
    case Reject::server_full: return "server_full";
    case Reject::timeout: return "timeout";
    case Reject::too_many_sessions: return "too_many_sessions";
    case Reject::unavailable: return "unavailable";
  }
  return "unknown";
}

size_t max_packet_bytes(uint8_t type) noexcept {
  switch (static_cast<MsgType>(type)) {
    case MsgType::hello:
    case MsgType::welcome:
    case MsgType::reject:
    case MsgType::bye:
    case MsgType::ping:
    case MsgType::key_request:
    case MsgType::avatar_removed: return kMaxHelloBytes;
    case MsgType::udp_register: return kUdpRegisterBytes;
    case MsgType::avatar_model: return kHeaderBytes + 14 + 255 + kMaxModelBytes;
    case MsgType::scene: return kMaxSceneBytes;
    case MsgType::pose:
    case MsgType::pose_delta: return kMaxDatagramBytes;
    case MsgType::mesh_topology:
    case MsgType::mesh: return kMaxMeshBytes;
  }
  return 0;
}

Reject decode_header(std::span<const uint8_t> bytes, Header& out) noexcept {
  if (bytes.size() < kHeaderBytes) return Reject::truncated;
  if (bytes[0] != kMagic) return Reject::bad_magic;
  if (bytes[1] < kMinProtocolVersion || bytes[1] > kProtocolVersion) return Reject::unknown_version;
  const size_t limit = max_packet_bytes(bytes[2]);
  if (limit == 0) return Reject::unknown_type;
  out.version = bytes[1];
  out.type = static_cast<MsgType>(bytes[2]);
  out.flags = bytes[3];
  out.payload_bytes =
      uint32_t(bytes[4]) | (uint32_t(bytes[5]) << 8) | (uint32_t(bytes[6]) << 16) | (uint32_t(bytes[7]) << 24);
  if (out.payload_bytes > limit - kHeaderBytes) return Reject::oversized;
  return Reject::ok;
}

// ---- encoders ---------------------------------------------------------------------------------

size_t encode_hello(const Hello& m, std::span<uint8_t> out) noexcept {
  if (m.name.size() > kMaxNameBytes || m.secret.size() > kMaxSecretBytes) return 0;
  Writer w = begin(out, MsgType::hello);
  w.u8(m.min_version);
  w.u8(m.max_version);
  w.u8(static_cast<uint8_t>(m.role));
  w.u8(static_cast<uint8_t>(m.mesh_lod));
  w.u32(m.capabilities);
  w.bytes(m.resume_token.bytes.data(), kTokenBytes);
  w.str8(m.name);
  w.str8(m.secret);
  return finish(w);
}

size_t encode_welcome(const Welcome& m, std::span<uint8_t> out) noexcept {
  Writer w = begin(out, MsgType::welcome);
  w.u8(m.version);
  w.u8(m.resumed ? 1 : 0);
  w.u16(0);
  w.u32(m.capabilities);
  w.bytes(m.session_token.bytes.data(), kTokenBytes);
  w.u32(m.client_id);
  return finish(w);
}

size_t encode_reject(const RejectMsg& m, std::span<uint8_t> out) noexcept {
  const std::string_view msg(m.message.data(), std::min<size_t>(m.message.size(), 255));
  Writer w = begin(out, MsgType::reject);
  w.u16(static_cast<uint16_t>(m.reason));
  w.u8(m.server_min_version);
  w.u8(m.server_max_version);
  w.str8(msg);
  return finish(w);
}

size_t encode_bye(std::span<uint8_t> out) noexcept {
  Writer w = begin(out, MsgType::bye);
  return finish(w);
}

size_t encode_avatar_model(const AvatarModel& m, std::span<uint8_t> out) noexcept {
  if (m.name.size() > kMaxNameBytes || m.model_bytes.size() > kMaxModelBytes) return 0;
  Writer w = begin(out, MsgType::avatar_model);
  w.u16(m.avatar);
  w.u32(m.revision);
  w.u16(m.dof_count);
  w.u8(static_cast<uint8_t>(m.name.size()));
  w.u8(0);
  w.bytes(m.name.data(), m.name.size());
  w.u32(static_cast<uint32_t>(m.model_bytes.size()));
  w.bytes(m.model_bytes.data(), m.model_bytes.size());
  return finish(w);
}

size_t encode_avatar_removed(uint16_t avatar, std::span<uint8_t> out) noexcept {
  Writer w = begin(out, MsgType::avatar_removed);
  w.u16(avatar);
  return finish(w);
}

size_t encode_udp_register(const UdpRegister& m, std::span<uint8_t> out) noexcept {
  Writer w = begin(out, MsgType::udp_register);
  w.bytes(m.token.bytes.data(), kTokenBytes);
  w.u64(m.nonce);
  return finish(w);
}

size_t encode_ping(std::span<uint8_t> out) noexcept {
  Writer w = begin(out, MsgType::ping);
  return finish(w);
}

size_t encode_key_request(uint16_t avatar, std::span<uint8_t> out) noexcept {
  Writer w = begin(out, MsgType::key_request);
  w.u16(avatar);
  return finish(w);
}

size_t encode_scene(std::span<const SceneEntry> entries, std::span<uint8_t> out) noexcept {
  if (entries.size() > 0xFFFF) return 0;
  Writer w = begin(out, MsgType::scene);
  w.u16(static_cast<uint16_t>(entries.size()));
  for (const auto& e : entries) {
    w.u16(e.avatar);
    w.u32(e.revision);
  }
  return finish(w);
}

size_t encode_pose(const PoseHeader& h, const rig::Pose& pose, std::span<uint8_t> out) noexcept {
  if (pose.dof_rad.size() > kMaxPoseDofs) return 0;
  Writer w = begin(out, MsgType::pose);
  w.u16(h.avatar);
  w.u16(h.flags);
  w.u32(h.sequence);
  w.u64(h.time_us);
  for (int i = 0; i < 3; ++i) {
    const float v = std::isfinite(pose.root_position_m[i]) ? pose.root_position_m[i] : 0.0f;
    const double q = std::clamp(std::round(double(v) / kRootPositionStep_m), -2147483647.0, 2147483647.0);
    w.i32(static_cast<int32_t>(q));
  }
  glm::quat q = pose.root_orientation;
  const float len = glm::length(q);
  q = (std::isfinite(len) && len > 1e-6f) ? q / len : glm::quat(1, 0, 0, 0);
  // One hemisphere only, so the same rotation always encodes the same way.
  if (q.w < 0) q = -q;
  w.i16(quantise(q.x, kQuatStep));
  w.i16(quantise(q.y, kQuatStep));
  w.i16(quantise(q.z, kQuatStep));
  w.i16(quantise(q.w, kQuatStep));
  w.u16(static_cast<uint16_t>(pose.dof_rad.size()));
  for (float a : pose.dof_rad) w.i16(quantise(wrap_angle(a), kAngleStep_rad));
  return finish(w);
}

static size_t encode_topology(const MeshTopology& m, std::span<uint8_t> out, bool texture) noexcept {
  if (m.vertex_count > kMaxMeshVertices) return 0;
  texture = texture && !m.uvs.empty();
  if (texture && (m.uv_source.size() != m.uvs.size() || m.uv_indices.size() != m.indices.size())) return 0;
  Writer w = begin(out, MsgType::mesh_topology);
  w.u16(m.avatar);
  w.u8(m.lod);
  w.u32(m.vertex_count);
  w.u32(static_cast<uint32_t>(m.indices.size()));
  for (uint32_t i : m.indices) w.u32(i);
  if (texture) {
    w.u32(static_cast<uint32_t>(m.uvs.size()));
    for (size_t v = 0; v < m.uvs.size(); ++v) {
      w.u32(m.uv_source[v]);
      w.f32(m.uvs[v].x);
      w.f32(m.uvs[v].y);
    }
    for (uint32_t i : m.uv_indices) w.u32(i);
  }
  return finish(w);
}

size_t encode_mesh_topology(const MeshTopology& m, std::span<uint8_t> out) noexcept {
  return encode_topology(m, out, false);
}

size_t encode_mesh_topology_with_uvs(const MeshTopology& m, std::span<uint8_t> out) noexcept {
  return encode_topology(m, out, true);
}

size_t encode_mesh(const MeshFrameHeader& h, std::span<const glm::vec3> positions_m, std::span<uint8_t> out) noexcept {
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (const auto& p : positions_m) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  if (positions_m.empty()) lo = hi = glm::vec3(0);
  const glm::vec3 ext = hi - lo;
  const float extent = std::max({ext.x, ext.y, ext.z});
  if (!std::isfinite(extent) || !std::isfinite(lo.x + lo.y + lo.z)) return 0;
  const float step = extent > 0 ? extent / 65535.0f : 1.0f;
  Writer w = begin(out, MsgType::mesh);
  w.u16(h.avatar);
  w.u8(h.lod);
  w.u8(0);
  w.u32(h.sequence);
  w.u64(h.time_us);
  w.f32(lo.x);
  w.f32(lo.y);
  w.f32(lo.z);
  w.f32(step);
  w.u32(static_cast<uint32_t>(positions_m.size()));
  if (!w.ok || out.size() - w.pos < 6 * positions_m.size()) return 0;
  for (const auto& p : positions_m) {
    for (int a = 0; a < 3; ++a) {
      const float q = std::round((p[a] - lo[a]) / step);
      w.u16(static_cast<uint16_t>(std::clamp(q, 0.0f, 65535.0f)));
    }
  }
  return finish(w);
}

}  // namespace mimic::net
