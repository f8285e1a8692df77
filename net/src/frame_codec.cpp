#include "mimic/net/frame_codec.h"

#include "mimic/core/text.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

namespace mimic::net {

namespace {

// Little-endian writer over a caller-owned buffer; `ok` turns false on overflow.
struct Writer {
  std::span<uint8_t> out;
  size_t pos = 0;
  bool ok = true;

  void bytes(const void* p, size_t n) {
    if (!ok || out.size() - pos < n) {
      ok = false;
      return;
    }
    if (n) std::memcpy(out.data() + pos, p, n);
    pos += n;
  }
  void u8(uint8_t v) { bytes(&v, 1); }
  void u16(uint16_t v) {
    const uint8_t b[2] = {uint8_t(v), uint8_t(v >> 8)};
    bytes(b, 2);
  }
  void u32(uint32_t v) {
    const uint8_t b[4] = {uint8_t(v), uint8_t(v >> 8), uint8_t(v >> 16), uint8_t(v >> 24)};
    bytes(b, 4);
  }
  void u64(uint64_t v) {
    u32(uint32_t(v));
    u32(uint32_t(v >> 32));
  }
  void i16(int16_t v) { u16(static_cast<uint16_t>(v)); }
  void i32(int32_t v) { u32(static_cast<uint32_t>(v)); }
  void f32(float v) { u32(std::bit_cast<uint32_t>(v)); }
  void str8(std::string_view s) {
    u8(static_cast<uint8_t>(s.size()));
    bytes(s.data(), s.size());
  }
};

struct Reader {
  std::span<const uint8_t> in;
  size_t pos = 0;
  bool ok = true;

