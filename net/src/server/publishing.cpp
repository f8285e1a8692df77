// What publishers bring (remote ones through their session, local ones through Server): avatars,
// model revisions, pose frames and mesh frames, each validated before anyone else sees it.
#include <cstring>

#include "server/server_impl.h"

namespace mimic::net {

Reject Session::on_model(std::span<const uint8_t> packet) {
  AvatarModel m;
  if (const Reject e = decode_avatar_model(packet, m); e != Reject::ok) return e;
  const uint8_t slot = static_cast<uint8_t>(m.avatar);
  if (m.avatar > 255) return Reject::malformed;
  if (auto it = slots.find(slot); it != slots.end()) {
    if (Avatar* a = srv.avatar(it->second)) {
      if (!srv.model_fits(avatar_model_packet_bytes(m), a)) return Reject::unavailable;
      srv.update_model(*a, m);
      return Reject::ok;
    }
  }
  if (slots.size() >= kMaxAvatarsPerPublisher) return Reject::unexpected;
  if (!srv.model_fits(avatar_model_packet_bytes(m), nullptr)) return Reject::unavailable;
  auto new_id = srv.new_avatar(m.name, m.dof_count, std::move(m.model_bytes), this);
  if (!new_id) return Reject::unexpected;
  slots[slot] = *new_id;
  srv.avatars[*new_id].owner_token = token;
  return Reject::ok;
}

Avatar* Session::slot_avatar(uint16_t slot) {
  auto it = slots.find(static_cast<uint8_t>(slot));
  if (slot > 255 || it == slots.end()) return nullptr;
  return srv.avatar(it->second);
}

Reject Session::on_pose(std::span<const uint8_t> packet) {
  PoseHeader h;
  // Validate every field before the bytes reach anyone else.
  if (const Reject e = decode_pose(packet, h, scratch_pose); e != Reject::ok) return e;
  Avatar* a = slot_avatar(h.avatar);
  if (!a) return Reject::unexpected;
  if (scratch_pose.dof_rad.size() != a->dof_count) return Reject::malformed;
  return srv.accept_pose(*a, packet);
}

Reject Session::on_mesh_topology(std::span<const uint8_t> packet) {
  if (const Reject e = decode_mesh_topology(packet, scratch_topology); e != Reject::ok) return e;
  Avatar* a = slot_avatar(scratch_topology.avatar);
  if (!a || scratch_topology.lod >= kMaxLods) return Reject::unexpected;
  scratch_topology.avatar = a->id;
  return srv.set_topology(*a, scratch_topology);
}

Reject Session::on_mesh(std::span<const uint8_t> packet) {
  MeshFrameHeader h;
  if (const Reject e = decode_mesh(packet, h, scratch_mesh); e != Reject::ok) return e;
  Avatar* a = slot_avatar(h.avatar);
  if (!a || h.lod >= kMaxLods) return Reject::unexpected;
  return srv.accept_mesh(*a, h.lod, packet);
}

Result<uint16_t> ServerImpl::new_avatar(const std::string& name, uint16_t dof_count, std::string model_bytes,
                                        Session* owner) {
  if (dof_count > kMaxPoseDofs) return fail(Errc::out_of_range, "too many DOFs for a pose frame");
  if (model_bytes.size() > kMaxModelBytes) return fail(Errc::out_of_range, "body model too large");
  if (!name_is_printable(name)) return fail(Errc::invalid_argument, "avatar name has control characters");
  if (!model_fits(kHeaderBytes + 14 + std::min(name.size(), kMaxNameBytes) + model_bytes.size(), nullptr))
    return fail(Errc::out_of_range, "the server's models would pass its memory bound");
  uint16_t id = 0;
  for (uint16_t i = 1; i < avatars.size(); ++i)
    if (!avatars[i].live) {
      id = i;
      break;
    }
  if (id == 0) {
    if (avatars.size() >= kMaxAvatars) return fail(Errc::out_of_range, "too many avatars");
    if (avatars.empty()) avatars.emplace_back();
    id = static_cast<uint16_t>(avatars.size());
    avatars.emplace_back();
  }
  Avatar& a = avatars[id];
  a = Avatar{};
  a.live = true;
  a.id = id;
  a.name = name.substr(0, kMaxNameBytes);
  a.dof_count = dof_count;
  a.owner = owner;
  a.lean = LeanPoseEncoder(opt.lean_pose_shift, opt.lean_key_interval);
  AvatarModel m;
  m.avatar = id;
  m.dof_count = dof_count;
  m.name = a.name;
  m.model_bytes = std::move(model_bytes);
  update_model(a, m);
  stats.avatars++;
  return id;
}

bool ServerImpl::model_fits(size_t packet_bytes, const Avatar* replacing) {
  uint64_t held = packet_bytes;
  for (const auto& a : avatars)
    if (a.live && &a != replacing && a.model_packet) held += a.model_packet->size();
  if (held <= opt.max_model_bytes_held) return true;
  stats.models_refused++;
  return false;
}

SharedBytes ServerImpl::make_model_packet(const AvatarModel& m) {
  auto* bytes = new std::vector<uint8_t>(avatar_model_packet_bytes(m));
  encode_avatar_model(m, *bytes);
  *model_bytes_held += bytes->size();
  stats.model_bytes_held = *model_bytes_held;
  // The count outlives the server if a write in flight still holds the packet at shutdown.
  return SharedBytes(bytes, [held = model_bytes_held](const std::vector<uint8_t>* p) {
    *held -= p->size();
    delete p;
  });
}

void ServerImpl::update_model(Avatar& a, const AvatarModel& m) {
  AvatarModel copy = m;
  copy.avatar = a.id;
  copy.revision = a.revision = next_revision++;
  copy.name = a.name;
  a.dof_count = m.dof_count;
  a.model_packet = make_model_packet(copy);
  a.has_pose = false;  // old frames may not match the new model
  a.lean.reset();
  a.lean_ok = false;
  reserve_fanout();
  for (auto& s : sessions) {
    if (!s->active || s->role != Role::subscriber) continue;
    s->ensure_slot(a.id);
    s->reserve_buffers();
    s->send_model(a);
    s->flush();
  }
  enforce_model_memory_cap();
}

void ServerImpl::drop_avatar(uint16_t id) {
  Avatar* a = avatar(id);
  if (!a) return;
  a->live = false;
  a->model_packet.reset();
  for (auto& m : a->mesh) {
    mesh_bytes_held -= m.frame_capacity;
    m = MeshSlot{};
  }
  stats.mesh_bytes_held = mesh_bytes_held;
  stats.avatars--;
  std::array<uint8_t, 16> buf{};
  const size_t n = encode_avatar_removed(id, buf);
  for (auto& s : sessions) {
    if (!s->active || s->role != Role::subscriber) continue;
    s->models_known.erase(id);
    if (id < s->lean_sent.size()) s->lean_sent[id] = 0;
    s->drop_queued_model(id);
    s->queue_control(std::span<const uint8_t>(buf.data(), n));
    s->flush();
  }
  stats.model_bytes_held = *model_bytes_held;
}

Reject ServerImpl::accept_pose(Avatar& a, std::span<const uint8_t> packet) {
  if (packet.size() > a.pose.size()) return Reject::oversized;
  const uint32_t seq = pose_sequence(packet);
  if (a.has_pose && static_cast<int32_t>(seq - a.sequence) <= 0) return Reject::out_of_order;
  send_udp_batch();  // queued datagrams may point into this avatar's buffers
  std::memcpy(a.pose.data(), packet.data(), packet.size());
  a.pose_size = packet.size();
  set_pose_avatar(std::span<uint8_t>(a.pose.data(), a.pose_size), a.id);
  a.sequence = seq;
  a.has_pose = true;
  a.lean_ok = a.lean.update(std::span<const uint8_t>(a.pose.data(), a.pose_size));
  stats.frames_in++;
  fan_out_pose(a.id);
  return Reject::ok;
}

Reject ServerImpl::set_topology(Avatar& a, const MeshTopology& t) {
  if (t.lod >= kMaxLods || t.vertex_count > kMaxMeshVertices) return Reject::oversized;
  auto& slot = a.mesh[t.lod];
  // Every frame buffer of the scene is sized from topologies (here and in each mesh subscriber's
  // copy of an unfinished write), so their sum is bounded: a topology that would pass the
  // budget is refused, whoever sends it.
  const size_t frame_capacity = mesh_packet_bytes(t.vertex_count);
  if (mesh_bytes_held - slot.frame_capacity + frame_capacity > opt.max_mesh_bytes) {
    stats.mesh_topologies_refused++;
    return Reject::unavailable;
  }
  try {
    auto packet = std::make_shared<std::vector<uint8_t>>(mesh_topology_packet_bytes(t.indices.size()));
    if (encode_mesh_topology(t, *packet) == 0) return Reject::oversized;
    std::shared_ptr<std::vector<uint8_t>> textured;
    if (!t.uvs.empty()) {
      textured = std::make_shared<std::vector<uint8_t>>(mesh_topology_packet_bytes(t.indices.size(), t.uvs.size()));
      if (encode_mesh_topology_with_uvs(t, *textured) == 0) return Reject::oversized;
    }
    // The frame buffer (and every mesh subscriber's) is sized here, not by the first frame.
    std::vector<uint8_t> frame(frame_capacity);
    slot.topology = std::move(packet);
    slot.topology_uv = std::move(textured);
    slot.frame = std::move(frame);
  } catch (const std::bad_alloc&) {
    stats.mesh_topologies_refused++;
    return Reject::unavailable;
  }
  mesh_bytes_held = mesh_bytes_held - slot.frame_capacity + frame_capacity;
  stats.mesh_bytes_held = mesh_bytes_held;
  slot.frame_capacity = frame_capacity;
  slot.frame_size = 0;
  slot.sequence = 0;
  reserve_fanout();
  for (auto& s : sessions) s->topology_changed(a.id, t.lod);
  return Reject::ok;
}

Reject ServerImpl::accept_mesh(Avatar& a, uint8_t lod, std::span<const uint8_t> packet) {
  auto& slot = a.mesh[lod];
  if (!slot.topology) return Reject::unexpected;
  // A frame carries exactly its topology's vertices (decode_mesh checked its length against its
  // count): the buffers were sized for that many, and a receiver draws them with those indices.
  if (packet.size() != slot.frame_capacity) return Reject::malformed;
  std::memcpy(slot.frame.data(), packet.data(), packet.size());
  slot.frame_size = packet.size();
  set_pose_avatar(std::span<uint8_t>(slot.frame.data(), slot.frame_size), a.id);  // same offset
  for (auto& s : sessions) {
    if (!s->active || s->role != Role::subscriber || s->mesh_lod != lod) continue;
    s->mark_mesh(a.id);
    if (!batching) s->flush();
  }
  return Reject::ok;
}

}  // namespace mimic::net
