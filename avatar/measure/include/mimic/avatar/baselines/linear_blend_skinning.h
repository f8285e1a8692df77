// Linear blend skinning (LBS) as a job in the manner of ozz-animation's SkinningJob: per vertex
// the four skinning matrices are blended by weight and applied to the rest position (and to the
// rest normal, by the same matrix's linear part, not renormalised — as ozz does).
//
// The baseline the contour deformer is measured against: it loses volume at bent joints and
// collapses to a "candy wrapper" under twist, which is what its property tests show.
#pragma once

#include <cstdint>
#include <span>

#include <glm/glm.hpp>

#include "mimic/avatar/baselines/skinning_transforms.h"

namespace mimic::avatar::baselines {

struct LinearBlendSkinningJob {
  std::span<const SkinningMatrix> skinning_matrices;  // [in] world_from_rest, one per joint
  std::span<const uint16_t> joint_indices;            // [in] kInfluences per vertex
  std::span<const float> joint_weights;               // [in] kInfluences per vertex, summing to 1
  std::span<const glm::vec3> in_positions;            // [in] rest positions (m), one per vertex
  std::span<const glm::vec3> in_normals;              // [in] optional: empty, or one per vertex
  std::span<glm::vec3> out_positions;                 // [out] world positions (m), one per vertex
  std::span<glm::vec3> out_normals;                   // [out] as many as in_normals

  // Shapes agree (indices are not range-checked per frame: validate_weights does that once).
  bool Validate() const;
  // Validates, then writes every output vertex. Never allocates; false if invalid.
  bool Run() const;
};

}  // namespace mimic::avatar::baselines