  bool need(size_t n) {
    if (!ok || in.size() - pos < n) ok = false;
    return ok;
  }
  uint8_t u8() {
    if (!need(1)) return 0;
    return in[pos++];
  }
  uint16_t u16() {
    if (!need(2)) return 0;
    const uint16_t v = uint16_t(in[pos] | (in[pos + 1] << 8));
    pos += 2;
    return v;
  }
  uint32_t u32() {
    if (!need(4)) return 0;
    const uint32_t v = uint32_t(in[pos]) | (uint32_t(in[pos + 1]) << 8) |
                       (uint32_t(in[pos + 2]) << 16) | (uint32_t(in[pos + 3]) << 24);
    pos += 4;
    return v;
  }
  uint64_t u64() {
    const uint64_t lo = u32();
    const uint64_t hi = u32();
    return lo | (hi << 32);
  }
  int16_t i16() { return static_cast<int16_t>(u16()); }
  int32_t i32() { return static_cast<int32_t>(u32()); }
  float f32() { return std::bit_cast<float>(u32()); }
  bool str(size_t n, std::string& out) {
    if (!need(n)) return false;
    out.assign(reinterpret_cast<const char*>(in.data() + pos), n);
    pos += n;
    return true;
  }
  size_t left() const { return in.size() - pos; }
  void token(SessionToken& t) {
    if (!need(kTokenBytes)) return;
    std::memcpy(t.bytes.data(), in.data() + pos, kTokenBytes);
    pos += kTokenBytes;
  }
};

// Writes the header with a placeholder length; finish() patches it.
Writer begin(std::span<uint8_t> out, MsgType type) {
  Writer w{out};
  w.u8(kMagic);
  w.u8(kProtocolVersion);
  w.u8(static_cast<uint8_t>(type));
  w.u8(0);
  w.u32(0);
  return w;
}

size_t finish(Writer& w) {
  if (!w.ok) return 0;
  const uint32_t payload = static_cast<uint32_t>(w.pos - kHeaderBytes);
  if (w.pos > max_packet_bytes(w.out[2])) return 0;
  w.out[4] = uint8_t(payload);
  w.out[5] = uint8_t(payload >> 8);
  w.out[6] = uint8_t(payload >> 16);
  w.out[7] = uint8_t(payload >> 24);
  return w.pos;
}

// Validates the header of a whole packet of the expected type and positions a reader on the
// payload.
Reject open(std::span<const uint8_t> packet, MsgType type, Reader& r) noexcept {
  Header h;
  if (const Reject e = decode_header(packet, h); e != Reject::ok) return e;
  if (h.type != type) return Reject::unexpected;
  if (packet.size() != kHeaderBytes + h.payload_bytes)
    return packet.size() < kHeaderBytes + h.payload_bytes ? Reject::truncated : Reject::malformed;
  r = Reader{packet.subspan(kHeaderBytes)};
  return Reject::ok;
}

// Truncated when a field ran past the end, malformed when bytes are left over.
Reject close(const Reader& r) noexcept {
  if (!r.ok) return Reject::truncated;
  return r.left() == 0 ? Reject::ok : Reject::malformed;
}

int16_t quantise(float v, float step) {
  const float q = std::round(v / step);
  return static_cast<int16_t>(std::clamp(q, -32767.0f, 32767.0f));
}

float wrap_angle(float a) {
  constexpr float kPi = 3.14159265358979f, kTwoPi = 2 * kPi;
  if (!std::isfinite(a)) return 0.0f;
  if (a >= -kPi && a <= kPi) return a;
  a = std::fmod(a + kPi, kTwoPi);
  if (a < 0) a += kTwoPi;
  return a - kPi;
}

}  // namespace

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
  out.payload_bytes = uint32_t(bytes[4]) | (uint32_t(bytes[5]) << 8) | (uint32_t(bytes[6]) << 16) |
                      (uint32_t(bytes[7]) << 24);
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

size_t encode_mesh_topology(const MeshTopology& m, std::span<uint8_t> out) noexcept {
  if (m.vertex_count > kMaxMeshVertices) return 0;
  Writer w = begin(out, MsgType::mesh_topology);
  w.u16(m.avatar);
  w.u8(m.lod);
  w.u32(m.vertex_count);
  w.u32(static_cast<uint32_t>(m.indices.size()));
  for (uint32_t i : m.indices) w.u32(i);
  return finish(w);
}

size_t encode_mesh(const MeshFrameHeader& h, std::span<const glm::vec3> positions_m,
                   std::span<uint8_t> out) noexcept {
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

// ---- decoders ---------------------------------------------------------------------------------

Reject decode_hello(std::span<const uint8_t> packet, Hello& out) {
  Reader r;
  if (const Reject e = open(packet, MsgType::hello, r); e != Reject::ok) return e;
  out.min_version = r.u8();
  out.max_version = r.u8();
  const uint8_t role = r.u8();
  out.mesh_lod = r.u8();
  out.capabilities = r.u32();
  r.token(out.resume_token);
  const uint8_t name_len = r.u8();
  if (name_len > kMaxNameBytes) return Reject::malformed;
  r.str(name_len, out.name);
  const uint8_t secret_len = r.u8();
  if (secret_len > kMaxSecretBytes) return Reject::malformed;
  r.str(secret_len, out.secret);
  if (const Reject e = close(r); e != Reject::ok) return e;
  if (role != uint8_t(Role::publisher) && role != uint8_t(Role::subscriber)) return Reject::malformed;
  if (out.min_version == 0 || out.min_version > out.max_version) return Reject::malformed;
  if (!name_is_printable(out.name)) return Reject::malformed;
  out.role = static_cast<Role>(role);
  return Reject::ok;
}

Reject decode_welcome(std::span<const uint8_t> packet, Welcome& out) {
  Reader r;
  if (const Reject e = open(packet, MsgType::welcome, r); e != Reject::ok) return e;
  out.version = r.u8();
  const uint8_t resumed = r.u8();
  r.u16();
  out.capabilities = r.u32();
  r.token(out.session_token);
  out.client_id = r.u32();
  if (const Reject e = close(r); e != Reject::ok) return e;
  if (resumed > 1 || out.version == 0) return Reject::malformed;
  out.resumed = resumed == 1;
  return Reject::ok;
}

Reject decode_reject(std::span<const uint8_t> packet, RejectMsg& out) {
  Reader r;
  if (const Reject e = open(packet, MsgType::reject, r); e != Reject::ok) return e;
  const uint16_t reason = r.u16();
  out.server_min_version = r.u8();
  out.server_max_version = r.u8();
  r.str(r.u8(), out.message);
  if (const Reject e = close(r); e != Reject::ok) return e;
  if (reason == 0 || reason >= kRejectCount) return Reject::malformed;
  out.reason = static_cast<Reject>(reason);
  return Reject::ok;
}

Reject decode_avatar_model(std::span<const uint8_t> packet, AvatarModel& out) {
  Reader r;
  if (const Reject e = open(packet, MsgType::avatar_model, r); e != Reject::ok) return e;
  out.avatar = r.u16();
  out.revision = r.u32();
  out.dof_count = r.u16();
  const uint8_t name_len = r.u8();
  const uint8_t reserved = r.u8();
  if (name_len > kMaxNameBytes || reserved != 0) return Reject::malformed;
  r.str(name_len, out.name);
  const uint32_t model_len = r.u32();
  if (!r.ok) return Reject::truncated;
  if (model_len > kMaxModelBytes) return Reject::oversized;
  r.str(model_len, out.model_bytes);
  if (const Reject e = close(r); e != Reject::ok) return e;
  if (out.dof_count > kMaxPoseDofs) return Reject::malformed;
  if (!name_is_printable(out.name)) return Reject::malformed;
  return Reject::ok;
}

Reject decode_avatar_removed(std::span<const uint8_t> packet, uint16_t& avatar) noexcept {
  Reader r;
  if (const Reject e = open(packet, MsgType::avatar_removed, r); e != Reject::ok) return e;
  avatar = r.u16();
  return close(r);
}

Reject decode_udp_register(std::span<const uint8_t> packet, UdpRegister& out) noexcept {
  Reader r;
  if (const Reject e = open(packet, MsgType::udp_register, r); e != Reject::ok) return e;
  r.token(out.token);
  out.nonce = r.u64();
  return close(r);
}

Reject decode_key_request(std::span<const uint8_t> packet, uint16_t& avatar) noexcept {
  Reader r;
  if (const Reject e = open(packet, MsgType::key_request, r); e != Reject::ok) return e;
  avatar = r.u16();
  return close(r);
}

Reject decode_scene(std::span<const uint8_t> packet, std::vector<SceneEntry>& out) {
  Reader r;
  if (const Reject e = open(packet, MsgType::scene, r); e != Reject::ok) return e;
  const uint16_t n = r.u16();
  if (!r.ok) return Reject::truncated;
  if (r.left() != 6u * n) return r.left() < 6u * n ? Reject::truncated : Reject::malformed;
  out.resize(n);
  for (auto& e : out) {
    e.avatar = r.u16();
    e.revision = r.u32();
  }
  return close(r);
}

Reject decode_pose(std::span<const uint8_t> packet, PoseHeader& h, rig::Pose& out) {
  Reader r;
  if (const Reject e = open(packet, MsgType::pose, r); e != Reject::ok) return e;
  h.avatar = r.u16();
  h.flags = r.u16();
  h.sequence = r.u32();
  h.time_us = r.u64();
  glm::vec3 root;
  for (int i = 0; i < 3; ++i) root[i] = float(double(r.i32()) * double(kRootPositionStep_m));
  glm::quat q;
  q.x = r.i16() * kQuatStep;
  q.y = r.i16() * kQuatStep;
  q.z = r.i16() * kQuatStep;
  q.w = r.i16() * kQuatStep;
  const uint16_t n = r.u16();
  if (!r.ok) return Reject::truncated;
  if (r.left() != 2u * n) return r.left() < 2u * n ? Reject::truncated : Reject::malformed;
  const float len = glm::length(q);
  // A unit quaternion quantised to 1/32767 per component keeps |q| within ~1e-4 of 1.
  if (!(len > 0.99f && len < 1.01f)) return Reject::malformed;
  out.root_position_m = root;
  out.root_orientation = q / len;
  out.dof_rad.resize(n);
  for (uint16_t i = 0; i < n; ++i) out.dof_rad[i] = r.i16() * kAngleStep_rad;
  return close(r);
}

Reject decode_mesh_topology(std::span<const uint8_t> packet, MeshTopology& out) {
  Reader r;
  if (const Reject e = open(packet, MsgType::mesh_topology, r); e != Reject::ok) return e;
  out.avatar = r.u16();
  out.lod = r.u8();
  out.vertex_count = r.u32();
  const uint32_t n = r.u32();
  if (!r.ok) return Reject::truncated;
  if (out.vertex_count > kMaxMeshVertices) return Reject::oversized;
  if (r.left() != 4ull * n) return r.left() < 4ull * n ? Reject::truncated : Reject::malformed;
  if (n % 3 != 0) return Reject::malformed;
  out.indices.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    out.indices[i] = r.u32();
    if (out.indices[i] >= out.vertex_count) return Reject::malformed;
  }
  return close(r);
}

Reject decode_mesh(std::span<const uint8_t> packet, MeshFrameHeader& h,
                   std::vector<glm::vec3>& positions_m) {
  Reader r;
  if (const Reject e = open(packet, MsgType::mesh, r); e != Reject::ok) return e;
  h.avatar = r.u16();
  h.lod = r.u8();
  const uint8_t reserved = r.u8();
  h.sequence = r.u32();
  h.time_us = r.u64();
  glm::vec3 lo;
  lo.x = r.f32();
  lo.y = r.f32();
  lo.z = r.f32();
  const float step = r.f32();
  const uint32_t n = r.u32();
  if (!r.ok) return Reject::truncated;
  if (reserved != 0 || !std::isfinite(lo.x + lo.y + lo.z) || !std::isfinite(step) || step <= 0)
    return Reject::malformed;
  if (n > kMaxMeshVertices) return Reject::oversized;
  if (r.left() != 6ull * n) return r.left() < 6ull * n ? Reject::truncated : Reject::malformed;
  positions_m.resize(n);
  for (uint32_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) positions_m[i][a] = lo[a] + float(r.u16()) * step;
  return close(r);
}

uint16_t pose_avatar(std::span<const uint8_t> packet) noexcept {
  if (packet.size() < kHeaderBytes + 2) return 0;
  return uint16_t(packet[kHeaderBytes] | (packet[kHeaderBytes + 1] << 8));
}

void set_pose_avatar(std::span<uint8_t> packet, uint16_t avatar) noexcept {
  if (packet.size() < kHeaderBytes + 2) return;
  packet[kHeaderBytes] = uint8_t(avatar);
  packet[kHeaderBytes + 1] = uint8_t(avatar >> 8);
}

uint32_t pose_sequence(std::span<const uint8_t> packet) noexcept {
  if (packet.size() < kHeaderBytes + 8) return 0;
  const uint8_t* p = packet.data() + kHeaderBytes + 4;
  return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}

// ---- PacketReader -----------------------------------------------------------------------------

PacketReader::PacketReader(size_t max_packet_bytes, size_t initial_capacity)
    : buf_(initial_capacity), max_packet_(max_packet_bytes) {}

std::span<uint8_t> PacketReader::write_space(size_t min_bytes) {
  if (buf_.size() - end_ < min_bytes) {
    // Compact first; grow only when a large packet (model, mesh) really needs the room.
    if (begin_ > 0) {
      std::memmove(buf_.data(), buf_.data() + begin_, end_ - begin_);
      end_ -= begin_;
      begin_ = 0;
    }
    if (buf_.size() - end_ < min_bytes) buf_.resize(end_ + min_bytes);
  }
  return std::span<uint8_t>(buf_).subspan(end_);
}

Reject PacketReader::next(std::span<const uint8_t>& packet) {
  packet = {};
  if (begin_ == end_) {
    begin_ = end_ = 0;
    return Reject::ok;
  }
  const std::span<const uint8_t> avail(buf_.data() + begin_, end_ - begin_);
  // Refuse foreign streams on the first byte rather than waiting for a whole header.
  if (avail[0] != kMagic) return Reject::bad_magic;
  if (avail.size() < kHeaderBytes) return Reject::ok;
  Header h;
  if (const Reject e = decode_header(avail, h); e != Reject::ok) return e;
  const size_t total = kHeaderBytes + size_t(h.payload_bytes);
  if (total > max_packet_) return Reject::oversized;
  if (avail.size() < total) {
    // Make sure the whole packet will fit without further compaction games.
    if (buf_.size() - begin_ < total) write_space(total - avail.size());
    return Reject::ok;
  }
  packet = avail.first(total);
  begin_ += total;
  return Reject::ok;
}

}  // namespace mimic::net
