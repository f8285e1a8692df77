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
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "mimic/avatar/body_model.h"
#include "mimic/net/client.h"
#include "mimic/render/avatar_lods.h"
#include "mimic/render/camera.h"
#include "mimic/render/hud.h"
#include "mimic/render/image.h"
#include "mimic/render/overlays.h"
#include "mimic/render/renderer.h"
#include "mimic/render/window.h"
#include "mimic/service/pipeline.h"
#include "body_posing.h"
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

std::vector<std::string> split_sources(const std::string& list) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start <= list.size()) {
    size_t semi = list.find(';', start);
    if (semi == std::string::npos) semi = list.size();
    if (semi > start) out.push_back(list.substr(start, semi - start));
    start = semi + 1;
  }
  return out;
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
};

glm::vec3 root_in_world(const ViewAvatar& a) {
  return glm::vec3(a.world_from_body * glm::vec4(a.pose.root_position_m, 1.0f));
}

// The orbit camera for the scene as it stands: every avatar's skin (as last deformed) inside
// the part of the window the status panel leaves free, seen from `preset` relative to where the
// avatars face on average (front: their faces).
render::Camera frame_scene(const std::vector<ViewAvatar>& avatars, render::CameraPreset preset, float aspect,
                           float panel_right) {
  glm::vec3 lo(1e9f), hi(-1e9f);
  glm::vec2 facing(0.0f);  // sum of unit headings (sin, cos)
  for (const ViewAvatar& a : avatars) {
    if (a.deform_ms <= 0) continue;  // arrived this frame: its skin is not posed yet
    for (const glm::vec3& p : a.lods->mesh(a.lod).positions) {
      const glm::vec3 w = glm::vec3(a.world_from_body * glm::vec4(p, 1.0f));
      lo = glm::min(lo, w);
      hi = glm::max(hi, w);
    }
    const float yaw = render::facing_yaw_rad(glm::quat_cast(glm::mat3(a.world_from_body)) * a.pose.root_orientation);
    facing += glm::vec2(std::sin(yaw), std::cos(yaw));
  }
  if (lo.x > hi.x) lo = glm::vec3(-0.5f, 0.0f, -0.5f), hi = glm::vec3(0.5f, 1.8f, 0.5f);  // nobody posed yet
  lo.y = std::min(lo.y, 0.0f);  // the feet on the floor, whatever the skin's lowest point
  render::Camera c;
  c.yaw_rad = render::preset_yaw_rad(preset, glm::length(facing) > 1e-3f ? std::atan2(facing.x, facing.y) : 0.0f);
  c.pitch_rad = avatars.size() > 1 ? 0.3f : 0.12f;
  // A panel wider than half the window is left out of the reckoning: the scene gets the middle.
  render::fit_box(c, lo, hi, aspect, panel_right < 0.5f ? panel_right + 0.01f : 0.0f, 1.0f);
  return c;
}

std::string overlay_names(unsigned mask) {
  std::string s;
  const char* names[] = {"skeleton", "primitives", "contours", "rays", "sensors"};
  for (int i = 0; i < 5; ++i)
    if (mask & (1u << i)) s += (s.empty() ? "" : ",") + std::string(names[i]);
  return s;
}

}  // namespace

