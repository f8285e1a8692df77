#include "mimic/solver/swing_twist.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>

namespace mimic::solver {

namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kTwoPi = 2.0f * kPi;

float unwrap_near(float angle, float previous) {
  return previous + std::remainder(angle - previous, kTwoPi);
}

float limit_violation(float v, std::span<const float> lo, std::span<const float> hi, size_t i) {
  if (i >= lo.size() || i >= hi.size()) return 0.0f;
  if (v < lo[i]) return lo[i] - v;
  if (v > hi[i]) return v - hi[i];
  return 0.0f;
}

// Candidate cost: distance to the previous values; leaving the limits costs far more.
// Of θ and θ ± 2π, the one inside the limits (if any) nearest the previous value: unwrapping
// towards a previous value far from the truth must not push an angle out of its range.
float nearest_turn(float angle, float previous, std::span<const float> lo, std::span<const float> hi, size_t i) {
  float best = angle, best_cost = 0;
  for (int k = -1; k <= 1; ++k) {
    const float a = angle + static_cast<float>(k) * kTwoPi;
    const float cost = 1e6f * limit_violation(a, lo, hi, i) + (a - previous) * (a - previous);
    if (k == -1 || cost < best_cost) best = a, best_cost = cost;
  }
  return best;
}

// With two DOFs the third angle is what gets dropped, so it should be small (prev = 0).
float branch_cost(const std::array<float, 3>& c, const std::array<float, 3>& prev,
                  std::span<const float> lo, std::span<const float> hi) {
  float cost = 0;
  for (size_t i = 0; i < 3; ++i) {
    const float d = c[i] - prev[i];
    const float v = limit_violation(c[i], lo, hi, i);
    cost += d * d + 1e6f * v;  // inside the limits first, nearest second
  }
  return cost;
}

// XYZ Euler angles of R' = Rx(α) Ry(β) Rz(γ) (glm matrices are column-major: m[col][row]).
void decompose3(const glm::quat& local, const glm::vec3& a0, const glm::vec3& a1, const glm::vec3& a2,
                std::span<float> angles, size_t n_out, std::span<const float> lo,
                std::span<const float> hi) {
  // In the basis (a0, a1, ±a2) the DOF rotations become rotations about x, y, z.
  // Double precision: near gimbal lock the float angles lose a fraction of a degree.
  const double s = glm::dot(glm::cross(a0, a1), a2) < 0 ? -1.0 : 1.0;
  const glm::dmat3 m(glm::dvec3(a0), glm::dvec3(a1), s * glm::dvec3(a2));
  const glm::dmat3 r = glm::transpose(m) * glm::mat3_cast(glm::dquat(local)) * m;
  std::array<float, 3> prev{angles[0], angles[1], n_out > 2 ? angles[2] : 0.0f};

  std::array<std::array<float, 3>, 2> cand{};
  int n_cand = 2;
  const double sb = std::clamp(r[2][0], -1.0, 1.0);
  const double beta = std::asin(sb);
  if (std::cos(beta) > 1e-6) {
    const double alpha = std::atan2(-r[2][1], r[2][2]);
    const double gamma = std::atan2(-r[1][0], r[0][0]);
    cand[0] = {float(alpha), float(beta), float(s * gamma)};
    cand[1] = {float(alpha + kPi), float(kPi - beta), float(s * (gamma + kPi))};
  } else {
    // Gimbal lock: α and γ turn about the same axis; keep α and give the rest to γ.
    const double alpha = prev[0];
    const glm::dmat3 rx_inv = glm::mat3_cast(glm::angleAxis(-alpha, glm::dvec3(1, 0, 0)));
    const glm::dmat3 nm = rx_inv * r;
    const double gamma = std::atan2(nm[0][1], nm[1][1]);
    const double b = std::atan2(nm[2][0], nm[2][2]);
    cand[0] = {float(alpha), float(b), float(s * gamma)};
    n_cand = 1;
  }
  int best = 0;
  float best_cost = 0;
  for (int k = 0; k < n_cand; ++k) {
    for (size_t i = 0; i < 3; ++i) cand[k][i] = nearest_turn(unwrap_near(cand[k][i], prev[i]), prev[i], lo, hi, i);
    const float cost = branch_cost(cand[k], prev, lo, hi);
    if (k == 0 || cost < best_cost) {
      best = k;
      best_cost = cost;
    }
  }
  for (size_t i = 0; i < n_out; ++i) angles[i] = cand[best][i];
}

}  // namespace

float twist_angle_rad(const glm::quat& q, const glm::vec3& axis) {
  const float along = q.x * axis.x + q.y * axis.y + q.z * axis.z;
  if (std::abs(along) < 1e-12f && std::abs(q.w) < 1e-12f) return 0.0f;  // a pure 180° swing
  return std::remainder(2.0f * std::atan2(along, q.w), kTwoPi);
}

void angles_from_rotation(const glm::quat& local, std::span<const glm::vec3> axes,
                          std::span<float> angles_rad, std::span<const float> min_rad,
                          std::span<const float> max_rad) {
  assert(axes.size() == angles_rad.size() && !axes.empty() && axes.size() <= 3);
  switch (axes.size()) {
    case 1:
      angles_rad[0] = nearest_turn(unwrap_near(twist_angle_rad(local, axes[0]), angles_rad[0]), angles_rad[0],
                                   min_rad, max_rad, 0);
      break;
    case 2: {
      // Dropping the rotation about a0 × a1 (the rightmost factor) keeps that axis' image.
      const glm::vec3 third = glm::cross(axes[0], axes[1]);
      decompose3(local, axes[0], axes[1], third, angles_rad, 2, min_rad, max_rad);
      break;
    }
    default:
      decompose3(local, axes[0], axes[1], axes[2], angles_rad, 3, min_rad, max_rad);
  }
}

void dofs_from_rotation(const avatar::Skeleton& skeleton, std::span<const int> dofs,
                        const glm::quat& rotation, std::span<float> dof_rad) {
  const size_t n = dofs.size();
  if (n == 0) return;
  assert(n <= 3);
  std::array<glm::vec3, 3> axes;
  std::array<float, 3> lo{}, hi{}, angles{};
  for (size_t i = 0; i < n; ++i) {
    const avatar::Dof& f = skeleton.dof(dofs[i]);
    axes[i] = f.axis;
    lo[i] = f.min_rad;
    hi[i] = f.max_rad;
    angles[i] = dof_rad[dofs[i]];
  }
  angles_from_rotation(rotation, std::span(axes.data(), n), std::span(angles.data(), n),
                       std::span(lo.data(), n), std::span(hi.data(), n));
  for (size_t i = 0; i < n; ++i) dof_rad[dofs[i]] = std::clamp(angles[i], lo[i], hi[i]);
}

void joint_dofs_from_rotation(const avatar::Skeleton& skeleton, int joint, const glm::quat& local,
                              std::span<float> dof_rad) {
  std::array<int, 3> dofs{};
  const int n = skeleton.dof_end(joint) - skeleton.dof_begin(joint);
  for (int i = 0; i < n; ++i) dofs[i] = skeleton.dof_begin(joint) + i;
  dofs_from_rotation(skeleton, std::span(dofs.data(), n), local, dof_rad);
}

}  // namespace mimic::solver
