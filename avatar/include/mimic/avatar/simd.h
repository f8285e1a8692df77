// The few AVX/FMA helpers the realtime skin and the baseline skinning kernels share. Where the target lacks
// AVX2 and FMA (a build without -march=native), the kernels take their portable scalar loops.
#pragma once

#if defined(__AVX2__) && defined(__FMA__)
#define MIMIC_SIMD_AVX2 1
#include <immintrin.h>

#include <glm/glm.hpp>

namespace mimic::avatar::simd {

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
inline Blend blend(const float* m0, const float* m1, const float* m2, const float* m3, __m256 w0, __m256 w1, __m256 w2,
                   __m256 w3) {
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
inline Blend blend(const float* m0, const float* m1, const float* m2, const float* m3, const float* w) {
  return blend(m0, m1, m2, m3, _mm256_broadcast_ss(w), _mm256_broadcast_ss(w + 1), _mm256_broadcast_ss(w + 2),
               _mm256_broadcast_ss(w + 3));
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

// Transposes eight registers of eight: out[k] holds lane k of in[0..7].
inline void transpose8x8(const __m256* in, __m256* out) {
  const __m256 t0 = _mm256_unpacklo_ps(in[0], in[1]), t1 = _mm256_unpackhi_ps(in[0], in[1]);
  const __m256 t2 = _mm256_unpacklo_ps(in[2], in[3]), t3 = _mm256_unpackhi_ps(in[2], in[3]);
  const __m256 t4 = _mm256_unpacklo_ps(in[4], in[5]), t5 = _mm256_unpackhi_ps(in[4], in[5]);
  const __m256 t6 = _mm256_unpacklo_ps(in[6], in[7]), t7 = _mm256_unpackhi_ps(in[6], in[7]);
  const __m256 u0 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0)),
               u1 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2));
  const __m256 u2 = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0)),
               u3 = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(3, 2, 3, 2));
  const __m256 u4 = _mm256_shuffle_ps(t4, t6, _MM_SHUFFLE(1, 0, 1, 0)),
               u5 = _mm256_shuffle_ps(t4, t6, _MM_SHUFFLE(3, 2, 3, 2));
  const __m256 u6 = _mm256_shuffle_ps(t5, t7, _MM_SHUFFLE(1, 0, 1, 0)),
               u7 = _mm256_shuffle_ps(t5, t7, _MM_SHUFFLE(3, 2, 3, 2));
  out[0] = _mm256_permute2f128_ps(u0, u4, 0x20), out[1] = _mm256_permute2f128_ps(u1, u5, 0x20);
  out[2] = _mm256_permute2f128_ps(u2, u6, 0x20), out[3] = _mm256_permute2f128_ps(u3, u7, 0x20);
  out[4] = _mm256_permute2f128_ps(u0, u4, 0x31), out[5] = _mm256_permute2f128_ps(u1, u5, 0x31);
  out[6] = _mm256_permute2f128_ps(u2, u6, 0x31), out[7] = _mm256_permute2f128_ps(u3, u7, 0x31);
}

// Eight rotations at once by quaternions q = (qx, qy, qz, qw) that need not be unit:
// p + k q×(q×p + w p) with k = 2 / |q|² (two_over_norm2) is the rotation by q/|q|, so a
// blended quaternion needs no normalisation, only that one factor.
inline void rotate8(__m256 qx, __m256 qy, __m256 qz, __m256 qw, __m256 two_over_norm2, __m256 x, __m256 y, __m256 z,
                    __m256& ox, __m256& oy, __m256& oz) {
  const __m256 cx = _mm256_fmadd_ps(qw, x, _mm256_fmsub_ps(qy, z, _mm256_mul_ps(qz, y)));
  const __m256 cy = _mm256_fmadd_ps(qw, y, _mm256_fmsub_ps(qz, x, _mm256_mul_ps(qx, z)));
  const __m256 cz = _mm256_fmadd_ps(qw, z, _mm256_fmsub_ps(qx, y, _mm256_mul_ps(qy, x)));
  ox = _mm256_fmadd_ps(two_over_norm2, _mm256_fmsub_ps(qy, cz, _mm256_mul_ps(qz, cy)), x);
  oy = _mm256_fmadd_ps(two_over_norm2, _mm256_fmsub_ps(qz, cx, _mm256_mul_ps(qx, cz)), y);
  oz = _mm256_fmadd_ps(two_over_norm2, _mm256_fmsub_ps(qx, cy, _mm256_mul_ps(qy, cx)), z);
}

// 2 / |q|², eight lanes.
inline __m256 two_over_norm2(__m256 qx, __m256 qy, __m256 qz, __m256 qw) {
  const __m256 n2 =
      _mm256_add_ps(_mm256_fmadd_ps(qx, qx, _mm256_mul_ps(qy, qy)), _mm256_fmadd_ps(qz, qz, _mm256_mul_ps(qw, qw)));
  return _mm256_div_ps(_mm256_set1_ps(2.0f), n2);
}

