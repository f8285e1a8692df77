// The browser page's subscriber and skin, compiled to WebAssembly (web/CMakeLists.txt): the
// same C++ `mimic view --connect` runs (the frame codec and lean pose stream of net/wire, the
// body model parser and the realtime skin of avatar/), behind a C interface the page's script
// calls. The page only moves bytes between its WebSocket and this module and draws what it
// deforms: the protocol, the models and the skin are this code, not a second implementation.
//
// The page writes what the WebSocket brings into mw_in(n) and commits it (mw_commit); packets
// to send back (HELLO, KEY_REQUEST) collect in mw_out(). Each avatar's skins are built per LOD
// the first time that LOD is asked for (a ray-cast pass), then mw_deform evaluates one frame.
#include <emscripten/emscripten.h>

#include <algorithm>
#include <array>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "mimic/avatar/appearance.h"
#include "mimic/avatar/body_model.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin_lod.h"
#include "mimic/net/frame_codec.h"
#include "mimic/net/pose_stream.h"

namespace {

using namespace mimic;

struct Lod {
  std::shared_ptr<const avatar::RealtimeBody> body;
  std::unique_ptr<avatar::RealtimeSkin> skin;
  std::vector<glm::vec3> positions_m, normals;
  std::vector<glm::vec3> albedo;  // the clothes' colours per vertex (avatar/appearance.h)
  bool failed = false;
};

struct WebAvatar {
  uint16_t id = 0;
  uint32_t revision = 0;
  uint16_t dof_count = 0;
  std::string name;
  std::unique_ptr<avatar::BodyModel> model;
  std::array<Lod, avatar::kSkinLodCount> lods;
  rig::Pose pose;
  net::LeanPoseState lean;
  bool has_pose = false, key_requested = false;
  uint64_t frames = 0;
  uint32_t sequence = 0;
  uint64_t time_us = 0;    // the latest pose's capture time (the publisher's wall clock, µs since the epoch)
  float height_m = 1.75f;  // of the first skin built, standing in its initial pose
};

struct Counters {
  uint32_t models = 0, frames = 0, lean_keys = 0, unreferenced = 0, key_requests = 0, bad_models = 0, bad_packets = 0,
           removed = 0;
  uint64_t model_bytes = 0, frame_bytes = 0, bytes_in = 0;
};

struct State {
  net::PacketReader reader{net::kMaxPacketBytes};
  std::map<uint16_t, WebAvatar> avatars;
  std::vector<uint8_t> out;
  std::vector<uint16_t> order;  // avatar ids, for index access from the page
  Counters n;
  int welcomed = 0;  // 1 after WELCOME, -1 after REJECT
  std::string reject_message;
  rig::Pose scratch;
};

State& state() {
  static State s;
  return s;
}

void queue(std::span<const uint8_t> packet) {
  auto& out = state().out;
  out.insert(out.end(), packet.begin(), packet.end());
}

void refresh_order() {
  State& s = state();
  s.order.clear();
  for (const auto& [id, a] : s.avatars) s.order.push_back(id);
}

void on_model(std::span<const uint8_t> p) {
  State& s = state();
  net::AvatarModel m;
  if (net::decode_avatar_model(p, m) != net::Reject::ok) {
    s.n.bad_packets++;
    return;
  }
  s.n.models++;
  s.n.model_bytes += p.size();
  auto body = avatar::body_model_from_json(m.model_bytes, m.name);
  if (!body) {
    s.n.bad_models++;
    return;
  }
  WebAvatar& a = s.avatars[m.avatar];
  a = WebAvatar{};
  a.id = m.avatar;
  a.revision = m.revision;
  a.dof_count = m.dof_count;
  a.name = m.name;
  a.model = std::make_unique<avatar::BodyModel>(std::move(*body));
  refresh_order();
}

void on_pose(std::span<const uint8_t> p, bool lean) {
  State& s = state();
  net::PoseHeader h;
  WebAvatar* a = nullptr;
  if (lean) {
    // The avatar field sits where a POSE frame has it (pose_stream.h).
    auto it = s.avatars.find(net::pose_avatar(p));
    if (it == s.avatars.end()) return;
    a = &it->second;
    const net::Reject e = net::decode_lean_pose(p, a->lean, h, s.scratch);
    if (e == net::Reject::unexpected) {
      s.n.unreferenced++;
      if (!a->key_requested) {
        std::array<uint8_t, 64> buf{};
        queue(std::span<const uint8_t>(buf.data(), net::encode_key_request(a->id, buf)));
        a->key_requested = true;
        s.n.key_requests++;
      }
      return;
    }
    if (e != net::Reject::ok) return;
    if (net::lean_pose_is_key(p)) {
      s.n.lean_keys++;
      a->key_requested = false;
    }
  } else {
    if (net::decode_pose(p, h, s.scratch) != net::Reject::ok) {
      s.n.bad_packets++;
      return;
    }
    auto it = s.avatars.find(h.avatar);
    if (it == s.avatars.end()) return;
    a = &it->second;
  }
  if (s.scratch.dof_rad.size() != a->dof_count) return;
  a->pose = s.scratch;
  a->has_pose = true;
  a->frames++;
  a->sequence = h.sequence;
  a->time_us = h.time_us;
  s.n.frames++;
  s.n.frame_bytes += p.size();
}

void handle(std::span<const uint8_t> p) {
  State& s = state();
  switch (static_cast<net::MsgType>(p[2])) {
    case net::MsgType::welcome: s.welcomed = 1; break;
    case net::MsgType::reject: {
      net::RejectMsg r;
      if (net::decode_reject(p, r) == net::Reject::ok) s.reject_message = net::printable(r.message);
      s.welcomed = -1;
      break;
    }
    case net::MsgType::avatar_model: on_model(p); break;
    case net::MsgType::avatar_removed: {
      uint16_t id = 0;
      if (net::decode_avatar_removed(p, id) == net::Reject::ok && s.avatars.erase(id)) {
        s.n.removed++;
        refresh_order();
      }
      break;
    }
    case net::MsgType::pose: on_pose(p, false); break;
    case net::MsgType::pose_delta: on_pose(p, true); break;
    default: break;  // SCENE, meshes: the models that follow it are what this page needs
  }
}

WebAvatar* find(int id) {
  auto it = state().avatars.find(static_cast<uint16_t>(id));
  return it == state().avatars.end() ? nullptr : &it->second;
}

// The skin of one LOD, built on first use (a ray-cast pass over the body: not per frame).
Lod* lod_of(int id, int lod) {
  WebAvatar* a = find(id);
  if (!a || lod < 0 || lod >= avatar::kSkinLodCount) return nullptr;
  Lod& l = a->lods[size_t(lod)];
  if (l.skin) return &l;
  if (l.failed) return nullptr;
  avatar::RealtimeOptions ro;
  ro.lod = lod;
  auto body = avatar::RealtimeBody::create(*a->model, ro);
  if (!body) {
    l.failed = true;
    return nullptr;
  }
  l.body = *body;
  l.skin = std::make_unique<avatar::RealtimeSkin>(l.body);
  l.positions_m.resize(l.body->vertex_count());
  l.normals.resize(l.body->vertex_count());
  l.skin->evaluate(l.body->skeleton().zero_pose(), l.positions_m, l.normals);
  l.albedo = avatar::clothing_albedo(l.body->skeleton(), l.positions_m);
  l.skin->evaluate(l.body->skeleton().rest_pose(), l.positions_m, l.normals);
  float lo = 1e9f, hi = -1e9f;
  for (const glm::vec3& p : l.positions_m) {
    lo = std::min(lo, p.y);
    hi = std::max(hi, p.y);
  }
  if (hi > lo) a->height_m = hi - lo;
  return &l;
}

}  // namespace

