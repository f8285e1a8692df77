// The realtime skin's per-point work (realtime_data.h): a star ring's points from their rest
// coordinates, and the rigid parts' vertices. Scalar reference loops, and eight-wide AVX2/FMA
// kernels where the build targets them (selected at compile time, as the baseline skinnings'
// kernels are: mimic/avatar/simd.h).
#include <algorithm>
#include <cmath>

#include "mimic/avatar/simd.h"
#include "realtime_data.h"

namespace mimic::avatar::realtime_detail {

namespace {

using Data = RealtimeBody::Data;

// The column slide's divisor (1 + a·slope·rise) kept from vanishing where a column runs almost
// along the plane.
constexpr float kMinColumnDivisor = 0.2f;

// One point, scalar: its coordinates (x, y, z) with the muscles applied; writes the position
// and widens the reach.
inline void star_point(const Data& d, const StarRing& s, uint32_t k, float x, float y, float z, glm::vec3& out,
                       Reach& reach) {
  // The band scale about the ring's rest centroid.
  x = s.centre.x + (x - s.centre.x) * s.scale;
  y = s.centre.y + (y - s.centre.y) * s.scale;
  // How far the plane's tilt, changed since the initial pose, moves the point along the link;
  // the point slides that far along its column of the rest surface (the limb keeps its shape
  // along the bone), then sits on the plane.
  const float shear = z * s.shear_z - (x * s.shear_q.x + y * s.shear_q.y);
  const bool lo = shear < 0.0f;
  const float sx = lo ? d.lo_x[k] : d.hi_x[k], sy = lo ? d.lo_y[k] : d.hi_y[k];
  const float divisor = std::max(1.0f + s.a * (sx * s.rise.x + sy * s.rise.y), kMinColumnDivisor);
  const float along = std::clamp(shear / divisor, d.dh_lo[k], d.dh_hi[k]);
  x += sx * along;
  y += sy * along;
  const float h = (z - (x * s.rise.x + y * s.rise.y)) * s.a;
  out = s.origin + x * s.px + y * s.py + h * s.axis;
  reach.radius = std::max(reach.radius, x * x + y * y + h * h);
  reach.height = std::max(reach.height, std::abs(z));
}

}  // namespace

Reach star_points_scalar(const Data& d, const Data::RingOp& r, const StarRing& s, const glm::vec2* muscle_w,
                         glm::vec3* out) {
  Reach reach;
  const uint32_t n = r.count;
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t k = r.first + i;
    float x = d.lx[k], y = d.ly[k], z = d.lz[k];
    if (muscle_w)
      for (uint32_t b = r.muscle_first; b < r.muscle_first + r.muscle_count; ++b) {
        const glm::vec2 w = muscle_w[d.muscle_blocks[b].dof];
        const float* m = d.muscle_data.data() + d.muscle_blocks[b].data;
        x += m[i] + w.x * m[3 * n + i] + w.y * m[6 * n + i];
        y += m[n + i] + w.x * m[4 * n + i] + w.y * m[7 * n + i];
        z += m[2 * n + i] + w.x * m[5 * n + i] + w.y * m[8 * n + i];
      }
    star_point(d, s, k, x, y, z, out[i], reach);
  }
  reach.radius = std::sqrt(reach.radius);
  return reach;
}

void driven_points_scalar(const Data& d, const Data::RingOp& r, const Frame& f, std::span<glm::vec3> pos) {
  const uint32_t s_first = d.rings[r.s_ring].first;
  const uint32_t* goal = d.goals.data() + r.goal_first;
  for (uint32_t j = 0; j < r.count; ++j) {
    const uint32_t k = r.first + j;
    const glm::vec3 sp = pos[s_first + j], g = pos[goal[j]];
    const float shrink = std::min(1.0f, glm::dot(g - sp, g - sp) * d.column_inv_len2[k]);
    pos[k] = sp + r.alpha * (g - sp) + shrink * (d.lx[k] * f.x + d.ly[k] * f.y + d.lz[k] * f.z);
  }
}

