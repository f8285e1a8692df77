// The pipeline's deform stage on the metaball body: every frame the pose moves and deforms the
// primitives, the contours are re-sampled and the skin rebuilt (mesh positions; normals off —
// the server streams joint values, receivers shade locally).
#pragma once

#include <memory>
#include <string>

#include "mimic/avatar/skeleton.h"
#include "mimic/avatar/skin.h"
#include "mimic/core/result.h"
#include "pipeline.h"

namespace mimic::app {

// The body model JSON text for an avatar: the file given with --body (validated), or the
// built-in default body; compact, as it goes on the wire once per join.
Result<std::string> body_model_text(const std::string& path);

// A deformer for `model_json` (a body model) hung on `skeleton` (Mimic's skeleton, possibly
// fitted to the wearer). Fails when the body does not fit the skeleton.
Result<std::unique_ptr<Deformer>> make_skin_deformer(const std::string& model_json, const avatar::Skeleton& skeleton);

}  // namespace mimic::app
