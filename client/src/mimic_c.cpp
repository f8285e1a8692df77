// The C ABI over mimic::client::Subscriber (mimic/mimic_c.h). Views handed to C point into the
// Subscriber's own buffers; the joint arrays are mirrors rebuilt when a model arrives and
// refreshed in place for each frame, so a frame costs C callers no allocation.
#include "mimic/mimic_c.h"

#include <cstddef>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "mimic/client.h"

namespace {

using mimic::client::Avatar;
using mimic::client::Mesh;
using mimic::client::Quat;
using mimic::client::Vec2;
using mimic::client::Vec3;

// The mesh buffers are handed out as they are: the C and C++ vectors must be the same floats.
static_assert(std::is_standard_layout_v<Vec3> && sizeof(Vec3) == sizeof(mimic_vec3) &&
              offsetof(Vec3, z) == offsetof(mimic_vec3, z));
static_assert(std::is_standard_layout_v<Vec2> && sizeof(Vec2) == sizeof(mimic_vec2) &&
              offsetof(Vec2, v) == offsetof(mimic_vec2, v));

mimic_vec3 c_vec(const Vec3& v) { return {v.x, v.y, v.z}; }
mimic_quat c_quat(const Quat& q) { return {q.x, q.y, q.z, q.w}; }

void copy_error(const std::string& text, char* error, size_t error_bytes) {
  if (!error || error_bytes == 0) return;
  const size_t n = std::min(text.size(), error_bytes - 1);
  std::memcpy(error, text.data(), n);
  error[n] = '\0';
}

}  // namespace

struct mimic_subscriber {
  std::unique_ptr<mimic::client::Subscriber> sub;
  std::map<uint16_t, std::vector<mimic_joint>> joints;  // mirrors of Avatar::joints
  mimic_avatar_fn on_avatar = nullptr, on_frame = nullptr;
  mimic_mesh_fn on_mesh = nullptr;
  mimic_removed_fn on_removed = nullptr;
  void *avatar_user = nullptr, *frame_user = nullptr, *mesh_user = nullptr, *removed_user = nullptr;

  // The C view of `a`; its joints mirror rebuilt when `rebuild` (a new model), else refreshed.
  mimic_avatar view(const Avatar& a, bool rebuild) {
    std::vector<mimic_joint>& js = joints[a.id];
    // A recreated avatar has new name strings: compare where the first one lives.
    if (rebuild || js.size() != a.joints.size() || (!js.empty() && js[0].name != a.joints[0].name.c_str())) {
      js.assign(a.joints.size(), mimic_joint{});
      for (size_t j = 0; j < js.size(); ++j) {
        js[j].name = a.joints[j].name.c_str();
        js[j].parent = a.joints[j].parent;
      }
    }
    for (size_t j = 0; j < js.size(); ++j) {
      js[j].position_m = c_vec(a.joints[j].position_m);
      js[j].orientation = c_quat(a.joints[j].orientation);
    }
    mimic_avatar v{};
    v.id = a.id;
    v.name = a.name.c_str();
    v.joint_count = static_cast<uint32_t>(js.size());
    v.joints = js.data();
    v.dof_count = static_cast<uint32_t>(a.dof_rad.size());
    v.dof_rad = a.dof_rad.data();
    v.root_position_m = c_vec(a.root_position_m);
    v.root_orientation = c_quat(a.root_orientation);
    v.sequence = a.sequence;
    v.time_us = a.time_us;
    v.stale = a.stale;
    v.has_pose = a.has_pose;
    v.frames = a.frames;
    v.lost = a.lost;
    return v;
  }

  static mimic_mesh view(const Mesh& m) {
    mimic_mesh v{};
    v.avatar = m.avatar;
    v.lod = m.lod;
    v.vertex_count = static_cast<uint32_t>(m.positions_m.size());
    v.positions_m = reinterpret_cast<const mimic_vec3*>(m.positions_m.data());
    v.normals = reinterpret_cast<const mimic_vec3*>(m.normals.data());
    v.index_count = static_cast<uint32_t>(m.indices.size());
    v.indices = m.indices.data();
    v.sequence = m.sequence;
    v.time_us = m.time_us;
    v.frames = m.frames;
    v.uvs = m.uvs.empty() ? nullptr : reinterpret_cast<const mimic_vec2*>(m.uvs.data());
    return v;
  }
};

