#include "mimic/solver/swing_twist.h"

#include "mimic/rig/joint_angles.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>

namespace mimic::solver {

namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kTwoPi = 2.0f * kPi;

float unwrap_near(float angle, float previous) { return previous + std::remainder(angle - previous, kTwoPi); }

float limit_violation(float v, std::span<const float> lo, std::span<const float> hi, size_t i) {
  if (i >= lo.size() || i >= hi.size()) return 0.0f;
  if (v < lo[i]) return lo[i] - v;
  if (v > hi[i]) return v - hi[i];
  return 0.0f;
}

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

// The decomposition nearest the previous values (avatar/joint_angles.h: exact Euler for three
// orthogonal axes, twist for one, best fit otherwise), then the limits: of that solution, the
// other Euler branch for three axes, and every angle ± 2π, the candidate inside the limits and
// nearest the previous values wins.
void decompose(const glm::quat& local, std::span<const glm::vec3> axes, std::span<float> angles,
               std::span<const float> lo, std::span<const float> hi) {
  const size_t n = axes.size();
  std::array<glm::dvec3, 3> ax;
  std::array<double, 3> prev{}, base{};
  for (size_t i = 0; i < n; ++i) ax[i] = glm::dvec3(axes[i]), prev[i] = angles[i];
  rig::dofs_from_rotation(std::span(ax.data(), n), glm::dquat(local), std::span(prev.data(), n),
                          std::span(base.data(), n), rig::kFloatLockCos);
  std::array<std::array<float, 3>, 2> cand{};
  for (size_t i = 0; i < n; ++i) cand[0][i] = static_cast<float>(base[i]);
  int n_cand = 1;
  const bool orthogonal3 = n == 3 && std::abs(glm::dot(axes[0], axes[1])) < 1e-4f &&
                           std::abs(glm::dot(axes[1], axes[2])) < 1e-4f && std::abs(glm::dot(axes[0], axes[2])) < 1e-4f;
  if (orthogonal3) {  // (α + π, π − β, γ + π) is the same rotation
    cand[1] = {cand[0][0] + kPi, kPi - cand[0][1], cand[0][2] + kPi};
    n_cand = 2;
  }
  std::array<float, 3> prevf{angles[0], n > 1 ? angles[1] : 0.0f, n > 2 ? angles[2] : 0.0f};
  int best = 0;
  float best_cost = 0;
  for (int k = 0; k < n_cand; ++k) {
    for (size_t i = 0; i < n; ++i) cand[k][i] = nearest_turn(unwrap_near(cand[k][i], prevf[i]), prevf[i], lo, hi, i);
    float cost = 0;
    for (size_t i = 0; i < n; ++i) {
      const float d = cand[k][i] - prevf[i];
      cost += d * d + 1e6f * limit_violation(cand[k][i], lo, hi, i);  // inside the limits first
    }
    if (k == 0 || cost < best_cost) best = k, best_cost = cost;
  }
  for (size_t i = 0; i < n; ++i) angles[i] = cand[best][i];
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
