// The shoulders' bands swept as tubes (band_sweep.h).
#include "band_sweep.h"

#include <algorithm>
#include <cmath>

#include "loop_follow.h"
#include "mimic/avatar/simd.h"

namespace mimic::avatar::realtime_detail {

namespace {

using Data = RealtimeBody::Data;

// The twist's share at t (0 at the loop, 1 at S): most of the turn next to S, as the arm's skin
// turns with the arm and the chest's stays.
inline float twist_share(float t) { return t * t * t; }
// The Hermite curve's tangents leave G and reach S at this fraction of the centres' distance.
constexpr float kTangentScale = 1.5f;
constexpr int kMaxRings = 8;
// Fewer points than this (LOD 3's four) do not draw a ring the polar blend can keep round: the
// straight blend folds less there (0.4 against 1.2 folds a frame, every 20th frame of the clips).
constexpr uint32_t kMinColumns = 8;

// Newell's normal of a closed polygon (unnormalised): its direction follows the point order.
template <typename At>
glm::vec3 newell(uint32_t n, At at) {
  glm::vec3 nn(0.0f);
  for (uint32_t j = 0; j < n; ++j) {
    const glm::vec3 a = at(j), c = at(j + 1 == n ? 0 : j + 1);
    nn += glm::vec3((a.y - c.y) * (a.z + c.z), (a.z - c.z) * (a.x + c.x), (a.x - c.x) * (a.y + c.y));
  }
  return nn;
}

// v turned by the smallest rotation taking unit a to unit b (b ≠ −a).
inline glm::vec3 transport(const glm::vec3& v, const glm::vec3& a, const glm::vec3& b) {
  const float c = glm::dot(a, b);
  const glm::vec3 k = glm::cross(a, b);
  if (!(c > -0.999f)) return v;  // a cusp of the curve: keep the axes
  return v * c + glm::cross(k, v) + k * (glm::dot(k, v) / (1.0f + c));
}

struct RingPlane {
  glm::vec3 c, x, y, n;
  float t;
};

// A band's columns this frame, structure of arrays (SweepScratch's).
struct Columns {
  float* ug_x;
  float* ug_y;
  float* r_g;
  float* h_g;
  float* r_s;
  float* h_s;
  float* turn;
};

// (cos a, sin a) within 1e-6, without branches (the quadrant by selects), so that a loop over
// points vectorises.
inline void cos_sin(float a_rad, float& c_out, float& s_out) {
  const float k = std::nearbyint(a_rad * 0.636619772f);
  const float r = (a_rad - k * 1.57079637f) - k * -4.37113900e-8f;
  const float r2 = r * r;
  const float s = r + r * r2 * (-0.166666667f + r2 * (0.00833333333f + r2 * -0.000198412698f));
  const float c = 1.0f + r2 * (-0.5f + r2 * (0.0416666667f + r2 * (-0.00138888889f + r2 * 0.0000248015873f)));
  const int q = static_cast<int>(k);
  const float so = (q & 1) ? c : s, co = (q & 1) ? s : c;
  s_out = (q & 2) ? -so : so;
  c_out = ((q + 1) & 2) ? -co : co;
}

inline float wrap_angle(float a) {
  return a > skin_detail::kPi ? a - skin_detail::kTwoPi : a < -skin_detail::kPi ? a + skin_detail::kTwoPi : a;
}

// One column, scalar: (gx, gy) in ug, (sx, sy) in (r_s, turn) → G's radius and direction, S's
// radius, the turn from G's direction to S's (less the rest turn); returns (cos, sin) of it.
inline glm::vec2 column_polar(const Columns& col, uint32_t j, const float* rest_cos, const float* rest_sin) {
  const float gx = col.ug_x[j], gy = col.ug_y[j], sx = col.r_s[j], sy = col.turn[j];
  const float rg = std::sqrt(gx * gx + gy * gy), rs = std::sqrt(sx * sx + sy * sy);
  const float ig = rg > 1e-9f ? 1.0f / rg : 0.0f, is = rs > 1e-9f ? 1.0f / rs : 0.0f;
  const float ugx = rg > 1e-9f ? gx * ig : 1.0f, ugy = gy * ig;
  const float usx = rs > 1e-9f ? sx * is : ugx, usy = rs > 1e-9f ? sy * is : ugy;
  float cx = usx * ugx + usy * ugy, cy = usy * ugx - usx * ugy;
  if (rest_cos) {
    const float ex = cx * rest_cos[j] + cy * rest_sin[j], ey = cy * rest_cos[j] - cx * rest_sin[j];
    cx = ex, cy = ey;
  }
  col.ug_x[j] = ugx, col.ug_y[j] = ugy, col.r_g[j] = rg, col.r_s[j] = rs;
  col.turn[j] = approx_atan2(cy, cx);
  return {cx, cy};
}

#if defined(MIMIC_SIMD_AVX2)
// atan2, eight lanes: approx_atan2's polynomial and quadrant selects.
inline __m256 atan2_8(__m256 y, __m256 x) {
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  const __m256 ax = _mm256_and_ps(x, abs_mask), ay = _mm256_and_ps(y, abs_mask);
  const __m256 hi = _mm256_max_ps(ax, ay), lo = _mm256_min_ps(ax, ay);
  const __m256 a = _mm256_and_ps(_mm256_div_ps(lo, hi), _mm256_cmp_ps(hi, _mm256_setzero_ps(), _CMP_GT_OQ));
  const __m256 s = _mm256_mul_ps(a, a);
  __m256 p = _mm256_fmadd_ps(_mm256_set1_ps(-0.0464964749f), s, _mm256_set1_ps(0.15931422f));
  p = _mm256_fmsub_ps(p, s, _mm256_set1_ps(0.327622764f));
  __m256 r = _mm256_fmadd_ps(_mm256_mul_ps(p, s), a, a);
  r = _mm256_blendv_ps(r, _mm256_sub_ps(_mm256_set1_ps(1.57079637f), r), _mm256_cmp_ps(ay, ax, _CMP_GT_OQ));
  r = _mm256_blendv_ps(r, _mm256_sub_ps(_mm256_set1_ps(3.14159274f), r), x);  // the sign bit of x
  return _mm256_xor_ps(r, _mm256_and_ps(y, _mm256_set1_ps(-0.0f)));
}

// (cos, sin), eight lanes: cos_sin's reduction, polynomials and quadrant.
inline void cos_sin8(__m256 a, __m256& c_out, __m256& s_out) {
  const __m256 k =
      _mm256_round_ps(_mm256_mul_ps(a, _mm256_set1_ps(0.636619772f)), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  const __m256 r =
      _mm256_fmadd_ps(k, _mm256_set1_ps(4.37113900e-8f), _mm256_fnmadd_ps(k, _mm256_set1_ps(1.57079637f), a));
  const __m256 r2 = _mm256_mul_ps(r, r);
  __m256 ps = _mm256_fmadd_ps(r2, _mm256_set1_ps(-0.000198412698f), _mm256_set1_ps(0.00833333333f));
  ps = _mm256_fmadd_ps(r2, ps, _mm256_set1_ps(-0.166666667f));
  const __m256 s = _mm256_fmadd_ps(_mm256_mul_ps(r, r2), ps, r);
  __m256 pc = _mm256_fmadd_ps(r2, _mm256_set1_ps(0.0000248015873f), _mm256_set1_ps(-0.00138888889f));
  pc = _mm256_fmadd_ps(r2, pc, _mm256_set1_ps(0.0416666667f));
  pc = _mm256_fmadd_ps(r2, pc, _mm256_set1_ps(-0.5f));
  const __m256 c = _mm256_fmadd_ps(r2, pc, _mm256_set1_ps(1.0f));
  const __m256i q = _mm256_cvtps_epi32(k);
  const __m256i one = _mm256_set1_epi32(1), two = _mm256_set1_epi32(2);
  const __m256 odd = _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(q, one), one));
  const __m256 so = _mm256_blendv_ps(s, c, odd), co = _mm256_blendv_ps(c, s, odd);
  s_out = _mm256_xor_ps(so, _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_and_si256(q, two), 30)));
  c_out =
      _mm256_xor_ps(co, _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_and_si256(_mm256_add_epi32(q, one), two), 30)));
}
#endif

