#include "mimic/avatar/baselines/linear_blend_skinning.h"

#include "mimic/avatar/baselines/skin_weights.h"
#include "mimic/avatar/simd.h"

namespace mimic::avatar::baselines {

bool LinearBlendSkinningJob::Validate() const {
  const size_t n = in_positions.size();
  return !skinning_matrices.empty() && joint_indices.size() == n * kInfluences &&
         joint_weights.size() == n * kInfluences && out_positions.size() >= n &&
         (in_normals.empty() || in_normals.size() == n) && out_normals.size() >= in_normals.size();
}

namespace {

// Per vertex: the four matrices blended by weight (eight fused multiply-adds on two columns per
// 256-bit register, as ozz's SIMD Float4x4 does), then applied to the rest position (and normal).
template <bool kNormals>
void skin(const SkinningMatrix* __restrict mats, const uint16_t* __restrict ji, const float* __restrict wi,
          const glm::vec3* __restrict in_p, const glm::vec3* __restrict in_n, glm::vec3* __restrict out_p,
          glm::vec3* __restrict out_n, size_t n) {
  for (size_t v = 0; v < n; ++v, ji += kInfluences, wi += kInfluences) {
#ifdef MIMIC_SIMD_AVX2
    const simd::Blend b = simd::blend(&mats[ji[0]].cols[0][0], &mats[ji[1]].cols[0][0], &mats[ji[2]].cols[0][0],
                                      &mats[ji[3]].cols[0][0], wi);
    simd::store3(out_p[v], simd::apply(b, simd::load3(in_p[v]), 1.0f));
    if constexpr (kNormals) simd::store3(out_n[v], simd::apply(b, simd::load3(in_n[v]), 0.0f));
#else
    float m[4][3];
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 3; ++r)
        m[c][r] = wi[0] * mats[ji[0]].cols[c][r] + wi[1] * mats[ji[1]].cols[c][r] + wi[2] * mats[ji[2]].cols[c][r] +
                  wi[3] * mats[ji[3]].cols[c][r];
    const glm::vec3 p = in_p[v];
    for (int r = 0; r < 3; ++r) out_p[v][r] = m[0][r] * p.x + m[1][r] * p.y + m[2][r] * p.z + m[3][r];
    if constexpr (kNormals) {
      const glm::vec3 q = in_n[v];
      for (int r = 0; r < 3; ++r) out_n[v][r] = m[0][r] * q.x + m[1][r] * q.y + m[2][r] * q.z;
    }
#endif
  }
}

}  // namespace

bool LinearBlendSkinningJob::Run() const {
  if (!Validate()) return false;
  if (in_normals.empty())
    skin<false>(skinning_matrices.data(), joint_indices.data(), joint_weights.data(), in_positions.data(), nullptr,
                out_positions.data(), nullptr, in_positions.size());
  else
    skin<true>(skinning_matrices.data(), joint_indices.data(), joint_weights.data(), in_positions.data(),
               in_normals.data(), out_positions.data(), out_normals.data(), in_positions.size());
  return true;
}

}  // namespace mimic::avatar::baselines
