#include "mimic/avatar/baselines/linear_blend_skinning.h"

#include "mimic/avatar/baselines/skin_weights.h"

namespace mimic::avatar::baselines {

bool LinearBlendSkinningJob::Validate() const {
  const size_t n = in_positions.size();
  return !skinning_matrices.empty() && joint_indices.size() == n * kInfluences && joint_weights.size() == n * kInfluences &&
         out_positions.size() >= n && (in_normals.empty() || in_normals.size() == n) &&
         out_normals.size() >= in_normals.size();
}

namespace {

// The blended matrix is twelve independent multiply-adds per influence: the compiler keeps it in
// vector registers (one 8-wide and one 4-wide with AVX), as ozz's SIMD matrix columns do.
template <bool kNormals>
void skin(const Affine3x4* __restrict mats, const uint16_t* __restrict ji, const float* __restrict wi,
          const glm::vec3* __restrict in_p, const glm::vec3* __restrict in_n, glm::vec3* __restrict out_p,
          glm::vec3* __restrict out_n, size_t n) {
  for (size_t v = 0; v < n; ++v, ji += kInfluences, wi += kInfluences) {
    const float* __restrict m0 = mats[ji[0]].m;
    const float* __restrict m1 = mats[ji[1]].m;
    const float* __restrict m2 = mats[ji[2]].m;
    const float* __restrict m3 = mats[ji[3]].m;
    alignas(16) float m[12];
    for (int k = 0; k < 12; ++k) m[k] = wi[0] * m0[k] + wi[1] * m1[k] + wi[2] * m2[k] + wi[3] * m3[k];
    const glm::vec3 p = in_p[v];
    out_p[v] = {m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]};
    if constexpr (kNormals) {
      const glm::vec3 q = in_n[v];
      out_n[v] = {m[0] * q.x + m[1] * q.y + m[2] * q.z, m[4] * q.x + m[5] * q.y + m[6] * q.z,
                  m[8] * q.x + m[9] * q.y + m[10] * q.z};
    }
  }
}

}  // namespace

bool LinearBlendSkinningJob::Run() const {
  if (!Validate()) return false;
  if (in_normals.empty())
    skin<false>(skinning_matrices.data(), joint_indices.data(), joint_weights.data(), in_positions.data(), nullptr,
                out_positions.data(), nullptr, in_positions.size());
  else
    skin<true>(skinning_matrices.data(), joint_indices.data(), joint_weights.data(), in_positions.data(), in_normals.data(),
               out_positions.data(), out_normals.data(), in_positions.size());
  return true;
}

}  // namespace mimic::avatar::baselines
