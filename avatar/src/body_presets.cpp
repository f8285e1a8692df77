#include "mimic/avatar/body_presets.h"

#include <array>
#include <string>

namespace mimic::avatar {

namespace {

// Proportions after anthropometric averages (adult stature ~1.62 m female, ~1.77 m male; a child
// of about eight, 1.25 m, with relatively shorter legs and a narrower frame; "heavy" keeps the
// adult male's skeleton length and adds girth front to back more than side to side).
constexpr std::array kPresets{
    BodyPreset{"child",
               "about 8 years, 1.25 m: shorter legs for the height, slighter frame",
               {.total_height = 0.75f,
                .frontal_scaling = 0.92f,
                .high_lateral_scaling = 0.90f,
                .low_lateral_scaling = 0.90f,
                .spine_origin_ratio = 0.96f}},
    BodyPreset{"adult_female",
               "1.62 m: narrower shoulders, wider hips",
               {.total_height = 0.97f,
                .frontal_scaling = 0.97f,
                .high_lateral_scaling = 0.92f,
                .low_lateral_scaling = 1.06f,
                .spine_origin_ratio = 1.01f}},
    BodyPreset{"adult_male",
               "1.77 m: broader shoulders, narrower hips",
               {.total_height = 1.06f,
                .frontal_scaling = 1.00f,
                .high_lateral_scaling = 1.08f,
                .low_lateral_scaling = 0.98f,
                .spine_origin_ratio = 1.00f}},
    BodyPreset{"tall",
               "1.90 m, slender, long legs",
               {.total_height = 1.14f,
                .frontal_scaling = 0.95f,
                .high_lateral_scaling = 0.96f,
                .low_lateral_scaling = 0.96f,
                .spine_origin_ratio = 1.02f}},
    BodyPreset{"heavy",
               "the adult male's height, a quarter wider and a third deeper",
               {.total_height = 1.06f,
                .frontal_scaling = 1.33f,
                .high_lateral_scaling = 1.25f,
                .low_lateral_scaling = 1.25f,
                .spine_origin_ratio = 1.00f}},
};

}  // namespace

std::span<const BodyPreset> body_presets() { return kPresets; }

const BodyPreset* find_body_preset(std::string_view name) {
  for (const BodyPreset& p : kPresets)
    if (p.name == name) return &p;
  return nullptr;
}

Result<BodyModel> load_body_or_preset(const std::string& spec) {
  constexpr std::string_view kPrefix = "preset:";
  if (spec.rfind(kPrefix, 0) != 0) return load_body_model(spec);
  const std::string_view name = std::string_view(spec).substr(kPrefix.size());
  const BodyPreset* preset = find_body_preset(name);
  if (!preset) {
    std::string known;
    for (const BodyPreset& p : kPresets) known += (known.empty() ? "" : ", ") + std::string(p.name);
    return fail(Errc::invalid_argument, "unknown body preset '" + std::string(name) + "' (presets: " + known + ")");
  }
  auto body = scale_body(default_body_model(), preset->scaling);
  if (body) body->name = std::string(preset->name);
  return body;
}

}  // namespace mimic::avatar
