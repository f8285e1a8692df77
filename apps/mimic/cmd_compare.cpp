// `mimic compare`: Mimic's body against a reference body mesh, posed alike, measured alike.
#include <cmath>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "body_posing.h"
#include "cli.h"
#include "command.h"
#include "mimic/avatar/measure.h"
#include "mimic/avatar/mesh_io.h"
#include "mimic/avatar/skin.h"
#include "mimic/avatar/surface_distance.h"

namespace mimic::app::cmd_compare {
namespace {

constexpr const char* kName = "compare";

constexpr const char* kAbout =
    "Measures Mimic's body against a reference mesh: the body is posed like the reference (its\n"
    "joint centres give the posture: upper arms, forearms, thighs and shins along the reference's),\n"
    "then both are measured the same way — standing height and tape girths at chest, waist, hips,\n"
    "thigh, calf and upper arm — and printed side by side with the difference and PASS/FAIL; then\n"
    "the mean surface distance both ways (body to reference and reference to body, mm, from\n"
    "area-weighted samples, exact point-to-triangle distances) overall and per region: head,\n"
    "torso, arms, hands, legs, feet (each point in the region of its nearest bone). docs/fit.md.";

int run_compare(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  p->footer("exit status: 0 compared (and, with --check, all within tolerance), 1 failure, 2 usage error");
  const std::string data = shared_data_dir();
  std::string obj, joints, body_path, out;
  double units_per_metre = 10.0, tolerance = 0.10;
  int samples = avatar::kDefaultDistanceSamples;
  bool json = false, check = false;
  p->add_option("--obj", obj, "reference mesh (default: the MakeHuman base mesh in ../shared/data/mesh)")
      ->type_name("FILE");
  p->add_option("--joints", joints, "its joint centres, MakeHuman CSV (default: beside the default mesh)")
      ->type_name("CSV");
  p->add_option("--units-per-metre", units_per_metre, "reference units per metre (MakeHuman decimetres)")
      ->check(cli::finite_range(0, INFINITY, cli::Bound::exclusive));
  p->add_option("--body", body_path, "body model to compare (default: the built-in body)")->type_name("FILE");
  p->add_option("--tolerance", tolerance, "allowed relative difference")
      ->check(cli::finite_range(0, 1, cli::Bound::exclusive, cli::Bound::exclusive));
  p->add_option("--samples", samples, "surface samples per side for the distance")->check(CLI::Range(100, 1000000));
  p->add_flag("--json", json, "print one JSON object instead of the table");
  p->add_flag("--check", check, "exit 1 when any measurement fails");
  p->add_option("--out", out, "also write the posed body mesh (.obj, .ply or .glb)")->type_name("FILE");
  if (auto exit_code = p.parse(argv)) return *exit_code;
  if (obj.empty()) {
    obj = data + "/mesh/makehuman_base_body.obj";
    if (joints.empty()) joints = data + "/mesh/makehuman_base_joints.csv";
  }
  if (joints.empty()) return p.usage_error("--joints CSV is required with --obj");
  const auto metres_per_unit = static_cast<float>(1.0 / units_per_metre);

  auto ref_mesh = avatar::read_obj(obj, metres_per_unit);
  if (!ref_mesh) return failure(kName, ref_mesh.error().message);
  auto ref_landmarks = avatar::load_makehuman_joints(joints, metres_per_unit);
  if (!ref_landmarks) return failure(kName, ref_landmarks.error().message);
  const avatar::BodyMeasurements ref = avatar::measure_body(*ref_mesh, *ref_landmarks);

  auto body = body_from_path(body_path);
  if (!body) return failure(kName, body.error().message);
  avatar::SkinOptions options;
  options.subdivision = 2;
  auto skin = avatar::ImplicitSkin::create(*body, options);
  if (!skin) return failure(kName, skin.error().message);
  const rig::Pose pose = avatar::pose_to_match(skin->skeleton(), *ref_landmarks);
  skin->evaluate(pose);
  const avatar::BodyLandmarks our_landmarks = avatar::landmarks_from_skeleton(skin->skeleton(), pose);
  const avatar::BodyMeasurements ours = avatar::measure_body(skin->mesh(), our_landmarks);
  const avatar::SurfaceDistance distance =
      avatar::surface_distance(skin->mesh(), our_landmarks, *ref_mesh, *ref_landmarks, samples);
  if (!out.empty())
    if (auto w = avatar::write_mesh(skin->mesh(), out); !w) return failure(kName, w.error().message);

  if (json) {
    auto j = nlohmann::json::parse(avatar::comparison_json(ours, ref, tolerance));
    j["surface_distance"] = nlohmann::json::parse(avatar::surface_distance_json(distance));
    std::printf("%s\n", j.dump().c_str());
  } else {
    std::printf("body: %s   reference: %s\n\n%s\n%s", body->name.c_str(), obj.c_str(),
                avatar::format_comparison(ours, ref, tolerance).c_str(),
                avatar::format_surface_distance(distance).c_str());
  }
  return check && !avatar::comparison_passes(ours, ref, tolerance) ? 1 : 0;
}

}  // namespace

MIMIC_COMMAND(compare, kName, "measure the body against a reference mesh (girths, surface distance)", run_compare);

}  // namespace mimic::app::cmd_compare
