// The built-in body as the hand-authored one (default_body.cpp) plus a table of fitted
// overrides: joint offsets and link tips, and the centres and semi-axes (relaxed and deformed
// states) of the non-rigid primitives, by name. The table is the fit of the authored body to the
// MakeHuman base mesh with the rigid parts held (`mimic fit --emit-default`, docs/fit.md), kept
// as data the project writes (avatar/src/default_body_fit.cpp); the mesh itself is not needed.
// Rigid parts (head, hands, feet) are never overridden, so they compose with the table as
// authored.
//
// Table format (JSON): {"format": "mimic-body-overrides", "version": 1, "joints": [{"name",
// "offset", "tip"}], "primitives": [{"name", "center", "semi_axes", "min": {"center",
// "semi_axes"}, "max": {…}}]}, metres in joint frames, as in docs/body-model.md.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "mimic/avatar/body_model.h"

namespace mimic::avatar {

// The overrides that turn `authored` into `fitted` (same joints and primitives, by name): every
// joint and non-rigid primitive that differs. One entry a line.
std::string body_overrides_json(const BodyModel& authored, const BodyModel& fitted);

// `base` with the table applied. Entries naming no joint or primitive of `base` are skipped and
// listed in `unmatched`; an entry naming a rigid-part primitive is skipped too (listed). Fails on
// text that does not parse or a body that does not validate.
Result<BodyModel> apply_body_overrides(const BodyModel& base, std::string_view json,
                                       std::vector<std::string>* unmatched = nullptr);

// Each left/right pair made mirror images of each other: the mean of the left one and the
// mirrored right one, for joints (offset, tip) and non-rigid primitives (centres and semi-axes of
// every state). The fit moves each side on its own; a symmetric body is written once per pair
// (docs/body-model.md) and looks like a person, not like the fit's noise.
BodyModel symmetrised(const BodyModel& model);

// The compiled-in table of the built-in body (generated: avatar/src/default_body_fit.cpp).
std::string_view default_body_fit_json();

}  // namespace mimic::avatar
