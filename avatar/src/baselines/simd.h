// Internal: the few AVX/FMA helpers the baseline skinning kernels share. Where the target lacks
// AVX2 and FMA (a build without -march=native), the kernels take their portable scalar loops.
#pragma once

#if defined(__AVX2__) && defined(__FMA__)
#define MIMIC_BASELINES_AVX2 1
#include <immintrin.h>

#include <glm/glm.hpp>

namespace mimic::avatar::baselines::simd {

// (a | b): a in the low 128 bits, b in the high.
inline __m256 pair(__m128 lo, __m128 hi) { return _mm256_insertf128_ps(_mm256_castps128_ps256(lo), hi, 1); }

inline __m128 load3(const glm::vec3& v) {  // (x, y, z, 0) without reading past the vector
  // 64-bit loads and stores through the unaligned-integer forms: a vec3 is only 4-byte aligned.
  const __m128 xy = _mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(&v.x)));
  return _mm_movelh_ps(xy, _mm_load_ss(&v.z));
}

inline void store3(glm::vec3& out, __m128 v) {
  _mm_storel_epi64(reinterpret_cast<__m128i*>(&out.x), _mm_castps_si128(v));
  _mm_store_ss(&out.z, _mm_movehl_ps(v, v));
}

template <int i>
inline __m128 splat(__m128 v) {
  return _mm_shuffle_ps(v, v, _MM_SHUFFLE(i, i, i, i));
}

// a × b in the x, y, z lanes (w lane: 0 when both w are finite).
inline __m128 cross(__m128 a, __m128 b) {
  const __m128 a_yzx = _mm_shuffle_ps(a, a, _MM_SHUFFLE(3, 0, 2, 1));
  const __m128 b_yzx = _mm_shuffle_ps(b, b, _MM_SHUFFLE(3, 0, 2, 1));
  const __m128 c = _mm_fmsub_ps(a, b_yzx, _mm_mul_ps(a_yzx, b));
  return _mm_shuffle_ps(c, c, _MM_SHUFFLE(3, 0, 2, 1));
}

// (a·a) in every lane, from four lanes.
inline __m128 dot4(__m128 a, __m128 b) {
  const __m128 m = _mm_mul_ps(a, b);
  const __m128 s = _mm_add_ps(m, _mm_shuffle_ps(m, m, _MM_SHUFFLE(2, 3, 0, 1)));  // (x+y, x+y, z+w, z+w)
  return _mm_add_ps(s, _mm_shuffle_ps(s, s, _MM_SHUFFLE(1, 0, 3, 2)));
}

// 1 / sqrt(x) to float precision: the hardware estimate and one Newton step.
inline __m128 rsqrt(__m128 x) {
  const __m128 y = _mm_rsqrt_ps(x);
  const __m128 half_x_yy = _mm_mul_ps(_mm_mul_ps(_mm_set1_ps(0.5f), x), _mm_mul_ps(y, y));
  return _mm_mul_ps(y, _mm_sub_ps(_mm_set1_ps(1.5f), half_x_yy));
}

// Rotation of v (w lane 0) by the unit quaternion q = (x, y, z, w): v + 2 q×(q×v + w v).
inline __m128 rotate(__m128 q, __m128 v) {
  const __m128 t = _mm_fmadd_ps(splat<3>(q), v, cross(q, v));
  const __m128 u = cross(q, t);
  return _mm_fmadd_ps(_mm_set1_ps(2.0f), u, v);
}

// Σ w_k M_k over four column-major matrices, as (col0 | col1) and (col2 | col3).
struct Blend {
  __m256 c01, c23;
};
inline Blend blend(const float* m0, const float* m1, const float* m2, const float* m3, const float* w) {
  const __m256 w0 = _mm256_broadcast_ss(w), w1 = _mm256_broadcast_ss(w + 1);
  const __m256 w2 = _mm256_broadcast_ss(w + 2), w3 = _mm256_broadcast_ss(w + 3);
  __m256 c01 = _mm256_mul_ps(w0, _mm256_load_ps(m0));
  __m256 c23 = _mm256_mul_ps(w0, _mm256_load_ps(m0 + 8));
  c01 = _mm256_fmadd_ps(w1, _mm256_load_ps(m1), c01);
  c23 = _mm256_fmadd_ps(w1, _mm256_load_ps(m1 + 8), c23);
  c01 = _mm256_fmadd_ps(w2, _mm256_load_ps(m2), c01);
  c23 = _mm256_fmadd_ps(w2, _mm256_load_ps(m2 + 8), c23);
  c01 = _mm256_fmadd_ps(w3, _mm256_load_ps(m3), c01);
  c23 = _mm256_fmadd_ps(w3, _mm256_load_ps(m3 + 8), c23);
  return {c01, c23};
}

