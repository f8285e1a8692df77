// mimic scale: a new body model from the paper's five scaling operators, or from a preset.
#include <cmath>
#include <cstdio>
#include <string>

#include "body_posing.h"
#include "cli.h"
#include "command.h"
#include "mimic/avatar/body_model.h"
#include "mimic/avatar/body_presets.h"

namespace mimic::app::cmd_scale {
namespace {

constexpr const char* kName = "scale";
constexpr const char* kAbout =
    "Writes a new body model (JSON, docs/body-model.md) scaled by the five operators of\n"
    "docs/body-scaling.md (--total-height, --frontal, --high-lateral, --low-lateral,\n"
    "--spine-origin-ratio), all ratios relative to the input body (1 keeps it). Every\n"
    "primitive's principal axes are tagged lateral, frontal or high by their dominant world\n"
    "direction in the standing posture (arms at the sides), and scaled by the matching ratio.";

// A preset's name, or an error that lists them.
Result<const avatar::BodyPreset*> find_preset(std::string_view name) {
  if (const avatar::BodyPreset* p = avatar::find_body_preset(name)) return p;
  std::string known;
  for (const avatar::BodyPreset& q : avatar::body_presets()) known += (known.empty() ? "" : ", ") + std::string(q.name);
  return fail(Errc::invalid_argument, "unknown preset '" + std::string(name) + "' (presets: " + known + ")");
}

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
  cli::Parser p(kName, kAbout);
  p->footer(
      "The result loads, animates and meshes like any body: mimic mesh --body FILE, mimic compare\n"
      "--body FILE, mimic run --body FILE. Exit status: 0 written, 1 failure, 2 usage error.");
  std::string preset, body_path, name, out;
  bool list = false;
  p->add_option("--preset", preset, "start from a preset's ratios (see --list); explicit operators override it")
      ->type_name("NAME")
      ->check(cli::parsed_by(find_preset, "NAME"));
  auto* list_flag = p->add_flag("--list", list, "the presets, their ratios and heights");
  // The operators; unset ones keep the preset's ratio (or 1).
  const std::pair<const char*, const char*> operators[] = {
      {"--total-height", "uniform scale of the whole body"},
      {"--frontal", "front-to-back depth (z)"},
      {"--high-lateral", "width (x) above the spine origin: torso, arms, head"},
      {"--low-lateral", "width (x) of the hips and legs"},
      {"--spine-origin-ratio", "pelvis height / total height, relative to now (total kept)"}};
  double ratios[5] = {0, 0, 0, 0, 0};  // 0: not given
  for (size_t i = 0; i < 5; ++i)
    p->add_option(operators[i].first, ratios[i], operators[i].second)
        ->default_str("")
        ->check(cli::finite_range(0, 10, cli::Bound::exclusive))
        ->excludes(list_flag);
  p->add_option("--body", body_path, "the body to scale (default: the built-in adult)")->type_name("FILE");
  p->add_option("--name", name, "the new body's name (default: the preset's name, or \"scaled\")");
  p->add_option("--out", out, "write there (default: standard output)")->type_name("FILE");
  if (auto exit_code = p.parse(argv)) return *exit_code;
  if (list) return list_presets();

  avatar::BodyScaling scaling;
  const avatar::BodyPreset* chosen = nullptr;
  if (!preset.empty()) {
    chosen = *find_preset(preset);
    scaling = chosen->scaling;
    if (name.empty()) name = std::string(chosen->name);
  }
  if (name.empty()) name = "scaled";
  float* const values[] = {&scaling.total_height, &scaling.frontal_scaling, &scaling.high_lateral_scaling,
                           &scaling.low_lateral_scaling, &scaling.spine_origin_ratio};
  for (size_t i = 0; i < 5; ++i)
    if (ratios[i] > 0) *values[i] = static_cast<float>(ratios[i]);
  auto body = body_from_path(body_path);
  if (!body) return failure(kName, body.error().what());
  auto scaled = avatar::scale_body(*body, scaling);
  // A preset's shape changes (a child's head, a woman's bust) follow its operators.
  if (scaled && chosen && !chosen->shape.empty()) scaled = avatar::reshape_body(*scaled, chosen->shape);
  if (!scaled) return failure(kName, scaled.error().what());
  scaled->name = name;
  const float before = skeleton_height_m(*body), after = skeleton_height_m(*scaled);
  std::fprintf(stderr,
               "mimic scale: %s: total %.3f, frontal %.3f, high lateral %.3f, low lateral %.3f, spine origin %.3f; "
               "height %.3f m -> %.3f m\n",
               scaled->name.c_str(), scaling.total_height, scaling.frontal_scaling, scaling.high_lateral_scaling,
               scaling.low_lateral_scaling, scaling.spine_origin_ratio, before, after);
  if (!out.empty()) {
    if (auto st = avatar::save_body_model(*scaled, out); !st) return failure(kName, st.error().what());
    return 0;
  }
  std::printf("%s\n", avatar::to_json(*scaled).c_str());
  return 0;
}

}  // namespace

MIMIC_COMMAND(scale, kName, "scale a body model (five operators or a preset: child, adult, tall, heavy ...)",
              run_scale);

}  // namespace mimic::app::cmd_scale