// Every column's polar form (column_polar), eight at a time where the build has AVX2 and FMA;
// returns the sum of the columns' turns as unit vectors (their circular mean's direction).
glm::vec2 columns_polar(const Columns& col, uint32_t n, const float* rest_cos, const float* rest_sin, bool vectorised) {
  glm::vec2 sum(0.0f);
  uint32_t j = 0;
#if defined(MIMIC_SIMD_AVX2)
  if (vectorised) {
    const __m256 tiny = _mm256_set1_ps(1e-9f), zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
    __m256 sum_c = zero, sum_s = zero;
    for (; j + 8 <= n; j += 8) {
      const __m256 gx = _mm256_loadu_ps(col.ug_x + j), gy = _mm256_loadu_ps(col.ug_y + j);
      const __m256 sx = _mm256_loadu_ps(col.r_s + j), sy = _mm256_loadu_ps(col.turn + j);
      const __m256 rg = _mm256_sqrt_ps(_mm256_fmadd_ps(gx, gx, _mm256_mul_ps(gy, gy)));
      const __m256 rs = _mm256_sqrt_ps(_mm256_fmadd_ps(sx, sx, _mm256_mul_ps(sy, sy)));
      const __m256 g_ok = _mm256_cmp_ps(rg, tiny, _CMP_GT_OQ), s_ok = _mm256_cmp_ps(rs, tiny, _CMP_GT_OQ);
      const __m256 ig = _mm256_and_ps(_mm256_div_ps(one, rg), g_ok), is = _mm256_and_ps(_mm256_div_ps(one, rs), s_ok);
      const __m256 ugx = _mm256_blendv_ps(one, _mm256_mul_ps(gx, ig), g_ok), ugy = _mm256_mul_ps(gy, ig);
      const __m256 usx = _mm256_blendv_ps(ugx, _mm256_mul_ps(sx, is), s_ok);
      const __m256 usy = _mm256_blendv_ps(ugy, _mm256_mul_ps(sy, is), s_ok);
      __m256 cx = _mm256_fmadd_ps(usx, ugx, _mm256_mul_ps(usy, ugy));
      __m256 cy = _mm256_fmsub_ps(usy, ugx, _mm256_mul_ps(usx, ugy));
      if (rest_cos) {
        const __m256 rc = _mm256_loadu_ps(rest_cos + j), rsn = _mm256_loadu_ps(rest_sin + j);
        const __m256 ex = _mm256_fmadd_ps(cx, rc, _mm256_mul_ps(cy, rsn));
        const __m256 ey = _mm256_fmsub_ps(cy, rc, _mm256_mul_ps(cx, rsn));
        cx = ex, cy = ey;
      }
      _mm256_storeu_ps(col.ug_x + j, ugx), _mm256_storeu_ps(col.ug_y + j, ugy);
      _mm256_storeu_ps(col.r_g + j, rg), _mm256_storeu_ps(col.r_s + j, rs);
      _mm256_storeu_ps(col.turn + j, atan2_8(cy, cx));
      sum_c = _mm256_add_ps(sum_c, cx), sum_s = _mm256_add_ps(sum_s, cy);
    }
    alignas(32) float c8[8], s8[8];
    _mm256_store_ps(c8, sum_c), _mm256_store_ps(s8, sum_s);
    for (int l = 0; l < 8; ++l) sum.x += c8[l], sum.y += s8[l];
  }
#else
  (void)vectorised;
#endif
  for (; j < n; ++j) sum += column_polar(col, j, rest_cos, rest_sin);
  return sum;
}