extern "C" {

const char* mimic_version(void) { return mimic::client::version(); }

const char* mimic_status_name(mimic_status status) {
  switch (status) {
    case MIMIC_OK: return "ok";
    case MIMIC_ERROR_ARGUMENT: return "bad argument";
    case MIMIC_ERROR_CONNECT: return "cannot connect";
    case MIMIC_ERROR_SESSION_ENDED: return "session ended";
    case MIMIC_ERROR_NOT_FOUND: return "not found";
  }
  return "unknown status";
}

void mimic_options_init(mimic_options* o) {
  if (!o) return;
  o->server = "127.0.0.1:7777";
  o->name = "mimic-c";
  o->udp = 0;
  o->mesh_lod = -1;
  o->connect_timeout_s = 3.0;
}

mimic_status mimic_subscriber_connect(const mimic_options* options, mimic_subscriber** out, char* error,
                                      size_t error_bytes) {
  if (out) *out = nullptr;
  if (!options || !out || !options->server) {
    copy_error("mimic_subscriber_connect: options, options->server and out are required", error, error_bytes);
    return MIMIC_ERROR_ARGUMENT;
  }
  if (options->mesh_lod < -1 || options->mesh_lod > 7 || !(options->connect_timeout_s > 0)) {
    copy_error("mimic_subscriber_connect: mesh_lod must be -1..7 and connect_timeout_s positive", error, error_bytes);
    return MIMIC_ERROR_ARGUMENT;
  }
  mimic::client::Options o;
  o.server = options->server;
  if (options->name) o.name = options->name;
  o.udp = options->udp != 0;
  o.mesh_lod = options->mesh_lod;
  o.connect_timeout_s = options->connect_timeout_s;
  std::string why;
  auto sub = mimic::client::Subscriber::connect(o, &why);
  if (!sub) {
    copy_error(why, error, error_bytes);
    return MIMIC_ERROR_CONNECT;
  }
  auto* s = new mimic_subscriber;
  s->sub = std::move(sub);
  s->sub->on_avatar = [s](const Avatar& a) {
    const mimic_avatar v = s->view(a, true);
    if (s->on_avatar) s->on_avatar(s->avatar_user, &v);
  };
  s->sub->on_frame = [s](const Avatar& a) {
    const mimic_avatar v = s->view(a, false);
    if (s->on_frame) s->on_frame(s->frame_user, &v);
  };
  s->sub->on_mesh = [s](const Mesh& m) {
    if (!s->on_mesh) return;
    const mimic_mesh v = mimic_subscriber::view(m);
    s->on_mesh(s->mesh_user, &v);
  };
  s->sub->on_removed = [s](uint16_t id) {
    s->joints.erase(id);
    if (s->on_removed) s->on_removed(s->removed_user, id);
  };
  *out = s;
  return MIMIC_OK;
}

void mimic_subscriber_destroy(mimic_subscriber* s) { delete s; }

mimic_status mimic_subscriber_on_avatar(mimic_subscriber* s, mimic_avatar_fn fn, void* user) {
  if (!s) return MIMIC_ERROR_ARGUMENT;
  s->on_avatar = fn;
  s->avatar_user = user;
  return MIMIC_OK;
}

mimic_status mimic_subscriber_on_frame(mimic_subscriber* s, mimic_avatar_fn fn, void* user) {
  if (!s) return MIMIC_ERROR_ARGUMENT;
  s->on_frame = fn;
  s->frame_user = user;
  return MIMIC_OK;
}

mimic_status mimic_subscriber_on_mesh(mimic_subscriber* s, mimic_mesh_fn fn, void* user) {
  if (!s) return MIMIC_ERROR_ARGUMENT;
  s->on_mesh = fn;
  s->mesh_user = user;
  return MIMIC_OK;
}

mimic_status mimic_subscriber_on_removed(mimic_subscriber* s, mimic_removed_fn fn, void* user) {
  if (!s) return MIMIC_ERROR_ARGUMENT;
  s->on_removed = fn;
  s->removed_user = user;
  return MIMIC_OK;
}

mimic_status mimic_subscriber_poll(mimic_subscriber* s, char* error, size_t error_bytes) {
  if (!s) return MIMIC_ERROR_ARGUMENT;
  std::string why;
  if (s->sub->poll(&why)) return MIMIC_OK;
  copy_error(why, error, error_bytes);
  return MIMIC_ERROR_SESSION_ENDED;
}

mimic_status mimic_subscriber_run_for(mimic_subscriber* s, double seconds, char* error, size_t error_bytes) {
  if (!s || !(seconds >= 0)) return MIMIC_ERROR_ARGUMENT;
  std::string why;
  if (s->sub->run_for(seconds, &why)) return MIMIC_OK;
  copy_error(why, error, error_bytes);
  return MIMIC_ERROR_SESSION_ENDED;
}

mimic_status mimic_subscriber_avatar_ids(const mimic_subscriber* s, uint16_t* ids, size_t capacity, size_t* count) {
  if (!s || (!ids && capacity > 0)) return MIMIC_ERROR_ARGUMENT;
  const auto all = s->sub->avatar_ids();
  for (size_t i = 0; i < all.size() && i < capacity; ++i) ids[i] = all[i];
  if (count) *count = all.size();
  return MIMIC_OK;
}

mimic_status mimic_subscriber_avatar(mimic_subscriber* s, uint16_t id, mimic_avatar* out) {
  if (!s || !out) return MIMIC_ERROR_ARGUMENT;
  const Avatar* a = s->sub->avatar(id);
  if (!a) return MIMIC_ERROR_NOT_FOUND;
  *out = s->view(*a, false);
  return MIMIC_OK;
}

mimic_status mimic_subscriber_mesh(mimic_subscriber* s, uint16_t id, mimic_mesh* out) {
  if (!s || !out) return MIMIC_ERROR_ARGUMENT;
  const Mesh* m = s->sub->mesh(id);
  if (!m) return MIMIC_ERROR_NOT_FOUND;
  *out = mimic_subscriber::view(*m);
  return MIMIC_OK;
}

}  // extern "C"
