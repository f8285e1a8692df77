#include "mimic/avatar/baselines/cor_skinning.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <unordered_map>
#include <vector>

#include "mimic/avatar/simd.h"

namespace mimic::avatar::baselines {

namespace {

// A sparse weight vector: up to 12 (joint, weight) entries (a triangle's three vertices × 4).
struct Sparse {
  uint16_t joint[12];
  float weight[12];
  int count = 0;
  float get(uint16_t j) const {
    for (int k = 0; k < count; ++k)
      if (joint[k] == j) return weight[k];
    return 0.0f;
  }
  void add(uint16_t j, float w) {
    for (int k = 0; k < count; ++k)
      if (joint[k] == j) {
        weight[k] += w;
        return;
      }
    joint[count] = j, weight[count] = w, ++count;
  }
};

uint32_t pair_key(uint16_t a, uint16_t b) {
  if (a > b) std::swap(a, b);
  return (uint32_t{a} << 16) | b;
}

}  // namespace

void compute_centers_of_rotation(std::span<const glm::vec3> rest, std::span<const uint32_t> indices,
                                 const SkinWeights& weights, std::span<glm::vec3> out, float sigma) {
  assert(weights.vertex_count() == rest.size() && out.size() == rest.size());
  const size_t tri_count = indices.size() / 3;
  std::vector<Sparse> tri_w(tri_count);
  std::vector<glm::vec3> centroid(tri_count);
  std::vector<float> area(tri_count);
  // Triangles indexed by each pair of joints they both weigh: only those can be similar to a
  // vertex with that pair (every term of s needs w_pj w_pk w_vj w_vk > 0).
  std::unordered_map<uint32_t, std::vector<uint32_t>> by_pair;
  for (size_t t = 0; t < tri_count; ++t) {
    const uint32_t* tri = &indices[3 * t];
    const glm::vec3 a = rest[tri[0]], b = rest[tri[1]], c = rest[tri[2]];
    centroid[t] = (a + b + c) / 3.0f;
    area[t] = 0.5f * glm::length(glm::cross(b - a, c - a));
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < kInfluences; ++i) {
        const float w = weights.weights[tri[k] * kInfluences + i];
        if (w > 0) tri_w[t].add(weights.joints[tri[k] * kInfluences + i], w / 3.0f);
      }
    const Sparse& s = tri_w[t];
    for (int i = 0; i < s.count; ++i)
      for (int k = i + 1; k < s.count; ++k)
        by_pair[pair_key(s.joint[i], s.joint[k])].push_back(static_cast<uint32_t>(t));
  }
  const float inv_sigma2 = 1.0f / (sigma * sigma);
  std::vector<size_t> stamp(tri_count, SIZE_MAX);
  for (size_t v = 0; v < rest.size(); ++v) {
    out[v] = rest[v];  // no similar triangle: p* = v, i.e. plain LBS
    const uint16_t* jv = &weights.joints[v * kInfluences];
    const float* wv = &weights.weights[v * kInfluences];
    double sum_w = 0;
    glm::dvec3 sum_c{0.0};
    for (int i = 0; i < kInfluences; ++i)
      for (int k = i + 1; k < kInfluences; ++k) {
        if (!(wv[i] > 0 && wv[k] > 0) || jv[i] == jv[k]) continue;
        auto it = by_pair.find(pair_key(jv[i], jv[k]));
        if (it == by_pair.end()) continue;
        for (uint32_t t : it->second) {
          if (stamp[t] == v) continue;
          stamp[t] = v;
          // Similarity over the vertex's joint pairs (the only ones with non-zero terms).
          double sim = 0;
          for (int a = 0; a < kInfluences; ++a)
            for (int b = a + 1; b < kInfluences; ++b) {
              if (!(wv[a] > 0 && wv[b] > 0) || jv[a] == jv[b]) continue;
              const float ta = tri_w[t].get(jv[a]), tb = tri_w[t].get(jv[b]);
              if (!(ta > 0 && tb > 0)) continue;
              const float x = wv[a] * tb - wv[b] * ta;
              sim += double(wv[a] * wv[b] * ta * tb) * std::exp(-double(x * x * inv_sigma2));
            }
          sum_w += sim * area[t];
          sum_c += sim * area[t] * glm::dvec3(centroid[t]);
        }
      }
    if (sum_w > 1e-12) out[v] = glm::vec3(sum_c / sum_w);
  }
}

