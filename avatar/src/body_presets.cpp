#include "mimic/avatar/body_presets.h"

#include <array>
#include <string>

namespace mimic::avatar {

namespace {

// Figures and their sources: docs/body-model.md, "Presets". The operators set stature and
// breadths; the shape changes below set what they cannot: proportions of parts to each other.

// A six-year-old (CDC 2000 stature-for-age, 50th percentile: 1.15 m): the head about a sixth of
// the stature (an adult's about a seventh: the head has grown to 90 % of its adult size by six),
// legs shorter for the height (sitting height 56 % of stature against 52 %), a rounder belly and
// softer, less muscled limbs.
const ShapeChange kChildShape[] = {
    {"part:head", glm::vec3(1.09f)},
    {"neck_base neck_mid neck_top", {1.12f, 1.0f, 1.12f}},
    {"abdomen lower_abdomen", {1.08f, 1.0f, 1.18f}, {0, 0, 0.006f}},
    {"l_deltoid l_biceps l_triceps l_forearm_muscles l_calf l_quadriceps l_hamstring", {0.94f, 1.0f, 0.94f}},
    {"part:left_hand part:right_hand part:left_foot part:right_foot", glm::vec3(1.1f)},
};

// An adult woman: a bust in front of the pectorals, fuller hips and buttocks; the waist-to-hip
// ratio (narrowest waist over widest hips) about 0.72 against the adult man's 0.85 (WHO 2008:
// women's ratios run about 0.1 under men's).
const ShapeChange kFemaleShape[] = {
    {"l_pectoral", {1.0f, 1.2f, 1.9f}, {0.004f, -0.018f, 0.018f}},
    {"waist l_lat_lower l_oblique abdomen lower_back", {1.3f, 1.0f, 1.2f}},
    {"l_gluteal", {1.04f, 1.0f, 1.1f}, {0, 0, -0.004f}},
    {"l_hip_side", {1.06f, 1.0f, 1.04f}, {0.004f, 0, 0}},
    {"part:head", {0.96f, 0.97f, 0.97f}},
};

// An adult man: a thicker waist (the ratio about 0.85), slimmer buttocks.
const ShapeChange kMaleShape[] = {
    {"waist l_lat_lower l_oblique abdomen lower_back", {1.2f, 1.0f, 1.16f}},
    {"l_gluteal l_hip_side", {0.96f, 1.0f, 0.96f}},
};

// The heavy body's operators widen everything, its head and hands too; these undo that on the
// head and hands (to the adult male's) and put the weight where it goes: belly, waist, hips and
// the upper limbs (after Snyder et al. and ANSUR II's heaviest decile: waist girth grows fastest).
const ShapeChange kHeavyShape[] = {
    {"part:head", {1.08f / 1.18f, 1.0f, 1.0f / 1.22f}},
    {"part:left_hand part:right_hand", {1.08f / 1.18f, 1.0f, 1.0f / 1.22f}},
    {"neck_base neck_mid neck_top", {1.06f, 1.0f, 1.02f}},
    {"waist l_lat_lower l_oblique abdomen lower_back", {1.2f, 1.0f, 1.16f}},
    {"abdomen", {1.1f, 1.15f, 1.45f}, {0, 0, 0.04f}},
    {"lower_abdomen", {1.12f, 1.1f, 1.4f}, {0, -0.006f, 0.03f}},
    {"waist l_lat_lower", {1.15f, 1.1f, 1.4f}, {0, 0, 0.02f}},
    {"l_humerus l_biceps l_triceps l_thigh_upper l_adductor", {1.08f, 1.0f, 1.08f}},
};

const std::array kPresets{
    BodyPreset{"child",
               "about 6 years, 1.15 m: head a sixth of the height, shorter legs, rounder belly",
               {.total_height = 0.675f,
                .frontal_scaling = 1.02f,
                .high_lateral_scaling = 0.98f,
                .low_lateral_scaling = 0.98f,
                .spine_origin_ratio = 0.90f},
               kChildShape},
    BodyPreset{"adult_female",
               "1.62 m: narrower shoulders, wider hips, a bust",
               {.total_height = 0.97f,
                .frontal_scaling = 0.97f,
                .high_lateral_scaling = 0.92f,
                .low_lateral_scaling = 1.06f,
                .spine_origin_ratio = 1.01f},
               kFemaleShape},
    BodyPreset{"adult_male",
               "1.77 m: broader shoulders, a thicker waist, narrower hips",
               {.total_height = 1.06f,
                .frontal_scaling = 1.00f,
                .high_lateral_scaling = 1.08f,
                .low_lateral_scaling = 0.98f,
                .spine_origin_ratio = 1.00f},
               kMaleShape},
    BodyPreset{"tall",
               "1.90 m, slender, long legs",
               {.total_height = 1.14f,
                .frontal_scaling = 0.95f,
                .high_lateral_scaling = 0.96f,
                .low_lateral_scaling = 0.96f,
                .spine_origin_ratio = 1.02f},
               {}},
    BodyPreset{"heavy",
               "the adult male's height and head, a heavy belly, wider torso and limbs",
               {.total_height = 1.06f,
                .frontal_scaling = 1.22f,
                .high_lateral_scaling = 1.18f,
                .low_lateral_scaling = 1.18f,
                .spine_origin_ratio = 1.00f},
               kHeavyShape},
};

}  // namespace

std::span<const BodyPreset> body_presets() { return kPresets; }

const BodyPreset* find_body_preset(std::string_view name) {
  for (const BodyPreset& p : kPresets)
    if (p.name == name) return &p;
  return nullptr;
}

Result<BodyModel> preset_body(const BodyPreset& preset, const BodyModel& base) {
  auto body = scale_body(base, preset.scaling);
  if (body && !preset.shape.empty()) body = reshape_body(*body, preset.shape);
  if (body) body->name = std::string(preset.name);
  return body;
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
  return preset_body(*preset);
}

}  // namespace mimic::avatar