// The band's geometry this frame: the ring planes along the curve, and per column G's point in
// G's plane (unit direction, radius, height), S's in S's (radius, height) and the turn from G's
// direction to S's, less the initial pose's (`rest_cos`, `rest_sin` of it; nullptr: the whole
// turn); `twist_rad` is the limb's twist about its own axis against the initial pose. Returns the
// number of rings.
int band_geometry(const Data& d, const Data::Sweep& b, std::span<const glm::vec3> pos, const float* rest_cos,
                  const float* rest_sin, float twist_rad, bool vectorised, RingPlane* planes, const Columns& col) {
  const Data::RingOp& first = d.rings[static_cast<size_t>(b.first_ring)];
  const uint32_t n = b.columns;
  const uint32_t* goal = d.goals.data() + first.goal_first;
  const uint32_t s_first = d.rings[static_cast<size_t>(first.s_ring)].first;
  glm::vec3 gc(0.0f), sc(0.0f);
  for (uint32_t j = 0; j < n; ++j) gc += pos[goal[j]], sc += pos[s_first + j];
  gc /= static_cast<float>(n), sc /= static_cast<float>(n);
  const glm::vec3 dc = sc - gc;
  const float span = glm::length(dc);
  const glm::vec3 along = span > 1e-9f ? dc / span : glm::vec3(0, 0, 1);
  const glm::vec3 ng = safe_normalize(b.sign_g * newell(n, [&](uint32_t j) { return pos[goal[j]]; }), along);
  const glm::vec3 ns = safe_normalize(b.sign_s * newell(n, [&](uint32_t j) { return pos[s_first + j]; }), along);
  glm::vec3 x = pos[goal[0]] - gc;
  x = safe_normalize(x - glm::dot(x, ng) * ng, glm::abs(ng.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0));
  x = safe_normalize(x - glm::dot(x, ng) * ng, glm::vec3(1, 0, 0));
  const glm::vec3 xg = x, yg = glm::cross(ng, x);

  // Along the curve c(t) = h00·gc + h10·k·span·ng + h01·sc + h11·k·span·ns, the rings' planes
  // across its tangent, the axes transported from G's.
  const float k = kTangentScale * span;
  glm::vec3 prev_n = ng;
  const int rings = std::min(b.rings, kMaxRings);
  for (int q = 0; q < rings; ++q) {
    const float t = 1.0f - d.rings[static_cast<size_t>(b.first_ring + q)].alpha;
    const float t2 = t * t, t3 = t2 * t;
    RingPlane& p = planes[q];
    p.t = t;
    p.c = (2 * t3 - 3 * t2 + 1) * gc + (t3 - 2 * t2 + t) * k * ng + (3 * t2 - 2 * t3) * sc + (t3 - t2) * k * ns;
    const glm::vec3 tangent =
        (6 * t2 - 6 * t) * gc + (3 * t2 - 4 * t + 1) * k * ng + (6 * t - 6 * t2) * sc + (3 * t2 - 2 * t) * k * ns;
    p.n = safe_normalize(tangent, prev_n);
    x = transport(x, prev_n, p.n);
    x = safe_normalize(x - glm::dot(x, p.n) * p.n, glm::vec3(1, 0, 0));
    p.x = x, p.y = glm::cross(p.n, x);
    prev_n = p.n;
  }
  x = transport(x, prev_n, ns);
  x = safe_normalize(x - glm::dot(x, ns) * ns, glm::vec3(1, 0, 0));
  const glm::vec3 xs = x, ys = glm::cross(ns, x);

  // Each column's G point in G's plane and S point in S's (the SoA columns hold the plane
  // coordinates until columns_polar turns them into radii, directions and turns).
  for (uint32_t j = 0; j < n; ++j) {
    const glm::vec3 g = pos[goal[j]] - gc, s = pos[s_first + j] - sc;
    col.ug_x[j] = glm::dot(g, xg), col.ug_y[j] = glm::dot(g, yg), col.h_g[j] = glm::dot(g, ng);
    col.r_s[j] = glm::dot(s, xs), col.turn[j] = glm::dot(s, ys), col.h_s[j] = glm::dot(s, ns);
  }
  const glm::vec2 sum = columns_polar(col, n, rest_cos, rest_sin, vectorised);
  // The columns' mean turn is the limb's own twist about its axis plus the turn its swing gives
  // S against axes carried along the curve; each column keeps its own turn about that mean. Only
  // the twist is ambiguous (half a turn either way is as near): it alone tapers (twist_in_band),
  // the swing's share is whole whatever its size.
  const float mean = approx_atan2(sum.y, sum.x);
  const float swing_turn = wrap_angle(mean - twist_rad);
  const float twist = swing_turn + skin_detail::twist_in_band(twist_rad);
  for (uint32_t j = 0; j < n; ++j) col.turn[j] = twist + wrap_angle(col.turn[j] - mean);
  return rings;
}

}  // namespace

