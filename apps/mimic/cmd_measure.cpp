// mimic measure: body measurements (height, tape girths, volume, area) of a mesh file.
#include <cmath>
#include <cstdio>
#include <string>

#include <nlohmann/json.hpp>

#include "cli.h"
#include "command.h"
#include "mimic/avatar/measure.h"
#include "mimic/avatar/mesh_check.h"
#include "mimic/avatar/mesh_io.h"

namespace mimic::app::cmd_measure {
namespace {

constexpr const char* kName = "measure";
constexpr const char* kAbout =
    "Measures a standing body mesh as a tailor would: standing height, tape-measure girths\n"
    "(chest, waist, hips, left thigh, left calf, left upper arm), enclosed volume and surface\n"
    "area. A girth is the convex-hull perimeter of the cross-section loop around the torso or\n"
    "limb axis, so arms beside the torso are not wrapped in (docs/measurements.md).";

int run_measure(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  p->footer(
      "Frames: +Y up, the body faces +Z, its left is +X. Shared data: $MIMIC_SHARED_DATA or\n"
      "../shared/data beside the checkout. Exit status: 0 measured, 1 unreadable input,\n"
      "2 bad usage.");
  std::string mesh_path, joints_path;
  double units_per_metre = 10.0;
  bool json = false;
  p->add_option("--obj", mesh_path,
                "mesh to measure: .obj, .ply or .glb (default: the shared MakeHuman\n"
                "base mesh, <shared data>/mesh/makehuman_base_body.obj)")
      ->type_name("FILE");
  p->add_option("--joints", joints_path,
                "joint centres, rows name,x,y,z with MakeHuman joint names (pelvis,\n"
                "spine-1..4, neck, head, head-2, ground, l-/r-upper-leg, -knee,\n"
                "-ankle, -shoulder, -elbow, -hand), in the mesh's units (default:\n"
                "<shared data>/mesh/makehuman_base_joints.csv for the default mesh;\n"
                "for another mesh without --joints they are estimated from average\n"
                "proportions, and the upper-arm girth is left out)")
      ->type_name("CSV");
  p->add_option("--units-per-metre", units_per_metre,
                "mesh and joint units per metre (10: MakeHuman decimetres;\n1 for meshes written by Mimic)")
      ->check(cli::finite_range(0, INFINITY, cli::Bound::exclusive));
  p->add_flag("--json", json, "print JSON instead of a table");
  if (auto exit_code = p.parse(argv)) return *exit_code;
  // The shared mesh comes with its joints; another mesh without them gets estimated ones.
  const std::string data = shared_data_dir();
  if (mesh_path.empty()) {
    mesh_path = data + "/mesh/makehuman_base_body.obj";
    if (joints_path.empty()) joints_path = data + "/mesh/makehuman_base_joints.csv";
  }

  const auto metres_per_unit = static_cast<float>(1.0 / units_per_metre);
  auto mesh = avatar::read_mesh(mesh_path, metres_per_unit);
  if (!mesh) return failure(kName, mesh.error().what());
  avatar::BodyLandmarks landmarks;
  if (joints_path.empty()) {
    landmarks = avatar::estimate_landmarks(*mesh);
  } else {
    auto loaded = avatar::load_makehuman_joints(joints_path, metres_per_unit);
    if (!loaded) return failure(kName, loaded.error().what());
    landmarks = std::move(*loaded);
  }

  const avatar::BodyMeasurements m = avatar::measure_body(*mesh, landmarks);
  const avatar::MeshTopology topo = avatar::analyze_topology(*mesh);
  const bool closed = avatar::is_closed_oriented_manifold(topo);

  if (json) {
    auto j = nlohmann::ordered_json::parse(avatar::measurements_json(m));
    nlohmann::ordered_json out;
    out["mesh"] = mesh_path;
    out["joints"] = joints_path.empty() ? nlohmann::ordered_json("estimated") : nlohmann::ordered_json(joints_path);
    out["units_per_metre"] = units_per_metre;
    out["vertices"] = topo.vertex_count;
    out["triangles"] = topo.face_count;
    out["closed_oriented_manifold"] = closed;
    out["genus"] = topo.genus;
    out["measurements"] = j;
    std::printf("%s\n", out.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace).c_str());
    return 0;
  }
  std::printf("mesh:   %s\njoints: %s\n", mesh_path.c_str(),
              joints_path.empty() ? "estimated from the mesh (no --joints; arms not located, no upper-arm girth)"
                                  : joints_path.c_str());
  std::printf("surface: %zu vertices, %zu triangles, %s, genus %d\n\n", topo.vertex_count, topo.face_count,
              closed ? "closed oriented manifold" : "NOT a closed oriented manifold", topo.genus);
  std::fputs(avatar::format_measurements(m).c_str(), stdout);
  if (!closed) std::printf("note: the volume of an open or non-manifold surface is not meaningful\n");
  return 0;
}

}  // namespace

MIMIC_COMMAND(measure, kName, "measure a body mesh: height, tape girths, volume, area", run_measure);

}  // namespace mimic::app::cmd_measure