// The hemisphere test of quaternion blending (flip q_k when q_0 · q_k < 0), per frame for every
// pair of joints instead of per vertex: a vertex then reads its three flips from its first
// joint's row (broadcast loads) instead of taking three dot products across lanes. The same
// test, for skeletons of up to kMaxJoints joints (16 KB on the stack).
struct HemisphereFlips {
  static constexpr size_t kMaxJoints = 64;
  // −0.0f where q_a · q_b < 0, else +0.0f: xor-ing it into q_b's lanes flips q_b.
  alignas(32) float mask[kMaxJoints * kMaxJoints];

  const float* row(uint16_t a) const { return mask + size_t{a} * kMaxJoints; }

  // `q`: joint 0's quaternion (x, y, z, w), each next joint's `stride` floats further. False
  // (and nothing filled) for more than kMaxJoints joints.
  bool fill(const float* q, size_t stride, size_t joints) {
    if (joints > kMaxJoints) return false;
    alignas(32) float x[kMaxJoints], y[kMaxJoints], z[kMaxJoints], w[kMaxJoints];
    const size_t padded = (joints + 7) & ~size_t{7};
    for (size_t j = 0; j < padded; ++j) {
      const bool in = j < joints;
      x[j] = in ? q[j * stride] : 0.0f, y[j] = in ? q[j * stride + 1] : 0.0f;
      z[j] = in ? q[j * stride + 2] : 0.0f, w[j] = in ? q[j * stride + 3] : 0.0f;
    }
    const __m256 sign = _mm256_set1_ps(-0.0f);
    for (size_t a = 0; a < joints; ++a) {
      const __m256 ax = _mm256_set1_ps(x[a]), ay = _mm256_set1_ps(y[a]), az = _mm256_set1_ps(z[a]),
                   aw = _mm256_set1_ps(w[a]);
      for (size_t b = 0; b < padded; b += 8) {
        const __m256 dot = _mm256_fmadd_ps(
            ax, _mm256_load_ps(x + b),
            _mm256_fmadd_ps(ay, _mm256_load_ps(y + b),
                            _mm256_fmadd_ps(az, _mm256_load_ps(z + b), _mm256_mul_ps(aw, _mm256_load_ps(w + b)))));
        _mm256_store_ps(mask + a * kMaxJoints + b, _mm256_and_ps(dot, sign));  // as flips_by_dots
      }
    }
    return true;
  }
};

// The flip masks of q1, q2, q3 against q0 from in-register dot products (skeletons past
// HemisphereFlips::kMaxJoints): each mask −0.0f in every lane where the dot is negative.
inline void flips_by_dots(__m128 q0, __m128 q1, __m128 q2, __m128 q3, __m128& f1, __m128& f2, __m128& f3) {
  const __m128 sign = _mm_set1_ps(-0.0f);
  const __m256 m12 = _mm256_mul_ps(pair(q0, q0), pair(q1, q2));
  const __m128 m3 = _mm_mul_ps(q0, q3);
  __m256 s12 = _mm256_add_ps(m12, _mm256_permute_ps(m12, _MM_SHUFFLE(2, 3, 0, 1)));
  s12 = _mm256_and_ps(_mm256_add_ps(s12, _mm256_permute_ps(s12, _MM_SHUFFLE(1, 0, 3, 2))), pair(sign, sign));
  __m128 s3 = _mm_add_ps(m3, _mm_permute_ps(m3, _MM_SHUFFLE(2, 3, 0, 1)));
  f3 = _mm_and_ps(_mm_add_ps(s3, _mm_permute_ps(s3, _MM_SHUFFLE(1, 0, 3, 2))), sign);
  f1 = _mm256_castps256_ps128(s12), f2 = _mm256_extractf128_ps(s12, 1);
}

// A vertex's flip masks (every lane) of its joints j[1..3] against j[0]: from the per-frame
// table, or, without one, from the dot products of the quaternions quat(0..3) (each __m128).
template <class Quat>
inline void flips_of(const HemisphereFlips* table, const uint16_t* j, Quat&& quat, __m256& f1, __m256& f2, __m256& f3) {
  if (table) {
    const float* row = table->row(j[0]);
    f1 = _mm256_broadcast_ss(row + j[1]), f2 = _mm256_broadcast_ss(row + j[2]), f3 = _mm256_broadcast_ss(row + j[3]);
  } else {
    __m128 g1, g2, g3;
    flips_by_dots(quat(0), quat(1), quat(2), quat(3), g1, g2, g3);
    f1 = pair(g1, g1), f2 = pair(g2, g2), f3 = pair(g3, g3);
  }
}

// 1 / sqrt(x), eight lanes: the estimate and one Newton step.
inline __m256 rsqrt8(__m256 x) {
  const __m256 y = _mm256_rsqrt_ps(x);
  return _mm256_mul_ps(
      y, _mm256_fnmadd_ps(_mm256_mul_ps(_mm256_set1_ps(0.5f), x), _mm256_mul_ps(y, y), _mm256_set1_ps(1.5f)));
}

}  // namespace mimic::avatar::simd
#endif
