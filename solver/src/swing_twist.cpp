#include "mimic/solver/swing_twist.h"

#include "fast_trig.h"
#include "mimic/rig/joint_angles.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>

namespace mimic::solver {

namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kTwoPi = 2.0f * kPi;

// The angle ± whole turns nearest `previous` (std::remainder's result up to float rounding, without
// its cost: it is called a dozen times per decomposition, a swivel search does dozens of those).
float unwrap_near(float angle, float previous) {
  const float d = angle - previous;
  return previous + (d - kTwoPi * std::nearbyint(d * (1.0f / kTwoPi)));
}

float squared_distance(const std::array<float, 3>& a, std::span<const float> b) {
  float d = 0;
  for (size_t i = 0; i < b.size(); ++i) d += (a[i] - b[i]) * (a[i] - b[i]);
  return d;
}

// rig::dofs_from_rotation for three mutually orthogonal unit axes, in float: the same exact
// Euler decomposition (basis of the axes, made right-handed by flipping the third; m = Rx(t0)·
// Ry(t1)·Rz(t2); t2 from the residual so that it stays exact near gimbal lock), of the two
// branches the one nearer `previous`. The double version builds three matrices and takes two
// more sines and cosines; here m's two columns that matter come from rotating two basis vectors.
void euler3_nearest(const glm::quat& local, std::span<const glm::vec3> axes, std::span<const float> previous,
                    std::array<float, 3>& out) {
  const float s2 = glm::dot(glm::cross(axes[0], axes[1]), axes[2]) < 0 ? -1.0f : 1.0f;
  const glm::vec3 b0 = axes[0], b1 = axes[1], b2 = s2 * axes[2];
  const glm::quat q = glm::normalize(local);
  const glm::vec3 v0 = q * b0, v2 = q * b2;  // columns 0 and 2 of m, in the world basis
  const float m00 = glm::dot(b0, v0), m10 = glm::dot(b1, v0), m20 = glm::dot(b2, v0);
  const float m02 = glm::dot(b0, v2), m12 = glm::dot(b1, v2), m22 = glm::dot(b2, v2);
  const float p0 = previous[0], p1 = previous[1], p2 = s2 * previous[2];
  const float sb = std::clamp(m02, -1.0f, 1.0f);
  const float cb = std::sqrt(std::max(0.0f, 1.0f - m02 * m02));
  const float t1 = detail::fast_atan2(sb, cb);  // asin(sb), cb ≥ 0
  const bool locked = cb < static_cast<float>(rig::kFloatLockCos);
  float t0 = p0, sa = 0, ca = 1;
  if (locked) {
    sa = std::sin(p0), ca = std::cos(p0);
  } else {
    t0 = detail::fast_atan2(-m12, m22);
    const float h = std::sqrt(m12 * m12 + m22 * m22);
    if (h > 0) sa = -m12 / h, ca = m22 / h;
  }
  // Residual (Rx(t0)·Ry(t1))ᵀ·m: its (1,0) and (0,0) entries give t2.
  const float r10 = ca * m10 + sa * m20;
  const float r00 = cb * m00 + sa * sb * m10 - ca * sb * m20;
  const float t2 = detail::fast_atan2(r10, r00);
  std::array<float, 3> a{unwrap_near(t0, p0), unwrap_near(t1, p1), unwrap_near(t2, p2)};
  std::array<float, 3> b = a;  // the other branch: (t0 + π, π − t1, t2 + π)
  if (!locked) b = {unwrap_near(t0 + kPi, p0), unwrap_near(kPi - t1, p1), unwrap_near(t2 + kPi, p2)};
  a[2] *= s2;
  b[2] *= s2;
  out = squared_distance(a, previous) <= squared_distance(b, previous) ? a : b;
}

bool orthogonal_triple(std::span<const glm::vec3> axes) {
  return axes.size() == 3 && std::abs(glm::dot(axes[0], axes[1])) < 1e-4f &&
         std::abs(glm::dot(axes[1], axes[2])) < 1e-4f && std::abs(glm::dot(axes[0], axes[2])) < 1e-4f;
}

float limit_violation(float v, std::span<const float> lo, std::span<const float> hi, size_t i) {
  if (i >= lo.size() || i >= hi.size()) return 0.0f;
  if (v < lo[i]) return lo[i] - v;
  if (v > hi[i]) return v - hi[i];
  return 0.0f;
}

// Of θ and θ ± 2π, the one inside the limits (if any) nearest the previous value: unwrapping
// towards a previous value far from the truth must not push an angle out of its range.
float nearest_turn(float angle, float previous, std::span<const float> lo, std::span<const float> hi, size_t i) {
  // Within 3 rad of the previous value and inside the limits, the angle itself wins by far (±2π
  // are at least 3.28 rad away): the common case, without the search.
  if (std::abs(angle - previous) < 3.0f && limit_violation(angle, lo, hi, i) == 0.0f) return angle;
  float best = angle, best_cost = 0;
  for (int k = -1; k <= 1; ++k) {
    const float a = angle + static_cast<float>(k) * kTwoPi;
    const float cost = 1e6f * limit_violation(a, lo, hi, i) + (a - previous) * (a - previous);
    if (k == -1 || cost < best_cost) best = a, best_cost = cost;
  }
  return best;
}

// Limits of three angles, as fixed-size arrays (none: ±infinity), so that the hot path of the
// limbs (shoulders, hips, wrists, ankles: three orthogonal axes) runs without spans' bounds.
struct Limits3 {
  std::array<float, 3> lo, hi;
  Limits3(std::span<const float> min_rad, std::span<const float> max_rad) {
    for (size_t i = 0; i < 3; ++i) {
      lo[i] = i < min_rad.size() && i < max_rad.size() ? min_rad[i] : -std::numeric_limits<float>::infinity();
      hi[i] = i < min_rad.size() && i < max_rad.size() ? max_rad[i] : std::numeric_limits<float>::infinity();
    }
  }
  float violation(float v, size_t i) const { return v < lo[i] ? lo[i] - v : v > hi[i] ? v - hi[i] : 0.0f; }
};

// Of the two Euler branches (each angle ± 2π), the one inside the limits and nearest the previous
// values: nearest_turn and the costs below, for three angles.
void choose_branch3(std::array<float, 3> base, const Limits3& lim, std::span<float> angles) {
  const std::array<float, 3> prev{angles[0], angles[1], angles[2]};
  std::array<std::array<float, 3>, 2> cand{base, {base[0] + kPi, kPi - base[1], base[2] + kPi}};
  int best = 0;
  float best_cost = 0;
  for (int k = 0; k < 2; ++k) {
    float cost = 0;
    for (size_t i = 0; i < 3; ++i) {
      float a = unwrap_near(cand[k][i], prev[i]);
      if (!(std::abs(a - prev[i]) < 3.0f && lim.violation(a, i) == 0.0f)) {  // else a wins by far, as in nearest_turn
        float turn_best = a, turn_cost = 0;
        for (int t = -1; t <= 1; ++t) {
          const float v = a + static_cast<float>(t) * kTwoPi;
          const float c = 1e6f * lim.violation(v, i) + (v - prev[i]) * (v - prev[i]);
          if (t == -1 || c < turn_cost) turn_best = v, turn_cost = c;
        }
        a = turn_best;
      }
      cand[k][i] = a;
      const float d = a - prev[i];
      cost += d * d + 1e6f * lim.violation(a, i);  // inside the limits first
    }
    if (k == 0 || cost < best_cost) best = k, best_cost = cost;
  }
  for (size_t i = 0; i < 3; ++i) angles[i] = cand[best][i];
}

// The decomposition nearest the previous values (avatar/joint_angles.h: exact Euler for three
// orthogonal axes, twist for one, best fit otherwise), then the limits: of that solution, the
// other Euler branch for three axes, and every angle ± 2π, the candidate inside the limits and
// nearest the previous values wins.
void decompose(const glm::quat& local, std::span<const glm::vec3> axes, std::span<float> angles,
               std::span<const float> lo, std::span<const float> hi) {
  const size_t n = axes.size();
  if (orthogonal_triple(axes)) {
    std::array<float, 3> base;
    euler3_nearest(local, axes, std::span<const float>(angles.data(), 3), base);
    choose_branch3(base, Limits3(lo, hi), angles);
    return;
  }
  // Two axes (the nearest expressible rotation) and others: rig's decomposition, in double.
  std::array<glm::dvec3, 3> ax;
  std::array<double, 3> prev{}, base{};
  for (size_t i = 0; i < n; ++i) ax[i] = glm::dvec3(axes[i]), prev[i] = angles[i];
  rig::dofs_from_rotation(std::span(ax.data(), n), glm::dquat(local), std::span(prev.data(), n),
                          std::span(base.data(), n), rig::kFloatLockCos);
  for (size_t i = 0; i < n; ++i) {
    const float p = angles[i];
    angles[i] = nearest_turn(unwrap_near(static_cast<float>(base[i]), p), p, lo, hi, i);
  }
}

}  // namespace

