#include "mimic/rig/joint_angles.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>

namespace mimic::rig {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;

double e(const glm::dmat3& m, int row, int col) { return m[col][row]; }

// Angle of the rotation about unit `axis` closest to q (the twist of a swing-twist split).
double twist_angle(const glm::dquat& q, const glm::dvec3& axis) {
  const double s = glm::dot(glm::dvec3(q.x, q.y, q.z), axis);
  return 2.0 * std::atan2(s, q.w);
}

// How far apart two rotations are: 1 − |<a, b>| is monotonic in the angle between them.
double rotation_misfit(const glm::dquat& a, const glm::dquat& b) {
  return 1.0 - std::abs(glm::dot(glm::normalize(a), glm::normalize(b)));
}

double distance2(std::span<const double> a, std::span<const double> b) {
  double d = 0;
  for (size_t i = 0; i < a.size(); ++i) d += (a[i] - b[i]) * (a[i] - b[i]);
  return d;
}

bool orthogonal(const glm::dvec3& a, const glm::dvec3& b) { return std::abs(glm::dot(a, b)) < 1e-6; }

// Minimises the misfit one axis at a time; each step is the exact optimum for its axis given
// the others, so the misfit never increases.
void refine(std::span<const glm::dvec3> axes, const glm::dquat& target, std::span<double> v, int iterations) {
  const size_t n = axes.size();
  for (int it = 0; it < iterations; ++it) {
    for (size_t i = 0; i < n; ++i) {
      glm::dquat before(1, 0, 0, 0), after(1, 0, 0, 0);
      for (size_t k = 0; k < i; ++k) before = before * glm::angleAxis(v[k], axes[k]);
      for (size_t k = i + 1; k < n; ++k) after = after * glm::angleAxis(v[k], axes[k]);
      const glm::dquat want = glm::inverse(before) * target * glm::inverse(after);
      v[i] = unwrap_near(twist_angle(want, axes[i]), v[i]);
    }
  }
}

// Exact decomposition for three mutually orthogonal unit axes. Writes both Euler branches
// (each unwrapped towards previous) into a and b.
void euler3(std::span<const glm::dvec3> axes, const glm::dquat& target, std::span<const double> previous,
            double lock_cos, std::array<double, 3>& a, std::array<double, 3>& b) {
  // Change of basis to x, y, z: B has the axes as columns, made right-handed by flipping a2.
  const double s2 = glm::dot(glm::cross(axes[0], axes[1]), axes[2]) < 0 ? -1.0 : 1.0;
  const glm::dmat3 basis(axes[0], axes[1], s2 * axes[2]);
  const glm::dmat3 m = glm::transpose(basis) * glm::mat3_cast(glm::normalize(target)) * basis;
  const double p0 = previous[0], p1 = previous[1], p2 = s2 * previous[2];
  // m = Rx(t0) · Ry(t1) · Rz(t2): m02 = sin t1, m12 = −sin t0 cos t1, m22 = cos t0 cos t1.
  const double t1 = std::asin(std::clamp(e(m, 0, 2), -1.0, 1.0));
  const double c1 = std::sqrt(std::max(0.0, 1.0 - e(m, 0, 2) * e(m, 0, 2)));
  const double t0 = c1 < lock_cos ? p0 : std::atan2(-e(m, 1, 2), e(m, 2, 2));
  // t2 from the residual, so it is exact even in (or near) gimbal lock.
  auto residual_t2 = [&](double x0, double x1) {
    const glm::dmat3 r = glm::transpose(glm::mat3_cast(glm::angleAxis(x0, glm::dvec3(1, 0, 0)) *
                                                       glm::angleAxis(x1, glm::dvec3(0, 1, 0)))) *
                         m;
    return std::atan2(e(r, 1, 0), e(r, 0, 0));
  };
  const double t2 = residual_t2(t0, t1);
  a = {unwrap_near(t0, p0), unwrap_near(t1, p1), unwrap_near(t2, p2)};
  // Second branch: (t0 + π, π − t1, t2 + π) is the same rotation.
  if (c1 < lock_cos) {
    b = a;
  } else {
    b = {unwrap_near(t0 + kPi, p0), unwrap_near(kPi - t1, p1), unwrap_near(t2 + kPi, p2)};
  }
  a[2] *= s2;
  b[2] *= s2;
}

}  // namespace

double unwrap_near(double angle_rad, double near_rad) {
  return angle_rad + kTwoPi * std::round((near_rad - angle_rad) / kTwoPi);
}

glm::dquat rotation_from_dofs(std::span<const glm::dvec3> axes, std::span<const double> values_rad) {
  glm::dquat r(1, 0, 0, 0);
  for (size_t i = 0; i < axes.size(); ++i) r = r * glm::angleAxis(values_rad[i], axes[i]);
  return r;
}