namespace {

inline glm::vec3 twisted_point(const Data& d, const BandTwist& t, uint32_t k, const glm::vec3& sp, const glm::vec3& g) {
  const float shrink = std::min(1.0f, glm::dot(g - sp, g - sp) * d.column_inv_len2[k]);
  return t.origin + t.to_s * sp + t.to_g * g + shrink * (t.offset * glm::vec3(d.lx[k], d.ly[k], d.lz[k]));
}

void driven_points_twisted_scalar(const Data& d, const Data::RingOp& r, const BandTwist& t, std::span<glm::vec3> pos) {
  const uint32_t s_first = d.rings[r.s_ring].first;
  const uint32_t* goal = d.goals.data() + r.goal_first;
  for (uint32_t j = 0; j < r.count; ++j)
    pos[r.first + j] = twisted_point(d, t, r.first + j, pos[s_first + j], pos[goal[j]]);
}

void round_tip_scalar(const Data& d, const Data::RingOp& r, const TipRound& t, glm::vec3* out) {
  const float* const radius2 = d.tip_radius2.data() + r.first;
  for (uint32_t k = 0; k < r.count; ++k) {
    glm::vec3& p = out[k];
    const glm::vec3 v = p - t.centre;
    const float limit2 = t.scale2 * radius2[k];
    if (!(glm::dot(v, t.along) > 0.0f && glm::dot(v, v) > limit2)) continue;
    // Back along the ray from the ring's origin (on the link's axis) to where it leaves the
    // capsule of that radius round the link and the joint's centre: through its side while short
    // of the joint, else through the sphere round the centre (the far root of |w + s·u|² =
    // limit²). Continuous as the pose and the limit change.
    const glm::vec3 u = p - t.origin;
    const float a = glm::dot(u, u), b = glm::dot(t.w, u), along_u = glm::dot(u, t.along);
    const float across2 = a - along_u * along_u;
    if (!(a > 1e-12f)) continue;
    const float s_side = across2 > 1e-12f ? std::sqrt(limit2 / across2) : 1.0f;
    const float s_sphere = (std::sqrt(std::max(b * b - a * (t.w2 - limit2), 0.0f)) - b) / a;
    const float s = t.origin_past + s_side * along_u <= 0.0f ? s_side : s_sphere;
    p = t.origin + std::clamp(s, 0.0f, 1.0f) * u;
  }
}

void star_frames_scalar(const Data& d, State& st) {
  for (const Data::FrameRun& run : d.frame_runs)
    for (uint32_t j = 0; j < run.count; ++j) {
      const uint32_t ri = d.run_rings[run.first + j];
      st.frames[ri] = star_frame(st.chains[run.chain], run.segment, d.run_u[run.first + j], run.along_link);
    }
}

}  // namespace

#if defined(MIMIC_SIMD_AVX2)

