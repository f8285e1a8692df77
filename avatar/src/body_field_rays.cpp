// The body field's ray casting one ray at a time (body_field.h): the metaball terms along a ray,
// the outermost crossing and the crossing nearest a point, by marching and refining.
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

// The metaball terms along one ray: term k contributes wn[k]·g(a t² + 2 b t + c).
struct RayTerms {
  float qa[kMaxRayCandidates], qb[kMaxRayCandidates], qc[kMaxRayCandidates];
  float ir2[kMaxRayCandidates], wn[kMaxRayCandidates], peak[kMaxRayCandidates];
  float t0[kMaxRayCandidates], t1[kMaxRayCandidates], chord[kMaxRayCandidates];
  float cbrt_inv_wn[kMaxRayCandidates], inv_qa[kMaxRayCandidates];
  int n = 0;
  float t_far = -1.0f;
  float t_hard = -1.0f;

  // Adds a metaball term if its support reaches t ≥ 0.
  void add(float a, float b, float c, float r2, float inv_r2, float weight_norm, float cbrt_inv_weight_norm) {
    const float disc = b * b - a * (c - r2);
    if (disc <= 0.0f || n == kMaxRayCandidates) return;
    const float root = std::sqrt(disc);
    const float inv_a = 1.0f / a;
    const float end = (root - b) * inv_a;
    if (end <= 0.0f) return;
    const float start = std::max(0.0f, (-b - root) * inv_a);
    qa[n] = a;
    qb[n] = b;
    qc[n] = c;
    ir2[n] = inv_r2;
    wn[n] = weight_norm;
    cbrt_inv_wn[n] = cbrt_inv_weight_norm;
    peak[n] = std::clamp(-b * inv_a, start, end);
    t0[n] = start;
    t1[n] = end;
    chord[n] = 2.0f * root * inv_a;  // whole support chord, also where the ray starts inside it
    inv_qa[n] = inv_a;
    t_far = std::max(t_far, end);
    ++n;
  }
  void add_hard(float a, float b, float c) {
    const float disc = b * b - a * (c - 1.0f);
    if (disc > 0.0f) t_hard = std::max(t_hard, (-b + std::sqrt(disc)) / a);
  }

  float field_at(float t) const {
    float sum = 0;
    for (int k = 0; k < n; ++k) sum += term((qa[k] * t + 2.0f * qb[k]) * t + qc[k], ir2[k], wn[k]);
    return sum;
  }

  // Beyond the last point where some term reaches 1/n, the sum of the n terms is below the
  // iso-level: the outermost crossing cannot lie further out. −1 when no term ever does.
  float start_bound() const {
    static const auto table = [] {
      std::array<float, kMaxRayCandidates + 1> t{};
      for (int i = 1; i <= kMaxRayCandidates; ++i) t[i] = std::cbrt(1.0f / static_cast<float>(i));
      return t;
    }();
    const float inv_n_cbrt = table[n];
    float start = -1.0f;
    for (int k = 0; k < n; ++k) {
      // term_k ≥ 1/n  ⇔  u ≥ (1/(n·wn))^(1/3)  ⇔  s ≤ R²·(1 − that).
      const float u_min = inv_n_cbrt * cbrt_inv_wn[k];
      if (u_min >= 1.0f) continue;
      const float s_max = (1.0f - u_min) / ir2[k];
      const float disc = qb[k] * qb[k] - qa[k] * (qc[k] - s_max);
      if (disc <= 0.0f) continue;
      start = std::max(start, (std::sqrt(disc) - qb[k]) * inv_qa[k]);
    }
    return start;
  }

