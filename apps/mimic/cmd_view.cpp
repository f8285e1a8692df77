// `mimic view`: see the avatar. With --screenshot, renders one frame offscreen (EGL, no display
// needed) and writes a PNG; otherwise opens the interactive viewer (view_interactive.cpp).
#if MIMIC_HAVE_RENDER  // built with MIMIC_WITH_VIEWER
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "body_posing.h"
#include "cli.h"
#include "command.h"
#include "mimic/avatar/mesh_io.h"
#include "mimic/core/vertex_normals.h"
#include "mimic/render/avatar_lods.h"
#include "mimic/render/camera.h"
#include "mimic/render/first_person.h"
#include "mimic/render/image.h"
#include "mimic/render/offscreen.h"
#include "mimic/render/overlays.h"
#include "mimic/render/renderer.h"
#include "source_args.h"
#include "view_interactive.h"

namespace mimic::app::cmd_view {
namespace {

constexpr const char* kName = "view";

constexpr const char* kAbout =
    "  mimic view --screenshot OUT.png [pose] [options]   one frame offscreen, as a PNG\n"
    "  mimic view [--source SPEC... | --connect HOST:PORT | --connect nats://HOST:PORT/SCENE]\n"
    "             [options]                              the interactive viewer\n"
    "\n"
    "Draws the deformed body: one skin material, a short-sleeved top and shorts with soft edges,\n"
    "lit by key, fill and rim lights, with a soft contact shadow on a floor grid (1 m squares,\n"
    "the X axis red, the Z axis (where the body faces) blue), and overlays that show\n"
    "the method: the skeleton, the primitives as ellipsoids (muscles coloured by their current\n"
    "f(t), blue at rest to red at full deformation), the contour rings, the rays cast for one\n"
    "ring, and the sensors with their axes (a magenta box when stale).\n"
    "\n"
    "The interactive scene (default: sim:walk, as mimic run: the built-in walk on six simulated\n"
    "trackers) is built as `mimic run` builds it: --source takes any source `mimic run` takes\n"
    "(sim:walk?sensors=11, replay:FILE.mlog, bvh:CLIP, flock:/dev/ttyUSB0?birds=4, vmc:PORT,\n"
    "actor:wander ...; mimic run --help lists them); repeat it for several avatars, or separate\n"
    "specs with ';'. --body, --calibration, --place and --navigate after a --source are its own;\n"
    "--body and --calibration before any --source are every avatar's (and --body poses\n"
    "screenshots).";

constexpr const char* kFooter =
    "examples:\n"
    "  mimic view --screenshot walk.png --motion walk --time 0.4 --camera side --overlay all\n"
    "  mimic view --screenshot eyes.png --pose rest --eyes 1 --look 0,-50   its own body, looking down\n"
    "  mimic view --source sim:walk --source actor:wander --place 2,0\n"
    "  mimic view --connect 127.0.0.1:7777\n"
    "\n"
    "interactive keys: H or F1 help, 1-5 overlays, L cycle LOD (auto, 0..3), T translucent,\n"
    "G grid, F first person through the next avatar's eyes (a drag turns the look), R reset camera\n"
    "(every avatar framed beside the panel, facing them), 6-0 and P camera presets (front, left,\n"
    "back, right, three-quarter, top of the avatar; one avatar is followed as it turns), Esc quit;\n"
    "left drag orbit, right or middle drag pan, wheel zoom.\n"
    "\n"
    "exit status: 0 done, 1 rendering or input failure, 2 usage error";

// What a screenshot shows, beside the drawing options.
struct ShotOptions {
  std::string out;  // --screenshot OUT.png; "": the interactive viewer
  PoseOptions pose;
  bool empty = false;
  std::string body;         // --body before any --source
  std::string compare_obj;  // --compare-obj: a reference mesh drawn beside the body
  double compare_units_per_metre = 10.0;
};

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

// "YAW[,PITCH]" in degrees (left and up positive, |YAW| ≤ 180, |PITCH| ≤ 85) into radians.
bool parse_look(const std::string& text, float& yaw_rad, float& pitch_rad) {
  const size_t comma = text.find(',');
  double yaw = 0, pitch = 0;
  try {
    size_t used = 0;
    const std::string first = text.substr(0, comma);
    yaw = std::stod(first, &used);
    if (used != first.size()) return false;
    if (comma != std::string::npos) {
      const std::string second = text.substr(comma + 1);
      pitch = std::stod(second, &used);
      if (used != second.size()) return false;
    }
  } catch (...) {
    return false;
  }
  if (!(std::abs(yaw) <= 180.0 && std::abs(pitch) <= 85.0)) return false;  // NaN fails too
  constexpr double kRadPerDeg = 3.14159265358979 / 180.0;
  yaw_rad = static_cast<float>(yaw * kRadPerDeg);
  pitch_rad = static_cast<float>(pitch * kRadPerDeg);
  return true;
}

// The reference mesh of --compare-obj beside the body (box lo..hi, facing `facing_yaw_rad`):
// standing on the floor, turned to face where the body faces, just to the body's right as the
// camera sees it (plain grey); the camera then fitted to both.
Result<render::MeshDraw> reference_beside(const ShotOptions& shot, const glm::vec3& lo, const glm::vec3& hi,
                                          float facing_yaw_rad, float aspect, render::Renderer& renderer,
                                          render::Camera& camera) {
  auto mesh = avatar::read_obj(shot.compare_obj, static_cast<float>(1.0 / shot.compare_units_per_metre));
  if (!mesh) return tl::unexpected(mesh.error());
  if (mesh->positions.empty()) return fail(Errc::invalid_argument, shot.compare_obj + ": no vertices");
  mesh->normals.assign(mesh->positions.size(), glm::vec3(0.0f));
  vertex_normals(mesh->positions, mesh->indices, mesh->normals);
  glm::vec3 ref_lo(1e9f), ref_hi(-1e9f);
  for (const glm::vec3& p : mesh->positions) ref_lo = glm::min(ref_lo, p), ref_hi = glm::max(ref_hi, p);
  const glm::vec3 ref_foot(0.5f * (ref_lo.x + ref_hi.x), ref_lo.y, 0.5f * (ref_lo.z + ref_hi.z));
  const glm::mat4 turn = glm::rotate(glm::mat4(1.0f), facing_yaw_rad, glm::vec3(0, 1, 0));
  // The camera's right along the floor, and how far each figure reaches along it.
  const glm::mat4 view = camera.view_from_world();
  const glm::vec3 right = glm::normalize(glm::vec3(view[0][0], 0.0f, view[2][0]));
  const glm::vec3 body_mid(0.5f * (lo.x + hi.x), 0.0f, 0.5f * (lo.z + hi.z));
  float body_reach = 0.0f, ref_reach = 0.0f;
  for (int c = 0; c < 8; ++c) {
    const glm::vec3 b((c & 1) ? hi.x : lo.x, 0.0f, (c & 4) ? hi.z : lo.z);
    const glm::vec3 r((c & 1) ? ref_hi.x : ref_lo.x, 0.0f, (c & 4) ? ref_hi.z : ref_lo.z);
    body_reach = std::max(body_reach, glm::dot(b - body_mid, right));
    ref_reach = std::max(ref_reach, glm::dot(glm::vec3(turn * glm::vec4(r - ref_foot, 0.0f)), -right));
  }
  const glm::vec3 place = body_mid + right * (body_reach + 0.15f + ref_reach);
  render::MeshDraw draw;
  draw.world_from_mesh = glm::translate(glm::mat4(1.0f), place) * turn * glm::translate(glm::mat4(1.0f), -ref_foot);
  draw.mesh = renderer.add_mesh(*mesh);
  glm::vec3 both_lo = glm::min(lo, glm::vec3(0.0f)), both_hi = hi;
  for (int c = 0; c < 8; ++c) {
    const glm::vec3 r((c & 1) ? ref_hi.x : ref_lo.x, (c & 2) ? ref_hi.y : ref_lo.y, (c & 4) ? ref_hi.z : ref_lo.z);
    const glm::vec3 w(draw.world_from_mesh * glm::vec4(r, 1.0f));
    both_lo = glm::min(both_lo, w), both_hi = glm::max(both_hi, w);
  }
  render::fit_box(camera, both_lo, both_hi, aspect);
  std::printf("compare   %s beside the body, %zu triangles\n", shot.compare_obj.c_str(), mesh->triangle_count());
  return draw;
}

int screenshot(const ShotOptions& shot, const ViewOptions& view) {
  const std::string& out = shot.out;
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
  frame.unlit = view.unlit;
  frame.ambient_occlusion = view.ambient_occlusion;
  std::vector<render::MeshDraw> draws;
  render::Lines lines, xray;
  glm::vec3 floor_center(0.0f);
  float height_m = 1.75f;

  if (!shot.empty) {
    auto body = body_from_path(shot.body);
    if (!body) return failure(kName, body.error().message);
    t0 = std::chrono::steady_clock::now();
    auto lods = render::AvatarLods::create(*body, nullptr, *renderer, view.method);
    if (!lods) return failure(kName, lods.error().message);
    std::printf("skin      %d LODs built                                            %8.2f ms\n", lods->count(),
                ms_since(t0));
    auto request = pose_from(shot.pose, lods->skeleton());
    if (!request) {
      const bool usage = request.error().code == Errc::invalid_argument;
      return usage ? usage_error(kName, request.error().message) : failure(kName, request.error().message);
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
    const float facing_rad = render::facing_yaw_rad(request->pose.root_orientation);
    frame.camera = render::preset_camera(view.camera, floor_center, height_m, aspect, facing_rad);
    if (!shot.compare_obj.empty()) {
      auto reference = reference_beside(shot, lo, hi, facing_rad, aspect, *renderer, frame.camera);
      if (!reference) return failure(kName, reference.error().message);
      draws.push_back(*reference);
    }
    if (!view.focus.empty()) {  // a close-up of one part: its vertices' box fills the image
      const avatar::Mesh& m = lods->mesh(probe_lod);
      glm::vec3 plo(1e9f), phi(-1e9f);
      for (const avatar::MeshPart& part : m.parts)
        if (part.name == view.focus)
          for (uint32_t k = 3 * part.first_triangle; k < 3 * (part.first_triangle + part.triangle_count); ++k)
            plo = glm::min(plo, m.positions[m.indices[k]]), phi = glm::max(phi, m.positions[m.indices[k]]);
      if (plo.x > phi.x) return usage_error(kName, "--focus: the mesh has no part '" + view.focus + "'");
      render::fit_box(frame.camera, plo, phi, aspect, 0.0f, 1.0f);
      frame.camera.near_m = 0.01f;
    }
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
    if (view.eyes > 0) {  // through the body's own eyes, its head left out
      std::vector<rig::RigidTransform> joints(static_cast<size_t>(lods->skeleton().joint_count()));
      rig::forward_kinematics(lods->skeleton(), request->pose, joints);
      const auto eyes = render::avatar_eyes(lods->skeleton(), joints, glm::mat4(1.0f));
      if (!eyes) return failure(kName, "--eyes: the body's skeleton has no head");
      render::look_through(frame.camera, *eyes);
      frame.camera.look(view.look_yaw_rad, view.look_pitch_rad);
      draws.back().hidden_parts = render::parts_hidden_from_own_eyes(lods->mesh(lod));
      frame.ground = view.grid;
    }
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

// A check from a parser that says yes or no ("WxH", the overlay list, the camera preset).
template <typename Accepts>
CLI::Validator accepted_by(Accepts accepts, std::string expects, std::string shown) {
  return CLI::Validator(
      [accepts, expects](std::string& input) -> std::string {
        return accepts(input) ? std::string() : expects + ", got '" + input + "'";
      },
      std::move(shown));
}

// The screenshot, its pose (mimic mesh's pose options, the relaxed posture by default) and --set.
CLI::Option* add_shot_options(cli::Parser& p, ShotOptions& shot) {
  const std::string group = "pose, for screenshots (one of)";
  auto* out =
      p->add_option("--screenshot", shot.out, "render one frame offscreen (no display needed) and write it as a PNG")
          ->type_name("OUT.png");
  shot.pose.pose = "rest";
  add_pose_options(p.app(), shot.pose);
  for (const char* name : {"--bvh", "--frame", "--scale", "--motion", "--time", "--pose", "--set"})
    p->get_option(name)->group(group);
  p->get_option("--pose")
      ->description("pose: the T-pose the body is authored in (zero), or the relaxed posture (rest)")
      ->default_str("rest");
  p->add_flag("--empty", shot.empty, "no avatar: the floor alone")->group(group);
  p->add_option("--compare-obj", shot.compare_obj,
                "draw this mesh (OBJ, e.g. a MakeHuman export) beside the body, in grey,\n"
                "standing on the floor and facing where the body faces")
      ->type_name("FILE.obj")
      ->group(group);
  p->add_option("--compare-units-per-metre", shot.compare_units_per_metre,
                "the --compare-obj file's units per metre (default 10: MakeHuman's decimetres)")
      ->check(cli::finite_range(0.001, 10000))
      ->group(group);
  return out;
}

// The local scene's sources (or --connect) and the interactive window's options.
void add_interactive_options(cli::Parser& p, cli::OptionGroups& sources, ViewOptions& view) {
  const std::string group = "interactive";
  CLI::Option* head = sources.head()->group(group);
  sources
      .member("--body",
              "that --source's body model (JSON, docs/body-model.md) or preset:NAME\n"
              "(mimic scale --list); before any --source: every avatar's, and the\n"
              "screenshot's. Default: the built-in body")
      ->type_name("FILE")
      ->group(group);
  sources
      .member("--calibration",
              "that --source's wearer's calibration (mimic calibrate); before any\n"
              "--source: every tracker's")
      ->type_name("FILE")
      ->group(group);
  sources.member("--place", "where it stands (default: side by side along X, 1.5 m apart)")
      ->type_name("X,Z[,DEG]")
      ->group(group);
  sources
      .member("--navigate",
              "move it with a 6-DOF device: spaceball:PATH, magellan:PATH,\n"
              "spacemouse[:sim] (?speed=M/S&turn=RAD/S&dead=ZONE)")
      ->type_name("SPEC")
      ->group(group);
  p->add_option_function<std::string>(
       "--room", [&view](const std::string& text) { service::parse_room(text, view.room); },
       "the room's size in metres (default 8x8; actors stay inside)")
      ->check(accepted_by(
          [](const std::string& t) {
            service::Room r;
            return service::parse_room(t, r);
          },
          "must be WxD in metres (2..100 each)", "WxD"))
      ->group(group);
  p->add_option("--connect", view.connect,
                "view the scene a `mimic run` (or `mimic relay`) serves: body models once,\n"
                "then pose frames, every avatar deformed here.\n"
                "nats://HOST:PORT[,nats://...]/SCENE: a scene published through a NATS\n"
                "broker (mimic run --nats), taken from it by a relay inside this process\n"
                "(credentials from MIMIC_NATS_USER + MIMIC_NATS_PASSWORD, or\n"
                "MIMIC_NATS_TOKEN); avatars appear as their models arrive, also if the\n"
                "broker comes up later")
      ->type_name("HOST:PORT")
      ->excludes(head)
      ->group(group);
  p->add_flag_function(
       "--no-lean", [&view](std::int64_t) { view.lean = false; },
       "with --connect: POSE frames instead of the lean pose stream asked for by\n"
       "default (key and delta frames at the server's precision)")
      ->group(group);
  p->add_option("--frames", view.frames, "quit after N frames (and print the mean frame time)")
      ->default_str("")
      ->check(CLI::NonNegativeNumber)
      ->group(group);
  p->add_option("--capture", view.capture, "save the window's last frame (with --frames)")
      ->type_name("FILE.png")
      ->group(group);
  p->add_flag_function(
       "--no-vsync", [&view](std::int64_t) { view.vsync = false; }, "do not wait for the display's refresh")
      ->group(group);
  p->add_flag("--help-overlay", view.help_overlay, "start with the help overlay shown")->group(group);
  p->add_flag_function(
       "--no-panel", [&view](std::int64_t) { view.panel = false; }, "no status panel (clean captures)")
      ->group(group);
  p->add_option("--eyes", view.eyes,
                "first person: through avatar K's eyes (from 1; a screenshot's body is 1),\n"
                "its head not drawn, a headset's field of view")
      ->type_name("K")
      ->default_str("")
      ->check(CLI::NonNegativeNumber)
      ->group(group);
  p->add_option_function<std::string>(
       "--look",
       [&view](const std::string& text) { view.look_given = parse_look(text, view.look_yaw_rad, view.look_pitch_rad); },
       "with --eyes: the look turned YAW degrees left (negative: right) and PITCH up\n"
       "from where the head looks, as a drag in the window turns it")
      ->check(accepted_by(
          [](const std::string& t) {
            float yaw = 0, pitch = 0;
            return parse_look(t, yaw, pitch);
          },
          "must be YAW[,PITCH] in degrees (|YAW| <= 180, |PITCH| <= 85)", "YAW[,PITCH]"))
      ->needs(p->get_option("--eyes"))
      ->group(group);
}

// How either mode draws.
void add_drawing_options(cli::Parser& p, ViewOptions& view) {
  p->add_option_function<std::string>(
       "--camera", [&view](const std::string& name) { view.camera = *render::parse_camera_preset(name); },
       "where from, relative to where the avatar faces: front (its face, the\n"
       "default), back, left (or side), right, three-quarter (front left), top")
      ->check(accepted_by([](const std::string& t) { return render::parse_camera_preset(t).has_value(); },
                          "must be front, back, left, right, side, three-quarter or top", "NAME"));
  p->add_option_function<std::string>(
       "--size", [&view](const std::string& text) { parse_size(text, view.width, view.height); },
       "image or window size in pixels (default 640x720, window 960x720)")
      ->check(accepted_by(
          [](const std::string& t) {
            int w = 0, h = 0;
            return parse_size(t, w, h);
          },
          "must be WxH, 16..8192 each", "WxH"));
  p->add_option("--lod", view.lod, "skin level of detail, 0 (finest) .. 3; default: by distance")
      ->default_str("")
      ->check(CLI::Range(0, render::kLodCount - 1));
  p->add_option_function<std::string>(
       "--overlay", [&view](const std::string& list) { render::parse_overlays(list, view.overlays); },
       "skeleton,primitives,contours,rays,sensors | all | none (default none)")
      ->check(accepted_by(
          [](const std::string& t) {
            unsigned m = 0;
            return render::parse_overlays(t, m);
          },
          "takes skeleton,primitives,contours,rays,sensors, all or none", "LIST"));
  p->add_option("--ray-ring", view.ray_ring, "the ring whose rays the rays overlay shows")
      ->check(CLI::Range(0, 100000));
  p->add_flag("--see-through", view.see_through, "draw the body translucent (to see overlays inside it)");
  p->add_option_function<std::string>(
       "--shading", [&view](const std::string& mode) { view.unlit = mode == "albedo"; },
       "lit (default): key, fill and rim lights; albedo: the materials' colours alone")
      ->check(CLI::IsMember({"lit", "albedo"}));
  p->add_flag_function(
      "--no-ao", [&view](std::int64_t) { view.ambient_occlusion = false; },
      "without the screen-space ambient occlusion (for comparison, or a slow GPU)");
  p->add_option_function<std::string>(
       "--method", [&view](const std::string& name) { view.method = *avatar::parse_skin_method(name); },
       "realtime (default): contours measured once and moved with the joints,\n"
       "muscles kept; full: every contour ray-cast and smoothed each frame")
      ->check(cli::parsed_by(avatar::parse_skin_method, "realtime|full"));
  p->add_option_function<double>(
       "--frame-height", [&view](const double& m) { view.frame_height_m = static_cast<float>(m); },
       "screenshots: frame M metres of height around the origin instead of fitting\n"
       "the body, so bodies of different sizes share one scale")
      ->type_name("M")
      ->check(cli::finite_range(0.5, 20));
  p->add_option("--focus", view.focus,
                "screenshots: frame one part of the mesh close up (head, left_hand, right_hand,\n"
                "left_foot, right_foot, or any skin piece)")
      ->type_name("PART");
  p->add_flag_function(
      "--no-grid", [&view](std::int64_t) { view.grid = false; }, "leave out the floor grid");
}

int run_view(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  p->footer(kFooter);
  ViewOptions view;
  ShotOptions shot;
  CLI::Option* screenshot_option = add_shot_options(p, shot);
  cli::OptionGroups sources(p.app(), "--source",
                            "any source `mimic run` takes; repeat for several avatars (or separate\n"
                            "specs with ';'). The options after it are its own",
                            "sim:walk");
  add_interactive_options(p, sources, view);
  add_drawing_options(p, view);
  screenshot_option->excludes(sources.head())->excludes(p->get_option("--connect"));
  if (auto exit_code = p.parse(argv)) return *exit_code;
  service::SourceEntry defaults;
  if (std::string e = sources_from_groups(sources.groups(), {.leading_defaults = true, .split_lists = true},
                                          view.sources, defaults);
      !e.empty())
    return p.usage_error(e);
  shot.body = defaults.body;
  if (!shot.out.empty()) {
    // --place or --navigate before any --source make a source too: not for a screenshot.
    if (!view.sources.empty())
      return p.usage_error(
          "--screenshot draws a posed body: give --bvh, --motion or --pose, not --source or --connect");
    if (view.eyes > 1) return p.usage_error("--eyes " + std::to_string(view.eyes) + ": a screenshot has one body, 1");
    if (view.eyes > 0 && shot.empty) return p.usage_error("--eyes: --empty has no body to look through");
    return screenshot(shot, view);
  }
  if (!view.sources.empty() && !view.connect.empty()) return p.usage_error("give --source or --connect, not both");
  if (view.sources.empty() && view.connect.empty()) {
    view.sources.emplace_back();  // sim:walk
    view.sources.back().body = defaults.body;
    view.sources.back().calibration = defaults.calibration;
  }
  // A window is wider than a portrait screenshot: room for the status panel beside the body.
  if (p->count("--size") == 0) view.width = 960;
  return run_interactive(view);
}

}  // namespace

MIMIC_COMMAND(view, kName, "see the avatar: the interactive viewer, or a PNG screenshot rendered offscreen", run_view);

}  // namespace mimic::app::cmd_view

#endif  // MIMIC_HAVE_RENDER
