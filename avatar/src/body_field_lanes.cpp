// The body field's ray casting eight rays in lock-step (body_field.h): star contours and ray
// batches, the same march and refinement as body_field_rays.cpp per lane.
#include "mimic/avatar/body_field.h"

#include <algorithm>
#if defined(__AVX__)
#include <immintrin.h>
#endif
#include <array>
#include <cmath>
#include <limits>

#include "body_field_rays.h"

namespace mimic::avatar {

using namespace field_detail;

namespace {

// Eight rays of one contour in lock step: the field and its slope are evaluated for all eight at
// once (each at its own t) while each ray runs the same march and refinement as RayTerms.
constexpr int kLanes = 8;
typedef float v8f __attribute__((vector_size(32)));

inline v8f splat(float x) { return v8f{x, x, x, x, x, x, x, x}; }
inline v8f vsqrt(v8f x) {
#if defined(__AVX__)
  return _mm256_sqrt_ps(x);
#else
  v8f r;
  for (int l = 0; l < kLanes; ++l) r[l] = std::sqrt(x[l]);
  return r;
#endif
}
typedef int v8i __attribute__((vector_size(32)));
inline v8f vmax(v8f a, v8f b) { return a > b ? a : b; }
inline v8f vmin(v8f a, v8f b) { return a < b ? a : b; }
inline v8f vabs(v8f a) { return a < 0.0f ? -a : a; }
inline bool all_of(v8i m) {
  int all = -1;
  for (int l = 0; l < kLanes; ++l) all &= m[l];
  return all != 0;
}

struct StarBatch {
  // Per metaball term k, per lane: s(t) = A t² + 2 B t + C on support [T0, T1]; WN = 0 where
  // the lane's ray misses the support (the term then adds nothing).
  v8f A[kMaxRayCandidates], B[kMaxRayCandidates], WN[kMaxRayCandidates];
  v8f T0[kMaxRayCandidates], T1[kMaxRayCandidates], CH[kMaxRayCandidates], PK[kMaxRayCandidates];
  v8f INV_A[kMaxRayCandidates], C[kMaxRayCandidates];
  float IR2[kMaxRayCandidates], CBRT_INV_WN[kMaxRayCandidates];
  int n = 0;

