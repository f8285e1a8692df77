#include "mimic/solver/least_squares_ik.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "rotation_vector.h"

namespace mimic::solver {

using rig::Pose;
using rig::RigidTransform;
using rig::Skeleton;

namespace {

constexpr int kRootUnknowns = 6;

using detail::exp_rotation;
using detail::rotation_vector;

// FK that also records every DOF's rotation axis in world space.
void evaluate(const Skeleton& s, const Pose& pose, std::span<RigidTransform> world,
              std::span<glm::vec3> axis_world) {
  const int n = s.joint_count();
  const glm::quat root_rot = glm::normalize(pose.root_orientation);
  for (int j = 0; j < n; ++j) {
    const int p = s.parent(j);
    glm::quat r = p < 0 ? root_rot : world[p].rotation;
    for (int i = s.dof_begin(j); i < s.dof_end(j); ++i) {
      const auto& f = s.dof(i);
      axis_world[i] = r * f.axis;
      r = r * glm::angleAxis(pose.dof_rad[i], f.axis);
    }
    world[j].rotation = r;
    world[j].translation = p < 0 ? pose.root_position_m + root_rot * s.offset_m(j)
                                 : world[p].apply(s.offset_m(j));
  }
}

// Fills residual rows in target order; returns the row count.
int fill_residual(std::span<const IkTarget> targets, std::span<const RigidTransform> world,
                  std::span<float> r) {
  int row = 0;
  for (const IkTarget& t : targets) {
    const RigidTransform& w = world[t.joint];
    if (t.position_weight > 0) {
      const glm::vec3 e = t.position_weight * (t.position_m - w.translation);
      r[row++] = e.x, r[row++] = e.y, r[row++] = e.z;
    }
    if (t.rotation_weight > 0) {
      const glm::vec3 e = t.rotation_weight * rotation_vector(t.rotation * glm::conjugate(w.rotation));
      r[row++] = e.x, r[row++] = e.y, r[row++] = e.z;
    }
  }
  return row;
}

// In-place Cholesky solve of the SPD n×n system a·x = b (x overwrites b). False if not SPD.
bool cholesky_solve(std::span<float> a, std::span<float> b, int n) {
  for (int j = 0; j < n; ++j) {
    float d = a[j * n + j];
    for (int k = 0; k < j; ++k) d -= a[j * n + k] * a[j * n + k];
    if (!(d > 1e-12f)) return false;
    d = std::sqrt(d);
    a[j * n + j] = d;
    for (int i = j + 1; i < n; ++i) {
      float v = a[i * n + j];
      for (int k = 0; k < j; ++k) v -= a[i * n + k] * a[j * n + k];
      a[i * n + j] = v / d;
    }
  }
  for (int i = 0; i < n; ++i) {  // L·y = b
    float v = b[i];
    for (int k = 0; k < i; ++k) v -= a[i * n + k] * b[k];
    b[i] = v / a[i * n + i];
  }
  for (int i = n - 1; i >= 0; --i) {  // Lᵀ·x = y
    float v = b[i];
    for (int k = i + 1; k < n; ++k) v -= a[k * n + i] * b[k];
    b[i] = v / a[i * n + i];
  }
  return true;
}

}  // namespace

LeastSquaresIkContext::LeastSquaresIkContext(const Skeleton& skeleton, int max_dofs, int max_targets)
    : joints_(skeleton.joint_count()), max_dofs_(max_dofs), max_targets_(max_targets) {
  const int cols = max_dofs + kRootUnknowns;
  const int rows = 6 * max_targets;
  world_.resize(joints_);
  dof_axis_world_.resize(skeleton.dof_count());
  jacobian_.resize(static_cast<size_t>(rows) * cols);
  residual_.resize(rows);
  normal_.resize(static_cast<size_t>(cols) * cols);
  rhs_.resize(cols);
  normal0_.resize(static_cast<size_t>(cols) * cols);
  rhs0_.resize(cols);
  saved_.resize(cols);
  columns_.resize(cols);
  chain_mask_.resize(max_targets);
}

bool LeastSquaresIkJob::Validate() const {
  if (!skeleton || !pose || !context) return false;
  const Skeleton& s = *skeleton;
  if (s.joint_count() > 64 || context->joints_ != s.joint_count()) return false;
  if (static_cast<int>(context->dof_axis_world_.size()) != s.dof_count()) return false;
  if (static_cast<int>(dofs.size()) > context->max_dofs_) return false;
  if (static_cast<int>(targets.size()) > context->max_targets_) return false;
  if (static_cast<int>(pose->dof_rad.size()) != s.dof_count()) return false;
  if (!prior_rad.empty() && static_cast<int>(prior_rad.size()) != s.dof_count()) return false;
  for (int d : dofs)
    if (d < 0 || d >= s.dof_count()) return false;
  for (const IkTarget& t : targets)
    if (t.joint < 0 || t.joint >= s.joint_count() || t.position_weight < 0 || t.rotation_weight < 0)
      return false;
  return max_iterations >= 0 && damping >= 0 && prior_weight >= 0;
}

bool LeastSquaresIkJob::Run() {
  if (!Validate()) return false;
  const Skeleton& s = *skeleton;
  LeastSquaresIkContext& c = *context;
  Pose& p = *pose;
  const int root_cols = solve_root ? kRootUnknowns : 0;
  const int cols = root_cols + static_cast<int>(dofs.size());
  const std::span<RigidTransform> world(c.world_);
  const std::span<glm::vec3> axes(c.dof_axis_world_);

  for (size_t t = 0; t < targets.size(); ++t) {
    uint64_t mask = 0;
    for (int j = targets[t].joint; j >= 0; j = s.parent(j)) mask |= uint64_t{1} << j;
    c.chain_mask_[t] = mask;
  }

  iterations = 0;
  const float prior2 = prior_rad.empty() ? 0.0f : prior_weight * prior_weight;
  // Objective: weighted residuals plus the prior, the quantity every accepted step lowers.
  auto objective = [&]() {
    evaluate(s, p, world, axes);
    const int rows = fill_residual(targets, world, c.residual_);
    float sum = 0;
    for (int r = 0; r < rows; ++r) sum += c.residual_[r] * c.residual_[r];
    if (prior2 > 0)
      for (int d : dofs) sum += prior2 * (p.dof_rad[d] - prior_rad[d]) * (p.dof_rad[d] - prior_rad[d]);
    return sum;
  };
  float cost = objective();
  // The damping carries over from the last solve with this context: after a hard frame the
  // next one starts with the step size that worked, instead of re-learning it.
  float lambda = std::clamp(c.lambda_, std::max(damping, 1e-4f), 1e3f);
  bool rebuild = true;
  float* a0 = c.normal0_.data();
  float* g0 = c.rhs0_.data();
  for (int it = 0; it < max_iterations && cols > 0; ++it) {
    if (rebuild) {
      const int rows = fill_residual(targets, world, c.residual_);  // world is at the current pose
      float* jac = c.jacobian_.data();
      std::fill(jac, jac + static_cast<size_t>(rows) * cols, 0.0f);
      // Jacobian, one row block per target term.
      int row = 0;
      for (size_t t = 0; t < targets.size(); ++t) {
        const IkTarget& tg = targets[t];
        const glm::vec3 e = world[tg.joint].translation;
        const int pos_row = tg.position_weight > 0 ? row : -1;
        if (tg.position_weight > 0) row += 3;
        const int rot_row = tg.rotation_weight > 0 ? row : -1;
        if (tg.rotation_weight > 0) row += 3;
        auto put = [&](int r0, float w, int col, const glm::vec3& v) {
          jac[(r0 + 0) * cols + col] = w * v.x;
          jac[(r0 + 1) * cols + col] = w * v.y;
          jac[(r0 + 2) * cols + col] = w * v.z;
        };
        if (solve_root) {
          const glm::vec3 arm = e - p.root_position_m;
          for (int k = 0; k < 3; ++k) {
            glm::vec3 unit(0.0f);
            unit[k] = 1.0f;
            if (pos_row >= 0) put(pos_row, tg.position_weight, k, unit);
            if (pos_row >= 0) put(pos_row, tg.position_weight, 3 + k, glm::cross(unit, arm));
            if (rot_row >= 0) put(rot_row, tg.rotation_weight, 3 + k, unit);
          }
        }
        for (size_t k = 0; k < dofs.size(); ++k) {
          const int d = dofs[k];
          const int j = s.dof(d).joint;
          if (!(c.chain_mask_[t] >> j & 1u)) continue;
          const int col = root_cols + static_cast<int>(k);
          if (pos_row >= 0) put(pos_row, tg.position_weight, col, glm::cross(axes[d], e - world[j].translation));
          if (rot_row >= 0) put(rot_row, tg.rotation_weight, col, axes[d]);
        }
      }
      // Normal equations, accumulated row by row over each target's non-zero columns only (a
      // hand row touches the spine and its arm, not the other arm).
      std::fill(a0, a0 + static_cast<size_t>(cols) * cols, 0.0f);
      std::fill(g0, g0 + cols, 0.0f);
      row = 0;
      for (size_t t = 0; t < targets.size(); ++t) {
        int* list = c.columns_.data();
        int n_list = 0;
        for (int k = 0; k < root_cols; ++k) list[n_list++] = k;
        for (size_t k = 0; k < dofs.size(); ++k)
          if (c.chain_mask_[t] >> s.dof(dofs[k]).joint & 1u) list[n_list++] = root_cols + static_cast<int>(k);
        const int n_rows = (targets[t].position_weight > 0 ? 3 : 0) + (targets[t].rotation_weight > 0 ? 3 : 0);
        for (int r = row; r < row + n_rows; ++r) {
          const float* jr = jac + static_cast<size_t>(r) * cols;
          const float res = c.residual_[r];
          for (int ii = 0; ii < n_list; ++ii) {
            const int i = list[ii];
            const float vi = jr[i];
            if (vi == 0.0f) continue;
            g0[i] += vi * res;
            float* ai = a0 + static_cast<size_t>(i) * cols;
            for (int kk = 0; kk <= ii; ++kk) ai[list[kk]] += vi * jr[list[kk]];
          }
        }
        row += n_rows;
      }
      for (int i = 0; i < cols; ++i)
        for (int k = 0; k < i; ++k) a0[k * cols + i] = a0[i * cols + k];
      for (size_t k = 0; k < dofs.size(); ++k) {
        const int col = root_cols + static_cast<int>(k);
        const int d = dofs[k];
        if (prior2 > 0) {
          a0[col * cols + col] += prior2;
          g0[col] += prior2 * (prior_rad[d] - p.dof_rad[d]);
        }
        // A DOF pinned at a limit with the gradient pushing outwards leaves the step.
        const auto& f = s.dof(d);
        const bool at_min = p.dof_rad[d] <= f.min_rad + 1e-6f && g0[col] < 0;
        const bool at_max = p.dof_rad[d] >= f.max_rad - 1e-6f && g0[col] > 0;
        if (at_min || at_max) {
          for (int i = 0; i < cols; ++i) a0[col * cols + i] = a0[i * cols + col] = 0.0f;
          a0[col * cols + col] = 1.0f;
          g0[col] = 0.0f;
        }
      }
      rebuild = false;
    }
    float* a = c.normal_.data();
    float* b = c.rhs_.data();
    std::copy(a0, a0 + static_cast<size_t>(cols) * cols, a);
    std::copy(g0, g0 + cols, b);
    for (int i = 0; i < cols; ++i) a[i * cols + i] += lambda * lambda;
    ++iterations;
    if (!cholesky_solve(std::span(a, static_cast<size_t>(cols) * cols), std::span(b, cols), cols)) break;
    float biggest = 0;
    for (int i = 0; i < cols; ++i) biggest = std::max(biggest, std::abs(b[i]));
    if (!std::isfinite(biggest)) break;

    // Trial step; kept only if it lowers the objective (Levenberg–Marquardt), else undone with
    // more damping, so the solve never oscillates between limits.
    const glm::vec3 saved_root_pos = p.root_position_m;
    const glm::quat saved_root_rot = p.root_orientation;
    for (size_t k = 0; k < dofs.size(); ++k) c.saved_[k] = p.dof_rad[dofs[k]];
    if (solve_root) {
      p.root_position_m += glm::vec3(b[0], b[1], b[2]);
      p.root_orientation = glm::normalize(exp_rotation(glm::vec3(b[3], b[4], b[5])) * p.root_orientation);
    }
    for (size_t k = 0; k < dofs.size(); ++k) {
      const int d = dofs[k];
      const auto& f = s.dof(d);
      p.dof_rad[d] = std::clamp(p.dof_rad[d] + b[root_cols + k], f.min_rad, f.max_rad);
    }
    const float trial = objective();
    if (trial < cost) {
      const float gain = cost - trial;
      cost = trial;
      lambda = std::max(std::max(damping, 1e-4f), lambda * 0.3f);
      rebuild = true;
      if (biggest < step_tolerance || gain < 1e-4f * cost) break;
    } else {
      p.root_position_m = saved_root_pos;
      p.root_orientation = saved_root_rot;
      for (size_t k = 0; k < dofs.size(); ++k) p.dof_rad[dofs[k]] = c.saved_[k];
      lambda *= 4.0f;
      if (lambda > 1e3f || biggest < step_tolerance) break;
    }
  }
  c.lambda_ = lambda;
  evaluate(s, p, world, axes);
  const int rows = fill_residual(targets, world, c.residual_);
  float sum = 0;
  for (int r = 0; r < rows; ++r) sum += c.residual_[r] * c.residual_[r];
  residual_norm = std::sqrt(sum);
  return true;
}

}  // namespace mimic::solver