float approx_atan2(float y, float x) {
  const float ax = std::abs(x), ay = std::abs(y);
  const float hi = std::max(ax, ay), lo = std::min(ax, ay);
  const float a = hi > 0.0f ? lo / hi : 0.0f;
  const float s = a * a;
  float r = ((-0.0464964749f * s + 0.15931422f) * s - 0.327622764f) * s * a + a;
  r = ay > ax ? 1.57079637f - r : r;
  r = x < 0.0f ? 3.14159274f - r : r;
  return y < 0.0f ? -r : r;
}

void SweepScratch::resize(size_t columns, size_t n_points) {
  for (std::vector<float>* v : {&ug_x, &ug_y, &r_g, &h_g, &r_s, &h_s, &turn, &shrink}) v->assign(columns, 0.0f);
  points.assign(n_points, glm::vec3(0.0f));
}

size_t SweepScratch::heap_bytes() const {
  return (ug_x.capacity() + ug_y.capacity() + r_g.capacity() + h_g.capacity() + r_s.capacity() + h_s.capacity() +
          turn.capacity() + shrink.capacity()) *
             sizeof(float) +
         points.capacity() * sizeof(glm::vec3);
}

float limb_twist_rad(const Data::Sweep& b, std::span<const rig::RigidTransform> world_from_joint) {
  const glm::quat local = glm::conjugate(world_from_joint[static_cast<size_t>(b.parent)].rotation) *
                          world_from_joint[static_cast<size_t>(b.joint)].rotation;
  const glm::quat q = local * b.rest_local_inv;  // the turn from the initial pose, in the parent's frame
  // Swing-twist about the rest axis: the twist is q's part about it.
  const float along = glm::dot(glm::vec3(q.x, q.y, q.z), b.rest_axis);
  return wrap_angle(2.0f * std::atan2(along, q.w));
}