namespace {

// Eight 3-vectors, one per lane.
struct V3 {
  __m256 x, y, z;
};
inline V3 splat(const glm::vec3& v) { return {_mm256_set1_ps(v.x), _mm256_set1_ps(v.y), _mm256_set1_ps(v.z)}; }
inline V3 lerp(const V3& a, const V3& b, __m256 u) {
  return {_mm256_fmadd_ps(u, _mm256_sub_ps(b.x, a.x), a.x), _mm256_fmadd_ps(u, _mm256_sub_ps(b.y, a.y), a.y),
          _mm256_fmadd_ps(u, _mm256_sub_ps(b.z, a.z), a.z)};
}
inline __m256 dot(const V3& a, const V3& b) {
  return _mm256_fmadd_ps(a.z, b.z, _mm256_fmadd_ps(a.y, b.y, _mm256_mul_ps(a.x, b.x)));
}
inline V3 scale(const V3& a, __m256 s) { return {_mm256_mul_ps(a.x, s), _mm256_mul_ps(a.y, s), _mm256_mul_ps(a.z, s)}; }
inline V3 sub_scaled(const V3& a, __m256 s, const V3& b) {  // a − s·b
  return {_mm256_fnmadd_ps(s, b.x, a.x), _mm256_fnmadd_ps(s, b.y, a.y), _mm256_fnmadd_ps(s, b.z, a.z)};
}
inline V3 cross(const V3& a, const V3& b) {
  return {_mm256_fmsub_ps(a.y, b.z, _mm256_mul_ps(a.z, b.y)), _mm256_fmsub_ps(a.z, b.x, _mm256_mul_ps(a.x, b.z)),
          _mm256_fmsub_ps(a.x, b.y, _mm256_mul_ps(a.y, b.x))};
}
inline V3 select(__m256 mask, const V3& yes, const V3& no) {
  return {_mm256_blendv_ps(no.x, yes.x, mask), _mm256_blendv_ps(no.y, yes.y, mask),
          _mm256_blendv_ps(no.z, yes.z, mask)};
}
// v/|v| where |v|² > 1e-20, else the fallback (as unit_or in realtime_deform.cpp).
inline V3 unit_or(const V3& v, const V3& fallback) {
  const __m256 l2 = dot(v, v);
  return select(_mm256_cmp_ps(l2, _mm256_set1_ps(1e-20f), _CMP_GT_OQ), scale(v, simd::rsqrt8(l2)), fallback);
}

// Eight columns of a boundary-driven ring from lane j: S's points, the loop's (gathered) and how
// far the rest offsets shrink with the column (min(1, |G − S|² · column_inv_len2)).
struct DrivenColumns {
  V3 s, g;
  __m256 shrink;
};
inline DrivenColumns driven_columns(const Data& d, const Data::RingOp& r, const glm::vec3* pos, uint32_t j) {
  DrivenColumns c;
  simd::load8(&pos[d.rings[r.s_ring].first + j].x, c.s.x, c.s.y, c.s.z);
  const __m256i g3 = _mm256_mullo_epi32(
      _mm256_loadu_si256(reinterpret_cast<const __m256i*>(d.goals.data() + r.goal_first + j)), _mm256_set1_epi32(3));
  const float* base = &pos[0].x;
  c.g = {_mm256_i32gather_ps(base, g3, 4), _mm256_i32gather_ps(base + 1, g3, 4), _mm256_i32gather_ps(base + 2, g3, 4)};
  const V3 col{_mm256_sub_ps(c.g.x, c.s.x), _mm256_sub_ps(c.g.y, c.s.y), _mm256_sub_ps(c.g.z, c.s.z)};
  c.shrink = _mm256_min_ps(_mm256_set1_ps(1.0f),
                           _mm256_mul_ps(dot(col, col), _mm256_loadu_ps(d.column_inv_len2.data() + r.first + j)));
  return c;
}

}  // namespace

