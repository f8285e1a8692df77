// The geometry of a swept junction band (sweep_geometry.h).
#include "sweep_geometry.h"

#include <algorithm>
#include <cmath>

#include "contour_layout_data.h"
#include "mimic/avatar/simd.h"

namespace mimic::avatar::skin_detail {

namespace {

// The Hermite curve's tangents leave G and reach S at this multiple of the centres' distance
// (measured with the first form's planes square to the curve, every 20th frame of the clips, LOD
// 0: 0.25 / 0.5 / 1 / 1.5 / 2 gave 18.1 / 14.6 / 9.3 / 8.0 / 11.2 folds a frame).
constexpr float kTangentScale = 1.5f;

// Newell's normal of a closed polygon (unnormalised): its direction follows the point order.
glm::vec3 newell(uint32_t n, const glm::vec3* p) {
  glm::vec3 nn(0.0f);
  for (uint32_t j = 0; j < n; ++j) {
    const glm::vec3 a = p[j], c = p[j + 1 == n ? 0 : j + 1];
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

// One column, scalar: (gx, gy) in ug, (sx, sy) in (r_s, turn) → G's radius and direction, S's
// radius, the turn from G's direction to S's (less the rest turn); returns (cos, sin) of it.
inline glm::vec2 column_polar(const SweepColumns& col, uint32_t j, const float* rest_cos, const float* rest_sin) {
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
glm::vec2 columns_polar(const SweepColumns& col, uint32_t n, const float* rest_cos, const float* rest_sin,
                        bool vectorised) {
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

void sweep_geometry(const SweepEnds& e, const float* ts, int rings, const float* rest_cos, const float* rest_sin,
                    float twist_rad, bool vectorised, SweepPlane* planes, const SweepColumns& col) {
  const uint32_t n = e.n;
  glm::vec3 gc(0.0f), sc(0.0f);
  for (uint32_t j = 0; j < n; ++j) gc += e.g[j], sc += e.s[j];
  gc /= static_cast<float>(n), sc /= static_cast<float>(n);
  const glm::vec3 dc = sc - gc;
  const float span = glm::length(dc);
  const glm::vec3 along = span > 1e-9f ? dc / span : glm::vec3(0, 0, 1);
  const glm::vec3 ng = safe_normalize(e.sign_g * newell(n, e.g), along);
  const glm::vec3 ns = safe_normalize(e.sign_s * newell(n, e.s), along);
  glm::vec3 x = e.g[0] - gc;
  x = safe_normalize(x - glm::dot(x, ng) * ng, glm::abs(ng.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0));
  x = safe_normalize(x - glm::dot(x, ng) * ng, glm::vec3(1, 0, 0));
  const glm::vec3 xg = x, yg = glm::cross(ng, x);

  // Centred on the curve c(t) = h00·gc + h10·k·ng + h01·sc + h11·k·ns, the rings' axes
  // transported from G's plane to theirs.
  const float k = kTangentScale * span;
  // The planes turn from G's towards S's about their common perpendicular, evenly in t. Planes
  // across the curve (turning with its tangent) round the bend's outer side out past the ends'
  // chord: a hanging arm's shoulder stood 239 mm from the body's middle, 10 cm below its top,
  // against the straight band's 206 and the full method's 209; turning evenly, 225 (by t², 215,
  // but then contact's pushes fold the band: 0.5 folds a frame more; by t³, 207 and 12.3 folds a
  // frame against 9.3, every 20th frame of the clips).
  const glm::vec3 bend = glm::cross(ng, ns);
  const float bend_sin = glm::length(bend), bend_rad = std::atan2(bend_sin, glm::dot(ng, ns));
  const glm::vec3 bend_axis = bend_sin > 1e-6f ? bend / bend_sin : glm::vec3(0.0f);
  glm::vec3 prev_n = ng;
  for (int q = 0; q < std::min(rings, kSweepMaxRings); ++q) {
    const float t = ts[q];
    const float t2 = t * t, t3 = t2 * t;
    SweepPlane& p = planes[q];
    p.t = t;
    p.c = (2 * t3 - 3 * t2 + 1) * gc + (t3 - 2 * t2 + t) * k * ng + (3 * t2 - 2 * t3) * sc + (t3 - t2) * k * ns;
    const float turn_rad = bend_rad * t;
    p.n = ng * std::cos(turn_rad) + glm::cross(bend_axis, ng) * std::sin(turn_rad);
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
    const glm::vec3 g = e.g[j] - gc, s = e.s[j] - sc;
    col.ug_x[j] = glm::dot(g, xg), col.ug_y[j] = glm::dot(g, yg), col.h_g[j] = glm::dot(g, ng);
    col.r_s[j] = glm::dot(s, xs), col.turn[j] = glm::dot(s, ys), col.h_s[j] = glm::dot(s, ns);
  }
  const glm::vec2 sum = columns_polar(col, n, rest_cos, rest_sin, vectorised);
  // The columns' mean turn is the limb's own twist about its axis plus the turn its swing gives
  // S against axes carried along the curve; each column keeps its own turn about that mean. Only
  // the twist is ambiguous (half a turn either way is as near): it alone tapers (twist_in_band),
  // the swing's share is whole whatever its size.
  if (rest_cos == nullptr) return;  // the whole turns, as measured
  const float mean = approx_atan2(sum.y, sum.x);
  const float twist = wrap_angle(mean - twist_rad) + twist_in_band(twist_rad);
  for (uint32_t j = 0; j < n; ++j) col.turn[j] = twist + wrap_angle(col.turn[j] - mean);
}

void sweep_ring_points(const SweepPlane& p, const SweepColumns& col, uint32_t n, const float* rest_turn,
                       const float* shrink_in, const float* off_r, const float* off_a, const float* off_h,
                       bool vectorised, glm::vec3* out_points) {
  const float t = p.t, share = sweep_twist_share(t);
  float* out = &out_points[0].x;
  const bool offsets = off_r != nullptr;
  uint32_t j = 0;
#if defined(MIMIC_SIMD_AVX2)
  if (vectorised) {
    const __m256 tv = _mm256_set1_ps(t), sv = _mm256_set1_ps(share), ut = _mm256_set1_ps(1.0f - t);
    const __m256 cx = _mm256_set1_ps(p.c.x), cy = _mm256_set1_ps(p.c.y), cz = _mm256_set1_ps(p.c.z);
    const __m256 xx = _mm256_set1_ps(p.x.x), xy = _mm256_set1_ps(p.x.y), xz = _mm256_set1_ps(p.x.z);
    const __m256 yx = _mm256_set1_ps(p.y.x), yy = _mm256_set1_ps(p.y.y), yz = _mm256_set1_ps(p.y.z);
    const __m256 nx = _mm256_set1_ps(p.n.x), ny = _mm256_set1_ps(p.n.y), nz = _mm256_set1_ps(p.n.z);
    const __m256 zero = _mm256_setzero_ps();
    for (; j + 8 <= n; j += 8) {
      const __m256 shrink = offsets ? _mm256_loadu_ps(shrink_in + j) : zero;
      const __m256 oa = offsets ? _mm256_loadu_ps(off_a + j) : zero;
      const __m256 orr = offsets ? _mm256_loadu_ps(off_r + j) : zero;
      const __m256 oh = offsets ? _mm256_loadu_ps(off_h + j) : zero;
      const __m256 angle = _mm256_fmadd_ps(
          shrink, oa,
          _mm256_fmadd_ps(sv, _mm256_loadu_ps(col.turn + j), _mm256_mul_ps(tv, _mm256_loadu_ps(rest_turn + j))));
      __m256 c, s;
      cos_sin8(angle, c, s);
      const __m256 ugx = _mm256_loadu_ps(col.ug_x + j), ugy = _mm256_loadu_ps(col.ug_y + j);
      const __m256 dx = _mm256_fmsub_ps(ugx, c, _mm256_mul_ps(ugy, s));
      const __m256 dy = _mm256_fmadd_ps(ugx, s, _mm256_mul_ps(ugy, c));
      const __m256 radius = _mm256_fmadd_ps(
          shrink, orr,
          _mm256_fmadd_ps(tv, _mm256_loadu_ps(col.r_s + j), _mm256_mul_ps(ut, _mm256_loadu_ps(col.r_g + j))));
      const __m256 height = _mm256_fmadd_ps(
          shrink, oh,
          _mm256_fmadd_ps(tv, _mm256_loadu_ps(col.h_s + j), _mm256_mul_ps(ut, _mm256_loadu_ps(col.h_g + j))));
      const __m256 u = _mm256_mul_ps(radius, dx), v = _mm256_mul_ps(radius, dy);
      const __m256 ox = _mm256_fmadd_ps(height, nx, _mm256_fmadd_ps(v, yx, _mm256_fmadd_ps(u, xx, cx)));
      const __m256 oy = _mm256_fmadd_ps(height, ny, _mm256_fmadd_ps(v, yy, _mm256_fmadd_ps(u, xy, cy)));
      const __m256 oz = _mm256_fmadd_ps(height, nz, _mm256_fmadd_ps(v, yz, _mm256_fmadd_ps(u, xz, cz)));
      simd::store8(out + 3 * j, ox, oy, oz);
    }
  }
#else
  (void)vectorised;
#endif
  for (; j < n; ++j) {
    const float shrink = offsets ? shrink_in[j] : 0.0f;
    const float oa = offsets ? off_a[j] : 0.0f, orr = offsets ? off_r[j] : 0.0f, oh = offsets ? off_h[j] : 0.0f;
    float c, s;
    cos_sin(t * rest_turn[j] + share * col.turn[j] + shrink * oa, c, s);
    const float dx = col.ug_x[j] * c - col.ug_y[j] * s, dy = col.ug_x[j] * s + col.ug_y[j] * c;
    const float radius = (1.0f - t) * col.r_g[j] + t * col.r_s[j] + shrink * orr;
    const float height = (1.0f - t) * col.h_g[j] + t * col.h_s[j] + shrink * oh;
    const float u = radius * dx, v = radius * dy;
    out[3 * j] = p.c.x + u * p.x.x + v * p.y.x + height * p.n.x;
    out[3 * j + 1] = p.c.y + u * p.x.y + v * p.y.y + height * p.n.y;
    out[3 * j + 2] = p.c.z + u * p.x.z + v * p.y.z + height * p.n.z;
  }
}

glm::vec3 sweep_offset(const SweepPlane& p, const SweepColumns& col, uint32_t j, float rest_turn,
                       const glm::vec3& point) {
  const float t = p.t;
  const glm::vec3 v = point - p.c;
  const float px = glm::dot(v, p.x), py = glm::dot(v, p.y);
  float c, sn;
  cos_sin(t * rest_turn + sweep_twist_share(t) * col.turn[j], c, sn);
  const float dx = col.ug_x[j] * c - col.ug_y[j] * sn, dy = col.ug_x[j] * sn + col.ug_y[j] * c;
  return {std::sqrt(px * px + py * py) - ((1.0f - t) * col.r_g[j] + t * col.r_s[j]),
          approx_atan2(dx * py - dy * px, dx * px + dy * py),
          glm::dot(v, p.n) - ((1.0f - t) * col.h_g[j] + t * col.h_s[j])};
}

void sweep_signs(SweepEnds& e) {
  glm::vec3 gc(0.0f), sc(0.0f);
  for (uint32_t j = 0; j < e.n; ++j) gc += e.g[j], sc += e.s[j];
  const glm::vec3 dc = sc - gc;
  e.sign_g = glm::dot(newell(e.n, e.g), dc) < 0.0f ? -1.0f : 1.0f;
  e.sign_s = glm::dot(newell(e.n, e.s), dc) < 0.0f ? -1.0f : 1.0f;
}

void approx_cos_sin(float a_rad, float& c, float& s) { cos_sin(a_rad, c, s); }

}  // namespace mimic::avatar::skin_detail
