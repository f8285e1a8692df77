// `mimic fit`: the metaball body fitted to a person's surface mesh (docs/fit.md).
#include <cmath>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "body_posing.h"
#include "cli.h"
#include "command.h"
#include "mimic/avatar/body_fit.h"
#include "mimic/avatar/mesh_io.h"

namespace mimic::app::cmd_fit {
namespace {

constexpr const char* kName = "fit";

constexpr const char* kAbout =
    "Fits the body to a person's surface mesh (a scan, a MakeHuman export) and writes it as a body\n"
    "model that --body takes everywhere. First the skeleton: spine, neck and limb lengths, hips and\n"
    "shoulders from the person's joints (--joints, MakeHuman names); then the shapes: every\n"
    "metaball's centre and semi-axes by Levenberg-Marquardt on the surface distance both ways\n"
    "(the body posed like the mesh, as `mimic compare` measures it), keeping only steps after\n"
    "which the skin is still closed and has no new folds. Progress goes to stderr. docs/fit.md.";

void print_progress(const avatar::FitProgress& p) {
  const auto& d = p.distance;
  if (p.stage == "shapes")
    std::fprintf(stderr, "  shapes %2d/%d: %6.2f mm body -> mesh, %6.2f mm mesh -> body%s\n", p.iteration, p.iterations,
                 d.body_to_reference.mean_m * 1e3, d.reference_to_body.mean_m * 1e3,
                 p.accepted ? "" : "  (step refused)");
  else
    std::fprintf(stderr, "  %-8s    : %6.2f mm body -> mesh, %6.2f mm mesh -> body%s\n", p.stage.c_str(),
                 d.body_to_reference.mean_m * 1e3, d.reference_to_body.mean_m * 1e3, p.accepted ? "" : "  (refused)");
}

int run_fit(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  p->footer(
      "exit status: 0 fitted and written, 1 failure (bad mesh or joints, a body that does not skin), 2 usage error");
  const std::string data = shared_data_dir();
  std::string mesh_path, joints, body_path, out, name = "fitted";
  double units_per_metre = 10.0;
  avatar::FitOptions options;
  bool json = false, no_skeleton = false, no_shapes = false;
  p->add_option("--mesh", mesh_path, "the person's mesh, .obj/.ply/.glb (default: the MakeHuman base mesh)")
      ->type_name("FILE");
  p->add_option("--joints", joints, "its joint centres, MakeHuman CSV (default: beside the default mesh)")
      ->type_name("CSV");
  p->add_option("--units-per-metre", units_per_metre, "mesh and joint units per metre (MakeHuman decimetres)")
      ->check(cli::finite_range(0, INFINITY, cli::Bound::exclusive));
  p->add_option("--body", body_path, "body to start from (default: the built-in body)")->type_name("FILE");
  p->add_option("--out", out, "the fitted body model (JSON)")->type_name("FILE")->required();
  p->add_option("--name", name, "the fitted body's name");
  p->add_option("--iterations", options.iterations, "shape iterations (at most)")->check(CLI::Range(0, 1000));
  p->add_option("--samples", options.samples, "surface samples per side per iteration")->check(CLI::Range(500, 200000));
  p->add_flag("--no-skeleton", no_skeleton, "keep the body's skeleton (fit the shapes only)");
  p->add_flag("--no-shapes", no_shapes, "fit the skeleton only");
  p->add_flag("--json", json, "print a JSON summary on stdout");
  if (auto exit_code = p.parse(argv)) return *exit_code;
  if (mesh_path.empty()) {
    mesh_path = data + "/mesh/makehuman_base_body.obj";
    if (joints.empty()) joints = data + "/mesh/makehuman_base_joints.csv";
  }
  if (joints.empty())
    return p.usage_error("--joints CSV is required with --mesh (the fit starts from the person's joints)");
  options.skeleton = !no_skeleton;
  options.shapes = !no_shapes;
  const auto metres_per_unit = static_cast<float>(1.0 / units_per_metre);

  auto mesh = avatar::read_mesh(mesh_path, metres_per_unit);
  if (!mesh) return failure(kName, mesh.error().message);
  if (mesh->triangle_count() == 0) return failure(kName, mesh_path + ": the mesh has no triangles");
  for (const glm::vec3& v : mesh->positions)
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
      return failure(kName, mesh_path + ": the mesh has a non-finite vertex");
  auto landmarks = avatar::load_makehuman_joints(joints, metres_per_unit);
  if (!landmarks) return failure(kName, landmarks.error().message);
  auto body = body_from_path(body_path);
  if (!body) return failure(kName, body.error().message);

  std::fprintf(stderr, "mimic fit: %s (%zu triangles) from %s\n", mesh_path.c_str(), mesh->triangle_count(),
               body->name.c_str());
  options.progress = print_progress;
  auto fitted = avatar::fit_body(*body, *mesh, *landmarks, options);
  if (!fitted) return failure(kName, fitted.error().message);
  fitted->body.name = name;
  if (auto st = avatar::save_body_model(fitted->body, out); !st) return failure(kName, st.error().message);
  auto posed = avatar::pose_body_like(fitted->body, *landmarks);
  if (!posed) return failure(kName, posed.error().message);

  const auto& a = fitted->after;
  if (json) {
    const nlohmann::json j{{"out", out},
                           {"iterations", fitted->iterations},
                           {"accepted_steps", fitted->accepted},
                           {"before", nlohmann::json::parse(avatar::surface_distance_json(fitted->before))},
                           {"after", nlohmann::json::parse(avatar::surface_distance_json(a))},
                           {"closed", posed->closed},
                           {"folds", posed->folds},
                           {"missed_rays", posed->missed_rays}};
    std::printf("%s\n", j.dump().c_str());
  } else {
    std::printf(
        "wrote %s: mean surface distance %.2f mm body -> mesh, %.2f mm mesh -> body (was %.2f, %.2f); "
        "skin %s, %d folds\n",
        out.c_str(), a.body_to_reference.mean_m * 1e3, a.reference_to_body.mean_m * 1e3,
        fitted->before.body_to_reference.mean_m * 1e3, fitted->before.reference_to_body.mean_m * 1e3,
        posed->closed ? "closed" : "NOT closed", posed->folds);
  }
  return 0;
}

}  // namespace

MIMIC_COMMAND(fit, kName, "fit the body to a person's surface mesh (skeleton, then shapes)", run_fit);

}  // namespace mimic::app::cmd_fit
