// The skinned glTF as a document before it is packed: the VRM writer adds its extension to the
// same JSON the .glb writer packs (not part of the public API).
#pragma once

#include <cstdint>
#include <vector>

#include <nlohmann/json.hpp>

#include "mimic/avatar/gltf_animation.h"
#include "mimic/core/result.h"

namespace mimic::avatar::detail {

struct GltfDocument {
  nlohmann::json doc;        // the glTF JSON, buffer 0 being `bin`
  std::vector<uint8_t> bin;  // the binary chunk, 4-byte aligned
};

// What encode_skinned_glb packs: node j is joint j, the last node holds the one skinned mesh.
// Without `animate` the document has no animation (times_s and poses are not looked at).
Result<GltfDocument> skinned_gltf(const SkinnedAnimation& animation, bool animate);

}  // namespace mimic::avatar::detail
