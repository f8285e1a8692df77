// The "skeleton" section of a body file (docs/body-model.md): joints with offsets, tips and
// degrees of freedom, a right joint that mirrors its left twin written once as "mirror": true.
// The body model reads and writes it through these; a program that needs only the skeleton (the
// client library, a retargeting tool) reads a body file's skeleton without the body.
#pragma once

#include <string>
#include <string_view>

#include <nlohmann/json_fwd.hpp>

#include "mimic/core/result.h"
#include "mimic/rig/skeleton.h"

namespace mimic {
class JsonReader;
}

namespace mimic::rig {

// The right-side twin of a left joint ("l_…" → "r_…"): name, parent and DOF names; offset and
// tip x negated; DOF axes (x, y, z) → (x, −y, −z), so equal angles give mirror-image postures.
JointDesc mirrored(const JointDesc& left);

// Reads `skeleton` (the section's object) at `path` ("$.skeleton"); errors go to `reader`.
SkeletonDesc read_skeleton_json(const nlohmann::json& skeleton, const std::string& path, JsonReader& reader);

// The section as the writer stores it ({"joints": [...]}, mirrored twins folded).
nlohmann::json skeleton_json(const SkeletonDesc& desc);

// The skeleton of a whole body file's text, checked (Skeleton::build); `source_name` names it in
// errors.
Result<Skeleton> skeleton_from_body_json(std::string_view text, std::string_view source_name);

}  // namespace mimic::rig
