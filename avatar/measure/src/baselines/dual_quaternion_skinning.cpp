#include "mimic/avatar/baselines/dual_quaternion_skinning.h"

#include <cmath>

#include "mimic/avatar/baselines/skin_weights.h"
#include "mimic/avatar/simd.h"

namespace mimic::avatar::baselines {

bool DualQuaternionSkinningJob::Validate() const {
  const size_t n = in_positions.size();
  return !skinning_dual_quats.empty() && joint_indices.size() == n * kInfluences &&
         joint_weights.size() == n * kInfluences && out_positions.size() >= n &&
         (in_normals.empty() || in_normals.size() == n) && out_normals.size() >= in_normals.size();
}

namespace {

inline float dot4(const float* a, const float* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]; }

#ifndef MIMIC_SIMD_AVX2
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
#ifdef MIMIC_SIMD_AVX2
    // One dual quaternion is one 256-bit register: real (low) | dual (high).
    __m256 b = _mm256_mul_ps(_mm256_set1_ps(w0), _mm256_load_ps(q0));
    b = _mm256_fmadd_ps(_mm256_set1_ps(w1), _mm256_load_ps(q1), b);
    b = _mm256_fmadd_ps(_mm256_set1_ps(w2), _mm256_load_ps(q2), b);
    b = _mm256_fmadd_ps(_mm256_set1_ps(w3), _mm256_load_ps(q3), b);
    __m128 r = _mm256_castps256_ps128(b), d = _mm256_extractf128_ps(b, 1);
    const __m128 inv = simd::rsqrt(simd::dot4(r, r));
    r = _mm_mul_ps(r, inv), d = _mm_mul_ps(d, inv);
    // Translation 2 (r_w d − d_w r + r × d); rotation p + 2 r × (r × p + r_w p).
    const __m128 t =
        _mm_mul_ps(_mm_set1_ps(2.0f),
                   _mm_add_ps(_mm_fmsub_ps(simd::splat<3>(r), d, _mm_mul_ps(simd::splat<3>(d), r)), simd::cross(r, d)));
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

#ifdef MIMIC_SIMD_AVX2
// Eight vertices at once: each vertex's four dual quaternions are blended in its own register,
// each flipped into the first one's hemisphere by xor-ing in its flip mask (from the per-frame
// table `flips`, or from in-register dot products without one); the eight blends are transposed
// so each register holds one component of eight vertices, and the transform runs eight-wide.
// The blend is not normalised: with k = 2 / |r|², rotation p + k r×(r×p + r_w p) and
// translation k (r_w d − d_w r + r × d) are those of the normalised dual quaternion.
// Returns the number of vertices done (a multiple of eight).
template <bool kNormals>
size_t skin_blocks(const DualQuat* __restrict dqs, const simd::HemisphereFlips* flips, const uint16_t* __restrict ji,
                   const float* __restrict wi, const glm::vec3* __restrict in_p, const glm::vec3* __restrict in_n,
                   glm::vec3* __restrict out_p, glm::vec3* __restrict out_n, size_t n) {
  size_t v = 0;
  for (; v + 8 <= n; v += 8) {
    __m256 b[8];
#pragma GCC unroll 8
    for (int i = 0; i < 8; ++i) {
      const uint16_t* j = ji + (v + i) * kInfluences;
      const float* w = wi + (v + i) * kInfluences;
      const __m256 d[4] = {_mm256_load_ps(dqs[j[0]].real), _mm256_load_ps(dqs[j[1]].real),
                           _mm256_load_ps(dqs[j[2]].real), _mm256_load_ps(dqs[j[3]].real)};
      __m256 f1, f2, f3;
      simd::flips_of(
          flips, j, [&](int k) { return _mm256_castps256_ps128(d[k]); }, f1, f2, f3);
      __m256 acc = _mm256_mul_ps(_mm256_broadcast_ss(w), d[0]);
      acc = _mm256_fmadd_ps(_mm256_broadcast_ss(w + 1), _mm256_xor_ps(d[1], f1), acc);
      acc = _mm256_fmadd_ps(_mm256_broadcast_ss(w + 2), _mm256_xor_ps(d[2], f2), acc);
      b[i] = _mm256_fmadd_ps(_mm256_broadcast_ss(w + 3), _mm256_xor_ps(d[3], f3), acc);
    }
    // Component k (rx ry rz rw dx dy dz dw) of the eight vertices.
    __m256 c[8];
    simd::transpose8x8(b, c);
    const __m256 rx = c[0], ry = c[1], rz = c[2], rw = c[3], dx = c[4], dy = c[5], dz = c[6], dw = c[7];
    const __m256 k = simd::two_over_norm2(rx, ry, rz, rw);
    // Translation k (r_w d − d_w r + r × d).
    const __m256 tx = _mm256_mul_ps(k, _mm256_add_ps(_mm256_fmsub_ps(rw, dx, _mm256_mul_ps(dw, rx)),
                                                     _mm256_fmsub_ps(ry, dz, _mm256_mul_ps(rz, dy))));
    const __m256 ty = _mm256_mul_ps(k, _mm256_add_ps(_mm256_fmsub_ps(rw, dy, _mm256_mul_ps(dw, ry)),
                                                     _mm256_fmsub_ps(rz, dx, _mm256_mul_ps(rx, dz))));
    const __m256 tz = _mm256_mul_ps(k, _mm256_add_ps(_mm256_fmsub_ps(rw, dz, _mm256_mul_ps(dw, rz)),
                                                     _mm256_fmsub_ps(rx, dy, _mm256_mul_ps(ry, dx))));
    __m256 ox, oy, oz, px, py, pz;
    simd::load8(&in_p[v].x, px, py, pz);
    simd::rotate8(rx, ry, rz, rw, k, px, py, pz, ox, oy, oz);
    simd::store8(&out_p[v].x, _mm256_add_ps(ox, tx), _mm256_add_ps(oy, ty), _mm256_add_ps(oz, tz));
    if constexpr (kNormals) {
      simd::load8(&in_n[v].x, px, py, pz);
      simd::rotate8(rx, ry, rz, rw, k, px, py, pz, ox, oy, oz);
      simd::store8(&out_n[v].x, ox, oy, oz);
    }
  }
  return v;
}
#endif

}  // namespace

