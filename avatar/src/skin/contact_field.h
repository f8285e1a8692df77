// The contact volumes' field (realtime_contact.h), a sum of posed metaballs, a ball at a time:
// shared by the pushes (realtime_contact.cpp, which also sums eight balls a step) and the arms'
// clearance (arm_clearance.cpp). Not a public header.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>

#include <glm/glm.hpp>

#include "mimic/avatar/simd.h"
#include "realtime_contact.h"

namespace mimic::avatar::realtime_detail {

struct FieldAt {
  float value = 0;
  glm::vec3 gradient{0.0f};
};

// The field alone, each ball's bounding sphere tested first (most are out of reach).
inline float field_value(const ContactTables& t, std::span<const uint16_t> balls, const ContactState& st,
                         const glm::vec3& p) {
  float value = 0;
  for (const uint16_t i : balls) {
    const ContactTables::Ball& b = t.balls[i];
    const glm::vec3 d = p - st.centre[i];
    if (glm::dot(d, d) >= b.bound_m * b.bound_m) continue;
    const glm::vec3 q = st.unit_from_world[i] * d;
    const float u = 1.0f - glm::dot(q, q) * b.inv_r2;
    if (u > 0.0f) value += b.weight_norm * u * u * u;
  }
  return value;
}

#ifdef MIMIC_SIMD_AVX2
// The field at eight points at once (a lane each), over the balls listed in `balls`: a probe's
// samples, without a sum across lanes per point.
inline __m256 field_values8(const ContactTables& t, const ContactState& st, std::span<const uint16_t> balls,
                            const float* xs, const float* ys, const float* zs) {
  const __m256 px = _mm256_loadu_ps(xs), py = _mm256_loadu_ps(ys), pz = _mm256_loadu_ps(zs);
  const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
  __m256 sum = zero;
  for (const uint16_t i : balls) {
    const glm::mat3& m = st.unit_from_world[i];
    const glm::vec3& c = st.centre[i];
    const __m256 dx = _mm256_sub_ps(px, _mm256_set1_ps(c.x)), dy = _mm256_sub_ps(py, _mm256_set1_ps(c.y)),
                 dz = _mm256_sub_ps(pz, _mm256_set1_ps(c.z));
    __m256 q2 = zero;
    for (int r = 0; r < 3; ++r) {
      const __m256 q =
          _mm256_fmadd_ps(_mm256_set1_ps(m[2][r]), dz,
                          _mm256_fmadd_ps(_mm256_set1_ps(m[1][r]), dy, _mm256_mul_ps(_mm256_set1_ps(m[0][r]), dx)));
      q2 = _mm256_fmadd_ps(q, q, q2);
    }
    const __m256 u = _mm256_max_ps(_mm256_fnmadd_ps(q2, _mm256_set1_ps(t.balls[i].inv_r2), one), zero);
    sum = _mm256_fmadd_ps(_mm256_mul_ps(_mm256_mul_ps(u, u), u), _mm256_set1_ps(t.balls[i].weight_norm), sum);
  }
  return sum;
}
#endif

// The most the field of `balls` can be anywhere within `radius` of `centre`: each ball's term at
// the nearest a point there can be to its centre in the ball's unit space (a metre moves a point
// at most inv_min_axis there).
inline float field_bound(const ContactTables& t, std::span<const uint16_t> balls, const ContactState& st,
                         const glm::vec3& centre, float radius) {
  float value = 0;
  for (const uint16_t i : balls) {
    const ContactTables::Ball& b = t.balls[i];
    const glm::vec3 q = st.unit_from_world[i] * (centre - st.centre[i]);
    const float d = std::max(std::sqrt(glm::dot(q, q)) - radius * b.inv_min_axis, 0.0f);
    const float u = 1.0f - d * d * b.inv_r2;
    if (u > 0.0f) value += b.weight_norm * u * u * u;
  }
  return value;
}

inline FieldAt field_at(const ContactTables& t, std::span<const uint16_t> balls, const ContactState& st,
                        const glm::vec3& p) {
  FieldAt f;
  for (const uint16_t i : balls) {
    const ContactTables::Ball& b = t.balls[i];
    const glm::vec3 q = st.unit_from_world[i] * (p - st.centre[i]);
    const float u = 1.0f - glm::dot(q, q) * b.inv_r2;
    if (u <= 0.0f) continue;
    f.value += b.weight_norm * u * u * u;
    // d/dp of w·u³ = −6 w u² / R² · Mᵀ q
    f.gradient -= (6.0f * b.weight_norm * u * u * b.inv_r2) * (glm::transpose(st.unit_from_world[i]) * q);
  }
  return f;
}

// The balls of the joints in `joints` (a bit per joint; joints from 64 on always) posed with their
// joints this frame. A joint's rotation matrix is made once for its run of balls.
inline void pose_balls(const ContactTables& t, ContactState& st, std::span<const rig::RigidTransform> world_from_joint,
                       uint64_t joints = ~uint64_t{0}) {
  int last = -1;
  glm::mat3 world_from_joint_rot(1.0f), joint_from_world(1.0f);
  for (size_t b = 0; b < t.balls.size(); ++b) {
    const int j = t.balls[b].joint;
    if (j < 64 && !(joints >> j & 1u)) continue;
    const rig::RigidTransform& w = world_from_joint[static_cast<size_t>(j)];
    if (j != last) {
      world_from_joint_rot = glm::mat3_cast(w.rotation), joint_from_world = glm::transpose(world_from_joint_rot);
      last = j;
    }
    st.unit_from_world[b] = t.balls[b].unit_from_joint * joint_from_world;
    st.centre[b] = w.translation + world_from_joint_rot * t.balls[b].centre_joint;
  }
}

}  // namespace mimic::avatar::realtime_detail