int run_interactive(Args& args, const ViewOptions& view) {
  long frames_limit = -1;
  if (!args.get_int("frames", frames_limit)) return usage_error(kName, args.error());
  const std::optional<std::string> capture = args.get("capture");

  auto window = render::Window::open("Mimic", view.width, view.height, !args.has("no-vsync"));
  if (!window) return failure(kName, window.error().message);
  auto renderer = render::Renderer::create();
  if (!renderer) return failure(kName, renderer.error().message);

  std::vector<ViewAvatar> avatars;
  std::unique_ptr<service::Pipeline> pipeline;
  std::string last_cut;  // before the client: its callback writes here
  std::unique_ptr<net::Client> client;
  std::string connection;
  auto model = body_from_args(args);
  if (!model) return failure(kName, model.error().message);

  if (auto where = args.get("connect")) {
    net::ClientOptions options;
    options.connect = *where;
    options.name = "mimic-view";
    options.lean = !args.has("no-lean");  // ~60 bytes a frame instead of 150: docs/protocol.md
    auto c = net::Client::connect(options);
    if (!c) return failure(kName, "cannot connect to " + *where + ": " + c.error().message);
    client = std::move(*c);
    connection = "connected to " + *where;
    // The client reconnects by itself after any cut; the panel says why it is away meanwhile.
    client->on_cut = [&last_cut](const std::string& why) { last_cut = why; };
  } else {
    pipeline = std::make_unique<service::Pipeline>(service::PipelineOutputs{});
    const auto specs = split_sources(args.get_or("source", "sim:walk"));
    auto body_skeleton = rig::Skeleton::build(model->skeleton);
    if (!body_skeleton) return failure(kName, "body model: " + body_skeleton.error().message);
    for (size_t i = 0; i < specs.size(); ++i) {
      auto feed = service::open_feed(specs[i], args.get_or("calibration", ""), &*body_skeleton);
      if (!feed) return failure(kName, feed.error().what());
      ViewAvatar a;
      a.name = "avatar" + std::to_string(i + 1);
      a.source = specs[i];
      auto lods = render::AvatarLods::create(*model, &(*feed)->skeleton(), *renderer, view.method);
      if (!lods) return failure(kName, "body model does not fit source " + specs[i] + ": " + lods.error().message);
      a.lods.emplace(std::move(*lods));
      a.pose = a.lods->skeleton().rest_pose();
      // Side by side along X, a metre and a half apart, the scene centred on the origin (moved
      // once the poses are known, so each stands in its place: see the framing below).
      const float x_m = (static_cast<float>(i) - 0.5f * static_cast<float>(specs.size() - 1)) * 1.5f;
      a.world_from_body = glm::translate(glm::mat4(1.0f), glm::vec3(x_m, 0.0f, 0.0f));
      if (auto st = pipeline->add_avatar(a.name, std::move(*feed), "", nullptr); !st)
        return failure(kName, st.error().what());
      avatars.push_back(std::move(a));
    }
    connection = "local pipeline, " + std::to_string(avatars.size()) + " avatar(s)";
  }

  render::Camera camera = render::preset_camera(view.camera, {0, 0, 0}, 1.75f,
                                                float(view.width) / float(view.height));
  render::Camera home = camera;
  bool framed = false;  // the camera has been fitted to the scene once its avatars stood somewhere
  float panel_right = 0.0f;           // the status panel's right edge, a fraction of the width
  glm::vec3 follow_offset(0.0f);      // the framed target's offset from the avatars' centre
  // The orbit camera keeps the avatars in view as they walk (the built-in walk leaves the first
  // framing within seconds); panning by hand stops that until R or C.
  bool follow = true;
  double last_frame_s = window->time_s();
  render::CameraFollow follower;
  unsigned overlays = view.overlays;
  int lod_mode = view.lod;  // -1 auto
  bool grid = view.grid, see_through = view.see_through, help = false;
  int ray_ring = view.ray_ring;
  int first_person = -1;  // avatar index, or -1: orbit
  long eyes = 0;          // --eyes K: start looking through avatar K's eyes (once it is there)
  if (!args.get_int("eyes", eyes) || eyes < 0) return usage_error(kName, "--eyes takes an avatar number from 1");
  render::Lines lines, xray;
  std::vector<render::MeshDraw> draws;
  std::vector<rig::RigidTransform> joints;
  double frame_ms_sum = 0, frame_ms_shown = 0, fps_shown = 0, window_start = window->time_s();
  int frames_in_window = 0;
  double total_ms = 0;
  long frames = 0;
  install_stop_handler();

  while (!window->should_close() && !stop_requested() && (frames_limit < 0 || frames < frames_limit)) {
    const auto t0 = std::chrono::steady_clock::now();
    const glm::vec3 target_before = camera.target;
    for (int key : window->begin_frame(camera)) {
      switch (key) {
        case render::kKeyEscape:
        case 'Q': window->request_close(); break;
        case 'H':
        case render::kKeyF1: help = !help; break;
        case '1': overlays ^= render::kOverlaySkeleton; break;
        case '2': overlays ^= render::kOverlayPrimitives; break;
        case '3': overlays ^= render::kOverlayContours; break;
        case '4': overlays ^= render::kOverlayRays; break;
        case '5': overlays ^= render::kOverlaySensors; break;
        case '[': ray_ring = std::max(0, ray_ring - 1); break;
        case ']': ++ray_ring; break;
        case 'T': see_through = !see_through; break;
        case 'G': grid = !grid; break;
        case 'L': lod_mode = lod_mode + 1 >= render::kLodCount ? -1 : lod_mode + 1; break;
        case 'R': camera = home; first_person = -1; camera.first_person_eye.reset(); follow = true; break;
        case 'C': follow = !follow; break;
        case 'F':
          first_person = first_person + 1 >= static_cast<int>(avatars.size()) ? -1 : first_person + 1;
          if (first_person < 0) camera.first_person_eye.reset();
          break;
        default: break;
      }
    }
    if (camera.target != target_before) follow = false;  // the user panned
    if (!follow) follower.reset();
    const double now_s = window->time_s();
    const float dt_s = static_cast<float>(std::clamp(now_s - last_frame_s, 0.0, 0.25));
    last_frame_s = now_s;

    // New poses: the local pipeline's pass, or what the network brought.
    if (pipeline) {
      pipeline->tick();
      for (size_t i = 0; i < avatars.size(); ++i) {
        avatars[i].pose = pipeline->pose(i);
        const devices::DeviceStatus st = pipeline->feed(i).status();
        avatars[i].stale = st.state != devices::DeviceState::streaming;
        avatars[i].status = std::string(state_name(st.state)) + ", " + std::to_string(st.records) + " records";
        // The sensors as the solver last saw them; stale when flagged so or older than 250 ms.
        avatars[i].sensors.clear();
        const double now = std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
        for (const devices::SensorSample& smp : pipeline->feed(i).latest_samples()) {
          const bool stale = (smp.flags & devices::kSampleValid) == 0 || (smp.flags & devices::kSampleStale) != 0 ||
                             now - smp.host_time_s > 0.25;
          avatars[i].sensors.push_back({glm::vec3(avatars[i].world_from_body * glm::vec4(smp.position_m, 1.0f)),
                                        glm::quat_cast(glm::mat3(avatars[i].world_from_body)) * smp.orientation, stale});
        }
      }
    } else {
      if (auto st = client->poll(); !st) return failure(kName, "connection ended: " + st.error().message);
      for (const auto& entry : client->avatars()) {
        const uint16_t id = entry.first;  // not a structured binding: Clang 14 cannot capture those
        const net::RemoteAvatar& remote = entry.second;
        auto it = std::find_if(avatars.begin(), avatars.end(), [&](const ViewAvatar& a) { return a.remote_id == id; });
        if (it == avatars.end() || it->revision != remote.revision) {
          auto body = avatar::body_model_from_json(remote.model_bytes, remote.name);
          if (!body) continue;  // a model we cannot read: skip the avatar, keep viewing the rest
          auto lods = render::AvatarLods::create(*body, nullptr, *renderer, view.method);
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
      // Avatars that left the scene go from the view too.
      std::erase_if(avatars, [&](const ViewAvatar& a) { return client->avatars().count(a.remote_id) == 0; });
      if (first_person >= static_cast<int>(avatars.size())) {
        first_person = -1;
        camera.first_person_eye.reset();
      }
      // Where the scene comes from (a mimic run, a relay, or a broker's scene through the relay
      // the client runs in this process) and what has come.
      const net::ClientStats& cs = client->stats();
      connection = args.get_or("connect", "") + ": " + std::to_string(cs.frames) + " pose frames" +
                   ((client->negotiated_capabilities() & net::kCapLeanPose) ? " (lean)" : "");
      if (!client->connected()) connection += ", reconnecting (" + last_cut + ")";
      if (cs.cuts > 0) {
        char text[96];
        std::snprintf(text, sizeof text, ", %llu cut(s), %.1f s without frames, %llu lost",
                      static_cast<unsigned long long>(cs.cuts), cs.outage_s, static_cast<unsigned long long>(cs.lost));
        connection += text;
      }
    }

    if (eyes > 0 && first_person < 0 && static_cast<long>(avatars.size()) >= eyes) first_person = static_cast<int>(eyes - 1);
    // Once the avatars have poses and skins (a few frames in), fit the orbit camera to the whole
    // scene, facing the avatars, beside the status panel.
    if (!framed && frames >= 5 && !avatars.empty()) {
      // Local avatars stand in a row 1.5 m apart where they are now: a motion that starts away
      // from its own origin (the built-in walk circles 1.2 m from it) would stand in a
      // neighbour otherwise.
      if (pipeline)
        for (size_t i = 0; i < avatars.size(); ++i) {
          const float x_m = (static_cast<float>(i) - 0.5f * static_cast<float>(avatars.size() - 1)) * 1.5f;
          const glm::vec3 root = avatars[i].pose.root_position_m;
          avatars[i].world_from_body = glm::translate(glm::mat4(1.0f), glm::vec3(x_m - root.x, 0.0f, -root.z));
        }
      camera = frame_scene(avatars, view.camera, float(view.width) / float(view.height), panel_right);
      home = camera;
      glm::vec3 centre(0.0f);
      for (const ViewAvatar& a : avatars) centre += root_in_world(a);
      follow_offset = camera.target - centre / static_cast<float>(avatars.size());
      follow_offset.y = 0.0f;
      framed = true;
    } else if (framed && follow && first_person < 0 && !avatars.empty()) {
      glm::vec3 centre(0.0f);
      for (const ViewAvatar& a : avatars) centre += root_in_world(a);
      follower.update(camera, centre / static_cast<float>(avatars.size()) + follow_offset, dt_s);
    }

    // Deform each avatar at the LOD its distance calls for, gather overlays.
    const int fb_w = window->framebuffer_width(), fb_h = window->framebuffer_height();
    lines.clear();
    xray.clear();
    draws.clear();
    for (size_t i = 0; i < avatars.size(); ++i) {
      ViewAvatar& a = avatars[i];
      const glm::vec3 root = glm::vec3(a.world_from_body * glm::vec4(a.pose.root_position_m, 1.0f));
      const float distance_m = glm::length(camera.eye() - root);
      a.lod = lod_mode >= 0 ? lod_mode : render::choose_lod(distance_m, 1.75f, camera.fov_y_rad, fb_h, a.lod);
      const auto d0 = std::chrono::steady_clock::now();
      const render::MeshId mesh = a.lods->update(a.lod, a.pose, *renderer);
      a.deform_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - d0).count();
      draws.push_back({mesh, a.world_from_body, see_through ? 0.35f : 1.0f});
      if (overlays & (render::kOverlayContours | render::kOverlayPrimitives | render::kOverlayRays)) {
        const avatar::BodySkin& skin = a.lods->overlay_skin(a.lod, a.pose);
        if (overlays & render::kOverlayContours) render::append_contours(skin, a.world_from_body, lines);
        if (overlays & render::kOverlayPrimitives)
          render::append_primitives(skin, a.lods->model(), a.pose, a.world_from_body, see_through ? lines : xray);
        if (overlays & render::kOverlayRays) render::append_rays(skin, ray_ring, a.world_from_body, xray);
      }
      if (overlays & render::kOverlaySkeleton) render::append_skeleton(a.lods->skeleton(), a.pose, a.world_from_body, xray);
      if (overlays & render::kOverlaySensors) render::append_sensors(a.sensors, xray);
      if (static_cast<int>(i) == first_person) {
        // The eyes of this avatar: a little in front of its face, looking where its head looks.
        joints.resize(a.lods->skeleton().joint_count());
        rig::forward_kinematics(a.lods->skeleton(), a.pose, joints);
        const int head = a.lods->skeleton().find_joint("head");
        if (head >= 0) {
          const rig::RigidTransform& h = joints[head];
          const glm::vec3 forward = h.apply_vector({0, 0, 1});
          camera.first_person_eye = glm::vec3(a.world_from_body * glm::vec4(h.apply({0, 0.09f, 0.14f}), 1.0f));
          camera.first_person_forward = glm::vec3(a.world_from_body * glm::vec4(forward, 0.0f));
        }
      }
    }

    render::FrameDesc frame;
    frame.width_px = fb_w;
    frame.height_px = fb_h;
    frame.camera = camera;
    frame.grid = grid;
    frame.meshes = draws;
    frame.lines = lines.vertices;
    frame.xray_lines = xray.vertices;
    renderer->render(frame);

    render::HudState hud;
    hud.frame_ms = frame_ms_shown;
    hud.fps = fps_shown;
    hud.lod_mode = lod_mode < 0 ? "auto (by distance)" : "fixed " + std::to_string(lod_mode);
    hud.camera = first_person >= 0 ? "first person: " + avatars[first_person].name : follow ? "orbit, following" : "orbit";
    hud.overlays = overlay_names(overlays);
    hud.connection = connection;
    hud.help = help || args.has("help-overlay");
    for (const ViewAvatar& a : avatars)
      hud.avatars.push_back({a.name, a.source, a.status, a.stale, a.lod, a.lods->triangle_count(a.lod), a.deform_ms,
                             glm::length(camera.eye() - glm::vec3(a.world_from_body * glm::vec4(a.pose.root_position_m, 1.0f)))});
    if (!args.has("no-panel")) panel_right = render::draw_hud(hud);
    window->render_ui();
    ++frames;
    if (capture && frames == frames_limit) {
      if (auto w = render::write_png(window->read(), *capture); !w) return failure(kName, w.error().message);
    }
    window->swap();

    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    total_ms += ms;
    frame_ms_sum += ms;
    ++frames_in_window;
    // Figures over the last second; during the first one, over the frames so far (a short run or
    // a capture would otherwise show 0 ms and 0 fps).
    const double window_s = window->time_s() - window_start;
    if (window_s >= 1.0 || fps_shown == 0) {
      frame_ms_shown = frame_ms_sum / frames_in_window;
      fps_shown = window_s > 0 ? frames_in_window / window_s : 0;
    }
    if (window_s >= 1.0) {
      frame_ms_sum = 0;
      frames_in_window = 0;
      window_start = window->time_s();
    }
  }
  std::printf("view      %ld frames, %.2f ms per frame (mean, work before the buffer swap)\n", frames,
              frames ? total_ms / static_cast<double>(frames) : 0.0);
  if (client) std::printf("scene     %s\n", connection.c_str());
  for (const ViewAvatar& a : avatars)
    std::printf("avatar    %s: %s; LOD %d, %zu triangles; %s\n", a.name.c_str(), a.source.c_str(), a.lod,
                a.lods->triangle_count(a.lod), a.status.c_str());
  return 0;
}

}  // namespace mimic::app

#endif  // MIMIC_HAVE_RENDER