void star_frames(const Data& d, State& st, bool vectorised) {
  if (!vectorised) return star_frames_scalar(d, st);
  constexpr float kMinLinkCos = 0.3f;  // as star_frame
  const __m256 min_cos = _mm256_set1_ps(kMinLinkCos),
               sin_min = _mm256_set1_ps(std::sqrt(1.0f - kMinLinkCos * kMinLinkCos));
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  alignas(32) float out[22][8];
  for (const Data::FrameRun& run : d.frame_runs) {
    const Chain& c = st.chains[run.chain];
    const int a = run.segment, b = std::min<int>(run.segment + 1, static_cast<int>(c.point.size()) - 1);
    const V3 pa = splat(c.point[a]), pb = splat(c.point[b]), na = splat(c.normal[a]), nb = splat(c.normal[b]);
    const V3 ra = splat(c.ref[a]), rb = splat(c.ref[b]);
    const glm::vec3 link = c.point[b] - c.point[a];
    const bool link_ok = glm::dot(link, link) > 1e-20f;
    const V3 link_dir = splat(link_ok ? link / std::sqrt(glm::dot(link, link)) : glm::vec3(0.0f));
    for (uint32_t j = 0; j < run.count; j += 8) {
      const __m256 u = _mm256_loadu_ps(d.run_u.data() + run.first + j);
      const V3 origin = lerp(pa, pb, u);
      const V3 n = unit_or(lerp(na, nb, u), na);
      const V3 ref = lerp(ra, rb, u);
      V3 front = sub_scaled(ref, dot(ref, n), n);
      // Reference along the normal (a degenerate posture): any perpendicular.
      const __m256 degenerate = _mm256_cmp_ps(dot(front, front), _mm256_set1_ps(1e-10f), _CMP_LT_OQ);
      if (_mm256_movemask_ps(degenerate)) {
        const __m256 use_x =
            _mm256_cmp_ps(_mm256_andnot_ps(_mm256_set1_ps(-0.0f), n.x), _mm256_set1_ps(0.9f), _CMP_LT_OQ);
        const V3 other{_mm256_blendv_ps(zero, one, use_x), _mm256_blendv_ps(one, zero, use_x), zero};
        front = select(degenerate, cross(n, other), front);
      }
      const V3 x = scale(front, simd::rsqrt8(dot(front, front)));
      const V3 y = cross(n, x);
      V3 axis = run.along_link && link_ok ? link_dir : n;
      const __m256 flip = _mm256_cmp_ps(dot(axis, n), zero, _CMP_LT_OQ);
      axis =
          select(flip, V3{_mm256_sub_ps(zero, axis.x), _mm256_sub_ps(zero, axis.y), _mm256_sub_ps(zero, axis.z)}, axis);
      const __m256 cos_tilt = dot(axis, n);
      const __m256 too_tilted = _mm256_cmp_ps(cos_tilt, min_cos, _CMP_LT_OQ);
      if (_mm256_movemask_ps(too_tilted)) {
        const V3 tilt = unit_or(sub_scaled(axis, cos_tilt, n), x);
        const V3 bounded{_mm256_fmadd_ps(min_cos, n.x, _mm256_mul_ps(sin_min, tilt.x)),
                         _mm256_fmadd_ps(min_cos, n.y, _mm256_mul_ps(sin_min, tilt.y)),
                         _mm256_fmadd_ps(min_cos, n.z, _mm256_mul_ps(sin_min, tilt.z))};
        axis = select(too_tilted, bounded, axis);
      }
      const __m256 along_per_normal = _mm256_div_ps(one, dot(axis, n));
      const V3 px = unit_or(sub_scaled(x, dot(x, axis), axis), y);
      const V3 py = cross(axis, px);
      const __m256* fields[22] = {
          &origin.x, &origin.y, &origin.z, &x.x,    &x.y,  &x.z,  &y.x,  &y.y,  &y.z,  &n.x,  &n.y,
          &n.z,      &axis.x,   &axis.y,   &axis.z, &px.x, &px.y, &px.z, &py.x, &py.y, &py.z, &along_per_normal};
      for (int f = 0; f < 22; ++f) _mm256_store_ps(out[f], *fields[f]);
      const uint32_t lanes = std::min<uint32_t>(8, run.count - j);
      for (uint32_t l = 0; l < lanes; ++l) {
        Frame& fr = st.frames[d.run_rings[run.first + j + l]];
        fr.origin = {out[0][l], out[1][l], out[2][l]};
        fr.x = {out[3][l], out[4][l], out[5][l]};
        fr.y = {out[6][l], out[7][l], out[8][l]};
        fr.z = {out[9][l], out[10][l], out[11][l]};
        fr.axis = {out[12][l], out[13][l], out[14][l]};
        fr.px = {out[15][l], out[16][l], out[17][l]};
        fr.py = {out[18][l], out[19][l], out[20][l]};
        fr.along_per_normal = out[21][l];
        fr.x_scale = 1.0f;
      }
    }
  }
}

void driven_points(const Data& d, const Data::RingOp& r, const Frame& f, std::span<glm::vec3> pos, bool vectorised) {
  if (!vectorised) return driven_points_scalar(d, r, f, pos);
  const uint32_t s_first = d.rings[r.s_ring].first;
  const uint32_t* goal = d.goals.data() + r.goal_first;
  const __m256 alpha = _mm256_set1_ps(r.alpha);
  const __m256 fxx = _mm256_set1_ps(f.x.x), fxy = _mm256_set1_ps(f.x.y), fxz = _mm256_set1_ps(f.x.z);
  const __m256 fyx = _mm256_set1_ps(f.y.x), fyy = _mm256_set1_ps(f.y.y), fyz = _mm256_set1_ps(f.y.z);
  const __m256 fzx = _mm256_set1_ps(f.z.x), fzy = _mm256_set1_ps(f.z.y), fzz = _mm256_set1_ps(f.z.z);
  uint32_t j = 0;
  for (; j + 8 <= r.count; j += 8) {
    const uint32_t k = r.first + j;
    const DrivenColumns c = driven_columns(d, r, pos.data(), j);
    const __m256 lx = _mm256_loadu_ps(d.lx.data() + k), ly = _mm256_loadu_ps(d.ly.data() + k),
                 lz = _mm256_loadu_ps(d.lz.data() + k);
    const __m256 ox = _mm256_fmadd_ps(alpha, _mm256_sub_ps(c.g.x, c.s.x), c.s.x);
    const __m256 oy = _mm256_fmadd_ps(alpha, _mm256_sub_ps(c.g.y, c.s.y), c.s.y);
    const __m256 oz = _mm256_fmadd_ps(alpha, _mm256_sub_ps(c.g.z, c.s.z), c.s.z);
    const __m256 rx = _mm256_fmadd_ps(lz, fzx, _mm256_fmadd_ps(ly, fyx, _mm256_mul_ps(lx, fxx)));
    const __m256 ry = _mm256_fmadd_ps(lz, fzy, _mm256_fmadd_ps(ly, fyy, _mm256_mul_ps(lx, fxy)));
    const __m256 rz = _mm256_fmadd_ps(lz, fzz, _mm256_fmadd_ps(ly, fyz, _mm256_mul_ps(lx, fxz)));
    simd::store8(&pos[k].x, _mm256_fmadd_ps(c.shrink, rx, ox), _mm256_fmadd_ps(c.shrink, ry, oy),
                 _mm256_fmadd_ps(c.shrink, rz, oz));
  }
  for (; j < r.count; ++j) {
    const uint32_t k = r.first + j;
    const glm::vec3 sp = pos[s_first + j], g = pos[goal[j]];
    const float shrink = std::min(1.0f, glm::dot(g - sp, g - sp) * d.column_inv_len2[k]);
    pos[k] = sp + r.alpha * (g - sp) + shrink * (d.lx[k] * f.x + d.ly[k] * f.y + d.lz[k] * f.z);
  }
}

