// The frame codec's decoders and the stream splitter (PacketReader): every field checked
// against the packet's bounds, a refusal named (Reject) rather than thrown.
#include "mimic/net/frame_codec.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "frame_codec_bytes.h"

namespace mimic::net {

using namespace codec_detail;

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

// The texture section after a topology's indices: u32 count, per textured vertex u32 source,
// f32 u, f32 v; then u32 uv_indices[index count]. Each corner must copy the skin vertex the
// plain triangle has there, so the textured triangles are the same triangles.
static Reject decode_mesh_texture(Reader& r, MeshTopology& out) {
  const uint32_t count = r.u32();
  if (!r.ok) return Reject::truncated;
  if (count == 0 || count > kMaxMeshVertices) return count ? Reject::oversized : Reject::malformed;
  const uint64_t want = 12ull * count + 4ull * out.indices.size();
  if (r.left() != want) return r.left() < want ? Reject::truncated : Reject::malformed;
  out.uv_source.resize(count);
  out.uvs.resize(count);
  for (uint32_t v = 0; v < count; ++v) {
    out.uv_source[v] = r.u32();
    out.uvs[v].x = r.f32();
    out.uvs[v].y = r.f32();
    const bool in_square = out.uvs[v].x >= 0 && out.uvs[v].x <= 1 && out.uvs[v].y >= 0 && out.uvs[v].y <= 1;
    if (out.uv_source[v] >= out.vertex_count || !in_square) return Reject::malformed;
  }
  out.uv_indices.resize(out.indices.size());
  for (size_t i = 0; i < out.indices.size(); ++i) {
    out.uv_indices[i] = r.u32();
    if (out.uv_indices[i] >= count || out.uv_source[out.uv_indices[i]] != out.indices[i]) return Reject::malformed;
  }
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
  if (r.left() < 4ull * n) return Reject::truncated;
  if (n % 3 != 0) return Reject::malformed;
  out.indices.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    out.indices[i] = r.u32();
    if (out.indices[i] >= out.vertex_count) return Reject::malformed;
  }
  out.uv_source.clear();
  out.uvs.clear();
  out.uv_indices.clear();
  if (r.left() == 0) return close(r);
  return decode_mesh_texture(r, out);
}

Reject decode_mesh(std::span<const uint8_t> packet, MeshFrameHeader& h, std::vector<glm::vec3>& positions_m) {
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
