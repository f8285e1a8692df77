// The interactive `mimic view`: a window that draws every avatar of the scene, deformed here.
// Local mode runs the service's pipeline (the same read → solve loop as `mimic run`, no network
// outputs) and deforms each avatar's pose at the LOD its distance calls for; --connect mode
// receives body models once and pose frames from a running `mimic run` or `mimic relay`, or from
// a scene on a NATS broker (nats://HOST:PORT/SCENE: net::Client runs a relay in this process),
// as the protocol intends, and deforms them the same way.
#if MIMIC_HAVE_RENDER  // built with MIMIC_WITH_VIEWER
#include "view_interactive.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "mimic/avatar/body_model.h"
#include "mimic/core/clock.h"
#include "mimic/net/client.h"
#include "mimic/render/avatar_lods.h"
#include "mimic/render/camera.h"
#include "mimic/render/first_person.h"
#include "mimic/render/hud.h"
#include "mimic/render/image.h"
#include "mimic/render/overlays.h"
#include "mimic/render/renderer.h"
#include "mimic/render/window.h"
#include "mimic/service/pipeline.h"
#include "mimic/service/scene_builder.h"
#include "body_posing.h"
#include "scene_connect.h"
#include "stop_signal.h"

namespace mimic::app {
namespace {

constexpr const char* kName = "view";

const char* state_name(devices::DeviceState s) {
  switch (s) {
    case devices::DeviceState::disconnected: return "disconnected";
    case devices::DeviceState::connecting: return "connecting";
    case devices::DeviceState::streaming: return "streaming";
    case devices::DeviceState::stale: return "stale";
    case devices::DeviceState::error: return "error";
  }
  return "?";
}

// One avatar as drawn: its skins at every LOD and where its pose comes from.
struct ViewAvatar {
  std::string name, source;
  std::optional<render::AvatarLods> lods;
  rig::Pose pose;
  glm::mat4 world_from_body{1.0f};
  bool stale = false;
  std::string status;
  // Remote avatars: the model revision the skins were built for.
  uint32_t revision = 0;
  uint16_t remote_id = 0;
  int lod = 0;
  double deform_ms = 0;
  std::vector<render::SensorMark> sensors;  // local pipeline only: the protocol carries poses
  // Local avatars standing in the default row: moved to their place in it once their poses are
  // known (see reframe), as their motion may start away from its own origin.
  bool in_row = false;
  glm::vec3 row_position_m{0.0f};
};

// Where the avatars come from: the local pipeline, or a connection to a served scene.
struct ViewScene {
  std::vector<ViewAvatar> avatars;
  std::unique_ptr<service::Pipeline> pipeline;
  std::string last_cut;  // before the client: its callback writes here
  std::unique_ptr<net::Client> client;
  std::string connect;  // --connect's address
  std::string connection;
};

// What the user changed with keys and mouse, and the camera that follows the avatars.
struct ViewState {
  render::Camera camera, home;
  bool framed = false;       // the camera has been fitted to the scene once its avatars stood somewhere
  float panel_right = 0.0f;  // the status panel's right edge, a fraction of the width
  // The orbit camera keeps every avatar in view beside the panel as they walk (the built-in walk
  // leaves the first framing within seconds, and circles away from an avatar standing beside
  // it): it is fitted again each frame from where the user turned it, and glides there. Panning
  // by hand stops that until R or C; the wheel's zoom is kept as a factor on the fitted distance.
  bool follow = true;
  float zoom = 1.0f;      // the user's distance over the fitted one
  float fitted_m = 0.0f;  // the distance last fitted, 0 before the first fit
  render::CameraFollow follower;
  // The camera preset (--camera, keys 6-0 and P), relative to where the avatars face. With one
  // avatar the orbit turns as it turns, keeping that view of it, until the user orbits by hand.
  render::CameraPreset preset = render::CameraPreset::kFront;
  bool track_heading = true;
  bool reframe = false;  // a preset key: fit the camera again from that preset
  unsigned overlays = 0;
  int lod_mode = -1;  // -1 auto
  bool grid = true, see_through = false, help = false, unlit = false, ambient_occlusion = true;
  int ray_ring = 40;
  int first_person = -1;  // avatar index, or -1: orbit
  long eyes = 0;          // --eyes K: start looking through avatar K's eyes (once it is there)
  // Entering an avatar's eyes: once the scene stands in place, turn the look to the nearest
  // other avatar if nobody is in view (render::yaw_towards_others), as a wearer would.
  bool turn_to_others = false;
  bool look_given = false;  // --look: the user chose the look; no turn
  // Per-frame buffers, kept for their capacity.
  render::Lines lines, xray;
  std::vector<render::MeshDraw> draws;
  std::vector<rig::RigidTransform> joints;
  std::vector<glm::vec3> others_m;
};

glm::vec3 root_in_world(const ViewAvatar& a) {
  return glm::vec3(a.world_from_body * glm::vec4(a.pose.root_position_m, 1.0f));
}

// The box around every avatar's skin as last deformed, in world metres, from the floor up.
void scene_box(const std::vector<ViewAvatar>& avatars, glm::vec3& lo, glm::vec3& hi) {
  lo = glm::vec3(1e9f), hi = glm::vec3(-1e9f);
  for (const ViewAvatar& a : avatars) {
    if (a.deform_ms <= 0) continue;  // arrived this frame: its skin is not posed yet
    for (const glm::vec3& p : a.lods->mesh(a.lod).positions) {
      const glm::vec3 w = glm::vec3(a.world_from_body * glm::vec4(p, 1.0f));
      lo = glm::min(lo, w);
      hi = glm::max(hi, w);
    }
  }
  if (lo.x > hi.x) lo = glm::vec3(-0.5f, 0.0f, -0.5f), hi = glm::vec3(0.5f, 1.8f, 0.5f);  // nobody posed yet
  lo.y = std::min(lo.y, 0.0f);  // the feet on the floor, whatever the skin's lowest point
}

// `c` turned as it is, moved and zoomed so every avatar fits the part of the window the status
// panel leaves free (a panel wider than half the window is left out: the scene gets the middle).
void fit_scene(render::Camera& c, const std::vector<ViewAvatar>& avatars, float aspect, float panel_right) {
  glm::vec3 lo, hi;
  scene_box(avatars, lo, hi);
  render::fit_box(c, lo, hi, aspect, panel_right < 0.5f ? panel_right + 0.01f : 0.0f, 1.0f);
}

// The orbit camera for the scene as it stands, seen from `preset` relative to where the avatars
// face on average (front: their faces).
// Where an avatar faces in the world, as a yaw (render::facing_yaw_rad).
float heading_rad(const ViewAvatar& a) {
  return render::facing_yaw_rad(glm::quat_cast(glm::mat3(a.world_from_body)) * a.pose.root_orientation);
}

// Where the avatars face on average, as a yaw; 0 before any stands.
float scene_heading_rad(const std::vector<ViewAvatar>& avatars) {
  glm::vec2 facing(0.0f);  // sum of unit headings (sin, cos)
  for (const ViewAvatar& a : avatars) {
    if (a.deform_ms <= 0) continue;
    const float yaw = heading_rad(a);
    facing += glm::vec2(std::sin(yaw), std::cos(yaw));
  }
  return glm::length(facing) > 1e-3f ? std::atan2(facing.x, facing.y) : 0.0f;
}

render::Camera frame_scene(const std::vector<ViewAvatar>& avatars, render::CameraPreset preset, float aspect,
                           float panel_right) {
  render::Camera c;
  c.yaw_rad = render::preset_yaw_rad(preset, scene_heading_rad(avatars));
  c.pitch_rad = preset == render::CameraPreset::kTop ? render::preset_pitch_rad(preset)
                : avatars.size() > 1                 ? 0.3f
                                                     : 0.12f;
  fit_scene(c, avatars, aspect, panel_right);
  return c;
}

std::string overlay_names(unsigned mask) {
  std::string s;
  const char* names[] = {"skeleton", "primitives", "contours", "rays", "sensors"};
  for (int i = 0; i < 5; ++i)
    if (mask & (1u << i)) s += (s.empty() ? "" : ",") + std::string(names[i]);
  return s;
}

// The scene of `view.sources`, built as `mimic run` builds it (service/scene_builder.h), run by
// a pipeline without outputs; each avatar skinned here at every LOD.
int open_local(const ViewOptions& view, render::Renderer& renderer, ViewScene& scene) {
  service::SceneSpec spec;
  spec.sources = view.sources;
  spec.room = view.room;
  spec.skins = false;  // skinned here, by the renderer's LODs
  auto built = service::build_scene(spec);
  if (!built)
    return built.error().usage ? usage_error(kName, built.error().message) : failure(kName, built.error().message);
  for (const std::string& note : built->notes) std::fprintf(stderr, "mimic view: %s\n", note.c_str());
  scene.pipeline = std::make_unique<service::Pipeline>();
  for (size_t i = 0; i < built->avatars.size(); ++i) {
    service::SceneAvatar& s = built->avatars[i];
    ViewAvatar a;
    a.name = "avatar" + std::to_string(i + 1);
    a.source = s.source;
    auto lods = render::AvatarLods::create(s.body.model, &s.feed->skeleton(), renderer, view.method);
    if (!lods) return failure(kName, "body model does not fit source " + s.source + ": " + lods.error().message);
    a.lods.emplace(std::move(*lods));
    a.pose = a.lods->skeleton().rest_pose();
    a.in_row = s.in_row;
    a.row_position_m = s.place.position_m;
    if (auto st = scene.pipeline->add_avatar(a.name, std::move(s.feed), "", nullptr); !st)
      return failure(kName, st.error().what());
    scene.avatars.push_back(std::move(a));
  }
  scene.connection = "local pipeline, " + std::to_string(scene.avatars.size()) + " avatar(s)";
  return -1;
}

int open_remote(const ViewOptions& view, ViewScene& scene) {
  net::ClientOptions options;
  options.connect = scene.connect;
  options.name = "mimic-view";
  options.lean = view.lean;  // ~60 bytes a frame instead of 150: docs/protocol.md
  auto c = connect_scene(options);
  if (!c) return failure(kName, "cannot connect to " + scene.connect + ": " + c.error().message);
  scene.client = std::move(*c);
  scene.connection = "connected to " + scene.connect;
  // The client reconnects by itself after any cut; the panel says why it is away meanwhile.
  scene.client->on_cut = [&last_cut = scene.last_cut](const std::string& why) { last_cut = why; };
  return -1;
}

// The local pipeline's pass: new poses, source states and the sensors as the solver last saw
// them (stale when flagged so or older than 250 ms).
void update_local(ViewScene& scene) {
  scene.pipeline->tick();
  const double now = steady_now_s();
  for (size_t i = 0; i < scene.avatars.size(); ++i) {
    ViewAvatar& a = scene.avatars[i];
    a.pose = scene.pipeline->pose(i);
    const devices::DeviceStatus st = scene.pipeline->feed(i).status();
    a.stale = st.state != devices::DeviceState::streaming;
    a.status = std::string(state_name(st.state)) + ", " + std::to_string(st.records) + " records";
    a.sensors.clear();
    for (const devices::SensorSample& smp : scene.pipeline->feed(i).latest_samples()) {
      const bool stale = (smp.flags & devices::kSampleValid) == 0 || (smp.flags & devices::kSampleStale) != 0 ||
                         now - smp.host_time_s > 0.25;
      a.sensors.push_back({glm::vec3(a.world_from_body * glm::vec4(smp.position_m, 1.0f)),
                           glm::quat_cast(glm::mat3(a.world_from_body)) * smp.orientation, stale});
    }
  }
}

// What the network brought: avatars that joined (skinned on arrival), new poses, avatars that left.
Status update_remote(const ViewOptions& view, render::Renderer& renderer, ViewScene& scene, ViewState& state) {
  if (auto st = scene.client->poll(); !st) return st;
  std::vector<ViewAvatar>& avatars = scene.avatars;
  for (const auto& entry : scene.client->avatars()) {
    const uint16_t id = entry.first;  // not a structured binding: Clang 14 cannot capture those
    const net::RemoteAvatar& remote = entry.second;
    auto it = std::find_if(avatars.begin(), avatars.end(), [&](const ViewAvatar& a) { return a.remote_id == id; });
    if (it == avatars.end() || it->revision != remote.revision) {
      auto body = avatar::body_model_from_json(remote.model_bytes, remote.name);
      if (!body) continue;  // a model we cannot read: skip the avatar, keep viewing the rest
      auto lods = render::AvatarLods::create(*body, nullptr, renderer, view.method);
      if (!lods) continue;
      if (it == avatars.end()) {
        avatars.emplace_back();
        it = avatars.end() - 1;
        it->name = net::printable(remote.name) + "#" + std::to_string(id);  // a peer's text
        it->remote_id = id;
        it->source = "remote avatar " + std::to_string(id);
      }
      it->lods.emplace(std::move(*lods));
      it->revision = remote.revision;
      it->pose = it->lods->skeleton().rest_pose();
    }
    if (remote.has_pose && remote.pose.dof_rad.size() == it->pose.dof_rad.size()) it->pose = remote.pose;
    it->stale = !remote.has_pose;
    it->status = std::to_string(remote.frames) + " frames, " + std::to_string(remote.lost) + " lost";
  }
  std::erase_if(avatars, [&](const ViewAvatar& a) { return scene.client->avatars().count(a.remote_id) == 0; });
  if (state.first_person >= static_cast<int>(avatars.size())) {
    state.first_person = -1;
    state.camera.first_person_eye.reset();
  }
  // Where the scene comes from (a mimic run, a relay, or a broker's scene through the relay the
  // client runs in this process) and what has come.
  const net::ClientStats& cs = scene.client->stats();
  scene.connection = scene.connect + ": " + std::to_string(cs.frames) + " pose frames" +
                     ((scene.client->negotiated_capabilities() & net::kCapLeanPose) ? " (lean)" : "");
  if (!scene.client->connected()) scene.connection += ", reconnecting (" + scene.last_cut + ")";
  if (cs.cuts > 0) {
    char text[96];
    std::snprintf(text, sizeof text, ", %llu cut(s), %.1f s without frames, %llu lost",
                  static_cast<unsigned long long>(cs.cuts), cs.outage_s, static_cast<unsigned long long>(cs.lost));
    scene.connection += text;
  }
  return {};
}

// Keys 6-0 and P: the camera presets, relative to the avatars.
std::optional<render::CameraPreset> preset_for_key(int key) {
  switch (key) {
    case '6': return render::CameraPreset::kFront;
    case '7': return render::CameraPreset::kLeft;
    case '8': return render::CameraPreset::kBack;
    case '9': return render::CameraPreset::kRight;
    case '0': return render::CameraPreset::kThreeQuarter;
    case 'P': return render::CameraPreset::kTop;
    default: return std::nullopt;
  }
}

void handle_keys(render::Window& window, ViewState& s, size_t avatar_count) {
  const glm::vec3 target_before = s.camera.target;
  const float distance_before = s.camera.distance_m;
  const float yaw_before = s.camera.yaw_rad, pitch_before = s.camera.pitch_rad;
  for (int key : window.begin_frame(s.camera)) {
    if (auto preset = preset_for_key(key)) {
      s.preset = *preset;
      s.reframe = s.follow = s.track_heading = true;
      s.zoom = 1.0f;
      s.first_person = -1;
      s.camera.first_person_eye.reset();
      continue;
    }
    switch (key) {
      case render::kKeyEscape:
      case 'Q': window.request_close(); break;
      case 'H':
      case render::kKeyF1: s.help = !s.help; break;
      case '1': s.overlays ^= render::kOverlaySkeleton; break;
      case '2': s.overlays ^= render::kOverlayPrimitives; break;
      case '3': s.overlays ^= render::kOverlayContours; break;
      case '4': s.overlays ^= render::kOverlayRays; break;
      case '5': s.overlays ^= render::kOverlaySensors; break;
      case '[': s.ray_ring = std::max(0, s.ray_ring - 1); break;
      case ']': ++s.ray_ring; break;
      case 'T': s.see_through = !s.see_through; break;
      case 'G': s.grid = !s.grid; break;
      case 'L': s.lod_mode = s.lod_mode + 1 >= render::kLodCount ? -1 : s.lod_mode + 1; break;
      case 'R':
        s.camera = s.home;
        s.first_person = -1;
        s.camera.first_person_eye.reset();
        s.camera.look_yaw_rad = s.camera.look_pitch_rad = 0.0f;
        s.follow = s.track_heading = true;
        s.zoom = 1.0f;
        break;
      case 'C': s.follow = !s.follow; break;
      case 'F':
        s.first_person = s.first_person + 1 >= static_cast<int>(avatar_count) ? -1 : s.first_person + 1;
        if (s.first_person < 0) s.camera.first_person_eye.reset();
        s.camera.look_yaw_rad = s.camera.look_pitch_rad = 0.0f;  // new eyes look where their head looks
        s.turn_to_others = s.first_person >= 0;
        break;
      default: break;
    }
  }
  if (s.camera.target != target_before) s.follow = false;                                             // the user panned
  if (s.camera.yaw_rad != yaw_before || s.camera.pitch_rad != pitch_before) s.track_heading = false;  // orbited
  if (s.camera.distance_m != distance_before && s.fitted_m > 0.0f && s.first_person < 0)
    s.zoom = s.camera.distance_m / s.fitted_m;  // the wheel
  if (!s.follow) s.follower.reset();
}

// Following: the camera fitted again to where the avatars are now (from the user's angle), and a
// glide there: the floor point through CameraFollow (aimed ahead of a walker), the height and the
// distance with the same time constant when the scene grows and a slower one when it shrinks, so
// a stride's swing does not make the view breathe.
void follow_scene(const ViewOptions& view, float dt_s, const std::vector<ViewAvatar>& avatars, ViewState& s) {
  render::Camera fit = s.camera;
  fit_scene(fit, avatars, float(view.width) / float(view.height), s.panel_right);
  s.fitted_m = fit.distance_m;
  s.follower.update(s.camera, fit.target, dt_s);
  const float k = 1.0f - std::exp(-dt_s / 0.4f);
  const float want_m = fit.distance_m * s.zoom;
  const float k_distance = want_m > s.camera.distance_m ? k : 1.0f - std::exp(-dt_s / 2.0f);
  s.camera.target.y += k * (fit.target.y - s.camera.target.y);
  s.camera.distance_m += k_distance * (want_m - s.camera.distance_m);
  // One avatar: the preset's side of it stays in view as it turns (a slower glide, so a walker's
  // sway does not swing the view).
  if (s.track_heading && avatars.size() == 1 && s.first_person < 0) {
    const float want_yaw = render::preset_yaw_rad(s.preset, scene_heading_rad(avatars));
    s.camera.yaw_rad += (1.0f - std::exp(-dt_s / 0.25f)) * std::remainder(want_yaw - s.camera.yaw_rad, 6.2831853f);
  }
}

// Once the avatars have poses and skins (a few frames in), fit the orbit camera to the whole
// scene, facing the avatars, beside the status panel; then follow them as they move.
void frame_camera(const ViewOptions& view, long frames, float dt_s, std::vector<ViewAvatar>& avatars, ViewState& s) {
  if (s.eyes > 0 && s.first_person < 0 && static_cast<long>(avatars.size()) >= s.eyes) {
    s.first_person = static_cast<int>(s.eyes - 1);
    s.turn_to_others = !s.look_given;
    s.eyes = 0;  // once: F and R take over from here
  }
  if (!s.framed && frames >= 5 && !avatars.empty()) {
    // Avatars of the default row stand in it 1.5 m apart where they are now: a motion that
    // starts away from its own origin (the built-in walk circles 1.2 m from it) would stand in
    // a neighbour otherwise.
    for (ViewAvatar& a : avatars)
      if (a.in_row)
        a.world_from_body =
            glm::translate(glm::mat4(1.0f), glm::vec3(a.row_position_m.x - a.pose.root_position_m.x, 0.0f,
                                                      a.row_position_m.z - a.pose.root_position_m.z));
    const float look_yaw_rad = s.camera.look_yaw_rad, look_pitch_rad = s.camera.look_pitch_rad;
    s.camera = frame_scene(avatars, s.preset, float(view.width) / float(view.height), s.panel_right);
    s.home = s.camera;
    s.camera.look_yaw_rad = look_yaw_rad, s.camera.look_pitch_rad = look_pitch_rad;  // --look, or a drag
    s.fitted_m = s.camera.distance_m;
    s.framed = true;
  } else if (s.framed && s.reframe && !avatars.empty()) {
    s.camera = frame_scene(avatars, s.preset, float(view.width) / float(view.height), s.panel_right);
    s.home = s.camera;
    s.fitted_m = s.camera.distance_m;
    s.reframe = false;
  } else if (s.framed && s.follow && s.first_person < 0 && !avatars.empty()) {
    follow_scene(view, dt_s, avatars, s);
  }
}

// The eyes of an avatar, as a headset shows them (render/first_person.h).
void look_through(const ViewAvatar& a, std::vector<rig::RigidTransform>& joints, render::Camera& camera) {
  joints.resize(a.lods->skeleton().joint_count());
  rig::forward_kinematics(a.lods->skeleton(), a.pose, joints);
  if (auto eyes = render::avatar_eyes(a.lods->skeleton(), joints, a.world_from_body))
    render::look_through(camera, *eyes);
}

// Deforms each avatar at the LOD its distance calls for, gathers the overlays, renders.
void draw_scene(render::Window& window, render::Renderer& renderer, std::vector<ViewAvatar>& avatars, ViewState& s) {
  render::Lines &lines = s.lines, &xray = s.xray;
  std::vector<render::MeshDraw>& draws = s.draws;
  lines.clear();
  xray.clear();
  draws.clear();
  const int fb_w = window.framebuffer_width(), fb_h = window.framebuffer_height();
  for (size_t i = 0; i < avatars.size(); ++i) {
    ViewAvatar& a = avatars[i];
    const float distance_m = glm::length(s.camera.eye() - root_in_world(a));
    a.lod = s.lod_mode >= 0 ? s.lod_mode : render::choose_lod(distance_m, 1.75f, s.camera.fov_y_rad, fb_h, a.lod);
    const auto d0 = std::chrono::steady_clock::now();
    const render::MeshId mesh = a.lods->update(a.lod, a.pose, renderer);
    a.deform_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - d0).count();
    // Through this avatar's eyes: its head (around the eye) is left out, the rest of it shows.
    const bool own = static_cast<int>(i) == s.first_person;
    draws.push_back({mesh, a.world_from_body, s.see_through ? 0.35f : 1.0f,
                     own ? render::parts_hidden_from_own_eyes(a.lods->mesh(a.lod)) : 0});
    if (s.overlays & (render::kOverlayContours | render::kOverlayPrimitives | render::kOverlayRays)) {
      const avatar::ImplicitSkin& skin = a.lods->overlay_skin(a.lod, a.pose);
      if (s.overlays & render::kOverlayContours) render::append_contours(skin, a.world_from_body, lines);
      if (s.overlays & render::kOverlayPrimitives)
        render::append_primitives(skin, a.lods->model(), a.pose, a.world_from_body, s.see_through ? lines : xray);
      if (s.overlays & render::kOverlayRays) render::append_rays(skin, s.ray_ring, a.world_from_body, xray);
    }
    if (s.overlays & render::kOverlaySkeleton)
      render::append_skeleton(a.lods->skeleton(), a.pose, a.world_from_body, xray);
    if (s.overlays & render::kOverlaySensors) render::append_sensors(a.sensors, xray);
    if (own) look_through(a, s.joints, s.camera);
  }
  if (s.turn_to_others && s.framed && s.first_person >= 0 && s.camera.first_person_eye) {
    s.others_m.clear();
    for (size_t i = 0; i < avatars.size(); ++i)
      if (static_cast<int>(i) != s.first_person) s.others_m.push_back(root_in_world(avatars[i]));
    // The middle two thirds of the view's width: someone at its very edge is not "in view".
    const float half_width_rad =
        std::atan(std::tan(0.5f * s.camera.first_person_fov_y_rad) * float(fb_w) / float(std::max(fb_h, 1)));
    s.camera.look_yaw_rad = render::yaw_towards_others(*s.camera.first_person_eye, s.camera.first_person_forward,
                                                       s.others_m, 0.67f * half_width_rad);
    s.turn_to_others = false;
  }
  render::FrameDesc frame;
  frame.width_px = fb_w;
  frame.height_px = fb_h;
  frame.camera = s.camera;
  frame.grid = s.grid;
  frame.unlit = s.unlit;
  frame.ambient_occlusion = s.ambient_occlusion;
  frame.ground = s.grid && s.first_person >= 0;
  frame.meshes = draws;
  frame.lines = lines.vertices;
  frame.xray_lines = xray.vertices;
  renderer.render(frame);
}

// Frame time over the last second (during the first one, over the frames so far: a short run or
// a capture would otherwise show 0 ms and 0 fps).
struct FrameTimes {
  double sum_ms = 0, shown_ms = 0, fps_shown = 0, window_start_s = 0, total_ms = 0;
  int in_window = 0;
  void add(double ms, double now_s) {
    total_ms += ms;
    sum_ms += ms;
    ++in_window;
    const double window_s = now_s - window_start_s;
    if (window_s >= 1.0 || fps_shown == 0) {
      shown_ms = sum_ms / in_window;
      fps_shown = window_s > 0 ? in_window / window_s : 0;
    }
    if (window_s >= 1.0) {
      sum_ms = 0;
      in_window = 0;
      window_start_s = now_s;
    }
  }
};

void draw_panel(const ViewOptions& view, const ViewScene& scene, const FrameTimes& times, ViewState& s) {
  render::HudState hud;
  hud.frame_ms = times.shown_ms;
  hud.fps = times.fps_shown;
  hud.lod_mode = s.lod_mode < 0 ? "auto (by distance)" : "fixed " + std::to_string(s.lod_mode);
  hud.camera = s.first_person >= 0 ? "first person: " + scene.avatars[s.first_person].name
               : s.follow          ? "orbit, following"
                                   : "orbit";
  hud.overlays = overlay_names(s.overlays);
  hud.connection = scene.connection;
  hud.help = s.help || view.help_overlay;
  for (const ViewAvatar& a : scene.avatars)
    hud.avatars.push_back({a.name, a.source, a.status, a.stale, a.lod, a.lods->triangle_count(a.lod), a.deform_ms,
                           glm::length(s.camera.eye() - root_in_world(a))});
  if (view.panel) s.panel_right = render::draw_hud(hud);
}

}  // namespace

