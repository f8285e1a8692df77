// Skinning influences shared by the baseline skinning jobs (linear blend, dual quaternion,
// optimized centres of rotation): exactly four (joint, weight) pairs per vertex, vertex-major,
// unused slots padded with weight 0 (and any valid joint index, 0 by convention).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/rig/skeleton.h"
#include "mimic/avatar/skin_weights.h"
#include "mimic/core/result.h"

namespace mimic::avatar::baselines {

inline constexpr int kInfluences = 4;

struct SkinWeights {
  std::vector<uint16_t> joints;  // kInfluences per vertex
  std::vector<float> weights;    // kInfluences per vertex, each in [0, 1], summing to 1

  size_t vertex_count() const { return weights.size() / kInfluences; }
};

// Checks shapes (joints.size() == weights.size(), a multiple of four), that every joint index is
// below `joint_count`, that weights are finite and non-negative and that each vertex's weights
// sum to 1 within `tolerance`. The message names the first offending vertex.
Status validate_weights(const SkinWeights& weights, int joint_count, float tolerance = 1e-4f);

// Weights of a rest mesh from the skeleton's links, the usual geometric binding a user would pick
// when no weights were authored: each vertex belongs to its nearest link (segment joint → tip in
// the rest posture); within `blend_band_m` of the link's start it blends with the parent link,
// within `blend_band_m` of its end with the nearest child link, by a smoothstep that reaches 1/2
// at the joint (so the two sides meet continuously). At most two influences per vertex.
// `world_from_joint_rest`: the joints in the posture of `rest_positions_m` (forward_kinematics).
// Allocates.
SkinWeights weights_from_links(const rig::Skeleton& skeleton,
                               std::span<const rig::RigidTransform> world_from_joint_rest,
                               std::span<const glm::vec3> rest_positions_m, float blend_band_m = 0.06f);

// The contour-derived influences of a skin (contour_skin_weights, RealtimeBody::weights) in the
// jobs' layout. Allocates.
SkinWeights from_influences(std::span<const JointInfluences> influences);

}  // namespace mimic::avatar::baselines