bool CorSkinningJob::Validate() const {
  const size_t n = in_positions.size();
  return !skinning_matrices.empty() && skinning_rotations.size() == skinning_matrices.size() &&
         joint_indices.size() == n * kInfluences && joint_weights.size() == n * kInfluences &&
         centers_of_rotation.size() == n && out_positions.size() >= n &&
         (in_normals.empty() || in_normals.size() == n) && out_normals.size() >= in_normals.size();
}

namespace {

template <bool kNormals>
void skin(const SkinningMatrix* __restrict mats, const glm::quat* __restrict rots, const uint16_t* __restrict ji,
          const float* __restrict wi, const glm::vec3* __restrict cor, const glm::vec3* __restrict in_p,
          const glm::vec3* __restrict in_n, glm::vec3* __restrict out_p, glm::vec3* __restrict out_n, size_t n) {
  static_assert(sizeof(glm::quat) == 16, "quaternions are four floats x, y, z, w");
  for (size_t v = 0; v < n; ++v, ji += kInfluences, wi += kInfluences) {
    const glm::quat q0 = rots[ji[0]], q1 = rots[ji[1]], q2 = rots[ji[2]], q3 = rots[ji[3]];
    const float w0 = wi[0];
    const float w1 = glm::dot(q0, q1) < 0 ? -wi[1] : wi[1];
    const float w2 = glm::dot(q0, q2) < 0 ? -wi[2] : wi[2];
    const float w3 = glm::dot(q0, q3) < 0 ? -wi[3] : wi[3];
#ifdef MIMIC_SIMD_AVX2
    __m128 q = _mm_mul_ps(_mm_set1_ps(w0), _mm_loadu_ps(&q0.x));
    q = _mm_fmadd_ps(_mm_set1_ps(w1), _mm_loadu_ps(&q1.x), q);
    q = _mm_fmadd_ps(_mm_set1_ps(w2), _mm_loadu_ps(&q2.x), q);
    q = _mm_fmadd_ps(_mm_set1_ps(w3), _mm_loadu_ps(&q3.x), q);
    q = _mm_mul_ps(q, simd::rsqrt(simd::dot4(q, q)));
    // t = the LBS-blended matrix applied to the centre; v' = R (v − p*) + t.
    const simd::Blend b = simd::blend(&mats[ji[0]].cols[0][0], &mats[ji[1]].cols[0][0], &mats[ji[2]].cols[0][0],
                                      &mats[ji[3]].cols[0][0], wi);
    const __m128 c = simd::load3(cor[v]);
    const __m128 t = simd::apply(b, c, 1.0f);
    simd::store3(out_p[v], _mm_add_ps(simd::rotate(q, _mm_sub_ps(simd::load3(in_p[v]), c)), t));
    if constexpr (kNormals) simd::store3(out_n[v], simd::rotate(q, simd::load3(in_n[v])));
#else
    glm::quat q{w0 * q0.w + w1 * q1.w + w2 * q2.w + w3 * q3.w, w0 * q0.x + w1 * q1.x + w2 * q2.x + w3 * q3.x,
                w0 * q0.y + w1 * q1.y + w2 * q2.y + w3 * q3.y, w0 * q0.z + w1 * q1.z + w2 * q2.z + w3 * q3.z};
    q = q * (1.0f / std::sqrt(glm::dot(q, q)));
    float m[4][3];
    for (int col = 0; col < 4; ++col)
      for (int r = 0; r < 3; ++r)
        m[col][r] = wi[0] * mats[ji[0]].cols[col][r] + wi[1] * mats[ji[1]].cols[col][r] +
                    wi[2] * mats[ji[2]].cols[col][r] + wi[3] * mats[ji[3]].cols[col][r];
    const glm::vec3 c = cor[v];
    glm::vec3 t;
    for (int r = 0; r < 3; ++r) t[r] = m[0][r] * c.x + m[1][r] * c.y + m[2][r] * c.z + m[3][r];
    out_p[v] = q * (in_p[v] - c) + t;
    if constexpr (kNormals) out_n[v] = q * in_n[v];
#endif
  }
}

#ifdef MIMIC_SIMD_AVX2
// Per frame, for the eight-wide kernel: each joint's matrix with its rotation quaternion in the
// columns' unused fourth lanes (x, y, z, w in columns 0..3), so one blend of two registers per
// influence gives both the blended matrix and the blended quaternion.
constexpr size_t kMaxPackedJoints = 256;  // 16 KB on the stack
struct PackedJoints {
  SkinningMatrix joint[kMaxPackedJoints];
};

void pack(std::span<const SkinningMatrix> mats, std::span<const glm::quat> rots, PackedJoints& out) {
  for (size_t j = 0; j < mats.size(); ++j) {
    out.joint[j] = mats[j];
    out.joint[j].cols[0][3] = rots[j].x, out.joint[j].cols[1][3] = rots[j].y;
    out.joint[j].cols[2][3] = rots[j].z, out.joint[j].cols[3][3] = rots[j].w;
  }
}

// Eight vertices at once. Per vertex one blend of the packed joints, the quaternion lanes'
// weights flipped into the first joint's hemisphere (masks from the per-frame table `flips`, or
// from in-register dot products without one). The sixteen blended registers of the eight
// vertices are transposed, so every matrix entry and quaternion component of the eight is one
// register: t = M c and the rotation about the centre run eight-wide, with k = 2 / |q|² in
// place of normalising q. Returns the number of vertices done (a multiple of eight).
template <bool kNormals>
size_t skin_blocks(const PackedJoints& packed, const glm::quat* __restrict rots, const simd::HemisphereFlips* flips,
                   const uint16_t* __restrict ji, const float* __restrict wi, const glm::vec3* __restrict cor,
                   const glm::vec3* __restrict in_p, const glm::vec3* __restrict in_n, glm::vec3* __restrict out_p,
                   glm::vec3* __restrict out_n, size_t n) {
  const __m256 q_lanes = _mm256_castsi256_ps(_mm256_setr_epi32(0, 0, 0, -1, 0, 0, 0, -1));
  size_t v = 0;
  for (; v + 8 <= n; v += 8) {
    __m256 c01[8], c23[8];
#pragma GCC unroll 8
    for (int i = 0; i < 8; ++i) {
      const uint16_t* j = ji + (v + i) * kInfluences;
      const float* w = wi + (v + i) * kInfluences;
      __m256 f1, f2, f3;
      simd::flips_of(
          flips, j, [&](int k) { return _mm_loadu_ps(&rots[j[k]].x); }, f1, f2, f3);
      // A flip negates the weight in the quaternion lanes only: the matrices blend as LBS's.
      const __m256 w0 = _mm256_broadcast_ss(w);
      const __m256 w1 = _mm256_xor_ps(_mm256_broadcast_ss(w + 1), _mm256_and_ps(f1, q_lanes));
      const __m256 w2 = _mm256_xor_ps(_mm256_broadcast_ss(w + 2), _mm256_and_ps(f2, q_lanes));
      const __m256 w3 = _mm256_xor_ps(_mm256_broadcast_ss(w + 3), _mm256_and_ps(f3, q_lanes));
      const simd::Blend b = simd::blend(&packed.joint[j[0]].cols[0][0], &packed.joint[j[1]].cols[0][0],
                                        &packed.joint[j[2]].cols[0][0], &packed.joint[j[3]].cols[0][0], w0, w1, w2, w3);
      c01[i] = b.c01, c23[i] = b.c23;
    }
    // a[k]: column 0 (x, y, z), qx, column 1, qy; b[k]: column 2, qz, column 3 (translation), qw.
    __m256 a[8], b[8];
    simd::transpose8x8(c01, a);
    simd::transpose8x8(c23, b);
    __m256 px, py, pz, cx, cy, cz, ox, oy, oz;
    simd::load8(&cor[v].x, cx, cy, cz);
    const __m256 tx = _mm256_fmadd_ps(a[0], cx, _mm256_fmadd_ps(a[4], cy, _mm256_fmadd_ps(b[0], cz, b[4])));
    const __m256 ty = _mm256_fmadd_ps(a[1], cx, _mm256_fmadd_ps(a[5], cy, _mm256_fmadd_ps(b[1], cz, b[5])));
    const __m256 tz = _mm256_fmadd_ps(a[2], cx, _mm256_fmadd_ps(a[6], cy, _mm256_fmadd_ps(b[2], cz, b[6])));
    const __m256 qx = a[3], qy = a[7], qz = b[3], qw = b[7];
    const __m256 k = simd::two_over_norm2(qx, qy, qz, qw);
    simd::load8(&in_p[v].x, px, py, pz);
    simd::rotate8(qx, qy, qz, qw, k, _mm256_sub_ps(px, cx), _mm256_sub_ps(py, cy), _mm256_sub_ps(pz, cz), ox, oy, oz);
    simd::store8(&out_p[v].x, _mm256_add_ps(ox, tx), _mm256_add_ps(oy, ty), _mm256_add_ps(oz, tz));
    if constexpr (kNormals) {
      simd::load8(&in_n[v].x, px, py, pz);
      simd::rotate8(qx, qy, qz, qw, k, px, py, pz, ox, oy, oz);
      simd::store8(&out_n[v].x, ox, oy, oz);
    }
  }
  return v;
}
#endif

}  // namespace

