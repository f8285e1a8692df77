#include "mimic/avatar/baselines/cor_skinning.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <unordered_map>
#include <vector>

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
      for (int k = i + 1; k < s.count; ++k) by_pair[pair_key(s.joint[i], s.joint[k])].push_back(static_cast<uint32_t>(t));
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
         centers_of_rotation.size() == n && out_positions.size() >= n && (in_normals.empty() || in_normals.size() == n) &&
         out_normals.size() >= in_normals.size();
}

namespace {

template <bool kNormals>
void skin(const Affine3x4* __restrict mats, const glm::quat* __restrict rots, const uint16_t* __restrict ji,
          const float* __restrict wi, const glm::vec3* __restrict cor, const glm::vec3* __restrict in_p,
          const glm::vec3* __restrict in_n, glm::vec3* __restrict out_p, glm::vec3* __restrict out_n, size_t n) {
  for (size_t v = 0; v < n; ++v, ji += kInfluences, wi += kInfluences) {
    const glm::quat q0 = rots[ji[0]], q1 = rots[ji[1]], q2 = rots[ji[2]], q3 = rots[ji[3]];
    const float w0 = wi[0];
    const float w1 = glm::dot(q0, q1) < 0 ? -wi[1] : wi[1];
    const float w2 = glm::dot(q0, q2) < 0 ? -wi[2] : wi[2];
    const float w3 = glm::dot(q0, q3) < 0 ? -wi[3] : wi[3];
    float qx = w0 * q0.x + w1 * q1.x + w2 * q2.x + w3 * q3.x;
    float qy = w0 * q0.y + w1 * q1.y + w2 * q2.y + w3 * q3.y;
    float qz = w0 * q0.z + w1 * q1.z + w2 * q2.z + w3 * q3.z;
    float qw = w0 * q0.w + w1 * q1.w + w2 * q2.w + w3 * q3.w;
    const float inv = 1.0f / std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
    qx *= inv, qy *= inv, qz *= inv, qw *= inv;
    const float* __restrict m0 = mats[ji[0]].m;
    const float* __restrict m1 = mats[ji[1]].m;
    const float* __restrict m2 = mats[ji[2]].m;
    const float* __restrict m3 = mats[ji[3]].m;
    alignas(16) float m[12];
    for (int k = 0; k < 12; ++k) m[k] = wi[0] * m0[k] + wi[1] * m1[k] + wi[2] * m2[k] + wi[3] * m3[k];
    const glm::vec3 c = cor[v];
    const glm::vec3 t{m[0] * c.x + m[1] * c.y + m[2] * c.z + m[3], m[4] * c.x + m[5] * c.y + m[6] * c.z + m[7],
                      m[8] * c.x + m[9] * c.y + m[10] * c.z + m[11]};
    // The rotation matrix of the blended quaternion, rows.
    const float xx = qx * qx, yy = qy * qy, zz = qz * qz, xy = qx * qy, xz = qx * qz, yz = qy * qz;
    const float wx = qw * qx, wy = qw * qy, wz = qw * qz;
    const glm::vec3 r0{1 - 2 * (yy + zz), 2 * (xy - wz), 2 * (xz + wy)};
    const glm::vec3 r1{2 * (xy + wz), 1 - 2 * (xx + zz), 2 * (yz - wx)};
    const glm::vec3 r2{2 * (xz - wy), 2 * (yz + wx), 1 - 2 * (xx + yy)};
    const glm::vec3 d = in_p[v] - c;
    out_p[v] = glm::vec3{glm::dot(r0, d), glm::dot(r1, d), glm::dot(r2, d)} + t;
    if constexpr (kNormals) {
      const glm::vec3 q = in_n[v];
      out_n[v] = {glm::dot(r0, q), glm::dot(r1, q), glm::dot(r2, q)};
    }
  }
}

}  // namespace

bool CorSkinningJob::Run() const {
  if (!Validate()) return false;
  if (in_normals.empty())
    skin<false>(skinning_matrices.data(), skinning_rotations.data(), joint_indices.data(), joint_weights.data(),
                centers_of_rotation.data(), in_positions.data(), nullptr, out_positions.data(), nullptr,
                in_positions.size());
  else
    skin<true>(skinning_matrices.data(), skinning_rotations.data(), joint_indices.data(), joint_weights.data(),
               centers_of_rotation.data(), in_positions.data(), in_normals.data(), out_positions.data(),
               out_normals.data(), in_positions.size());
  return true;
}

}  // namespace mimic::avatar::baselines
