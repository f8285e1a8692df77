// `mimic view`: see the avatar. With --screenshot, renders one frame offscreen (EGL, no display
// needed) and writes a PNG; otherwise opens the interactive viewer (view_interactive.cpp).
#if MIMIC_HAVE_RENDER  // built with MIMIC_WITH_VIEWER
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "body_posing.h"
#include "command.h"
#include "mimic/render/avatar_lods.h"
#include "mimic/render/camera.h"
#include "mimic/render/image.h"
#include "mimic/render/offscreen.h"
#include "mimic/render/overlays.h"
#include "mimic/render/renderer.h"
#include "source_args.h"
#include "view_interactive.h"

namespace mimic::app::cmd_view {
namespace {

constexpr const char* kName = "view";

constexpr const char* kUsage =
    "usage: mimic view --screenshot OUT.png [pose] [options]   one frame offscreen, as a PNG\n"
    "       mimic view [--source SPEC | --connect HOST:PORT | --connect nats://HOST:PORT/SCENE] [options]\n"
    "                                                              the interactive viewer\n"
    "\n"
    "Draws the deformed body: smooth shading with one colour per skin piece, a floor grid (1 m\n"
    "squares, the X axis red, the Z axis — where the body faces — blue), and overlays that show\n"
    "the method: the skeleton, the primitives as ellipsoids (muscles coloured by their current\n"
    "f(t), blue at rest to red at full deformation), the contour rings, the rays cast for one\n"
    "ring, and the sensors with their axes (a magenta box when stale).\n"
    "\n"
    "pose, for screenshots (one of):\n"
    "  --bvh CLIP --frame N  frame N of a BVH clip, retargeted onto the body (--scale M per unit)\n"
    "  --motion NAME         a built-in motion: idle or walk ...\n"
    "  --time S              ... at S seconds (default 0)\n"
    "  --pose zero|rest      the T-pose or the relaxed posture (default rest)\n"
    "  --set DOF=RAD,...     then set these joint DOFs (radians), e.g. l_shoulder_abduction=2.5\n"
    "  --empty               no avatar: the floor alone\n"
    "\n"
    "interactive sources (default: sim:walk, as mimic run: the built-in walk on six simulated\n"
    "trackers); the scene is built as `mimic run` builds it:\n"
    "  --source SPEC         any source `mimic run` takes: sim:walk?sensors=11, replay:FILE.mlog,\n"
    "                        bvh:CLIP, flock:/dev/ttyUSB0?birds=4, vmc:PORT, actor:wander ...;\n"
    "                        repeat for several avatars (or separate specs with ';'). After a\n"
    "                        --source, these options are its own:\n"
    "    --body FILE         its body model (before any --source: every avatar's)\n"
    "    --calibration FILE  its wearer's calibration (mimic calibrate; before any --source:\n"
    "                        every tracker's)\n"
    "    --place X,Z[,DEG]   where it stands (default: side by side along X, 1.5 m apart)\n"
    "    --navigate SPEC     move it with a 6-DOF device: spaceball:PATH, magellan:PATH,\n"
    "                        spacemouse[:sim] (?speed=M/S&turn=RAD/S&dead=ZONE)\n"
    "  --room WxD            the room's size in metres (default 8x8; actors stay inside)\n"
    "  --connect HOST:PORT   view the scene a `mimic run` (or `mimic relay`) serves: body models\n"
    "                        once, then pose frames, every avatar deformed here\n"
    "  --connect nats://HOST:PORT[,nats://HOST:PORT...]/SCENE\n"
    "                        view a scene published through a NATS broker (mimic run --nats):\n"
    "                        a relay inside this process takes it from the broker (credentials\n"
    "                        from MIMIC_NATS_USER + MIMIC_NATS_PASSWORD, or MIMIC_NATS_TOKEN);\n"
    "                        avatars appear as their models arrive, also if the broker comes\n"
    "                        up later\n"
    "  --no-lean             with --connect: POSE frames instead of the lean pose stream asked\n"
    "                        for by default (key and delta frames at the server's precision)\n"
    "\n"
    "options:\n"
    "  --camera NAME         where from, relative to where the avatar faces: front (its face,\n"
    "                        the default), side (its left), back, three-quarter (front left)\n"
    "  --size WxH            image or window size in pixels (default 640x720, window 960x720)\n"
    "  --lod N               skin level of detail, 0 (finest) .. 3; default: by distance\n"
    "  --overlay LIST        skeleton,primitives,contours,rays,sensors | all | none (default none)\n"
    "  --ray-ring N          the ring whose rays the rays overlay shows (default 40)\n"
    "  --body FILE           body model (JSON, docs/body-model.md) or preset:NAME (mimic scale\n"
    "                        --list); default: the built-in body\n"
    "  --see-through         draw the body translucent (to see overlays inside it)\n"
    "  --method M            realtime (default): contours measured once and moved with the joints,\n"
    "                        muscles kept; full: every contour ray-cast and smoothed each frame\n"
    "  --frame-height M      screenshots: frame M metres of height around the origin instead of\n"
    "                        fitting the body, so bodies of different sizes share one scale\n"
    "  --no-grid             leave out the floor grid\n"
    "  --frames N            interactive: quit after N frames (and print the mean frame time)\n"
    "  --capture FILE.png    interactive: save the window's last frame (with --frames)\n"
    "  --no-vsync            interactive: do not wait for the display's refresh\n"
    "  --help-overlay        interactive: start with the help overlay shown\n"
    "  --no-panel            interactive: no status panel (clean captures)\n"
    "  --eyes K              interactive: start in first person, at avatar K's head (from 1)\n"
    "  -h, --help            this text\n"
    "\n"
    "interactive keys: H or F1 help, 1-5 overlays, L cycle LOD (auto, 0..3), T translucent,\n"
    "G grid, F first-person at the next avatar's head, R reset camera (every avatar framed beside\n"
    "the panel, facing them), Esc quit; left drag orbit, right or middle drag pan, wheel zoom.\n"
    "\n"
    "exit status: 0 done, 1 rendering or input failure, 2 usage error\n";

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

bool parse_size(const std::string& text, int& w, int& h) {
  const size_t x = text.find('x');
  if (x == std::string::npos) return false;
  try {
    size_t used = 0;
    w = std::stoi(text.substr(0, x), &used);
    if (used != x) return false;
    h = std::stoi(text.substr(x + 1), &used);
    if (used != text.size() - x - 1) return false;
  } catch (...) {
    return false;
  }
  return w >= 16 && h >= 16 && w <= 8192 && h <= 8192;
}

// "l_shoulder_abduction=2.5,r_elbow_flexion=1" onto the pose; errors name the DOF.
Status apply_dof_settings(const std::string& list, const rig::Skeleton& skeleton, rig::Pose& pose) {
  size_t start = 0;
  while (start < list.size()) {
    size_t comma = list.find(',', start);
    if (comma == std::string::npos) comma = list.size();
    const std::string item = list.substr(start, comma - start);
    const size_t eq = item.find('=');
    if (eq == std::string::npos) return fail(Errc::invalid_argument, "--set wants DOF=RADIANS, got '" + item + "'");
    const std::string name = item.substr(0, eq);
    const int dof = skeleton.find_dof(name);
    if (dof < 0) return fail(Errc::invalid_argument, "--set: the skeleton has no DOF '" + name + "'");
    try {
      pose.dof_rad[dof] = std::stof(item.substr(eq + 1));
    } catch (...) {
      return fail(Errc::invalid_argument, "--set: '" + item.substr(eq + 1) + "' is not a number");
    }
    start = comma + 1;
  }
  return {};
}

int screenshot(Args& args, const ViewOptions& view) {
  const std::string out = *args.get("screenshot");
  auto t0 = std::chrono::steady_clock::now();
  auto context = render::OffscreenContext::create(view.width, view.height);
  if (!context) return failure(kName, context.error().message);
  auto renderer = render::Renderer::create();
  if (!renderer) return failure(kName, renderer.error().message);
  std::printf("context   %-52s %8.2f ms\n", context->describe(), ms_since(t0));

  const float aspect = static_cast<float>(view.width) / static_cast<float>(view.height);
  render::FrameDesc frame;
  frame.width_px = view.width;
  frame.height_px = view.height;
  frame.grid = view.grid;
  std::vector<render::MeshDraw> draws;
  render::Lines lines, xray;
  glm::vec3 floor_center(0.0f);
  float height_m = 1.75f;

  if (!args.has("empty")) {
    auto body = body_from_args(args);
    if (!body) return failure(kName, body.error().message);
    t0 = std::chrono::steady_clock::now();
    auto lods = render::AvatarLods::create(*body, nullptr, *renderer, view.method);
    if (!lods) return failure(kName, lods.error().message);
    std::printf("skin      %d LODs built                                            %8.2f ms\n", lods->count(),
                ms_since(t0));
    auto request = pose_from_args(args, lods->skeleton());
    if (!request) {
      const bool usage = request.error().code == Errc::invalid_argument;
      return usage ? usage_error(kName, request.error().message) : failure(kName, request.error().message);
    }
    if (!args.has("bvh") && !args.has("motion") && !args.has("pose")) {
      request->pose = avatar::relaxed_posture(lods->skeleton());
      request->pose.root_position_m.y = rig::standing_root_height_m(lods->skeleton());
      request->description = "rest posture";
    }
    if (auto set = args.get("set")) {
      if (auto s = apply_dof_settings(*set, lods->skeleton(), request->pose); !s)
        return usage_error(kName, s.error().message);
    }
    // Frame the body as posed: centred on its footprint, its height fitted.
    const int probe_lod = view.lod >= 0 ? view.lod : 0;
    lods->update(probe_lod, request->pose, *renderer);
    glm::vec3 lo(1e9f), hi(-1e9f);
    for (const glm::vec3& p : lods->mesh(probe_lod).positions) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    floor_center = {0.5f * (lo.x + hi.x), 0.0f, 0.5f * (lo.z + hi.z)};
    height_m = std::max(hi.y, 0.5f);
    if (view.frame_height_m > 0) {  // one scale for every body: a fixed frame about the origin
      floor_center = glm::vec3(0.0f);
      height_m = view.frame_height_m;
    }
    // Presets are relative to the avatar: front faces its face wherever the pose turned it.
    frame.camera = render::preset_camera(view.camera, floor_center, height_m, aspect,
                                         render::facing_yaw_rad(request->pose.root_orientation));
    const int lod = view.lod >= 0
                        ? view.lod
                        : render::choose_lod(frame.camera.distance_m, height_m, frame.camera.fov_y_rad, view.height);
    t0 = std::chrono::steady_clock::now();
    const render::MeshId mesh = lods->update(lod, request->pose, *renderer);
    const double deform_ms = ms_since(t0);
    draws.push_back({mesh, glm::mat4(1.0f), view.see_through ? 0.35f : 1.0f});
    std::printf("pose      %-52s %8.2f ms\n", request->description.c_str(), request->load_ms);
    std::printf("frame     LOD %d, %zu triangles, deformed in %.3f ms\n", lod, lods->triangle_count(lod), deform_ms);
    if (view.overlays & (render::kOverlayContours | render::kOverlayPrimitives | render::kOverlayRays)) {
      const avatar::ImplicitSkin& skin = lods->overlay_skin(lod, request->pose);
      if (view.overlays & render::kOverlayContours) render::append_contours(skin, glm::mat4(1.0f), lines);
      if (view.overlays & render::kOverlayPrimitives)
        render::append_primitives(skin, lods->model(), request->pose, glm::mat4(1.0f), view.see_through ? lines : xray);
      if (view.overlays & render::kOverlayRays) render::append_rays(skin, view.ray_ring, glm::mat4(1.0f), xray);
    }
    if (view.overlays & render::kOverlaySkeleton)
      render::append_skeleton(lods->skeleton(), request->pose, glm::mat4(1.0f), xray);
  } else {
    frame.camera = render::preset_camera(view.camera, floor_center, height_m, aspect);
    std::printf("scene     empty\n");
  }

  frame.meshes = draws;
  frame.lines = lines.vertices;
  frame.xray_lines = xray.vertices;
  t0 = std::chrono::steady_clock::now();
  renderer->render(frame);
  const render::Image image = context->read();
  const double render_ms = ms_since(t0);
  if (auto w = render::write_png(image, out); !w) return failure(kName, w.error().message);
  std::printf("wrote     %-40s %dx%d, rendered in %8.2f ms\n", out.c_str(), view.width, view.height, render_ms);
  return 0;
}

int run_view(const std::vector<std::string>& argv) {
  // The --source groups first (as mimic run takes them); --body and --calibration before any
  // --source stay here, for every avatar (and --body for screenshots).
  std::vector<std::string> rest = argv;
  ViewOptions view;
  std::string error;
  if (!take_sources(rest, view.sources, error, {.leading_defaults = true, .split_lists = true}))
    return usage_error(kName, error);
  Args args(rest, {"screenshot", "bvh",     "frame", "scale",        "motion",   "time", "pose",        "set",
                   "camera",     "size",    "lod",   "overlay",      "ray-ring", "body", "calibration", "connect",
                   "frames",     "capture", "eyes",  "frame-height", "method",   "room"},
            {"empty", "no-grid", "see-through", "no-vsync", "help-overlay", "no-panel", "no-lean"});
  if (args.help()) {
    std::printf("%s", kUsage);
    return 0;
  }
  if (!args.ok()) return usage_error(kName, args.error());
  if (!args.positionals().empty()) return usage_error(kName, "unexpected argument '" + args.positionals()[0] + "'");
  for (service::SourceEntry& e : view.sources) {
    if (e.body.empty()) e.body = args.get_or("body", "");
    if (e.calibration.empty()) e.calibration = args.get_or("calibration", "");
  }
  if (auto r = args.get("room"); r && !service::parse_room(*r, view.room))
    return usage_error(kName, "--room must be WxD in metres (2..100 each), got '" + *r + "'");
  if (auto cam = args.get("camera")) {
    auto preset = render::parse_camera_preset(*cam);
    if (!preset) return usage_error(kName, "--camera must be front, side, back or three-quarter, got '" + *cam + "'");
    view.camera = *preset;
  }
  if (auto size = args.get("size"); size && !parse_size(*size, view.width, view.height))
    return usage_error(kName, "--size must be WxH, 16..8192 each, got '" + *size + "'");
  long lod = -1, ring = view.ray_ring;
  if (!args.get_int("lod", lod) || !args.get_int("ray-ring", ring)) return usage_error(kName, args.error());
  if (args.has("lod") && (lod < 0 || lod >= render::kLodCount))
    return usage_error(kName, "--lod must be in 0.." + std::to_string(render::kLodCount - 1));
  if (ring < 0 || ring > 100000) return usage_error(kName, "--ray-ring must be a ring number from 0");
  view.lod = static_cast<int>(lod);
  view.ray_ring = static_cast<int>(ring);
  if (auto list = args.get("overlay"); list && !render::parse_overlays(*list, view.overlays))
    return usage_error(kName,
                       "--overlay takes skeleton,primitives,contours,rays,sensors, all or none; got '" + *list + "'");
  view.grid = !args.has("no-grid");
  view.see_through = args.has("see-through");
  double frame_height_m = 0;
  if (!args.get_double("frame-height", frame_height_m)) return usage_error(kName, args.error());
  if (args.has("frame-height") && !(frame_height_m >= 0.5 && frame_height_m <= 20))
    return usage_error(kName, "--frame-height must be 0.5..20 metres");
  view.frame_height_m = static_cast<float>(frame_height_m);
  if (auto method = args.get("method")) {
    auto m = avatar::parse_skin_method(*method);
    if (!m) return usage_error(kName, "--method: " + m.error().message);
    view.method = *m;
  }

  if (args.has("screenshot")) {
    if (!view.sources.empty() || args.has("connect"))
      return usage_error(kName,
                         "--screenshot draws a posed body: give --bvh, --motion or --pose, not --source or --connect");
    return screenshot(args, view);
  }
  if (!view.sources.empty() && args.has("connect")) return usage_error(kName, "give --source or --connect, not both");
  if (view.sources.empty() && !args.has("connect")) {
    view.sources.emplace_back();  // sim:walk
    view.sources.back().body = args.get_or("body", "");
    view.sources.back().calibration = args.get_or("calibration", "");
  }
  // A window is wider than a portrait screenshot: room for the status panel beside the body.
  if (!args.has("size")) view.width = 960;
  return run_interactive(args, view);
}

}  // namespace

MIMIC_COMMAND(view, kName, "see the avatar: the interactive viewer, or a PNG screenshot rendered offscreen", run_view);

}  // namespace mimic::app::cmd_view

#endif  // MIMIC_HAVE_RENDER
