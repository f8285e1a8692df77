// The client library over net::Client: body model bytes → skeleton once per model, pose frames →
// forward kinematics into the Avatar the callbacks see.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <optional>
#include <thread>

#include "mimic/rig/skeleton_json.h"
#include "mimic/rig/skeleton.h"
#include "mimic/client.h"
#include "mimic/core/vertex_normals.h"
#include "mimic/net/client.h"

namespace mimic::client {

namespace {

Vec3 to_vec3(const glm::vec3& v) { return {v.x, v.y, v.z}; }
Quat to_quat(const glm::quat& q) { return {q.x, q.y, q.z, q.w}; }

// The skeleton the model describes; Mimic's default skeleton when the model is not a Mimic body
// model but the DOF count fits it; none otherwise (the avatar then carries angles only).
std::optional<rig::Skeleton> skeleton_of(const net::RemoteAvatar& r) {
  if (auto s = rig::skeleton_from_body_json(r.model_bytes, r.name); s && s->dof_count() == r.dof_count)
    return std::move(*s);
  if (auto s = rig::Skeleton::build(rig::default_skeleton_desc()); s && s->dof_count() == r.dof_count)
    return std::move(*s);
  return std::nullopt;
}

}  // namespace

struct Subscriber::Impl {
  struct Entry {
    Avatar view;
    std::optional<rig::Skeleton> skeleton;
    std::vector<rig::RigidTransform> world_from_joint;
    uint32_t revision = 0;
  };
  std::unique_ptr<net::Client> client;
  std::map<uint16_t, Entry> avatars;
  // A mesh as the callbacks see it, and the welded skin it is gathered from each frame.
  struct MeshEntry {
    Mesh view;
    uint64_t topology = 0;           // net::RemoteAvatar::mesh_topologies it was shaped by
    std::vector<uint32_t> source;    // per view vertex, the wire vertex it copies
    std::vector<uint32_t> welded;    // the wire's triangles
    std::vector<glm::vec3> normals;  // on the wire's (welded) vertices
  };
  std::map<uint16_t, MeshEntry> meshes;

  // A new topology shapes the buffers; every frame then fills them in place.
  Mesh& mesh(const net::RemoteAvatar& r) {
    MeshEntry& e = meshes[r.id];
    const size_t n = r.mesh_positions_m.size();
    if (e.topology != r.mesh_topologies || e.normals.size() != n || e.view.avatar != r.id) shape(e, r);
    Mesh& m = e.view;
    m.lod = r.mesh_last.lod;
    ::mimic::vertex_normals(r.mesh_positions_m, e.welded, e.normals);
    for (size_t i = 0; i < e.source.size(); ++i) {
      const uint32_t s = e.source[i] < n ? e.source[i] : 0;
      m.positions_m[i] = to_vec3(r.mesh_positions_m[s]);
      m.normals[i] = to_vec3(e.normals[s]);
    }
    m.sequence = r.mesh_last.sequence;
    m.time_us = r.mesh_last.time_us;
    m.frames = r.mesh_frames;
    return m;
  }

  static void shape(MeshEntry& e, const net::RemoteAvatar& r) {
    const size_t n = r.mesh_positions_m.size();
    // The decoder checked the texture section against the topology (sources, same triangles).
    const bool textured = !r.mesh_uvs.empty() && r.mesh_uv_indices.size() == r.mesh_indices.size();
    e.topology = r.mesh_topologies;
    e.welded = r.mesh_indices;
    e.normals.assign(n, glm::vec3(0));
    e.view = Mesh{};
    e.view.avatar = r.id;
    if (textured) {
      e.source = r.mesh_uv_source;
      e.view.indices = r.mesh_uv_indices;
      e.view.uvs.reserve(r.mesh_uvs.size());
      for (const auto& uv : r.mesh_uvs) e.view.uvs.push_back({uv.x, uv.y});
    } else {
      e.source.resize(n);
      for (size_t i = 0; i < n; ++i) e.source[i] = uint32_t(i);
      e.view.indices = r.mesh_indices;
    }
    e.view.positions_m.assign(e.source.size(), Vec3{});
    e.view.normals.assign(e.source.size(), Vec3{});
  }

  Entry& model(const net::RemoteAvatar& r) {
    Entry& e = avatars[r.id];
    if (e.revision == r.revision && e.view.id == r.id && e.revision != 0) return e;
    e.revision = r.revision;
    e.skeleton = skeleton_of(r);
    e.view = Avatar{};
    e.view.id = r.id;
    e.view.name = r.name;
    e.view.dof_rad.assign(r.dof_count, 0.0f);
    if (e.skeleton) {
      const rig::Skeleton& s = *e.skeleton;
      for (int d = 0; d < s.dof_count(); ++d) e.view.dof_names.push_back(s.dof(d).name);
      e.world_from_joint.resize(size_t(s.joint_count()));
      rig::forward_kinematics(s, s.rest_pose(), e.world_from_joint);
      for (int j = 0; j < s.joint_count(); ++j)
        e.view.joints.push_back({s.joint_name(j), s.parent(j), to_vec3(e.world_from_joint[size_t(j)].translation),
                                 to_quat(e.world_from_joint[size_t(j)].rotation)});
    }
    return e;
  }

