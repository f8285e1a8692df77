// The contact volumes' field (realtime_contact.h): a sum of posed metaballs, evaluated at a point
// alone or eight balls a step. Shared by the pushes (realtime_contact.cpp) and the arms' clearance
// (arm_clearance.cpp). Not a public header.
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

// The active balls as eight-lane rows (ContactState::lanes); returns the padded count.
inline uint32_t fill_lanes(const ContactTables& t, ContactState& st, uint32_t n) {
  const uint32_t padded = (n + 7) / 8 * 8;
  float* rows = st.lanes.data();
  const size_t w = st.lane_stride;
  for (uint32_t k = 0; k < padded; ++k) {
    if (k >= n) {
      for (int r = 0; r < ContactState::kLaneRows; ++r) rows[r * w + k] = 0.0f;
      continue;
    }
    const uint16_t i = st.active[k];
    const glm::mat3& m = st.unit_from_world[i];
    rows[0 * w + k] = st.centre[i].x, rows[1 * w + k] = st.centre[i].y, rows[2 * w + k] = st.centre[i].z;
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) rows[(3 + 3 * r + c) * w + k] = m[c][r];  // row r of the matrix
    rows[12 * w + k] = t.balls[i].inv_r2;
    rows[13 * w + k] = t.balls[i].weight_norm;
    rows[14 * w + k] = t.balls[i].inv_min_axis;
  }
  return padded;
}

#ifdef MIMIC_SIMD_AVX2
// A point's offset from eight balls' centres in their unit spaces (lane rows 0–11), and the sum
// of eight lanes.
struct LaneOffset {
  __m256 x, y, z;
};
inline LaneOffset unit_offset(const float* rows, size_t w, uint32_t k, __m256 px, __m256 py, __m256 pz) {
  auto row = [&](int r) { return _mm256_loadu_ps(rows + static_cast<size_t>(r) * w + k); };
  const __m256 dx = _mm256_sub_ps(px, row(0)), dy = _mm256_sub_ps(py, row(1)), dz = _mm256_sub_ps(pz, row(2));
  return {_mm256_fmadd_ps(row(5), dz, _mm256_fmadd_ps(row(4), dy, _mm256_mul_ps(row(3), dx))),
          _mm256_fmadd_ps(row(8), dz, _mm256_fmadd_ps(row(7), dy, _mm256_mul_ps(row(6), dx))),
          _mm256_fmadd_ps(row(11), dz, _mm256_fmadd_ps(row(10), dy, _mm256_mul_ps(row(9), dx)))};
}
inline __m256 length2(const LaneOffset& q) {
  return _mm256_fmadd_ps(q.z, q.z, _mm256_fmadd_ps(q.y, q.y, _mm256_mul_ps(q.x, q.x)));
}
inline float lane_sum(__m256 v) {
  const __m128 h = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
  const __m128 h2 = _mm_add_ps(h, _mm_movehl_ps(h, h));
  return _mm_cvtss_f32(_mm_add_ss(h2, _mm_shuffle_ps(h2, h2, 1)));
}

// field_value over the lanes, eight balls a step.
inline float field_value_lanes(const ContactState& st, uint32_t padded, const glm::vec3& p) {
  const float* rows = st.lanes.data();
  const size_t w = st.lane_stride;
  const __m256 px = _mm256_set1_ps(p.x), py = _mm256_set1_ps(p.y), pz = _mm256_set1_ps(p.z);
  const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
  __m256 sum = zero;
  for (uint32_t k = 0; k < padded; k += 8) {
    const __m256 s = length2(unit_offset(rows, w, k, px, py, pz));
    const __m256 u = _mm256_max_ps(_mm256_fnmadd_ps(s, _mm256_loadu_ps(rows + 12 * w + k), one), zero);
    sum = _mm256_fmadd_ps(_mm256_mul_ps(_mm256_mul_ps(u, u), u), _mm256_loadu_ps(rows + 13 * w + k), sum);
  }
  return lane_sum(sum);
}

