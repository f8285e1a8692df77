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
void evaluate(const Skeleton& s, const Pose& pose, std::span<RigidTransform> world, std::span<glm::vec3> axis_world) {
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
    world[j].translation = p < 0 ? pose.root_position_m + root_rot * s.offset_m(j) : world[p].apply(s.offset_m(j));
  }
}

// Fills residual rows in target order; returns the row count.
int fill_residual(std::span<const IkTarget> targets, std::span<const RigidTransform> world, std::span<float> r) {
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
  columns_.resize(static_cast<size_t>(max_targets) * cols);
  column_begin_.resize(max_targets);
  column_count_.resize(max_targets);
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
    if (t.joint < 0 || t.joint >= s.joint_count() || t.position_weight < 0 || t.rotation_weight < 0) return false;
  return max_iterations >= 0 && damping >= 0 && prior_weight >= 0;
}

// Per target, the Jacobian columns it touches: the root's, then the DOFs along its joint's chain
// (a hand's row touches the spine and its arm, not the other arm). Fixed for one Run().
void LeastSquaresIkJob::ListColumns(int root_cols) {
  const Skeleton& s = *skeleton;
  LeastSquaresIkContext& c = *context;
  int* list = c.columns_.data();
  for (size_t t = 0; t < targets.size(); ++t) {
    uint64_t mask = 0;
    for (int j = targets[t].joint; j >= 0; j = s.parent(j)) mask |= uint64_t{1} << j;
    int n = 0;
    c.column_begin_[t] = static_cast<int>(list - c.columns_.data());
    for (int k = 0; k < root_cols; ++k) list[n++] = k;
    for (size_t k = 0; k < dofs.size(); ++k)
      if (mask >> s.dof(dofs[k]).joint & 1u) list[n++] = root_cols + static_cast<int>(k);
    c.column_count_[t] = n;
    list += n;
  }
}

// Weighted residuals plus the prior at the current pose: the quantity every accepted step lowers.
float LeastSquaresIkJob::Objective(float prior2) {
  LeastSquaresIkContext& c = *context;
  const Pose& p = *pose;
  evaluate(*skeleton, p, c.world_, c.dof_axis_world_);
  const int rows = fill_residual(targets, c.world_, c.residual_);
  float sum = 0;
  for (int r = 0; r < rows; ++r) sum += c.residual_[r] * c.residual_[r];
  if (prior2 > 0)
    for (int d : dofs) sum += prior2 * (p.dof_rad[d] - prior_rad[d]) * (p.dof_rad[d] - prior_rad[d]);
  return sum;
}

// Each target's block of the Jacobian at the current pose (world and axes evaluated there), over
// its own columns only: rows × its column count, row-major, blocks one after another.
void LeastSquaresIkJob::FillJacobian(int root_cols) {
  const Skeleton& s = *skeleton;
  LeastSquaresIkContext& c = *context;
  const Pose& p = *pose;
  float* block = c.jacobian_.data();
  for (size_t t = 0; t < targets.size(); ++t) {
    const IkTarget& tg = targets[t];
    const int n = c.column_count_[t];
    const int* list = c.columns_.data() + c.column_begin_[t];
    const int n_rows = (tg.position_weight > 0 ? 3 : 0) + (tg.rotation_weight > 0 ? 3 : 0);
    std::fill(block, block + static_cast<size_t>(n_rows) * n, 0.0f);
    float* pos_rows = tg.position_weight > 0 ? block : nullptr;
    float* rot_rows = tg.rotation_weight > 0 ? block + (pos_rows ? 3 * n : 0) : nullptr;
    auto put = [n](float* rows, float w, int col, const glm::vec3& v) {
      rows[0 * n + col] = w * v.x;
      rows[1 * n + col] = w * v.y;
      rows[2 * n + col] = w * v.z;
    };
    const glm::vec3 e = c.world_[tg.joint].translation;
    if (root_cols > 0) {
      const glm::vec3 arm = e - p.root_position_m;
      for (int k = 0; k < 3; ++k) {
        glm::vec3 unit(0.0f);
        unit[k] = 1.0f;
        if (pos_rows) put(pos_rows, tg.position_weight, k, unit);
        if (pos_rows) put(pos_rows, tg.position_weight, 3 + k, glm::cross(unit, arm));
        if (rot_rows) put(rot_rows, tg.rotation_weight, 3 + k, unit);
      }
    }
    for (int col = root_cols; col < n; ++col) {
      const int d = dofs[static_cast<size_t>(list[col] - root_cols)];
      const int j = s.dof(d).joint;
      if (pos_rows)
        put(pos_rows, tg.position_weight, col, glm::cross(c.dof_axis_world_[d], e - c.world_[j].translation));
      if (rot_rows) put(rot_rows, tg.rotation_weight, col, c.dof_axis_world_[d]);
    }
    block += static_cast<size_t>(n_rows) * n;
  }
}

