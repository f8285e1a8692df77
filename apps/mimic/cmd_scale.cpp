// mimic scale: a new body model from the paper's five scaling operators, or from a preset.
#include <cmath>
#include <cstdio>
#include <string>

#include "body_posing.h"
#include "command.h"
#include "mimic/avatar/body_model.h"
#include "mimic/avatar/body_presets.h"

namespace mimic::app {
namespace {

constexpr const char* kName = "scale";
constexpr const char* kUsage =
    "usage: mimic scale [--preset NAME] [--total-height M] [--frontal F] [--high-lateral H]\n"
    "                   [--low-lateral L] [--spine-origin-ratio R] [--body FILE] [--name NAME]\n"
    "                   [--out BODY.json]\n"
    "       mimic scale --list\n"
    "\n"
    "Writes a new body model (JSON, docs/body-model.md) scaled by the five operators of\n"
    "docs/body-scaling.md, all ratios relative to the input body (1 keeps it):\n"
    "  --total-height M        uniform scale of the whole body\n"
    "  --frontal F             front-to-back depth (z)\n"
    "  --high-lateral H        width (x) above the spine origin: torso, arms, head\n"
    "  --low-lateral L         width (x) of the hips and legs\n"
    "  --spine-origin-ratio R  pelvis height / total height, relative to now (total kept)\n"
    "Every primitive's principal axes are tagged lateral, frontal or high by their dominant world\n"
    "direction in the standing posture (arms at the sides), and scaled by the matching ratio.\n"
    "\n"
    "options:\n"
    "  --preset NAME   start from a preset's ratios (see --list); explicit operators override it\n"
    "  --list          the presets, their ratios and heights\n"
    "  --body FILE     the body to scale (default: the built-in adult)\n"
    "  --name NAME     the new body's name (default: the preset's name, or \"scaled\")\n"
    "  --out FILE      write there (default: standard output)\n"
    "  -h, --help      this text\n"
    "\n"
    "The result loads, animates and meshes like any body: mimic mesh --body FILE, mimic compare\n"
    "--body FILE, mimic run --body FILE. Exit status: 0 written, 1 failure, 2 usage error.\n";

// Standing height of the skin's skeleton (top of the head link over the sole), for listings.
float skeleton_height_m(const avatar::BodyModel& body) {
  auto s = rig::Skeleton::build(body.skeleton);
  if (!s) return 0;
  rig::Pose p = s->zero_pose();
  p.root_position_m.y = rig::standing_root_height_m(*s);
  std::vector<rig::RigidTransform> w(s->joint_count());
  rig::forward_kinematics(*s, p, w);
  float top = 0;
  for (int j = 0; j < s->joint_count(); ++j) top = std::max(top, w[j].apply(s->tip_m(j)).y);
  return top;
}

int list_presets() {
  const float base = skeleton_height_m(avatar::default_body_model());
  std::printf("%-13s %6s %6s %7s %7s %7s %7s  %s\n", "preset", "height", "total", "frontal", "high_x", "low_x", "spine",
              "description");
  for (const avatar::BodyPreset& p : avatar::body_presets()) {
    const avatar::BodyScaling& s = p.scaling;
    std::printf("%-13.*s %5.2fm %6.2f %7.2f %7.2f %7.2f %7.2f  %.*s\n", int(p.name.size()), p.name.data(),
                base * s.total_height, s.total_height, s.frontal_scaling, s.high_lateral_scaling, s.low_lateral_scaling,
                s.spine_origin_ratio, int(p.description.size()), p.description.data());
  }
  std::printf("\nheights: sole to the top of the head link, of the built-in body so scaled\n");
  return 0;
}

int run_scale(const std::vector<std::string>& argv) {
  Args args(argv, {"preset", "total-height", "frontal", "high-lateral", "low-lateral", "spine-origin-ratio", "body", "name", "out"},
            {"list"});
  if (args.help()) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  if (!args.ok()) return usage_error(kName, args.error());
  if (!args.positionals().empty()) return usage_error(kName, "unexpected argument '" + args.positionals()[0] + "'");
  if (args.has("list")) return list_presets();

  avatar::BodyScaling scaling;
  std::string name = "scaled";
  if (auto preset = args.get("preset")) {
    const avatar::BodyPreset* p = avatar::find_body_preset(*preset);
    if (!p) {
      std::string known;
      for (const avatar::BodyPreset& q : avatar::body_presets()) known += (known.empty() ? "" : ", ") + std::string(q.name);
      return usage_error(kName, "unknown preset '" + *preset + "' (presets: " + known + ")");
    }
    scaling = p->scaling;
    name = std::string(p->name);
  }
  struct Operator {
    const char* option;
    float* value;
  } ops[] = {{"total-height", &scaling.total_height},
             {"frontal", &scaling.frontal_scaling},
             {"high-lateral", &scaling.high_lateral_scaling},
             {"low-lateral", &scaling.low_lateral_scaling},
             {"spine-origin-ratio", &scaling.spine_origin_ratio}};
  for (const Operator& op : ops) {
    double v = *op.value;
    if (!args.get_double(op.option, v)) return usage_error(kName, args.error());
    if (!(v > 0) || !std::isfinite(v) || v > 10)
      return usage_error(kName, std::string("--") + op.option + " must be a ratio in (0, 10]");
    *op.value = static_cast<float>(v);
  }
  auto body = body_from_args(args);
  if (!body) return failure(kName, body.error().what());
  auto scaled = avatar::scale_body(*body, scaling);
  if (!scaled) return failure(kName, scaled.error().what());
  scaled->name = args.get_or("name", name);
  const float before = skeleton_height_m(*body), after = skeleton_height_m(*scaled);
  std::fprintf(stderr,
               "mimic scale: %s: total %.3f, frontal %.3f, high lateral %.3f, low lateral %.3f, spine origin %.3f; "
               "height %.3f m -> %.3f m\n",
               scaled->name.c_str(), scaling.total_height, scaling.frontal_scaling, scaling.high_lateral_scaling,
               scaling.low_lateral_scaling, scaling.spine_origin_ratio, before, after);
  if (auto out = args.get("out")) {
    if (auto st = avatar::save_body_model(*scaled, *out); !st) return failure(kName, st.error().what());
    return 0;
  }
  std::printf("%s\n", avatar::to_json(*scaled).c_str());
  return 0;
}

}  // namespace

MIMIC_COMMAND(scale, kName, "scale a body model (five operators or a preset: child, adult, tall, heavy ...)", kUsage,
              run_scale);

}  // namespace mimic::app