void driven_points_twisted(const Data& d, const Data::RingOp& r, const BandTwist& t, std::span<glm::vec3> pos,
                           bool vectorised) {
  if (!vectorised) return driven_points_twisted_scalar(d, r, t, pos);
  // m·v for a 3×3 matrix of broadcasts (column-major, as glm's).
  struct M3 {
    __m256 m[9];
    explicit M3(const glm::mat3& a) {
      for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) m[3 * c + r] = _mm256_set1_ps(a[c][r]);
    }
    V3 times(const V3& v, const V3& add) const {
      return {_mm256_fmadd_ps(m[6], v.z, _mm256_fmadd_ps(m[3], v.y, _mm256_fmadd_ps(m[0], v.x, add.x))),
              _mm256_fmadd_ps(m[7], v.z, _mm256_fmadd_ps(m[4], v.y, _mm256_fmadd_ps(m[1], v.x, add.y))),
              _mm256_fmadd_ps(m[8], v.z, _mm256_fmadd_ps(m[5], v.y, _mm256_fmadd_ps(m[2], v.x, add.z)))};
    }
  };
  const M3 to_s(t.to_s), to_g(t.to_g), offset(t.offset);
  const V3 origin = splat(t.origin), zero = splat(glm::vec3(0.0f));
  uint32_t j = 0;
  for (; j + 8 <= r.count; j += 8) {
    const uint32_t k = r.first + j;
    const DrivenColumns c = driven_columns(d, r, pos.data(), j);
    const V3 off = offset.times(
        {_mm256_loadu_ps(d.lx.data() + k), _mm256_loadu_ps(d.ly.data() + k), _mm256_loadu_ps(d.lz.data() + k)}, zero);
    const V3 w = to_g.times(c.g, to_s.times(c.s, origin));
    simd::store8(&pos[k].x, _mm256_fmadd_ps(c.shrink, off.x, w.x), _mm256_fmadd_ps(c.shrink, off.y, w.y),
                 _mm256_fmadd_ps(c.shrink, off.z, w.z));
  }
  const uint32_t s_first = d.rings[r.s_ring].first;
  const uint32_t* goal = d.goals.data() + r.goal_first;
  for (; j < r.count; ++j) pos[r.first + j] = twisted_point(d, t, r.first + j, pos[s_first + j], pos[goal[j]]);
}