void sweep_band(const Data& d, const Data::Sweep& b, float twist_rad, std::span<const glm::vec3> pos, SweepScratch& sc,
                bool vectorised) {
  RingPlane planes[kMaxRings];
  const Columns col{sc.ug_x.data(), sc.ug_y.data(), sc.r_g.data(), sc.h_g.data(),
                    sc.r_s.data(),  sc.h_s.data(),  sc.turn.data()};
  const float* rest_turn = d.sweep_rest_turn.data() + b.column_first;
  const int rings = band_geometry(d, b, pos, d.sweep_rest_cos.data() + b.column_first,
                                  d.sweep_rest_sin.data() + b.column_first, twist_rad, vectorised, planes, col);
  const Data::RingOp& first = d.rings[static_cast<size_t>(b.first_ring)];
  const uint32_t* goal = d.goals.data() + first.goal_first;
  const uint32_t s_first = d.rings[static_cast<size_t>(first.s_ring)].first;
  for (uint32_t j = 0; j < b.columns; ++j) {
    const glm::vec3 gs = pos[goal[j]] - pos[s_first + j];
    sc.shrink[j] = std::min(1.0f, glm::dot(gs, gs) * d.column_inv_len2[first.first + j]);
  }
  const uint32_t n = b.columns;
  for (int q = 0; q < rings; ++q) {
    const RingPlane& p = planes[q];
    const float t = p.t, share = twist_share(t);
    const size_t at = b.offset_first + static_cast<size_t>(q) * n;
    const float* off_r = d.sweep_off_r.data() + at;
    const float* off_a = d.sweep_off_a.data() + at;
    const float* off_h = d.sweep_off_h.data() + at;
    float* out = &sc.points[static_cast<size_t>(q) * n].x;
    uint32_t j = 0;
#if defined(MIMIC_SIMD_AVX2)
    if (vectorised) {
      const __m256 tv = _mm256_set1_ps(t), sv = _mm256_set1_ps(share), ut = _mm256_set1_ps(1.0f - t);
      const __m256 cx = _mm256_set1_ps(p.c.x), cy = _mm256_set1_ps(p.c.y), cz = _mm256_set1_ps(p.c.z);
      const __m256 xx = _mm256_set1_ps(p.x.x), xy = _mm256_set1_ps(p.x.y), xz = _mm256_set1_ps(p.x.z);
      const __m256 yx = _mm256_set1_ps(p.y.x), yy = _mm256_set1_ps(p.y.y), yz = _mm256_set1_ps(p.y.z);
      const __m256 nx = _mm256_set1_ps(p.n.x), ny = _mm256_set1_ps(p.n.y), nz = _mm256_set1_ps(p.n.z);
      for (; j + 8 <= n; j += 8) {
        const __m256 shrink = _mm256_loadu_ps(sc.shrink.data() + j);
        const __m256 angle = _mm256_fmadd_ps(shrink, _mm256_loadu_ps(off_a + j),
                                             _mm256_fmadd_ps(sv, _mm256_loadu_ps(sc.turn.data() + j),
                                                             _mm256_mul_ps(tv, _mm256_loadu_ps(rest_turn + j))));
        __m256 c, s;
        cos_sin8(angle, c, s);
        const __m256 ugx = _mm256_loadu_ps(sc.ug_x.data() + j), ugy = _mm256_loadu_ps(sc.ug_y.data() + j);
        const __m256 dx = _mm256_fmsub_ps(ugx, c, _mm256_mul_ps(ugy, s));
        const __m256 dy = _mm256_fmadd_ps(ugx, s, _mm256_mul_ps(ugy, c));
        const __m256 radius = _mm256_fmadd_ps(shrink, _mm256_loadu_ps(off_r + j),
                                              _mm256_fmadd_ps(tv, _mm256_loadu_ps(sc.r_s.data() + j),
                                                              _mm256_mul_ps(ut, _mm256_loadu_ps(sc.r_g.data() + j))));
        const __m256 height = _mm256_fmadd_ps(shrink, _mm256_loadu_ps(off_h + j),
                                              _mm256_fmadd_ps(tv, _mm256_loadu_ps(sc.h_s.data() + j),
                                                              _mm256_mul_ps(ut, _mm256_loadu_ps(sc.h_g.data() + j))));
        const __m256 u = _mm256_mul_ps(radius, dx), v = _mm256_mul_ps(radius, dy);
        const __m256 ox = _mm256_fmadd_ps(height, nx, _mm256_fmadd_ps(v, yx, _mm256_fmadd_ps(u, xx, cx)));
        const __m256 oy = _mm256_fmadd_ps(height, ny, _mm256_fmadd_ps(v, yy, _mm256_fmadd_ps(u, xy, cy)));
        const __m256 oz = _mm256_fmadd_ps(height, nz, _mm256_fmadd_ps(v, yz, _mm256_fmadd_ps(u, xz, cz)));
        simd::store8(out + 3 * j, ox, oy, oz);
      }
    }
#endif
    for (; j < n; ++j) {
      const float shrink = sc.shrink[j];
      float c, s;
      cos_sin(t * rest_turn[j] + share * sc.turn[j] + shrink * off_a[j], c, s);
      const float dx = sc.ug_x[j] * c - sc.ug_y[j] * s, dy = sc.ug_x[j] * s + sc.ug_y[j] * c;
      const float radius = (1.0f - t) * sc.r_g[j] + t * sc.r_s[j] + shrink * off_r[j];
      const float height = (1.0f - t) * sc.h_g[j] + t * sc.h_s[j] + shrink * off_h[j];
      const float u = radius * dx, v = radius * dy;
      out[3 * j] = p.c.x + u * p.x.x + v * p.y.x + height * p.n.x;
      out[3 * j + 1] = p.c.y + u * p.x.y + v * p.y.y + height * p.n.y;
      out[3 * j + 2] = p.c.z + u * p.x.z + v * p.y.z + height * p.n.z;
    }
  }
}