bool CorSkinningJob::Run() const {
  if (!Validate()) return false;
  const size_t n = in_positions.size();
  size_t done = 0;  // vertices the eight-wide kernel took; the rest one by one
#ifdef MIMIC_SIMD_AVX2
  if (n >= 8 && skinning_matrices.size() <= kMaxPackedJoints) {
    PackedJoints packed;
    pack(skinning_matrices, skinning_rotations, packed);
    simd::HemisphereFlips table;
    const simd::HemisphereFlips* flips =
        table.fill(&skinning_rotations[0].x, 4, skinning_rotations.size()) ? &table : nullptr;
    done = in_normals.empty() ? skin_blocks<false>(packed, skinning_rotations.data(), flips, joint_indices.data(),
                                                   joint_weights.data(), centers_of_rotation.data(),
                                                   in_positions.data(), nullptr, out_positions.data(), nullptr, n)
                              : skin_blocks<true>(packed, skinning_rotations.data(), flips, joint_indices.data(),
                                                  joint_weights.data(), centers_of_rotation.data(), in_positions.data(),
                                                  in_normals.data(), out_positions.data(), out_normals.data(), n);
  }
#endif
  const uint16_t* ji = joint_indices.data() + done * kInfluences;
  const float* wi = joint_weights.data() + done * kInfluences;
  if (in_normals.empty())
    skin<false>(skinning_matrices.data(), skinning_rotations.data(), ji, wi, centers_of_rotation.data() + done,
                in_positions.data() + done, nullptr, out_positions.data() + done, nullptr, n - done);
  else
    skin<true>(skinning_matrices.data(), skinning_rotations.data(), ji, wi, centers_of_rotation.data() + done,
               in_positions.data() + done, in_normals.data() + done, out_positions.data() + done,
               out_normals.data() + done, n - done);
  return true;
}

}  // namespace mimic::avatar::baselines