Reach star_points_avx2(const Data& d, const Data::RingOp& r, const StarRing& s, const glm::vec2* muscle_w,
                       glm::vec3* out) {
  const uint32_t n = r.count;
  const __m256 cx = _mm256_set1_ps(s.centre.x), cy = _mm256_set1_ps(s.centre.y), scale = _mm256_set1_ps(s.scale);
  const __m256 shear_z = _mm256_set1_ps(s.shear_z), shear_qx = _mm256_set1_ps(s.shear_q.x),
               shear_qy = _mm256_set1_ps(s.shear_q.y);
  const __m256 a = _mm256_set1_ps(s.a), rx = _mm256_set1_ps(s.rise.x), ry = _mm256_set1_ps(s.rise.y);
  const __m256 one = _mm256_set1_ps(1.0f), min_div = _mm256_set1_ps(kMinColumnDivisor), zero = _mm256_setzero_ps();
  const __m256 ox = _mm256_set1_ps(s.origin.x), oy = _mm256_set1_ps(s.origin.y), oz = _mm256_set1_ps(s.origin.z);
  const __m256 pxx = _mm256_set1_ps(s.px.x), pxy = _mm256_set1_ps(s.px.y), pxz = _mm256_set1_ps(s.px.z);
  const __m256 pyx = _mm256_set1_ps(s.py.x), pyy = _mm256_set1_ps(s.py.y), pyz = _mm256_set1_ps(s.py.z);
  const __m256 axx = _mm256_set1_ps(s.axis.x), axy = _mm256_set1_ps(s.axis.y), axz = _mm256_set1_ps(s.axis.z);
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  __m256 radius2 = zero, height = zero;
  // The ring's slices of the tables, held in registers across the stores (which could alias the
  // vectors' own pointers as far as the compiler knows).
  const float *const lx = d.lx.data() + r.first, *const ly = d.ly.data() + r.first, *const lz = d.lz.data() + r.first;
  const float *const lo_x = d.lo_x.data() + r.first, *const lo_y = d.lo_y.data() + r.first;
  const float *const hi_x = d.hi_x.data() + r.first, *const hi_y = d.hi_y.data() + r.first;
  const float *const dh_lo = d.dh_lo.data() + r.first, *const dh_hi = d.dh_hi.data() + r.first;
  const Data::MuscleBlock* const blocks = d.muscle_blocks.data() + r.muscle_first;
  const float* const muscle_data = d.muscle_data.data();
  const uint32_t block_count = muscle_w ? r.muscle_count : 0;
  // The last chunk of a ring reads on into the next ring's entries (the tables are padded by
  // eight at their end) and keeps only its own lanes.
  const __m256 lane = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
  alignas(32) glm::vec3 tail[8];
  for (uint32_t i = 0; i < n; i += 8) {
    __m256 x = _mm256_loadu_ps(lx + i), y = _mm256_loadu_ps(ly + i), z = _mm256_loadu_ps(lz + i);
    for (uint32_t b = 0; b < block_count; ++b) {
      const glm::vec2 w2 = muscle_w[blocks[b].dof];
      const __m256 wx = _mm256_set1_ps(w2.x), wy = _mm256_set1_ps(w2.y);
      const float* m = muscle_data + blocks[b].data + i;
      x = _mm256_add_ps(x, _mm256_fmadd_ps(wy, _mm256_loadu_ps(m + 6 * n),
                                           _mm256_fmadd_ps(wx, _mm256_loadu_ps(m + 3 * n), _mm256_loadu_ps(m))));
      y = _mm256_add_ps(y, _mm256_fmadd_ps(wy, _mm256_loadu_ps(m + 7 * n),
                                           _mm256_fmadd_ps(wx, _mm256_loadu_ps(m + 4 * n), _mm256_loadu_ps(m + n))));
      z = _mm256_add_ps(z,
                        _mm256_fmadd_ps(wy, _mm256_loadu_ps(m + 8 * n),
                                        _mm256_fmadd_ps(wx, _mm256_loadu_ps(m + 5 * n), _mm256_loadu_ps(m + 2 * n))));
    }
    x = _mm256_fmadd_ps(_mm256_sub_ps(x, cx), scale, cx);
    y = _mm256_fmadd_ps(_mm256_sub_ps(y, cy), scale, cy);
    const __m256 shear = _mm256_fmsub_ps(z, shear_z, _mm256_fmadd_ps(x, shear_qx, _mm256_mul_ps(y, shear_qy)));
    const __m256 lo = _mm256_cmp_ps(shear, zero, _CMP_LT_OQ);
    const __m256 sx = _mm256_blendv_ps(_mm256_loadu_ps(hi_x + i), _mm256_loadu_ps(lo_x + i), lo);
    const __m256 sy = _mm256_blendv_ps(_mm256_loadu_ps(hi_y + i), _mm256_loadu_ps(lo_y + i), lo);
    const __m256 divisor =
        _mm256_max_ps(_mm256_fmadd_ps(a, _mm256_fmadd_ps(sx, rx, _mm256_mul_ps(sy, ry)), one), min_div);
    const __m256 along = _mm256_min_ps(_mm256_max_ps(_mm256_div_ps(shear, divisor), _mm256_loadu_ps(dh_lo + i)),
                                       _mm256_loadu_ps(dh_hi + i));
    x = _mm256_fmadd_ps(sx, along, x);
    y = _mm256_fmadd_ps(sy, along, y);
    const __m256 h = _mm256_mul_ps(_mm256_sub_ps(z, _mm256_fmadd_ps(x, rx, _mm256_mul_ps(y, ry))), a);
    const __m256 wx = _mm256_fmadd_ps(h, axx, _mm256_fmadd_ps(y, pyx, _mm256_fmadd_ps(x, pxx, ox)));
    const __m256 wy = _mm256_fmadd_ps(h, axy, _mm256_fmadd_ps(y, pyy, _mm256_fmadd_ps(x, pxy, oy)));
    const __m256 wz = _mm256_fmadd_ps(h, axz, _mm256_fmadd_ps(y, pyz, _mm256_fmadd_ps(x, pxz, oz)));
    const __m256 valid = _mm256_cmp_ps(lane, _mm256_set1_ps(static_cast<float>(n - i)), _CMP_LT_OQ);
    radius2 =
        _mm256_max_ps(radius2, _mm256_and_ps(valid, _mm256_fmadd_ps(h, h, _mm256_fmadd_ps(y, y, _mm256_mul_ps(x, x)))));
    height = _mm256_max_ps(height, _mm256_and_ps(valid, _mm256_and_ps(z, abs_mask)));
    if (i + 8 <= n) {
      simd::store8(&out[i].x, wx, wy, wz);
    } else {
      simd::store8(&tail[0].x, wx, wy, wz);
      std::copy(tail, tail + (n - i), out + i);
    }
  }
  alignas(32) float r2[8], hz[8];
  _mm256_store_ps(r2, radius2);
  _mm256_store_ps(hz, height);
  Reach reach;
  for (int l = 0; l < 8; ++l)
    reach.radius = std::max(reach.radius, r2[l]), reach.height = std::max(reach.height, hz[l]);
  reach.radius = std::sqrt(reach.radius);
  return reach;
}