int run_interactive(const ViewOptions& view) {
  const long frames_limit = view.frames;
  const std::optional<std::string> capture =
      view.capture.empty() ? std::nullopt : std::optional<std::string>(view.capture);
  ViewState state;
  // The toggles start as the command line set them.
  std::tie(state.overlays, state.lod_mode, state.grid, state.see_through, state.ray_ring) =
      std::tie(view.overlays, view.lod, view.grid, view.see_through, view.ray_ring);
  state.eyes = view.eyes;
  state.look_given = view.look_given;
  auto window = render::Window::open("Mimic", view.width, view.height, view.vsync);
  if (!window) return failure(kName, window.error().message);
  auto renderer = render::Renderer::create();
  if (!renderer) return failure(kName, renderer.error().message);
  ViewScene scene;
  scene.connect = view.connect;
  if (int rc = scene.connect.empty() ? open_local(view, *renderer, scene) : open_remote(view, scene); rc >= 0)
    return rc;

  state.preset = view.camera;
  state.unlit = view.unlit;
  state.ambient_occlusion = view.ambient_occlusion;
  state.camera = render::preset_camera(view.camera, {0, 0, 0}, 1.75f, float(view.width) / float(view.height));
  state.home = state.camera;
  state.camera.look(view.look_yaw_rad, view.look_pitch_rad);
  double last_frame_s = window->time_s();
  FrameTimes times;
  times.window_start_s = window->time_s();
  long frames = 0;
  install_stop_handler();
  while (!window->should_close() && !stop_requested() && (frames_limit < 0 || frames < frames_limit)) {
    const auto t0 = std::chrono::steady_clock::now();
    handle_keys(*window, state, scene.avatars.size());
    const double now_s = window->time_s();
    const float dt_s = static_cast<float>(std::clamp(now_s - last_frame_s, 0.0, 0.25));
    last_frame_s = now_s;
    // New poses: the local pipeline's pass, or what the network brought.
    if (scene.pipeline)
      update_local(scene);
    else if (auto st = update_remote(view, *renderer, scene, state); !st)
      return failure(kName, "connection ended: " + st.error().message);
    frame_camera(view, frames, dt_s, scene.avatars, state);
    draw_scene(*window, *renderer, scene.avatars, state);
    draw_panel(view, scene, times, state);
    window->render_ui();
    ++frames;
    if (capture && frames == frames_limit) {
      if (auto w = render::write_png(window->read(), *capture); !w) return failure(kName, w.error().message);
    }
    window->swap();
    times.add(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count(),
              window->time_s());
  }
  std::printf("view      %ld frames, %.2f ms per frame (mean, work before the buffer swap)\n", frames,
              frames ? times.total_ms / static_cast<double>(frames) : 0.0);
  if (scene.client) std::printf("scene     %s\n", scene.connection.c_str());
  if (!scene.avatars.empty() && state.first_person < 0) {
    // Where the camera looks from, as the angle between the first avatar's facing and the way to
    // the eye (0°: its face; 180°: its back), both along the floor.
    const ViewAvatar& a = scene.avatars.front();
    const float facing_rad = heading_rad(a);
    const glm::vec3 to_eye = state.camera.eye() - root_in_world(a);
    const float eye_rad = std::atan2(to_eye.x, to_eye.z);
    std::printf("camera    %.0f deg from %s's face\n",
                std::abs(std::remainder(eye_rad - facing_rad, 6.2831853f)) * 57.29578f, a.name.c_str());
  }
  for (const ViewAvatar& a : scene.avatars)
    std::printf("avatar    %s: %s; LOD %d, %zu triangles; %s\n", a.name.c_str(), a.source.c_str(), a.lod,
                a.lods->triangle_count(a.lod), a.status.c_str());
  return 0;
}

}  // namespace mimic::app

#endif  // MIMIC_HAVE_RENDER
