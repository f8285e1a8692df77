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

#ifdef MIMIC_BASELINES_AVX2
// Eight vertices at once: each vertex's dual quaternions are blended in its own register (signs
// from the three real-part dot products at once), the eight blends are transposed so each
// register holds one component of eight vertices, and normalisation and the transform run
// eight-wide. Returns the number of vertices done (a multiple of eight).
template <bool kNormals>
size_t skin_blocks(const DualQuat* __restrict dqs, const uint16_t* __restrict ji, const float* __restrict wi,
                   const glm::vec3* __restrict in_p, const glm::vec3* __restrict in_n, glm::vec3* __restrict out_p,
                   glm::vec3* __restrict out_n, size_t n) {
  const __m256 sign_mask = _mm256_castsi256_ps(_mm256_set1_epi32(int(0x80000000u)));
  size_t v = 0;
  for (; v + 8 <= n; v += 8) {
    __m256 b[8];
    for (int i = 0; i < 8; ++i) {
      const uint16_t* j = ji + (v + i) * kInfluences;
      const __m256 d0 = _mm256_load_ps(dqs[j[0]].real), d1 = _mm256_load_ps(dqs[j[1]].real);
      const __m256 d2 = _mm256_load_ps(dqs[j[2]].real), d3 = _mm256_load_ps(dqs[j[3]].real);
      // r0·r1 and r0·r2 side by side, r0·r3 alone, each summed across its four lanes; a
      // negative dot flips that dual quaternion (its weight's sign, in effect).
      const __m256 m12 = _mm256_mul_ps(_mm256_permute2f128_ps(d0, d0, 0x00), _mm256_permute2f128_ps(d1, d2, 0x20));
      const __m128 m3 = _mm_mul_ps(_mm256_castps256_ps128(d0), _mm256_castps256_ps128(d3));
      __m256 s12 = _mm256_add_ps(m12, _mm256_permute_ps(m12, _MM_SHUFFLE(2, 3, 0, 1)));
      s12 = _mm256_and_ps(_mm256_add_ps(s12, _mm256_permute_ps(s12, _MM_SHUFFLE(1, 0, 3, 2))), sign_mask);
      __m128 s3 = _mm_add_ps(m3, _mm_permute_ps(m3, _MM_SHUFFLE(2, 3, 0, 1)));
      s3 = _mm_and_ps(_mm_add_ps(s3, _mm_permute_ps(s3, _MM_SHUFFLE(1, 0, 3, 2))), _mm256_castps256_ps128(sign_mask));
      const float* w = wi + (v + i) * kInfluences;
      __m256 acc = _mm256_mul_ps(_mm256_broadcast_ss(w), d0);
      acc = _mm256_fmadd_ps(_mm256_broadcast_ss(w + 1), _mm256_xor_ps(d1, _mm256_permute2f128_ps(s12, s12, 0x00)), acc);
      acc = _mm256_fmadd_ps(_mm256_broadcast_ss(w + 2), _mm256_xor_ps(d2, _mm256_permute2f128_ps(s12, s12, 0x11)), acc);
      b[i] = _mm256_fmadd_ps(_mm256_broadcast_ss(w + 3), _mm256_xor_ps(d3, simd::pair(s3, s3)), acc);
    }
    // 8×8 transpose: c[k] holds component k (rx ry rz rw dx dy dz dw) of the eight vertices.
    const __m256 t0 = _mm256_unpacklo_ps(b[0], b[1]), t1 = _mm256_unpackhi_ps(b[0], b[1]);
    const __m256 t2 = _mm256_unpacklo_ps(b[2], b[3]), t3 = _mm256_unpackhi_ps(b[2], b[3]);
    const __m256 t4 = _mm256_unpacklo_ps(b[4], b[5]), t5 = _mm256_unpackhi_ps(b[4], b[5]);
    const __m256 t6 = _mm256_unpacklo_ps(b[6], b[7]), t7 = _mm256_unpackhi_ps(b[6], b[7]);
    const __m256 u0 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0)), u1 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2));
    const __m256 u2 = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0)), u3 = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(3, 2, 3, 2));
    const __m256 u4 = _mm256_shuffle_ps(t4, t6, _MM_SHUFFLE(1, 0, 1, 0)), u5 = _mm256_shuffle_ps(t4, t6, _MM_SHUFFLE(3, 2, 3, 2));
    const __m256 u6 = _mm256_shuffle_ps(t5, t7, _MM_SHUFFLE(1, 0, 1, 0)), u7 = _mm256_shuffle_ps(t5, t7, _MM_SHUFFLE(3, 2, 3, 2));
    __m256 rx = _mm256_permute2f128_ps(u0, u4, 0x20), ry = _mm256_permute2f128_ps(u1, u5, 0x20);
    __m256 rz = _mm256_permute2f128_ps(u2, u6, 0x20), rw = _mm256_permute2f128_ps(u3, u7, 0x20);
    __m256 dx = _mm256_permute2f128_ps(u0, u4, 0x31), dy = _mm256_permute2f128_ps(u1, u5, 0x31);
    __m256 dz = _mm256_permute2f128_ps(u2, u6, 0x31), dw = _mm256_permute2f128_ps(u3, u7, 0x31);
    // Normalise by the real part's length (estimate and one Newton step).
    const __m256 len2 = _mm256_fmadd_ps(rx, rx, _mm256_fmadd_ps(ry, ry, _mm256_fmadd_ps(rz, rz, _mm256_mul_ps(rw, rw))));
    const __m256 y = _mm256_rsqrt_ps(len2);
    const __m256 inv = _mm256_mul_ps(y, _mm256_fnmadd_ps(_mm256_mul_ps(_mm256_set1_ps(0.5f), len2), _mm256_mul_ps(y, y),
                                                         _mm256_set1_ps(1.5f)));
    rx = _mm256_mul_ps(rx, inv), ry = _mm256_mul_ps(ry, inv), rz = _mm256_mul_ps(rz, inv), rw = _mm256_mul_ps(rw, inv);
    dx = _mm256_mul_ps(dx, inv), dy = _mm256_mul_ps(dy, inv), dz = _mm256_mul_ps(dz, inv), dw = _mm256_mul_ps(dw, inv);
    const __m256 two = _mm256_set1_ps(2.0f);
    // Rotation of (x, y, z) by r: p + 2 r×(r×p + w p).
    auto rotate = [&](__m256 x, __m256 yy, __m256 z, __m256& ox, __m256& oy, __m256& oz) {
      const __m256 cx = _mm256_fmadd_ps(rw, x, _mm256_fmsub_ps(ry, z, _mm256_mul_ps(rz, yy)));
      const __m256 cy = _mm256_fmadd_ps(rw, yy, _mm256_fmsub_ps(rz, x, _mm256_mul_ps(rx, z)));
      const __m256 cz = _mm256_fmadd_ps(rw, z, _mm256_fmsub_ps(rx, yy, _mm256_mul_ps(ry, x)));
      ox = _mm256_fmadd_ps(two, _mm256_fmsub_ps(ry, cz, _mm256_mul_ps(rz, cy)), x);
      oy = _mm256_fmadd_ps(two, _mm256_fmsub_ps(rz, cx, _mm256_mul_ps(rx, cz)), yy);
      oz = _mm256_fmadd_ps(two, _mm256_fmsub_ps(rx, cy, _mm256_mul_ps(ry, cx)), z);
    };
    // Translation 2 (r_w d − d_w r + r × d).
    const __m256 tx = _mm256_mul_ps(two, _mm256_add_ps(_mm256_fmsub_ps(rw, dx, _mm256_mul_ps(dw, rx)),
                                                       _mm256_fmsub_ps(ry, dz, _mm256_mul_ps(rz, dy))));
    const __m256 ty = _mm256_mul_ps(two, _mm256_add_ps(_mm256_fmsub_ps(rw, dy, _mm256_mul_ps(dw, ry)),
                                                       _mm256_fmsub_ps(rz, dx, _mm256_mul_ps(rx, dz))));
    const __m256 tz = _mm256_mul_ps(two, _mm256_add_ps(_mm256_fmsub_ps(rw, dz, _mm256_mul_ps(dw, rz)),
                                                       _mm256_fmsub_ps(rx, dy, _mm256_mul_ps(ry, dx))));
    __m256 ox, oy, oz, px, py, pz;
    simd::load8(&in_p[v].x, px, py, pz);
    rotate(px, py, pz, ox, oy, oz);
    simd::store8(&out_p[v].x, _mm256_add_ps(ox, tx), _mm256_add_ps(oy, ty), _mm256_add_ps(oz, tz));
    if constexpr (kNormals) {
      simd::load8(&in_n[v].x, px, py, pz);
      rotate(px, py, pz, ox, oy, oz);
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
  if (in_normals.empty()) {
#ifdef MIMIC_BASELINES_AVX2
    done = skin_blocks<false>(skinning_dual_quats.data(), joint_indices.data(), joint_weights.data(), in_positions.data(),
                              nullptr, out_positions.data(), nullptr, n);
#endif
    skin<false>(skinning_dual_quats.data(), joint_indices.data() + done * kInfluences,
                joint_weights.data() + done * kInfluences, in_positions.data() + done, nullptr,
                out_positions.data() + done, nullptr, n - done);
  } else {
#ifdef MIMIC_BASELINES_AVX2
    done = skin_blocks<true>(skinning_dual_quats.data(), joint_indices.data(), joint_weights.data(), in_positions.data(),
                             in_normals.data(), out_positions.data(), out_normals.data(), n);
#endif
    skin<true>(skinning_dual_quats.data(), joint_indices.data() + done * kInfluences,
               joint_weights.data() + done * kInfluences, in_positions.data() + done, in_normals.data() + done,
               out_positions.data() + done, out_normals.data() + done, n - done);
  }
  return true;
}

}  // namespace mimic::avatar::baselines