void rigid_points(const glm::mat3& rot, const glm::vec3& t, const glm::vec3* local, uint32_t count, glm::vec3* out,
                  bool vectorised) {
  uint32_t i = 0;
  if (vectorised) {
    const __m256 m00 = _mm256_set1_ps(rot[0][0]), m01 = _mm256_set1_ps(rot[0][1]), m02 = _mm256_set1_ps(rot[0][2]);
    const __m256 m10 = _mm256_set1_ps(rot[1][0]), m11 = _mm256_set1_ps(rot[1][1]), m12 = _mm256_set1_ps(rot[1][2]);
    const __m256 m20 = _mm256_set1_ps(rot[2][0]), m21 = _mm256_set1_ps(rot[2][1]), m22 = _mm256_set1_ps(rot[2][2]);
    const __m256 tx = _mm256_set1_ps(t.x), ty = _mm256_set1_ps(t.y), tz = _mm256_set1_ps(t.z);
    for (; i + 8 <= count; i += 8) {
      __m256 x, y, z;
      simd::load8(&local[i].x, x, y, z);
      // Column-major: rot[c][r]; out = Σ_c rot[c]·p[c].
      const __m256 wx = _mm256_fmadd_ps(m20, z, _mm256_fmadd_ps(m10, y, _mm256_fmadd_ps(m00, x, tx)));
      const __m256 wy = _mm256_fmadd_ps(m21, z, _mm256_fmadd_ps(m11, y, _mm256_fmadd_ps(m01, x, ty)));
      const __m256 wz = _mm256_fmadd_ps(m22, z, _mm256_fmadd_ps(m12, y, _mm256_fmadd_ps(m02, x, tz)));
      simd::store8(&out[i].x, wx, wy, wz);
    }
  }
  for (; i < count; ++i) out[i] = rot * local[i] + t;
}