// Undamped normal equations JᵀJ·δ = Jᵀr (+ the prior) at the current pose, accumulated from each
// target's block over its own columns. Every sum runs over the rows in order, so the figures
// do not depend on how the blocks are laid out.
void LeastSquaresIkJob::BuildNormalEquations(int cols, int root_cols, float prior2) {
  const Skeleton& s = *skeleton;
  LeastSquaresIkContext& c = *context;
  const Pose& p = *pose;
  // The residual is the last objective's: it was evaluated at the current pose (the first, or
  // the step just accepted).
  FillJacobian(root_cols);
  float* a0 = c.normal0_.data();
  float* g0 = c.rhs0_.data();
  std::fill(a0, a0 + static_cast<size_t>(cols) * cols, 0.0f);
  std::fill(g0, g0 + cols, 0.0f);
  const float* block = c.jacobian_.data();
  const float* res = c.residual_.data();
  for (size_t t = 0; t < targets.size(); ++t) {
    const int n = c.column_count_[t];
    const int* list = c.columns_.data() + c.column_begin_[t];
    const int n_rows = (targets[t].position_weight > 0 ? 3 : 0) + (targets[t].rotation_weight > 0 ? 3 : 0);
    for (int ii = 0; ii < n; ++ii) {
      const int i = list[ii];
      float g = g0[i];
      for (int r = 0; r < n_rows; ++r) g += block[r * n + ii] * res[r];
      g0[i] = g;
      float* ai = a0 + static_cast<size_t>(i) * cols;
      for (int kk = 0; kk <= ii; ++kk) {
        float v = ai[list[kk]];
        for (int r = 0; r < n_rows; ++r) v += block[r * n + ii] * block[r * n + kk];
        ai[list[kk]] = v;
      }
    }
    block += static_cast<size_t>(n_rows) * n;
    res += n_rows;
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
}

// The pose moved by the step δ (root first when it is an unknown), DOFs clamped to their limits.
void LeastSquaresIkJob::ApplyStep(std::span<const float> step, int root_cols) {
  const Skeleton& s = *skeleton;
  Pose& p = *pose;
  if (root_cols > 0) {
    p.root_position_m += glm::vec3(step[0], step[1], step[2]);
    p.root_orientation = glm::normalize(exp_rotation(glm::vec3(step[3], step[4], step[5])) * p.root_orientation);
  }
  for (size_t k = 0; k < dofs.size(); ++k) {
    const int d = dofs[k];
    const auto& f = s.dof(d);
    p.dof_rad[d] = std::clamp(p.dof_rad[d] + step[root_cols + k], f.min_rad, f.max_rad);
  }
}

bool LeastSquaresIkJob::Run() {
  if (!Validate()) return false;
  LeastSquaresIkContext& c = *context;
  Pose& p = *pose;
  const int root_cols = solve_root ? kRootUnknowns : 0;
  const int cols = root_cols + static_cast<int>(dofs.size());
  ListColumns(root_cols);

  iterations = 0;
  const float prior2 = prior_rad.empty() ? 0.0f : prior_weight * prior_weight;
  float cost = Objective(prior2);
  // The damping carries over from the last solve with this context: after a hard frame the
  // next one starts with the step size that worked, instead of re-learning it.
  float lambda = std::clamp(c.lambda_, std::max(damping, 1e-4f), 1e3f);
  bool rebuild = true;
  bool world_current = true;  // world and axes are those of the pose (the last objective's)
  for (int it = 0; it < max_iterations && cols > 0; ++it) {
    if (rebuild) BuildNormalEquations(cols, root_cols, prior2);
    rebuild = false;
    float* a = c.normal_.data();
    float* b = c.rhs_.data();
    std::copy(c.normal0_.data(), c.normal0_.data() + static_cast<size_t>(cols) * cols, a);
    std::copy(c.rhs0_.data(), c.rhs0_.data() + cols, b);
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
    ApplyStep(std::span<const float>(b, cols), root_cols);
    const float trial = Objective(prior2);
    world_current = trial < cost;
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
  if (!world_current) evaluate(*skeleton, p, c.world_, c.dof_axis_world_);
  const int rows = fill_residual(targets, c.world_, c.residual_);
  float sum = 0;
  for (int r = 0; r < rows; ++r) sum += c.residual_[r] * c.residual_[r];
  residual_norm = std::sqrt(sum);
  return true;
}

}  // namespace mimic::solver