  // Outermost t with field ≥ 1 (or a hard ellipsoid's exit), −1 when none.
  float outermost() {
    float t_meta = -1.0f;
    const float start = n > 0 ? start_bound() : -1.0f;
    if (start >= 0.0f) {
      t_far = start;
      // March inwards from the far end of all supports with a step no longer than an eighth
      // of the shortest support chord around the current t, stopping at every primitive's peak
      // on the way, so neither a thin primitive nor a blended bridge between two is stepped over.
      float t_out = t_far, f_out = field_at(t_far);
      float t = t_far;
      if (f_out >= kIsoLevel) return std::max(t_far, t_hard);
      while (t > 0.0f) {
        float step = std::numeric_limits<float>::max();
        float below = -1.0f;    // the next support end inside, when t is in no support
        float peak_in = -1.0f;  // the next peak inside
        for (int k = 0; k < n; ++k) {
          if (t <= t1[k] && t >= t0[k])
            step = std::min(step, chord[k]);
          else if (t1[k] < t)
            below = std::max(below, t1[k]);
          if (peak[k] < t) peak_in = std::max(peak_in, peak[k]);
        }
        float next = step < std::numeric_limits<float>::max() ? t - std::max(step * 0.125f, kMinStep_m) : below;
        next = std::max(next, peak_in);
        if (next < 0.0f) {
          if (step == std::numeric_limits<float>::max()) break;  // nothing further in
          next = 0.0f;                                           // the last sample at the origin
        }
        t = next;
        const float f = field_at(t);
        if (f >= kIsoLevel) {
          t_meta = refine(t, f, t_out, f_out);
          break;
        }
        t_out = t;
        f_out = f;
      }
    }
    return std::max(t_meta, t_hard);
  }

  // Field and its derivative along the ray.
  float field_and_slope(float t, float& slope) const {
    float sum = 0, d = 0;
    for (int k = 0; k < n; ++k) {
      const float u = 1.0f - ((qa[k] * t + 2.0f * qb[k]) * t + qc[k]) * ir2[k];
      if (u > 0.0f) {
        sum += wn[k] * u * u * u;
        d -= 3.0f * wn[k] * u * u * ir2[k] * 2.0f * (qa[k] * t + qb[k]);
      }
    }
    slope = d;
    return sum;
  }

  // Bracketed root of field − 1 on [lo, hi] (lo < hi, one end inside and the other outside):
  // Newton steps from the secant estimate, falling back to bisection whenever a step leaves the
  // bracket.
  float refine(float lo, float f_lo, float hi, float f_hi) const {
    float flo = f_lo - kIsoLevel, fhi = f_hi - kIsoLevel;
    const bool lo_inside = flo >= 0.0f;
    float t = (lo * fhi - hi * flo) / (fhi - flo);
    for (int it = 0; it < 32; ++it) {
      float slope;
      const float f = field_and_slope(t, slope) - kIsoLevel;
      // |f| < 5e-4 is about ten micrometres along the ray at the body's field gradients.
      if (std::abs(f) < 5e-4f || hi - lo < 1e-5f) return t;
      if ((f >= 0.0f) == lo_inside)
        lo = t, flo = f;
      else
        hi = t, fhi = f;
      float next = slope != 0.0f ? t - f / slope : 0.5f * (lo + hi);
      if (!(next > lo && next < hi)) next = 0.5f * (lo + hi);
      if (std::abs(next - t) < 2e-6f) return next;
      t = next;
    }
    return t;
  }