// The most the field can be anywhere within `radius` of `centre`: each ball's term at the
// nearest a point there can be to its centre in the ball's unit space (a metre moves a point at
// most inv_min_axis there), eight balls a step.
inline float field_bound_lanes(const ContactState& st, uint32_t padded, const glm::vec3& centre, float radius) {
  const float* rows = st.lanes.data();
  const size_t w = st.lane_stride;
  const __m256 px = _mm256_set1_ps(centre.x), py = _mm256_set1_ps(centre.y), pz = _mm256_set1_ps(centre.z);
  const __m256 r = _mm256_set1_ps(radius);
  const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
  __m256 sum = zero;
  for (uint32_t k = 0; k < padded; k += 8) {
    const __m256 q = _mm256_sqrt_ps(length2(unit_offset(rows, w, k, px, py, pz)));
    const __m256 d = _mm256_max_ps(_mm256_fnmadd_ps(r, _mm256_loadu_ps(rows + 14 * w + k), q), zero);
    const __m256 u =
        _mm256_max_ps(_mm256_fnmadd_ps(_mm256_mul_ps(d, d), _mm256_loadu_ps(rows + 12 * w + k), one), zero);
    sum = _mm256_fmadd_ps(_mm256_mul_ps(_mm256_mul_ps(u, u), u), _mm256_loadu_ps(rows + 13 * w + k), sum);
  }
  return lane_sum(sum);
}

// field_at over the lanes: the value and its gradient, eight balls a step.
inline FieldAt field_at_lanes(const ContactState& st, uint32_t padded, const glm::vec3& p) {
  const float* rows = st.lanes.data();
  const size_t w = st.lane_stride;
  const __m256 px = _mm256_set1_ps(p.x), py = _mm256_set1_ps(p.y), pz = _mm256_set1_ps(p.z);
  const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps(), six = _mm256_set1_ps(6.0f);
  __m256 sum = zero, gx = zero, gy = zero, gz = zero;
  for (uint32_t k = 0; k < padded; k += 8) {
    auto row = [&](int r) { return _mm256_loadu_ps(rows + r * w + k); };
    const LaneOffset q = unit_offset(rows, w, k, px, py, pz);
    const __m256 u = _mm256_max_ps(_mm256_fnmadd_ps(length2(q), row(12), one), zero);
    const __m256 wu2 = _mm256_mul_ps(row(13), _mm256_mul_ps(u, u));
    sum = _mm256_fmadd_ps(wu2, u, sum);
    // d/dp of w·u³ = −6 w u² / R² · Mᵀ q (zero where u is: outside the ball)
    const __m256 c = _mm256_mul_ps(_mm256_mul_ps(six, wu2), row(12));
    gx =
        _mm256_fnmadd_ps(c, _mm256_fmadd_ps(row(9), q.z, _mm256_fmadd_ps(row(6), q.y, _mm256_mul_ps(row(3), q.x))), gx);
    gy = _mm256_fnmadd_ps(c, _mm256_fmadd_ps(row(10), q.z, _mm256_fmadd_ps(row(7), q.y, _mm256_mul_ps(row(4), q.x))),
                          gy);
    gz = _mm256_fnmadd_ps(c, _mm256_fmadd_ps(row(11), q.z, _mm256_fmadd_ps(row(8), q.y, _mm256_mul_ps(row(5), q.x))),
                          gz);
  }
  return {lane_sum(sum), glm::vec3(lane_sum(gx), lane_sum(gy), lane_sum(gz))};
}
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

// The most the field of `balls` can be anywhere within `radius` of `centre` (field_bound_lanes,
// a ball at a time: for a few balls, cheaper than filling lanes).
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
  glm::mat3 joint_from_world(1.0f);
  for (size_t b = 0; b < t.balls.size(); ++b) {
    const int j = t.balls[b].joint;
    if (j < 64 && !(joints >> j & 1u)) continue;
    const rig::RigidTransform& w = world_from_joint[static_cast<size_t>(j)];
    if (j != last) joint_from_world = glm::transpose(glm::mat3_cast(w.rotation)), last = j;
    st.unit_from_world[b] = t.balls[b].unit_from_joint * joint_from_world;
    st.centre[b] = w.translation + glm::transpose(joint_from_world) * t.balls[b].centre_joint;
  }
}

}  // namespace mimic::avatar::realtime_detail