bool DualQuaternionSkinningJob::Run() const {
  if (!Validate()) return false;
  const size_t n = in_positions.size();
  size_t done = 0;  // vertices the eight-wide kernel took; the rest one by one
#ifdef MIMIC_SIMD_AVX2
  simd::HemisphereFlips table;
  const simd::HemisphereFlips* flips =
      n >= 8 && table.fill(skinning_dual_quats[0].real, sizeof(DualQuat) / sizeof(float), skinning_dual_quats.size())
          ? &table
          : nullptr;
  done = in_normals.empty()
             ? skin_blocks<false>(skinning_dual_quats.data(), flips, joint_indices.data(), joint_weights.data(),
                                  in_positions.data(), nullptr, out_positions.data(), nullptr, n)
             : skin_blocks<true>(skinning_dual_quats.data(), flips, joint_indices.data(), joint_weights.data(),
                                 in_positions.data(), in_normals.data(), out_positions.data(), out_normals.data(), n);
#endif
  const uint16_t* ji = joint_indices.data() + done * kInfluences;
  const float* wi = joint_weights.data() + done * kInfluences;
  if (in_normals.empty())
    skin<false>(skinning_dual_quats.data(), ji, wi, in_positions.data() + done, nullptr, out_positions.data() + done,
                nullptr, n - done);
  else
    skin<true>(skinning_dual_quats.data(), ji, wi, in_positions.data() + done, in_normals.data() + done,
               out_positions.data() + done, out_normals.data() + done, n - done);
  return true;
}

}  // namespace mimic::avatar::baselines