  // Field and slope at t, and what the march needs to step on from t: the shortest support
  // chord containing t (+inf when none), the largest support end before t and the largest peak
  // before t (−1 when none). Lanes whose ray misses term k have T1 = PK = −1 there. Marching
  // outwards (Up), `gap` and `peak` are the smallest support start and peak after t (+inf when
  // none).
  template <bool Up = false>
  void eval(v8f t, v8f& f, v8f& slope, v8f& step, v8f& gap, v8f& peak) const {
    constexpr float inf = std::numeric_limits<float>::infinity();
    v8f sum = splat(0), d = splat(0);
    v8f st = splat(inf), bl = splat(Up ? inf : -1.0f), pk = splat(Up ? inf : -1.0f);
    for (int k = 0; k < n; ++k) {
      const v8f at = A[k] * t;
      v8f u = splat(1.0f) - ((at + 2.0f * B[k]) * t + C[k]) * IR2[k];
      u = u > 0.0f ? u : splat(0.0f);
      const v8f wu2 = WN[k] * u * u;
      sum += wu2 * u;
      d -= (6.0f * IR2[k]) * wu2 * (at + B[k]);
      const auto inside = (t <= T1[k]) & (t >= T0[k]);
      st = inside ? vmin(st, CH[k]) : st;
      if constexpr (Up) {
        bl = ((T1[k] >= 0.0f) & (T0[k] > t)) ? vmin(bl, T0[k]) : bl;
        pk = PK[k] > t ? vmin(pk, PK[k]) : pk;
      } else {
        bl = T1[k] < t ? vmax(bl, T1[k]) : bl;
        pk = PK[k] < t ? vmax(pk, PK[k]) : pk;
      }
    }
    f = sum;
    slope = d;
    step = st;
    gap = bl;
    peak = pk;
  }
};

}  // namespace

namespace {

const std::array<float, kMaxRayCandidates + 1>& inv_n_cbrt_table() {
  static const auto table = [] {
    std::array<float, kMaxRayCandidates + 1> t{};
    for (int i = 1; i <= kMaxRayCandidates; ++i) t[i] = std::cbrt(1.0f / static_cast<float>(i));
    return t;
  }();
  return table;
}

// The search of RayTerms::nearest for eight lanes: each lane marches from its point, inwards
// where the point is outside (first pass) or outwards where it is inside (second pass), to the
// first sample across the surface; per pass a lane is marching, refining (bracketed) or done.
void march_nearest(const StarBatch& batch, v8f t_near, v8f t_lo, v8f t_hi, v8f t_hard, std::span<RayHit> out) {
  const v8f iso = splat(kIsoLevel), zero = splat(0.0f), inf = splat(std::numeric_limits<float>::infinity());
  const v8i none = v8i{} != v8i{};
  v8f best = splat(-1.0f);
  v8i in0 = none;
  for (int pass = 0; pass < 2; ++pass) {
    const bool up = pass == 1;
    const v8f limit = up ? t_hi : t_lo;
    v8i done = up ? ~in0 | ~(t_near < limit) : ~(t_near > limit), refining = none;
    v8f t = t_near, t_prev = t_near, f_prev = zero;
    v8f lo = zero, hi = zero, flo = zero, fhi = zero, iters = zero;
    // The first pass's first sample is taken by every lane: it tells each point's side.
    for (int guard = 0; guard < 256 && ((!up && guard == 0) || !all_of(done)); ++guard) {
      v8f f, slope, step, gap, peak;
      if (up)
        batch.eval<true>(t, f, slope, step, gap, peak);
      else
        batch.eval<false>(t, f, slope, step, gap, peak);
      const v8i inside = f >= iso;
      if (!up && guard == 0) {
        in0 = inside;
        done = done | in0;  // points inside search outwards, in the second pass
      }
      const v8f fr = f - iso;
      // Marching: a sample across the surface brackets the crossing with the last one.
      const v8i marching = ~done & ~refining;
      const v8i bracketed = marching & (inside != in0);
      lo = bracketed ? (up ? t_prev : t) : lo;
      hi = bracketed ? (up ? t : t_prev) : hi;
      flo = bracketed ? (up ? f_prev - iso : fr) : flo;
      fhi = bracketed ? (up ? fr : f_prev - iso) : fhi;
      // Same side: the next sample (same rule as RayTerms::nearest).
      const v8i same = marching & ~bracketed;
      v8f next = step < inf ? t + (up ? 1.0f : -1.0f) * vmax(step * 0.125f, splat(kMinStep_m)) : gap;
      next = up ? vmin(next, peak) : vmax(next, peak);
      const v8i past = up ? next > limit : next < limit;
      const v8i exhausted = same & ((up ? t >= limit : t <= limit) | (past & ~(step < inf)));
      next = past ? limit : next;
      t_prev = same ? t : t_prev;
      f_prev = same ? f : f_prev;
      // Refining: Newton from the bracket, bisection whenever a step would leave it.
      const v8i lo_inside = flo >= zero;
      iters = refining ? iters + 1.0f : iters;
      const v8i converged = refining & ((vabs(fr) < 5e-4f) | (hi - lo < 1e-5f) | (iters >= 32.0f));
      best = converged ? t : best;
      const v8i stepping = refining & ~converged;
      const v8i to_lo = stepping & ((fr >= zero) == lo_inside);
      const v8i to_hi = stepping & ~to_lo;
      lo = to_lo ? t : lo;
      flo = to_lo ? fr : flo;
      hi = to_hi ? t : hi;
      fhi = to_hi ? fr : fhi;
      const v8f mid = 0.5f * (lo + hi);
      v8f newton = slope != zero ? t - fr / slope : mid;
      newton = ((newton > lo) & (newton < hi)) ? newton : mid;
      const v8i settled = stepping & (vabs(newton - t) < 2e-6f);
      best = settled ? newton : best;
      const v8f secant = (lo * fhi - hi * flo) / (fhi - flo);
      t = bracketed ? secant : stepping ? newton : (same & ~exhausted) ? next : t;
      iters = bracketed ? zero : iters;
      done = done | exhausted | converged | settled;
      refining = (refining | bracketed) & ~done;
    }
  }
  // Inside throughout: the surface lies beyond the window. Then a hard ellipsoid's exit nearer.
  best = ((best < 0.0f) & in0) ? t_hi : best;
  const auto hard_nearer = (t_hard >= 0.0f) & ((best < 0.0f) | (vabs(t_hard - t_near) < vabs(best - t_near)));
  best = hard_nearer ? t_hard : best;
  for (size_t l = 0; l < out.size(); ++l) out[l] = RayHit{best[l]};
}

// The outermost search's start per lane: beyond the last point where some term reaches 1/n
// (n the lane's terms), no crossing; −1 where no term can reach the iso-level alone.
v8f outermost_start(const StarBatch& batch, v8f count) {
  const auto& inv_n_cbrt = inv_n_cbrt_table();
  v8f inv_cbrt_n;
  for (int l = 0; l < kLanes; ++l) inv_cbrt_n[l] = inv_n_cbrt[static_cast<int>(count[l])];
  v8f start = splat(-1.0f);
  for (int k = 0; k < batch.n; ++k) {
    const v8f u_min = inv_cbrt_n * batch.CBRT_INV_WN[k];
    const v8f s_max = (1.0f - u_min) / batch.IR2[k];
    const v8f disc = batch.B[k] * batch.B[k] - batch.A[k] * (batch.C[k] - s_max);
    const v8f exit_t = (vsqrt(vmax(disc, splat(0.0f))) - batch.B[k]) * batch.INV_A[k];
    const auto ok = (batch.WN[k] > 0.0f) & (u_min < 1.0f) & (disc > 0.0f);
    start = ok ? vmax(start, exit_t) : start;
  }
  return start;
}

// The search of RayTerms::outermost for eight lanes, from each lane's start inwards; a lane's
// hard ellipsoids' exit `t_hard` bounds its result from below.
void march_outermost(const StarBatch& batch, v8f start, v8f t_hard, std::span<RayHit> out) {
  const int live = static_cast<int>(out.size());
  // Every lane's march and refinement as masks over the eight lanes: a lane is starting
  // (first sample, at the start bound), marching (field below the iso-level so far),
  // refining (bracketed) or done; each pass evaluates all eight and moves each lane on.
  const v8f iso = splat(kIsoLevel), zero = splat(0.0f), inf = splat(std::numeric_limits<float>::infinity());
  v8i done = start < zero, starting = ~done, refining = v8i{} != v8i{};
  v8f result = t_hard, t = vmax(start, zero), t_out = t, f_out = zero;
  v8f lo = zero, hi = zero, flo = zero, fhi = zero, iters = zero;
  for (int guard = 0; guard < 256 && !all_of(done); ++guard) {
    v8f f, slope, step, below, peak;
    batch.eval(t, f, slope, step, below, peak);
    const v8i inside = f >= iso;
    // The start already inside: nothing lies beyond it.
    const v8i start_in = starting & inside;
    result = start_in ? vmax(t, t_hard) : result;
    // Marching into the surface: bracketed between this sample and the last one outside.
    const v8i marching = ~done & ~refining;
    const v8i bracketed = marching & ~starting & inside;
    const v8f fr = f - iso;
    lo = bracketed ? t : lo;
    flo = bracketed ? fr : flo;
    hi = bracketed ? t_out : hi;
    fhi = bracketed ? f_out - iso : fhi;
    // Still outside: the next sample inwards (same rule as RayTerms::outermost).
    const v8i outside = marching & ~inside;
    v8f next = step < inf ? t - vmax(step * 0.125f, splat(kMinStep_m)) : below;
    next = vmax(next, peak);
    next = ((next < zero) & (step < inf)) ? zero : next;  // the last sample at the origin
    const v8i exhausted = outside & ((t <= zero) | (next < zero));
    result = exhausted ? t_hard : result;
    t_out = outside ? t : t_out;
    f_out = outside ? f : f_out;
    // Refining: Newton from the bracket, bisection whenever a step would leave it.
    iters = refining ? iters + 1.0f : iters;
    const v8i converged = refining & ((vabs(fr) < 5e-4f) | (hi - lo < 1e-5f) | (iters >= 32.0f));
    result = converged ? vmax(t, t_hard) : result;
    const v8i stepping = refining & ~converged;
    const v8i above = fr >= zero;
    lo = stepping & above ? t : lo;
    flo = stepping & above ? fr : flo;
    hi = stepping & ~above ? t : hi;
    fhi = stepping & ~above ? fr : fhi;
    const v8f mid = 0.5f * (lo + hi);
    v8f newton = slope != zero ? t - fr / slope : mid;
    newton = ((newton > lo) & (newton < hi)) ? newton : mid;
    const v8i settled = stepping & (vabs(newton - t) < 2e-6f);
    result = settled ? vmax(newton, t_hard) : result;
    // New bracket: its first estimate is the secant between the two samples.
    const v8f secant = (lo * fhi - hi * flo) / (fhi - flo);
    t = bracketed ? secant : stepping ? newton : outside & ~exhausted ? next : t;
    iters = bracketed ? zero : iters;
    done = done | start_in | exhausted | converged | settled;
    refining = (refining | bracketed) & ~done;
    starting = v8i{} != v8i{};
  }
  for (int l = 0; l < live; ++l) out[l] = RayHit{done[l] ? result[l] : t_hard[l]};
}

}  // namespace

// Eight rays in lock-step (the same march and refinement as RayTerms::outermost, or with
// `nears` RayTerms::nearest, per lane): `quadratic(k, a, b, c)` gives, per lane, the metaball
// term k's quadratic along the ray in the primitive's unit frame, |q0 + t·q1|² = a t² + 2 b t + c.
template <class Quadratic>
void BodyField::cast_lanes(std::span<const uint16_t> candidates, int n, Quadratic&& quadratic,
                           std::span<const RayNear> nears, std::span<RayHit> out) const {
  StarBatch batch;
  const int live = static_cast<int>(out.size());
  const bool near = !nears.empty();
  // Nearest search: each lane's point and window.
  v8f t_near = splat(0.0f), t_lo = splat(0.0f), t_hi = splat(std::numeric_limits<float>::infinity());
  if (near) {
    for (int l = 0; l < kLanes; ++l) {
      const RayNear& w = nears[static_cast<size_t>(std::min(l, live - 1))];
      t_lo[l] = w.t_min;
      t_hi[l] = w.t_max;
      t_near[l] = std::clamp(w.t_near, w.t_min, w.t_max);
    }
  }
  {
    // Terms of every lane; hard ellipsoids give their exit directly (for the nearest search the
    // exit within the window nearest each lane's point, clamped to the window's end).
    v8f t_hard = splat(-1.0f);
    v8f count = splat(0.0f);
    batch.n = 0;
    for (int k = 0; k < n; ++k) {
      const uint16_t idx = candidates[k];
      v8f a, b, c;
      quadratic(k, a, b, c);
      const v8f inv_a = 1.0f / a;
      if (hard_[idx]) {
        const v8f disc = b * b - a * (c - 1.0f);
        const v8f root = vsqrt(vmax(disc, splat(0.0f)));
        const v8f exit_t = (root - b) * inv_a;
        if (near) {
          const v8f entry_t = (-b - root) * inv_a, e = vmin(exit_t, t_hi);
          const auto nearer = (t_hard < 0.0f) | (vabs(e - t_near) < vabs(t_hard - t_near));
          t_hard = ((disc > 0.0f) & (entry_t <= t_hi) & (exit_t >= t_lo) & nearer) ? e : t_hard;
        } else {
          t_hard = disc > 0.0f ? vmax(t_hard, exit_t) : t_hard;
        }
        continue;
      }
      const v8f disc = b * b - a * (c - r2_[idx]);
      const v8f root = vsqrt(vmax(disc, splat(0.0f)));
      const v8f end = (root - b) * inv_a;
      const auto valid = (disc > 0.0f) & (end > 0.0f);
      bool any = false;  // a term no lane's ray meets costs every march step nothing: leave it out
      for (int l = 0; l < kLanes; ++l) any = any || valid[l];
      if (!any) continue;
      const int m = batch.n;
      batch.A[m] = a;
      batch.B[m] = b;
      batch.INV_A[m] = inv_a;
      batch.C[m] = c;
      batch.IR2[m] = inv_r2_[idx];
      batch.CBRT_INV_WN[m] = cbrt_inv_wn_[idx];
      batch.WN[m] = valid ? splat(weight_norm_[idx]) : splat(0.0f);
      const v8f start = vmax(splat(0.0f), (-b - root) * inv_a);
      batch.T0[m] = start;
      batch.T1[m] = valid ? end : splat(-1.0f);
      batch.CH[m] = 2.0f * root * inv_a;
      batch.PK[m] = valid ? vmin(vmax(-b * inv_a, start), end) : splat(-1.0f);
      count += valid ? splat(1.0f) : splat(0.0f);
      ++batch.n;
    }
    if (near) {
      march_nearest(batch, t_near, t_lo, t_hi, t_hard, out);
      return;
    }
    march_outermost(batch, outermost_start(batch, count), t_hard, out);
  }
}

void BodyField::cast_star(const glm::vec3& origin, const glm::vec3& front, const glm::vec3& left,
                          std::span<const float> cos_a, std::span<const float> sin_a,
                          std::span<const uint16_t> candidates, std::span<RayHit> hits) const {
  // Everything that does not depend on the ray's angle is computed once per contour:
  // q0 = M(o − c), M·front, M·left; then q1 = cos·Mf + sin·Ml per ray.
  const int n = std::min<int>(static_cast<int>(candidates.size()), kMaxRayCandidates);
  glm::vec3 q0[kMaxRayCandidates], mf[kMaxRayCandidates], ml[kMaxRayCandidates];
  float cc[kMaxRayCandidates];
  for (int k = 0; k < n; ++k) {
    const uint16_t idx = candidates[k];
    const glm::mat3& m = unit_from_world_[idx];
    q0[k] = m * (origin - center_[idx]);
    mf[k] = m * front;
    ml[k] = m * left;
    cc[k] = glm::dot(q0[k], q0[k]);
  }

  const size_t rays = std::min(cos_a.size(), sin_a.size());
  for (size_t first = 0; first < rays; first += kLanes) {
    const int live = static_cast<int>(std::min<size_t>(kLanes, rays - first));
    v8f ca, sa;
    for (int l = 0; l < kLanes; ++l) {
      const size_t r = first + static_cast<size_t>(std::min(l, live - 1));
      ca[l] = cos_a[r];
      sa[l] = sin_a[r];
    }
    cast_lanes(
        candidates, n,
        [&](int k, v8f& a, v8f& b, v8f& c) {
          const v8f qx = ca * mf[k].x + sa * ml[k].x, qy = ca * mf[k].y + sa * ml[k].y,
                    qz = ca * mf[k].z + sa * ml[k].z;
          a = qx * qx + qy * qy + qz * qz;
          b = q0[k].x * qx + q0[k].y * qy + q0[k].z * qz;
          c = splat(cc[k]);
        },
        {}, hits.subspan(first, static_cast<size_t>(live)));
  }
}

void BodyField::cast_rays_lanes(std::span<const glm::vec3> origins, std::span<const glm::vec3> dirs,
                                std::span<const uint16_t> candidates, std::span<const RayNear> nears,
                                std::span<RayHit> hits) const {
  const int n = std::min<int>(static_cast<int>(candidates.size()), kMaxRayCandidates);
  const size_t rays = std::min(origins.size(), dirs.size());
  for (size_t first = 0; first < rays; first += kLanes) {
    const int live = static_cast<int>(std::min<size_t>(kLanes, rays - first));
    v8f ox, oy, oz, dx, dy, dz;
    for (int l = 0; l < kLanes; ++l) {
      const size_t r = first + static_cast<size_t>(std::min(l, live - 1));
      ox[l] = origins[r].x, oy[l] = origins[r].y, oz[l] = origins[r].z;
      dx[l] = dirs[r].x, dy[l] = dirs[r].y, dz[l] = dirs[r].z;
    }
    cast_lanes(
        candidates, n,
        [&](int k, v8f& a, v8f& b, v8f& c) {
          const uint16_t idx = candidates[k];
          const glm::mat3& m = unit_from_world_[idx];  // column-major: m[col][row]
          const glm::vec3 ctr = center_[idx];
          const v8f px = ox - ctr.x, py = oy - ctr.y, pz = oz - ctr.z;
          const v8f q0x = m[0][0] * px + m[1][0] * py + m[2][0] * pz;
          const v8f q0y = m[0][1] * px + m[1][1] * py + m[2][1] * pz;
          const v8f q0z = m[0][2] * px + m[1][2] * py + m[2][2] * pz;
          const v8f q1x = m[0][0] * dx + m[1][0] * dy + m[2][0] * dz;
          const v8f q1y = m[0][1] * dx + m[1][1] * dy + m[2][1] * dz;
          const v8f q1z = m[0][2] * dx + m[1][2] * dy + m[2][2] * dz;
          a = q1x * q1x + q1y * q1y + q1z * q1z;
          b = q0x * q1x + q0y * q1y + q0z * q1z;
          c = q0x * q0x + q0y * q0y + q0z * q0z;
        },
        nears.empty() ? nears : nears.subspan(first, static_cast<size_t>(live)),
        hits.subspan(first, static_cast<size_t>(live)));
  }
}

void BodyField::cast_rays(std::span<const glm::vec3> origins, std::span<const glm::vec3> dirs,
                          std::span<const uint16_t> candidates, std::span<RayHit> hits) const {
  cast_rays_lanes(origins, dirs, candidates, {}, hits);
}

void BodyField::cast_rays_nearest(std::span<const glm::vec3> origins, std::span<const glm::vec3> dirs,
                                  std::span<const RayNear> nears, std::span<const uint16_t> candidates,
                                  std::span<RayHit> hits) const {
  cast_rays_lanes(origins, dirs, candidates, nears.first(std::min(origins.size(), dirs.size())), hits);
}

}  // namespace mimic::avatar