// The blended matrix applied to a point (x, y, z, _) or, with `translate` 0, to a direction.
inline __m128 apply(const Blend& b, __m128 p, float translate) {
  const __m256 xy = pair(splat<0>(p), splat<1>(p));
  const __m256 z1 = pair(splat<2>(p), _mm_set1_ps(translate));
  const __m256 r = _mm256_fmadd_ps(b.c01, xy, _mm256_mul_ps(b.c23, z1));
  return _mm_add_ps(_mm256_castps256_ps128(r), _mm256_extractf128_ps(r, 1));
}

// Eight packed (x, y, z) triples ⇄ three registers of x, y and z, by shuffles (the usual
// "AoS3 to SoA" permutation: lanes gathered with two blends, then put in order by one permute).
inline void load8(const float* p, __m256& x, __m256& y, __m256& z) {
  const __m256 a = _mm256_loadu_ps(p), b = _mm256_loadu_ps(p + 8), c = _mm256_loadu_ps(p + 16);
  // a = x0 y0 z0 x1 y1 z1 x2 y2 | b = z2 x3 y3 z3 x4 y4 z4 x5 | c = y5 z5 x6 y6 z6 x7 y7 z7
  const __m256 xs = _mm256_blend_ps(_mm256_blend_ps(a, b, 0b10010010), c, 0b00100100);
  const __m256 ys = _mm256_blend_ps(_mm256_blend_ps(a, b, 0b00100100), c, 0b01001001);
  const __m256 zs = _mm256_blend_ps(_mm256_blend_ps(a, b, 0b01001001), c, 0b10010010);
  x = _mm256_permutevar8x32_ps(xs, _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5));
  y = _mm256_permutevar8x32_ps(ys, _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6));
  z = _mm256_permutevar8x32_ps(zs, _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7));
}

inline void store8(float* p, __m256 x, __m256 y, __m256 z) {
  // The inverse permutations, then the same blends.
  const __m256 xs = _mm256_permutevar8x32_ps(x, _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5));
  const __m256 ys = _mm256_permutevar8x32_ps(y, _mm256_setr_epi32(5, 0, 3, 6, 1, 4, 7, 2));
  const __m256 zs = _mm256_permutevar8x32_ps(z, _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7));
  _mm256_storeu_ps(p, _mm256_blend_ps(_mm256_blend_ps(xs, ys, 0b10010010), zs, 0b00100100));
  _mm256_storeu_ps(p + 8, _mm256_blend_ps(_mm256_blend_ps(xs, ys, 0b00100100), zs, 0b01001001));
  _mm256_storeu_ps(p + 16, _mm256_blend_ps(_mm256_blend_ps(xs, ys, 0b01001001), zs, 0b10010010));
}

// Transposes eight (x, y, z, w) quadruples into four registers of eight x, y, z and w.
inline void transpose8x4(const __m128* in, __m256& x, __m256& y, __m256& z, __m256& w) {
  const __m256 r0 = pair(in[0], in[4]), r1 = pair(in[1], in[5]), r2 = pair(in[2], in[6]), r3 = pair(in[3], in[7]);
  const __m256 t0 = _mm256_unpacklo_ps(r0, r1), t1 = _mm256_unpackhi_ps(r0, r1);
  const __m256 t2 = _mm256_unpacklo_ps(r2, r3), t3 = _mm256_unpackhi_ps(r2, r3);
  x = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0));
  y = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2));
  z = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0));
  w = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(3, 2, 3, 2));
}

// Eight rotations at once: (x, y, z) by the unit quaternions (qx, qy, qz, qw):
// p + 2 q×(q×p + w p).
inline void rotate8(__m256 qx, __m256 qy, __m256 qz, __m256 qw, __m256 x, __m256 y, __m256 z, __m256& ox, __m256& oy,
                    __m256& oz) {
  const __m256 two = _mm256_set1_ps(2.0f);
  const __m256 cx = _mm256_fmadd_ps(qw, x, _mm256_fmsub_ps(qy, z, _mm256_mul_ps(qz, y)));
  const __m256 cy = _mm256_fmadd_ps(qw, y, _mm256_fmsub_ps(qz, x, _mm256_mul_ps(qx, z)));
  const __m256 cz = _mm256_fmadd_ps(qw, z, _mm256_fmsub_ps(qx, y, _mm256_mul_ps(qy, x)));
  ox = _mm256_fmadd_ps(two, _mm256_fmsub_ps(qy, cz, _mm256_mul_ps(qz, cy)), x);
  oy = _mm256_fmadd_ps(two, _mm256_fmsub_ps(qz, cx, _mm256_mul_ps(qx, cz)), y);
  oz = _mm256_fmadd_ps(two, _mm256_fmsub_ps(qx, cy, _mm256_mul_ps(qy, cx)), z);
}

// 1 / sqrt(x), eight lanes: the estimate and one Newton step.
inline __m256 rsqrt8(__m256 x) {
  const __m256 y = _mm256_rsqrt_ps(x);
  return _mm256_mul_ps(y, _mm256_fnmadd_ps(_mm256_mul_ps(_mm256_set1_ps(0.5f), x), _mm256_mul_ps(y, y),
                                           _mm256_set1_ps(1.5f)));
}

}  // namespace mimic::avatar::baselines::simd
#endif
