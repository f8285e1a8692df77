// `mimic mesh`: one avatar frame as a mesh file (OBJ, binary PLY or glTF .glb).
#include <chrono>
#include <optional>
#include <cstdio>

#include "body_posing.h"
#include "cli.h"
#include "command.h"
#include "mimic/core/file.h"
#include "mimic/avatar/mesh_check.h"
#include "mimic/avatar/mesh_io.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/rigid_mesh_table.h"
#include "mimic/avatar/skin.h"
#include "mimic/avatar/skin_lod.h"
#include "mimic/avatar/texture_layout.h"

namespace mimic::app::cmd_mesh {
namespace {

constexpr const char* kName = "mesh";

constexpr const char* kAbout =
    "Poses the metaball body, samples its skin as cross-section contours (smoothed with cubic\n"
    "B-splines by --method full), stitches the eleven skin pieces into one closed envelope with\n"
    "the rigid head, hands and feet, and writes the mesh: metres, +Y up, the body facing +Z, one group per part.\n"
    "Prints what it did and how long each stage took. The pose: one of --bvh CLIP --frame N,\n"
    "--motion NAME [--time S] or --pose zero|rest.";

struct Options {
  PoseOptions pose;
  std::string out, body, method = "realtime", lod = "0", emit_rigid;
  int subdivision = 1;
  bool no_rigid = false, no_muscles = false, uv = false;
};

std::optional<int> parse(cli::Parser& p, const std::vector<std::string>& argv, Options& o) {
  p->footer("exit status: 0 written, 1 bad input or write failure, 2 usage error");
  add_pose_options(p.app(), o.pose);
  p->add_option("--out", o.out, ".obj, .ply (binary) or .glb (glTF 2.0); written atomically (required)")
      ->type_name("FILE");
  p->add_option("--body", o.body, "body model (JSON, see docs/body-model.md); default: the built-in body")
      ->type_name("FILE");
  p->add_option("--method", o.method,
                "realtime (as run, view and export): contours ray-cast once\n"
                "in the zero posture and moved with their rings (the paper's realtime\n"
                "method, muscles kept; contour points are the vertices); full: every\n"
                "contour ray-cast in the pose and smoothed by B-splines")
      ->check(cli::parsed_by(avatar::parse_skin_method, "realtime|full"));
  p->add_flag("--no-muscles", o.no_muscles, "realtime: the contours keep their measured shape");
  p->add_option("--lod", o.lod,
                "contours per link and points per contour: 0 the body's own (default)\n"
                "to 3 (770 triangles), for the whole body or per piece, e.g.\n"
                "torso=0,neck=1,arms=2,legs=1,rigid=0 (pieces not named: all=N, else 0)")
      ->check(cli::parsed_by(avatar::parse_skin_lods, "N|PIECE=N,..."));
  auto* subdivision = p->add_option("--subdivision", o.subdivision,
                                    "--method full: B-spline samples per contour span (0 = contour\n"
                                    "points are the vertices, no smoothing)")
                          ->check(CLI::Range(0, 16));
  p->add_flag("--no-rigid", o.no_rigid, "leave out the head, hands and feet");
  p->add_flag("--uv", o.uv,
              "texture coordinates per part (u around each contour, v along each\n"
              "piece), the seams split so the file's vertices are not welded there;\n"
              "a .glb gets one material per part (a checker in the part's colour)");
  p->add_option("--emit-rigid-meshes", o.emit_rigid,
                "instead: mesh the body's head, left hand and left foot from their field and\n"
                "write them as the C++ table the program ships (scripts/regen_rigid_meshes.sh)")
      ->type_name("FILE.cpp");
  if (auto exit_code = p.parse(argv)) return exit_code;
  if (o.out.empty() && o.emit_rigid.empty()) return p.usage_error("--out FILE is required");
  if (*avatar::parse_skin_method(o.method) == avatar::SkinMethod::realtime && subdivision->count() > 0)
    return p.usage_error(
        "--subdivision is for --method full (the realtime method, the default, has its contour points as vertices)");
  return std::nullopt;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// `uv`: the texture layout to split the seams with, or null for the welded mesh.
int write_out(const avatar::Mesh& welded, const avatar::TextureLayout* uv, const std::string& out) {
  const avatar::MeshTopology topo = avatar::analyze_topology(welded);
  const avatar::Mesh mesh = uv ? avatar::textured_mesh(welded, *uv) : avatar::Mesh{};
  const avatar::Mesh& written = uv ? mesh : welded;
  std::printf("mesh      %zu vertices, %zu triangles, %zu parts, %zu closed components, volume %.1f dm3, %s\n",
              welded.positions.size(), welded.triangle_count(), welded.parts.size(), topo.components,
              topo.signed_volume * 1e3,
              avatar::is_closed_oriented_manifold(topo) ? "closed oriented manifold" : "NOT CLOSED");
  if (uv)
    std::printf("uv        per-part texture coordinates, %zu vertices with the seams split\n",
                written.positions.size());
  const auto t0 = std::chrono::steady_clock::now();
  if (auto w = avatar::write_mesh(written, out); !w) return failure(kName, w.error().message);
  std::printf("wrote     %-52s %8.2f ms\n", out.c_str(), ms_since(t0));
  return 0;
}

int report_pose_error(const Error& e) {
  return e.code == Errc::invalid_argument ? usage_error(kName, e.message) : failure(kName, e.message);
}

// The realtime method: the shared body (contours ray-cast once, muscle terms), then one frame.
// `body` is already at its LOD (with_skin_lods), so the realtime body takes it as it is (LOD 0).
int realtime_mesh(const Options& args, const avatar::BodyModel& body) {
  auto t0 = std::chrono::steady_clock::now();
  avatar::RealtimeOptions o;
  o.rigid_parts = !args.no_rigid;
  auto shared = avatar::RealtimeBody::create(body, o);
  if (!shared) return failure(kName, shared.error().message);
  std::printf("skin      contours measured once, %4zu muscle points           %8.2f ms\n", (*shared)->muscle_points(),
              ms_since(t0));
  auto request = pose_from(args.pose, (*shared)->skeleton());
  if (!request) return report_pose_error(request.error());
  std::printf("pose      %-52s %8.2f ms\n", request->description.c_str(), request->load_ms);
  avatar::RealtimeSkin skin(*shared);
  avatar::Mesh mesh = (*shared)->rest_mesh();
  skin.evaluate(request->pose, mesh.positions, mesh.normals, !args.no_muscles);
  const avatar::RealtimeTimings& t = skin.timings();
  std::printf("frame     realtime: joints and rings %.3f, contour points %.3f, normals %.3f: total %.3f ms\n",
              t.joints_us / 1e3, t.points_us / 1e3, t.normals_us / 1e3, t.total_us() / 1e3);
  return write_out(mesh, args.uv ? &(*shared)->texture_layout() : nullptr, args.out);
}

// The shipped table of rigid meshes (rigid_mesh_table.h), meshed from the body's field.
int emit_rigid_meshes(const avatar::BodyModel& body, const std::string& path) {
  const auto t0 = std::chrono::steady_clock::now();
  auto source = avatar::rigid_mesh_table(body);
  if (!source) return failure(kName, source.error().message);
  if (auto st = write_file_atomic(path, *source); !st) return failure(kName, st.error().message);
  std::printf("wrote     %-52s %8.2f ms\n", path.c_str(), ms_since(t0));
  return 0;
}

int run_mesh(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  Options args;
  if (auto exit_code = parse(p, argv, args)) return *exit_code;
  const auto lods = avatar::parse_skin_lods(args.lod);
  const auto method = avatar::parse_skin_method(args.method);

  auto t0 = std::chrono::steady_clock::now();
  auto body = body_from_path(args.body);
  if (!body) return failure(kName, body.error().message);
  const double body_ms = ms_since(t0);
  std::printf("body      %-40s %4zu primitives   %8.2f ms\n",
              (args.body.empty() ? "built-in default" : args.body.c_str()), body->primitives.size(), body_ms);
  if (!args.emit_rigid.empty()) return emit_rigid_meshes(*body, args.emit_rigid);
  const avatar::BodyModel at_lod = avatar::with_skin_lods(*body, *lods);
  std::printf("lod       %s\n", avatar::skin_lods_name(*lods).c_str());
  if (*method == avatar::SkinMethod::realtime) return realtime_mesh(args, at_lod);

  t0 = std::chrono::steady_clock::now();
  avatar::SkinOptions options;
  options.subdivision = args.subdivision;
  options.rigid_parts = !args.no_rigid;
  auto skin = avatar::ImplicitSkin::create(at_lod, options);
  if (!skin) return failure(kName, skin.error().message);
  std::printf("skin      topology and rigid parts built                       %8.2f ms\n", ms_since(t0));

  auto request = pose_from(args.pose, skin->skeleton());
  if (!request) return report_pose_error(request.error());
  std::printf("pose      %-52s %8.2f ms\n", request->description.c_str(), request->load_ms);

  skin->evaluate(request->pose);
  const avatar::SkinTimings& t = skin->timings();
  const avatar::SkinStats& st = skin->stats();
  std::printf(
      "frame     FK %.3f, deform %.3f, contours %.3f (%d rings, %d rays, %d missed),\n"
      "          B-spline %.3f, stitch %.3f, normals %.3f: total %.3f ms\n",
      t.fk_us / 1e3, t.deform_us / 1e3, t.contours_us / 1e3, st.contours, st.rays, st.missed_rays, t.bspline_us / 1e3,
      t.stitch_us / 1e3, t.normals_us / 1e3, t.total_us() / 1e3);
  const avatar::TextureLayout layout = args.uv ? avatar::texture_layout(*skin) : avatar::TextureLayout{};
  return write_out(skin->mesh(), args.uv ? &layout : nullptr, args.out);
}

}  // namespace

MIMIC_COMMAND(mesh, kName, "pose the metaball body and write its skin as OBJ, PLY or glTF", run_mesh);

}  // namespace mimic::app::cmd_mesh
