#include "mimic/avatar/baselines/dual_quaternion_skinning.h"

#include <cmath>

#include "mimic/avatar/baselines/skin_weights.h"
#include "simd.h"

namespace mimic::avatar::baselines {

bool DualQuaternionSkinningJob::Validate() const {
  const size_t n = in_positions.size();
  return !skinning_dual_quats.empty() && joint_indices.size() == n * kInfluences &&
         joint_weights.size() == n * kInfluences && out_positions.size() >= n &&
         (in_normals.empty() || in_normals.size() == n) && out_normals.size() >= in_normals.size();
}

namespace {

inline float dot4(const float* a, const float* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]; }

#ifndef MIMIC_BASELINES_AVX2
inline glm::vec3 cross(const float* a, const glm::vec3& b) {
  return {a[1] * b.z - a[2] * b.y, a[2] * b.x - a[0] * b.z, a[0] * b.y - a[1] * b.x};
}
#endif

template <bool kNormals>
void skin(const DualQuat* __restrict dqs, const uint16_t* __restrict ji, const float* __restrict wi,
          const glm::vec3* __restrict in_p, const glm::vec3* __restrict in_n, glm::vec3* __restrict out_p,
          glm::vec3* __restrict out_n, size_t n) {
  for (size_t v = 0; v < n; ++v, ji += kInfluences, wi += kInfluences) {
    const float* __restrict q0 = dqs[ji[0]].real;
    const float* __restrict q1 = dqs[ji[1]].real;
    const float* __restrict q2 = dqs[ji[2]].real;
    const float* __restrict q3 = dqs[ji[3]].real;
    // Antipodal quaternions are the same rotation: flip each into the first one's hemisphere.
    const float w0 = wi[0];
    const float w1 = dot4(q0, q1) < 0 ? -wi[1] : wi[1];
    const float w2 = dot4(q0, q2) < 0 ? -wi[2] : wi[2];
    const float w3 = dot4(q0, q3) < 0 ? -wi[3] : wi[3];
#ifdef MIMIC_BASELINES_AVX2
    // One dual quaternion is one 256-bit register: real (low) | dual (high).
    __m256 b = _mm256_mul_ps(_mm256_set1_ps(w0), _mm256_load_ps(q0));
    b = _mm256_fmadd_ps(_mm256_set1_ps(w1), _mm256_load_ps(q1), b);
    b = _mm256_fmadd_ps(_mm256_set1_ps(w2), _mm256_load_ps(q2), b);
    b = _mm256_fmadd_ps(_mm256_set1_ps(w3), _mm256_load_ps(q3), b);
    __m128 r = _mm256_castps256_ps128(b), d = _mm256_extractf128_ps(b, 1);
    const __m128 inv = simd::rsqrt(simd::dot4(r, r));
    r = _mm_mul_ps(r, inv), d = _mm_mul_ps(d, inv);
    // Translation 2 (r_w d − d_w r + r × d); rotation p + 2 r × (r × p + r_w p).
    const __m128 t = _mm_mul_ps(_mm_set1_ps(2.0f),
                                _mm_add_ps(_mm_fmsub_ps(simd::splat<3>(r), d, _mm_mul_ps(simd::splat<3>(d), r)),
                                           simd::cross(r, d)));
    simd::store3(out_p[v], _mm_add_ps(simd::rotate(r, simd::load3(in_p[v])), t));
    if constexpr (kNormals) simd::store3(out_n[v], simd::rotate(r, simd::load3(in_n[v])));
#else
    float b[8];  // real then dual: the two halves are contiguous in DualQuat
    for (int k = 0; k < 8; ++k) b[k] = w0 * q0[k] + w1 * q1[k] + w2 * q2[k] + w3 * q3[k];
    const float inv = 1.0f / std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2] + b[3] * b[3]);
    for (int k = 0; k < 8; ++k) b[k] *= inv;
    const float* r = b;
    const float* d = b + 4;
    const glm::vec3 p = in_p[v];
    const glm::vec3 rot = p + 2.0f * cross(r, cross(r, p) + r[3] * p);
    const glm::vec3 dv{d[0], d[1], d[2]};
    out_p[v] = rot + 2.0f * (r[3] * dv - d[3] * glm::vec3{r[0], r[1], r[2]} + cross(r, dv));
    if constexpr (kNormals) {
      const glm::vec3 q = in_n[v];
      out_n[v] = q + 2.0f * cross(r, cross(r, q) + r[3] * q);
    }
#endif
  }
}

}  // namespace

bool DualQuaternionSkinningJob::Run() const {
  if (!Validate()) return false;
  if (in_normals.empty())
    skin<false>(skinning_dual_quats.data(), joint_indices.data(), joint_weights.data(), in_positions.data(), nullptr,
                out_positions.data(), nullptr, in_positions.size());
  else
    skin<true>(skinning_dual_quats.data(), joint_indices.data(), joint_weights.data(), in_positions.data(),
               in_normals.data(), out_positions.data(), out_normals.data(), in_positions.size());
  return true;
}

}  // namespace mimic::avatar::baselines
