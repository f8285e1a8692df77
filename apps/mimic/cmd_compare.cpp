// `mimic compare`: Mimic's body against a reference body mesh, posed alike, measured alike.
#include <cmath>
#include <cstdio>

#include "body_posing.h"
#include "command.h"
#include "mimic/avatar/measure.h"
#include "mimic/avatar/mesh_io.h"
#include "mimic/avatar/skin.h"

namespace mimic::app {
namespace {

constexpr const char* kName = "compare";

constexpr const char* kUsage =
    "usage: mimic compare [--obj FILE] [--joints CSV] [--units-per-metre N] [--body FILE]\n"
    "                     [--tolerance F] [--json] [--check] [--out FILE]\n"
    "\n"
    "Measures Mimic's body against a reference mesh: the body is posed like the reference (its\n"
    "joint centres give the posture: upper arms, forearms, thighs and shins along the reference's),\n"
    "then both are measured the same way — standing height and tape girths at chest, waist, hips,\n"
    "thigh, calf and upper arm — and printed side by side with the difference and PASS/FAIL.\n"
    "\n"
    "options:\n"
    "  --obj FILE            reference mesh (default: the MakeHuman base mesh in ../shared/data/mesh)\n"
    "  --joints CSV          its joint centres, MakeHuman CSV (default: beside the default mesh)\n"
    "  --units-per-metre N   reference units per metre (default 10, MakeHuman decimetres)\n"
    "  --body FILE           body model to compare (default: the built-in body)\n"
    "  --tolerance F         allowed relative difference (default 0.10)\n"
    "  --json                print one JSON object instead of the table\n"
    "  --check               exit 1 when any measurement fails\n"
    "  --out FILE            also write the posed body mesh (.obj, .ply or .glb)\n"
    "  -h, --help            this text\n"
    "\n"
    "exit status: 0 compared (and, with --check, all within tolerance), 1 failure, 2 usage error\n";

int run_compare(const std::vector<std::string>& argv) {
  Args args(argv, {"obj", "joints", "units-per-metre", "body", "tolerance", "out"}, {"json", "check"});
  if (args.help()) {
    std::printf("%s", kUsage);
    return 0;
  }
  if (!args.ok()) return usage_error(kName, args.error());
  if (!args.positionals().empty()) return usage_error(kName, "unexpected argument '" + args.positionals()[0] + "'");
  double units_per_metre = 10.0, tolerance = 0.10;
  if (!args.get_double("units-per-metre", units_per_metre) || !args.get_double("tolerance", tolerance))
    return usage_error(kName, args.error());
  if (!(units_per_metre > 0) || !std::isfinite(units_per_metre))
    return usage_error(kName, "--units-per-metre must be a positive number");
  if (!(tolerance > 0 && tolerance < 1)) return usage_error(kName, "--tolerance must be in (0, 1)");
  const std::string data = shared_data_dir();
  const std::string obj = args.get_or("obj", data + "/mesh/makehuman_base_body.obj");
  const std::string joints = args.get_or("joints", args.has("obj") ? "" : data + "/mesh/makehuman_base_joints.csv");
  if (joints.empty()) return usage_error(kName, "--joints CSV is required with --obj");
  const auto metres_per_unit = static_cast<float>(1.0 / units_per_metre);

  auto ref_mesh = avatar::read_obj(obj, metres_per_unit);
  if (!ref_mesh) return failure(kName, ref_mesh.error().message);
  auto ref_landmarks = avatar::load_makehuman_joints(joints, metres_per_unit);
  if (!ref_landmarks) return failure(kName, ref_landmarks.error().message);
  const avatar::BodyMeasurements ref = avatar::measure_body(*ref_mesh, *ref_landmarks);

  auto body = body_from_args(args);
  if (!body) return failure(kName, body.error().message);
  avatar::SkinOptions options;
  options.subdivision = 2;
  auto skin = avatar::BodySkin::create(*body, options);
  if (!skin) return failure(kName, skin.error().message);
  const rig::Pose pose = avatar::pose_to_match(skin->skeleton(), *ref_landmarks);
  skin->evaluate(pose);
  const avatar::BodyMeasurements ours =
      avatar::measure_body(skin->mesh(), avatar::landmarks_from_skeleton(skin->skeleton(), pose));
  if (auto out = args.get("out"))
    if (auto w = avatar::write_mesh(skin->mesh(), *out); !w) return failure(kName, w.error().message);

  if (args.has("json")) {
    std::printf("%s\n", avatar::comparison_json(ours, ref, tolerance).c_str());
  } else {
    std::printf("body: %s   reference: %s\n\n%s", body->name.c_str(), obj.c_str(),
                avatar::format_comparison(ours, ref, tolerance).c_str());
  }
  return args.has("check") && !avatar::comparison_passes(ours, ref, tolerance) ? 1 : 0;
}

}  // namespace

MIMIC_COMMAND(compare, kName, "measure the body against a reference mesh (height and girths)", kUsage, run_compare);

}  // namespace mimic::app