void dofs_from_rotation(std::span<const glm::dvec3> axes, const glm::dquat& target_in, std::span<const double> previous,
                        std::span<double> out, double lock_cos) {
  const size_t n = axes.size();
  assert(n >= 1 && n <= kMaxJointDofs && previous.size() == n && out.size() == n);
  const glm::dquat target = glm::normalize(target_in);
  if (n == 1) {
    out[0] = unwrap_near(twist_angle(target, axes[0]), previous[0]);
    return;
  }
  if (n == 3 && orthogonal(axes[0], axes[1]) && orthogonal(axes[1], axes[2]) && orthogonal(axes[0], axes[2])) {
    std::array<double, 3> a, b;
    euler3(axes, target, previous, lock_cos, a, b);
    const auto& best = distance2(a, previous) <= distance2(b, previous) ? a : b;
    std::copy(best.begin(), best.end(), out.begin());
    return;
  }
  if (n == 2 && orthogonal(axes[0], axes[1])) {
    // Complete to three axes, solve exactly, drop the third and polish: both branches, the
    // better fit wins (the nearer one when they fit equally well).
    const glm::dvec3 full[3] = {axes[0], axes[1], glm::cross(axes[0], axes[1])};
    const double prev3[3] = {previous[0], previous[1], 0.0};
    std::array<double, 3> a, b;
    euler3(full, target, prev3, lock_cos, a, b);
    double va[2] = {a[0], a[1]}, vb[2] = {b[0], b[1]};
    refine(axes, target, va, 8);
    refine(axes, target, vb, 8);
    const double fa = rotation_misfit(rotation_from_dofs(axes, va), target);
    const double fb = rotation_misfit(rotation_from_dofs(axes, vb), target);
    const double* best = va;
    if (fb < fa - 1e-12 || (std::abs(fa - fb) <= 1e-12 && distance2(vb, previous) < distance2(va, previous))) best = vb;
    out[0] = best[0];
    out[1] = best[1];
    return;
  }
  // General axes: per-axis minimisation from the previous values.
  std::copy(previous.begin(), previous.end(), out.begin());
  refine(axes, target, out, 50);
}

bool dofs_aim(std::span<const glm::dvec3> axes, const glm::dvec3& from_in, const glm::dvec3& to_in,
              std::span<const double> previous, std::span<double> out) {
  assert((axes.size() == 1 || axes.size() == 2) && previous.size() == axes.size() && out.size() == axes.size());
  const glm::dvec3 from = glm::normalize(from_in), to = glm::normalize(to_in);
  // One axis: the angle between the two directions projected onto the plane normal to it.
  auto aim1 = [](const glm::dvec3& axis, const glm::dvec3& f, const glm::dvec3& t, double prev, double& angle) {
    const glm::dvec3 fp = f - glm::dot(f, axis) * axis, tp = t - glm::dot(t, axis) * axis;
    if (glm::length(fp) < 1e-12 || glm::length(tp) < 1e-12) {
      angle = prev;
    } else {
      angle = unwrap_near(std::atan2(glm::dot(axis, glm::cross(fp, tp)), glm::dot(fp, tp)), prev);
    }
    return std::abs(glm::dot(f, axis) - glm::dot(t, axis)) < 1e-9;
  };
  if (axes.size() == 1) return aim1(axes[0], from, to, previous[0], out[0]);

  // Two axes: θ1 must put R(a1, θ1)·from on the cone about a0 that holds `to`:
  // a0 · R(a1, θ1) from = A cos θ1 + B sin θ1 + C (Rodrigues), = a0 · to.
  const glm::dvec3 &a0 = axes[0], &a1 = axes[1];
  const double c = glm::dot(a0, a1) * glm::dot(a1, from);
  const double A = glm::dot(a0, from) - c, B = glm::dot(a0, glm::cross(a1, from));
  const double r = std::hypot(A, B);
  bool exact = true;
  double cands[2];
  int count = 0;
  if (r < 1e-12) {
    cands[count++] = previous[1];
    exact = std::abs(c - glm::dot(a0, to)) < 1e-9;
  } else {
    double ratio = (glm::dot(a0, to) - c) / r;
    if (ratio > 1.0 || ratio < -1.0) exact = false;
    ratio = std::clamp(ratio, -1.0, 1.0);
    const double phi = std::atan2(B, A), delta = std::acos(ratio);
    cands[count++] = phi + delta;
    cands[count++] = phi - delta;
  }
  double best[2] = {0, 0}, best_d = 1e300;
  for (int k = 0; k < count; ++k) {
    double v[2];
    v[1] = unwrap_near(cands[k], previous[1]);
    const glm::dvec3 f1 = glm::angleAxis(v[1], a1) * from;
    aim1(a0, f1, to, previous[0], v[0]);
    const double d = distance2(v, previous);
    if (d < best_d) {
      best_d = d;
      best[0] = v[0];
      best[1] = v[1];
    }
  }
  out[0] = best[0];
  out[1] = best[1];
  return exact;
}

void solve_joint_dofs(const Skeleton& skeleton, int joint, const glm::dquat& local, std::span<float> dof_rad) {
  const int begin = skeleton.dof_begin(joint), n = skeleton.dof_end(joint) - begin;
  if (n == 0) return;
  std::array<glm::dvec3, kMaxJointDofs> axes;
  std::array<double, kMaxJointDofs> prev, out;
  for (int i = 0; i < n; ++i) {
    axes[i] = glm::dvec3(skeleton.dof(begin + i).axis);
    prev[i] = dof_rad[begin + i];
  }
  dofs_from_rotation(std::span(axes.data(), n), local, std::span(prev.data(), n), std::span(out.data(), n));
  for (int i = 0; i < n; ++i) dof_rad[begin + i] = static_cast<float>(out[i]);
}

}  // namespace mimic::rig