void measure_sweeps(std::span<const glm::vec3> rest, std::span<const rig::RigidTransform> world_from_joint, Data& d) {
  for (size_t ri = 0; ri < d.rings.size(); ++ri) {
    Data::RingOp& r = d.rings[ri];
    // The shoulders' bands: those that twist with their limb (loop_follow.h).
    if (r.kind != RingKind::driven || r.count < kMinColumns || !r.twists || r.sweep >= 0) continue;
    Data::Sweep b;
    b.first_ring = static_cast<int>(ri);
    if (r.follow < 0) continue;
    const skin_detail::LoopFollow& lf = d.follows[static_cast<size_t>(r.follow)];
    if (lf.parent < 0) continue;
    b.joint = lf.joint, b.parent = lf.parent;
    b.rest_axis = lf.axis;
    b.rest_local_inv = glm::conjugate(glm::conjugate(world_from_joint[static_cast<size_t>(lf.parent)].rotation) *
                                      world_from_joint[static_cast<size_t>(lf.joint)].rotation);
    b.columns = r.count;
    while (ri + static_cast<size_t>(b.rings) < d.rings.size()) {
      const Data::RingOp& o = d.rings[ri + static_cast<size_t>(b.rings)];
      if (o.kind != RingKind::driven || o.s_ring != r.s_ring || o.count != r.count) break;
      ++b.rings;
    }
    if (b.rings > kMaxRings) continue;
    // Orient G's and S's normals along the band (from the loop towards S) in the initial pose.
    const uint32_t* goal = d.goals.data() + r.goal_first;
    const uint32_t s_first = d.rings[static_cast<size_t>(r.s_ring)].first;
    glm::vec3 gc(0.0f), sc(0.0f);
    for (uint32_t j = 0; j < r.count; ++j) gc += rest[goal[j]], sc += rest[s_first + j];
    const glm::vec3 dc = sc - gc;
    b.sign_g = glm::dot(newell(r.count, [&](uint32_t j) { return rest[goal[j]]; }), dc) < 0.0f ? -1.0f : 1.0f;
    b.sign_s = glm::dot(newell(r.count, [&](uint32_t j) { return rest[s_first + j]; }), dc) < 0.0f ? -1.0f : 1.0f;
    b.column_first = static_cast<uint32_t>(d.sweep_rest_turn.size());
    // The rest turns: the whole turn of each column in the initial pose.
    std::vector<float> ug_x(r.count), ug_y(r.count), r_g(r.count), h_g(r.count), r_s(r.count), h_s(r.count),
        turn(r.count);
    const Columns col{ug_x.data(), ug_y.data(), r_g.data(), h_g.data(), r_s.data(), h_s.data(), turn.data()};
    RingPlane planes[kMaxRings];
    band_geometry(d, b, rest, nullptr, nullptr, 0.0f, false, planes, col);
    // Without a rest turn the geometry gives each column's whole turn (the band's mean turn in
    // the initial pose is far inside the taper's 120°).
    d.sweep_rest_turn.insert(d.sweep_rest_turn.end(), turn.begin(), turn.end());
    for (float a : turn) {
      float c, sn;
      cos_sin(a, c, sn);
      d.sweep_rest_cos.push_back(c), d.sweep_rest_sin.push_back(sn);
    }
    // The polar offsets that give the initial pose's points back (the rest turn now known: the
    // geometry again, as a frame sees it).
    band_geometry(d, b, rest, d.sweep_rest_cos.data() + b.column_first, d.sweep_rest_sin.data() + b.column_first, 0.0f,
                  false, planes, col);
    const float* rest_turn = d.sweep_rest_turn.data() + b.column_first;
    b.offset_first = static_cast<uint32_t>(d.sweep_off_r.size());
    for (int q = 0; q < b.rings; ++q) {
      const RingPlane& p = planes[q];
      Data::RingOp& o = d.rings[ri + static_cast<size_t>(q)];
      o.sweep = static_cast<int>(d.sweeps.size());
      const float t = p.t, share = twist_share(t);
      for (uint32_t j = 0; j < r.count; ++j) {
        const glm::vec3 v = rest[o.first + j] - p.c;
        const float px = glm::dot(v, p.x), py = glm::dot(v, p.y);
        float c, sn;
        cos_sin(t * rest_turn[j] + share * turn[j], c, sn);
        const float dx = ug_x[j] * c - ug_y[j] * sn, dy = ug_x[j] * sn + ug_y[j] * c;
        d.sweep_off_r.push_back(std::sqrt(px * px + py * py) - ((1.0f - t) * r_g[j] + t * r_s[j]));
        d.sweep_off_a.push_back(approx_atan2(dx * py - dy * px, dx * px + dy * py));
        d.sweep_off_h.push_back(glm::dot(v, p.n) - ((1.0f - t) * h_g[j] + t * h_s[j]));
      }
    }
    d.sweeps.push_back(b);
  }
}

}  // namespace mimic::avatar::realtime_detail