extern "C" {

// HELLO of a subscriber asking for the lean pose stream; the page sends mw_out() next.
EMSCRIPTEN_KEEPALIVE int mw_hello(int lean) {
  net::Hello h;
  h.role = net::Role::subscriber;
  h.capabilities = net::kCapPose | (lean ? uint32_t(net::kCapLeanPose) : 0u);
  h.name = "browser";
  std::array<uint8_t, 512> buf{};
  const size_t n = net::encode_hello(h, buf);
  queue(std::span<const uint8_t>(buf.data(), n));
  return int(n);
}

// A new connection: the last one's partial packet, avatars and replies are dropped (the scene
// arrives anew after the next HELLO).
EMSCRIPTEN_KEEPALIVE void mw_reset() {
  State& s = state();
  s.reader = net::PacketReader{net::kMaxPacketBytes};
  s.avatars.clear();
  s.order.clear();
  s.out.clear();
  s.welcomed = 0;
  s.reject_message.clear();
}

EMSCRIPTEN_KEEPALIVE uint8_t* mw_out() { return state().out.data(); }
EMSCRIPTEN_KEEPALIVE int mw_out_size() { return int(state().out.size()); }
EMSCRIPTEN_KEEPALIVE void mw_out_clear() { state().out.clear(); }

// Room for `n` received bytes; mw_commit(n) then handles every complete packet. Returns 0, or
// the Reject code of a stream that cannot go on (the page closes the socket).
EMSCRIPTEN_KEEPALIVE uint8_t* mw_in(int n) { return state().reader.write_space(size_t(std::max(n, 1))).data(); }
EMSCRIPTEN_KEEPALIVE int mw_commit(int n) {
  State& s = state();
  s.reader.commit(size_t(n));
  s.n.bytes_in += uint64_t(n);
  for (;;) {
    std::span<const uint8_t> p;
    const net::Reject e = s.reader.next(p);
    if (e != net::Reject::ok) return int(e);
    if (p.empty()) return 0;
    handle(p);
  }
}

EMSCRIPTEN_KEEPALIVE int mw_welcomed() { return state().welcomed; }
EMSCRIPTEN_KEEPALIVE const char* mw_reject_message() { return state().reject_message.c_str(); }

EMSCRIPTEN_KEEPALIVE int mw_avatar_count() { return int(state().order.size()); }
EMSCRIPTEN_KEEPALIVE int mw_avatar_id(int i) {
  const auto& o = state().order;
  return i >= 0 && size_t(i) < o.size() ? o[size_t(i)] : -1;
}
EMSCRIPTEN_KEEPALIVE uint32_t mw_revision(int id) { return find(id) ? find(id)->revision : 0; }
EMSCRIPTEN_KEEPALIVE int mw_has_pose(int id) { return find(id) && find(id)->has_pose; }
EMSCRIPTEN_KEEPALIVE double mw_frames(int id) { return find(id) ? double(find(id)->frames) : 0; }
// The capture time of the avatar's latest pose, µs since the Unix epoch on the publisher's wall
// clock (exact in a double until the year 2255): the page's end-to-end latency starts there.
EMSCRIPTEN_KEEPALIVE double mw_time_us(int id) { return find(id) ? double(find(id)->time_us) : 0; }
// Root position (metres, world): where the page aims its camera and measures LOD distance.
EMSCRIPTEN_KEEPALIVE float mw_root(int id, int axis) {
  WebAvatar* a = find(id);
  return a && axis >= 0 && axis < 3 ? a->pose.root_position_m[axis] : 0.0f;
}
EMSCRIPTEN_KEEPALIVE float mw_height(int id) {
  WebAvatar* a = find(id);
  return a ? a->height_m : 0.0f;
}

EMSCRIPTEN_KEEPALIVE int mw_lod_count() { return avatar::kSkinLodCount; }
// The avatar library's LOD rule (the viewer's): body height on screen, with hysteresis.
EMSCRIPTEN_KEEPALIVE int mw_choose_lod(float distance_m, int current, float viewport_height_px, float fov_y_rad,
                                       float body_height_m) {
  avatar::LodView v;
  v.viewport_height_px = std::max(viewport_height_px, 1.0f);
  v.vertical_fov_rad = fov_y_rad;
  v.body_height_m = body_height_m;
  return std::clamp(avatar::choose_lod_at_distance(distance_m, current, v), 0, avatar::kSkinLodCount - 1);
}

// Topology of an avatar's LOD (builds it on first use): counts, the index array, and the parts
// (ranges of triangles) the page colours.
EMSCRIPTEN_KEEPALIVE int mw_vertex_count(int id, int lod) {
  Lod* l = lod_of(id, lod);
  return l ? int(l->positions_m.size()) : 0;
}
EMSCRIPTEN_KEEPALIVE int mw_index_count(int id, int lod) {
  Lod* l = lod_of(id, lod);
  return l ? int(l->body->rest_mesh().indices.size()) : 0;
}
EMSCRIPTEN_KEEPALIVE const uint32_t* mw_indices(int id, int lod) {
  Lod* l = lod_of(id, lod);
  return l ? l->body->rest_mesh().indices.data() : nullptr;
}
EMSCRIPTEN_KEEPALIVE int mw_part_count(int id, int lod) {
  Lod* l = lod_of(id, lod);
  return l ? int(l->body->rest_mesh().parts.size()) : 0;
}
EMSCRIPTEN_KEEPALIVE int mw_part_first(int id, int lod, int part) {
  Lod* l = lod_of(id, lod);
  return l ? int(l->body->rest_mesh().parts.at(size_t(part)).first_triangle) : 0;
}
EMSCRIPTEN_KEEPALIVE int mw_part_triangles(int id, int lod, int part) {
  Lod* l = lod_of(id, lod);
  return l ? int(l->body->rest_mesh().parts.at(size_t(part)).triangle_count) : 0;
}
EMSCRIPTEN_KEEPALIVE const char* mw_part_name(int id, int lod, int part) {
  Lod* l = lod_of(id, lod);
  return l ? l->body->rest_mesh().parts.at(size_t(part)).name.c_str() : "";
}

// The colour of each vertex (rgb floats, 0..1): skin, clothes with soft edges, as `mimic view`.
EMSCRIPTEN_KEEPALIVE const float* mw_albedo(int id, int lod) {
  Lod* l = lod_of(id, lod);
  return l ? &l->albedo[0].x : nullptr;
}

// One frame of the realtime skin at the avatar's latest pose: positions (xyz floats, metres);
// mw_normals gives the matching unit normals. Null when the avatar or LOD is not there.
EMSCRIPTEN_KEEPALIVE const float* mw_deform(int id, int lod) {
  WebAvatar* a = find(id);
  Lod* l = lod_of(id, lod);
  if (!a || !l) return nullptr;
  if (a->has_pose) l->skin->evaluate(a->pose, l->positions_m, l->normals);
  return &l->positions_m[0].x;
}
EMSCRIPTEN_KEEPALIVE const float* mw_normals(int id, int lod) {
  Lod* l = lod_of(id, lod);
  return l ? &l->normals[0].x : nullptr;
}

// The deform alone, `n` times at the latest pose: microseconds per frame (the page's bench).
EMSCRIPTEN_KEEPALIVE double mw_bench_deform(int id, int lod, int n) {
  WebAvatar* a = find(id);
  Lod* l = lod_of(id, lod);
  if (!a || !l || n <= 0) return -1;
  const rig::Pose& pose = a->has_pose ? a->pose : l->body->skeleton().rest_pose();
  const double t0 = emscripten_get_now();
  for (int i = 0; i < n; ++i) l->skin->evaluate(pose, l->positions_m, l->normals);
  return (emscripten_get_now() - t0) * 1000.0 / n;
}

// Counters for the page's stats: 0 models, 1 frames, 2 lean keys, 3 unreferenced deltas,
// 4 key requests, 5 bad models, 6 bad packets, 7 removals, 8 model bytes, 9 frame bytes,
// 10 bytes in.
EMSCRIPTEN_KEEPALIVE double mw_counter(int i) {
  const Counters& c = state().n;
  const double v[] = {double(c.models),       double(c.frames),      double(c.lean_keys),   double(c.unreferenced),
                      double(c.key_requests), double(c.bad_models),  double(c.bad_packets), double(c.removed),
                      double(c.model_bytes),  double(c.frame_bytes), double(c.bytes_in)};
  return i >= 0 && size_t(i) < std::size(v) ? v[size_t(i)] : 0;
}

}  // extern "C"