float twist_angle_rad(const glm::quat& q, const glm::vec3& axis) {
  const float along = q.x * axis.x + q.y * axis.y + q.z * axis.z;
  if (std::abs(along) < 1e-12f && std::abs(q.w) < 1e-12f) return 0.0f;  // a pure 180° swing
  return std::remainder(2.0f * std::atan2(along, q.w), kTwoPi);
}

void angles_from_rotation(const glm::quat& local, std::span<const glm::vec3> axes, std::span<float> angles_rad,
                          std::span<const float> min_rad, std::span<const float> max_rad) {
  assert(axes.size() == angles_rad.size() && !axes.empty() && axes.size() <= 3);
  decompose(local, axes, angles_rad, min_rad, max_rad);
}

void dofs_from_rotation(const rig::Skeleton& skeleton, std::span<const int> dofs, const glm::quat& rotation,
                        std::span<float> dof_rad) {
  const size_t n = dofs.size();
  if (n == 0) return;
  assert(n <= 3);
  std::array<glm::vec3, 3> axes;
  std::array<float, 3> lo{}, hi{}, angles{};
  for (size_t i = 0; i < n; ++i) {
    const rig::Dof& f = skeleton.dof(dofs[i]);
    axes[i] = f.axis;
    lo[i] = f.min_rad;
    hi[i] = f.max_rad;
    angles[i] = dof_rad[dofs[i]];
  }
  angles_from_rotation(rotation, std::span(axes.data(), n), std::span(angles.data(), n), std::span(lo.data(), n),
                       std::span(hi.data(), n));
  for (size_t i = 0; i < n; ++i) dof_rad[dofs[i]] = std::clamp(angles[i], lo[i], hi[i]);
}

void joint_dofs_from_rotation(const rig::Skeleton& skeleton, int joint, const glm::quat& local,
                              std::span<float> dof_rad) {
  std::array<int, 3> dofs{};
  const int n = skeleton.dof_end(joint) - skeleton.dof_begin(joint);
  for (int i = 0; i < n; ++i) dofs[i] = skeleton.dof_begin(joint) + i;
  dofs_from_rotation(skeleton, std::span(dofs.data(), n), local, dof_rad);
}

}  // namespace mimic::solver
