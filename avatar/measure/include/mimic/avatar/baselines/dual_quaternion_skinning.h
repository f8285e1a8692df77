// Dual quaternion skinning (DQS; Kavan et al. 2008) as a job: per vertex the four unit dual
// quaternions are blended by weight (each flipped into the hemisphere of the first so antipodal
// rotations do not cancel), normalised, and applied as a rigid transform to the rest position
// and normal. Preserves volume under twist where LBS collapses, at the price of a bulge at bent
// joints.
#pragma once

#include <cstdint>
#include <span>

#include <glm/glm.hpp>

#include "mimic/avatar/baselines/skinning_transforms.h"

namespace mimic::avatar::baselines {

struct DualQuaternionSkinningJob {
  std::span<const DualQuat> skinning_dual_quats;  // [in] world_from_rest, one per joint
  std::span<const uint16_t> joint_indices;        // [in] kInfluences per vertex
  std::span<const float> joint_weights;           // [in] kInfluences per vertex, summing to 1
  std::span<const glm::vec3> in_positions;        // [in] rest positions (m)
  std::span<const glm::vec3> in_normals;          // [in] optional
  std::span<glm::vec3> out_positions;             // [out]
  std::span<glm::vec3> out_normals;               // [out] as many as in_normals

  bool Validate() const;
  // Never allocates (with AVX2, a per-frame hemisphere table of up to 64 joints, 16 KB, lives on
  // the stack); false if invalid.
  bool Run() const;
};

}  // namespace mimic::avatar::baselines