void round_joint_tip(const Data& d, const Data::RingOp& r, const TipRound& t, glm::vec3* out, bool vectorised) {
  if (!vectorised) return round_tip_scalar(d, r, t, out);
  const V3 centre = splat(t.centre), along = splat(t.along), origin = splat(t.origin), w = splat(t.w);
  const __m256 scale2 = _mm256_set1_ps(t.scale2), w2 = _mm256_set1_ps(t.w2), zero = _mm256_setzero_ps();
  const __m256 one = _mm256_set1_ps(1.0f), tiny = _mm256_set1_ps(1e-12f);
  const __m256 origin_past = _mm256_set1_ps(t.origin_past);
  const __m256 lane = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
  const float* const radius2 = d.tip_radius2.data() + r.first;  // padded by eight
  const uint32_t n = r.count;
  alignas(32) glm::vec3 tail[8];
  for (uint32_t i = 0; i < n; i += 8) {
    // A ring's last chunk works on a copy: the ring's points may end the vertex buffer.
    glm::vec3* const at = i + 8 <= n ? out + i : tail;
    if (at == tail) std::fill(std::copy(out + i, out + n, tail), tail + 8, glm::vec3(0.0f));
    V3 p;
    simd::load8(&at[0].x, p.x, p.y, p.z);
    const V3 v = sub_scaled(p, one, centre);
    const __m256 limit2 = _mm256_mul_ps(scale2, _mm256_loadu_ps(radius2 + i));
    __m256 move =
        _mm256_and_ps(_mm256_cmp_ps(dot(v, along), zero, _CMP_GT_OQ), _mm256_cmp_ps(dot(v, v), limit2, _CMP_GT_OQ));
    move = _mm256_and_ps(move, _mm256_cmp_ps(lane, _mm256_set1_ps(static_cast<float>(n - i)), _CMP_LT_OQ));
    if (_mm256_movemask_ps(move) == 0) continue;
    const V3 u = sub_scaled(p, one, origin);
    const __m256 a = dot(u, u), b = dot(w, u), along_u = dot(u, along);
    const __m256 across2 = _mm256_fnmadd_ps(along_u, along_u, a);
    move = _mm256_and_ps(move, _mm256_cmp_ps(a, tiny, _CMP_GT_OQ));
    const __m256 s_side = _mm256_blendv_ps(one, _mm256_sqrt_ps(_mm256_div_ps(limit2, _mm256_max_ps(across2, tiny))),
                                           _mm256_cmp_ps(across2, tiny, _CMP_GT_OQ));
    const __m256 root =
        _mm256_sqrt_ps(_mm256_max_ps(_mm256_fmsub_ps(b, b, _mm256_mul_ps(a, _mm256_sub_ps(w2, limit2))), zero));
    const __m256 s_sphere = _mm256_div_ps(_mm256_sub_ps(root, b), _mm256_max_ps(a, tiny));
    const __m256 short_of_joint = _mm256_cmp_ps(_mm256_fmadd_ps(s_side, along_u, origin_past), zero, _CMP_LE_OQ);
    const __m256 s = _mm256_min_ps(_mm256_max_ps(_mm256_blendv_ps(s_sphere, s_side, short_of_joint), zero), one);
    p = select(
        move,
        V3{_mm256_fmadd_ps(s, u.x, origin.x), _mm256_fmadd_ps(s, u.y, origin.y), _mm256_fmadd_ps(s, u.z, origin.z)}, p);
    simd::store8(&at[0].x, p.x, p.y, p.z);
    if (at == tail) std::copy(tail, tail + (n - i), out + i);
  }
}

#else

void round_joint_tip(const Data& d, const Data::RingOp& r, const TipRound& t, glm::vec3* out, bool) {
  round_tip_scalar(d, r, t, out);
}

void star_frames(const Data& d, State& st, bool) { star_frames_scalar(d, st); }

void driven_points(const Data& d, const Data::RingOp& r, const Frame& f, std::span<glm::vec3> pos, bool) {
  driven_points_scalar(d, r, f, pos);
}

void driven_points_twisted(const Data& d, const Data::RingOp& r, const BandTwist& t, std::span<glm::vec3> pos, bool) {
  driven_points_twisted_scalar(d, r, t, pos);
}

Reach star_points_avx2(const Data& d, const Data::RingOp& r, const StarRing& s, const glm::vec2* muscle_w,
                       glm::vec3* out) {
  return star_points_scalar(d, r, s, muscle_w, out);
}

void rigid_points(const glm::mat3& rot, const glm::vec3& t, const glm::vec3* local, uint32_t count, glm::vec3* out,
                  bool) {
  for (uint32_t i = 0; i < count; ++i) out[i] = rot * local[i] + t;
}

#endif

}  // namespace mimic::avatar::realtime_detail
