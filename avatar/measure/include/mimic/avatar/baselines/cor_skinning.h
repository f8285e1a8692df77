// Skinning with optimized centres of rotation (CoR; Le & Hodgins 2016, "Real-time Skeletal
// Skinning with Optimized Centers of Rotation").
//
// Once per rest mesh, every vertex i gets a centre of rotation p*_i: the area-weighted mean of
// the rest triangles' centroids, each weighted by the similarity of its (vertex-averaged) skinning
// weights to the vertex's,
//   s(w_p, w_v) = Σ_{j<k} w_pj w_pk w_vj w_vk exp(−(w_pj w_vk − w_pk w_vj)² / σ²),  σ = 0.1,
// so p*_i lies on the "bone" of the weight pattern the vertex shares. A vertex no triangle is
// similar to (e.g. a single influence) keeps p* = its rest position, which makes it plain LBS.
//
// Each frame: R = the rotation of the normalised, hemisphere-aligned blend of the joints'
// rotation quaternions; t = the LBS-blended matrix applied to p*; v' = R (v − p*) + t, n' = R n.
#pragma once

#include <cstdint>
#include <span>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/avatar/baselines/skin_weights.h"
#include "mimic/avatar/baselines/skinning_transforms.h"

namespace mimic::avatar::baselines {

// Centres of rotation for a closed or open triangle mesh in its rest posture. `indices`: three
// per triangle; `weights` one set per rest position. Writes one centre per vertex. Allocates;
// cost about (blended vertices) × (triangles sharing a joint pair with them).
void compute_centers_of_rotation(std::span<const glm::vec3> rest_positions_m, std::span<const uint32_t> indices,
                                 const SkinWeights& weights, std::span<glm::vec3> out_centers_m, float sigma = 0.1f);

struct CorSkinningJob {
  std::span<const SkinningMatrix> skinning_matrices;  // [in] world_from_rest, one per joint
  std::span<const glm::quat> skinning_rotations;      // [in] the same transforms' rotations
  std::span<const uint16_t> joint_indices;            // [in] kInfluences per vertex
  std::span<const float> joint_weights;               // [in] kInfluences per vertex
  std::span<const glm::vec3> centers_of_rotation;     // [in] compute_centers_of_rotation, per vertex
  std::span<const glm::vec3> in_positions;            // [in] rest positions (m)
  std::span<const glm::vec3> in_normals;              // [in] optional
  std::span<glm::vec3> out_positions;                 // [out]
  std::span<glm::vec3> out_normals;                   // [out] as many as in_normals

  bool Validate() const;
  // Never allocates (with AVX2, per-frame tables of up to 256 joints' matrices and 64 joints'
  // hemisphere flips, 32 KB, live on the stack); false if invalid.
  bool Run() const;
};

}  // namespace mimic::avatar::baselines
