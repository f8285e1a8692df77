// Named bodies across human variety: the five scaling operators (body_model.h, BodyScaling)
// applied to the built-in adult, then changes of the primitives' shapes (ShapeChange) that the
// operators cannot make: a child's larger head, a woman's bust and waist, a heavy body's belly
// with an adult's head. Factors are relative to the built-in body (about 1.67 m); lateral and
// frontal factors act on top of total_height, as in scale_body. Figures and sources:
// docs/body-model.md ("Presets").
#pragma once

#include <span>
#include <string_view>

#include "mimic/avatar/body_model.h"

namespace mimic::avatar {

struct BodyPreset {
  std::string_view name;         // e.g. "child", "adult_female"
  std::string_view description;  // one line for listings
  BodyScaling scaling;
  std::span<const ShapeChange> shape;  // applied after the operators, in order
};

// child, adult_female, adult_male, tall, heavy, in that order.
std::span<const BodyPreset> body_presets();
// nullptr when no preset has that name.
const BodyPreset* find_body_preset(std::string_view name);

// The preset's body: `base` (the built-in body by default) scaled, then reshaped.
Result<BodyModel> preset_body(const BodyPreset& preset, const BodyModel& base = default_body_model());

// A body named on a command line: "preset:NAME" (the built-in body scaled by that preset) or
// the path of a body model file (docs/body-model.md). Fails naming the presets on an unknown
// name, or as load_body_model does.
Result<BodyModel> load_body_or_preset(const std::string& spec);

}  // namespace mimic::avatar