  void pose(const net::RemoteAvatar& r) {
    Entry& e = model(r);
    Avatar& v = e.view;
    v.dof_rad.assign(r.pose.dof_rad.begin(), r.pose.dof_rad.end());
    v.root_position_m = to_vec3(r.pose.root_position_m);
    v.root_orientation = to_quat(r.pose.root_orientation);
    v.sequence = r.last.sequence;
    v.time_us = r.last.time_us;
    v.stale = (r.last.flags & net::kPoseStale) != 0;
    v.has_pose = true;
    v.frames = r.frames;
    v.lost = r.lost;
    if (!e.skeleton || r.pose.dof_rad.size() != size_t(e.skeleton->dof_count())) return;
    rig::forward_kinematics(*e.skeleton, r.pose, e.world_from_joint);
    for (size_t j = 0; j < v.joints.size(); ++j) {
      v.joints[j].position_m = to_vec3(e.world_from_joint[j].translation);
      v.joints[j].orientation = to_quat(e.world_from_joint[j].rotation);
    }
  }
};

Subscriber::Subscriber(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Subscriber::~Subscriber() = default;

std::unique_ptr<Subscriber> Subscriber::connect(const Options& options, std::string* error) {
  net::ClientOptions o;
  o.connect = options.server;
  o.role = net::Role::subscriber;
  o.name = options.name;
  o.udp = options.udp;
  o.connect_timeout_s = options.connect_timeout_s;
  if (options.mesh_lod >= 0) {
    if (options.mesh_lod > 7) {
      if (error) *error = "mesh LOD must be 0..7 (or -1 for none)";
      return nullptr;
    }
    o.mesh_lod = static_cast<uint8_t>(options.mesh_lod);
  }
  auto c = net::Client::connect(o);
  if (!c) {
    if (error) *error = c.error().what();
    return nullptr;
  }
  auto impl = std::make_unique<Impl>();
  impl->client = std::move(*c);
  std::unique_ptr<Subscriber> s(new Subscriber(std::move(impl)));
  Subscriber* self = s.get();
  self->impl_->client->on_model = [self](const net::RemoteAvatar& r) {
    self->impl_->avatars.erase(r.id);  // a new revision: rebuild
    const auto& e = self->impl_->model(r);
    if (self->on_avatar) self->on_avatar(e.view);
  };
  self->impl_->client->on_pose = [self](const net::RemoteAvatar& r, uint64_t) {
    self->impl_->pose(r);
    if (self->on_frame) self->on_frame(self->impl_->avatars[r.id].view);
  };
  self->impl_->client->on_mesh = [self](const net::RemoteAvatar& r) {
    const Mesh& m = self->impl_->mesh(r);
    if (self->on_mesh) self->on_mesh(m);
  };
  self->impl_->client->on_removed = [self](uint16_t id) {
    self->impl_->avatars.erase(id);
    self->impl_->meshes.erase(id);
    if (self->on_removed) self->on_removed(id);
  };
  return s;
}

bool Subscriber::poll(std::string* error) {
  if (auto st = impl_->client->poll(); !st) {
    if (error) *error = st.error().what();
    return false;
  }
  return true;
}

bool Subscriber::run_for(double seconds, std::string* error) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                            std::chrono::duration<double>(seconds));
  if (auto st = impl_->client->run_until(until); !st) {
    if (error) *error = st.error().what();
    return false;
  }
  return true;
}

std::vector<uint16_t> Subscriber::avatar_ids() const {
  std::vector<uint16_t> ids;
  for (const auto& [id, e] : impl_->avatars) ids.push_back(id);
  return ids;
}

const Avatar* Subscriber::avatar(uint16_t id) const {
  auto it = impl_->avatars.find(id);
  return it == impl_->avatars.end() ? nullptr : &it->second.view;
}

const Mesh* Subscriber::mesh(uint16_t id) const {
  auto it = impl_->meshes.find(id);
  return it == impl_->meshes.end() ? nullptr : &it->second.view;
}

Link Subscriber::link() const {
  const net::ClientStats& s = impl_->client->stats();
  Link l;
  l.connected = impl_->client->connected();
  l.cuts = s.cuts;
  l.outages = s.outages;
  l.outage_s = s.outage_s;
  l.lost = s.lost;
  return l;
}

const char* version() { return MIMIC_VERSION; }

}  // namespace mimic::client