  // Where the solid around t_near ends along the ray, within the window: from a point outside,
  // the first crossing inwards (the surface beneath it); from a point inside, the first one
  // outwards (t_max when the window is inside throughout). −1 when a point outside has no solid
  // beneath it within the window. The march of outermost(), run from t_near.
  float nearest(const RayNear& w) const {
    constexpr float inf = std::numeric_limits<float>::infinity();
    const float tn = std::clamp(w.t_near, w.t_min, w.t_max);
    float t = tn, f = field_at(tn);
    const bool in0 = f >= kIsoLevel, up = in0;
    const float limit = up ? w.t_max : w.t_min;
    while (up ? t < limit : t > limit) {
      float step = inf, gap = up ? inf : -1.0f, pk = up ? inf : -1.0f;
      for (int k = 0; k < n; ++k) {
        if (t <= t1[k] && t >= t0[k])
          step = std::min(step, chord[k]);
        else if (!up && t1[k] < t)
          gap = std::max(gap, t1[k]);
        else if (up && t0[k] > t)
          gap = std::min(gap, t0[k]);
        if (!up && peak[k] < t) pk = std::max(pk, peak[k]);
        if (up && peak[k] > t) pk = std::min(pk, peak[k]);
      }
      float next = step < inf ? t + (up ? 1.0f : -1.0f) * std::max(step * 0.125f, kMinStep_m) : gap;
      next = up ? std::min(next, pk) : std::max(next, pk);
      if (up ? next > limit : next < limit) {
        if (step == inf) break;  // nothing more before the limit
        next = limit;
      }
      const float fn = field_at(next);
      if ((fn >= kIsoLevel) != in0) return up ? refine(t, f, next, fn) : refine(next, fn, t, f);
      t = next;
      f = fn;
    }
    return in0 ? w.t_max : -1.0f;
  }
};

// A hard ellipsoid's exit along the ray within the window (clamped to t_max), as a crossing for
// the nearest search: replaces `best` when nearer to t_near.
inline void nearest_hard_exit(float entry, float exit, const RayNear& w, float tn, float& best) {
  if (entry > w.t_max || exit < w.t_min) return;
  const float e = std::min(exit, w.t_max);
  if (best < 0.0f || std::abs(e - tn) < std::abs(best - tn)) best = e;
}

}  // namespace

bool BodyField::ray_quadratic(uint16_t idx, const glm::vec3& origin, const glm::vec3& dir, float& a, float& b,
                              float& c) const {
  // Cheap reject: the ray must pass within the primitive's bounding sphere, ahead of the origin.
  const glm::vec3 v = center_[idx] - origin;
  const float along = glm::dot(v, dir), bound = bound_radius_[idx];
  if (along < -bound || glm::dot(v, v) - along * along > bound * bound) return false;
  const glm::mat3& m = unit_from_world_[idx];
  const glm::vec3 q0 = m * (origin - center_[idx]);
  const glm::vec3 q1 = m * dir;
  a = glm::dot(q1, q1), b = glm::dot(q0, q1), c = glm::dot(q0, q0);
  return true;
}

RayHit BodyField::cast_outermost(const glm::vec3& origin, const glm::vec3& dir,
                                 std::span<const uint16_t> candidates) const {
  RayTerms terms;
  for (uint16_t idx : candidates) {
    float a, b, c;
    if (!ray_quadratic(idx, origin, dir, a, b, c)) continue;
    if (hard_[idx])
      terms.add_hard(a, b, c);
    else
      terms.add(a, b, c, r2_[idx], inv_r2_[idx], weight_norm_[idx], cbrt_inv_wn_[idx]);
  }
  return RayHit{terms.outermost()};
}

RayHit BodyField::cast_nearest(const glm::vec3& origin, const glm::vec3& dir, std::span<const uint16_t> candidates,
                               RayNear near) const {
  RayTerms terms;
  float hard_best = -1.0f;
  const float tn = std::clamp(near.t_near, near.t_min, near.t_max);
  for (uint16_t idx : candidates) {
    float a, b, c;
    if (!ray_quadratic(idx, origin, dir, a, b, c)) continue;
    if (hard_[idx]) {
      const float disc = b * b - a * (c - 1.0f);
      if (disc > 0.0f) {
        const float root = std::sqrt(disc), inv_a = 1.0f / a;
        nearest_hard_exit((-b - root) * inv_a, (root - b) * inv_a, near, tn, hard_best);
      }
    } else {
      terms.add(a, b, c, r2_[idx], inv_r2_[idx], weight_norm_[idx], cbrt_inv_wn_[idx]);
    }
  }
  float t = terms.nearest(near);
  if (hard_best >= 0.0f && (t < 0.0f || std::abs(hard_best - tn) < std::abs(t - tn))) t = hard_best;
  return RayHit{t};
}

}  // namespace mimic::avatar
