#include "mimic/solver/least_squares_ik.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstddef>

#include "axis_turn.h"
#include "rotation_vector.h"
#include "sparse_cholesky.h"

namespace mimic::solver {

using rig::Pose;
using rig::RigidTransform;
using rig::Skeleton;

namespace {

constexpr int kRootUnknowns = 6;

using detail::exp_rotation;
using detail::rotation_vector;

// FK that also records every DOF's rotation axis in world space, for the joints in `mask` only
// (a set closed under parents: the targets' chains).
void evaluate(const Skeleton& s, const Pose& pose, uint64_t mask, std::span<const detail::AxisKind> kinds,
              std::span<RigidTransform> world, std::span<glm::vec3> axis_world) {
  const int n = s.joint_count();
  const glm::quat root_rot = glm::normalize(pose.root_orientation);
  for (int j = 0; j < n; ++j) {
    if (!(mask >> j & 1u)) continue;
    const int p = s.parent(j);
    glm::quat r = p < 0 ? root_rot : world[p].rotation;
    for (int i = s.dof_begin(j); i < s.dof_end(j); ++i)
      r = detail::turned(r, s.dof(i).axis, kinds[i], pose.dof_rad[i], &axis_world[i]);
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

using detail::kLanes;
int stride_for(int cols) { return detail::padded_stride(cols); }

}  // namespace

LeastSquaresIkContext::LeastSquaresIkContext(const Skeleton& skeleton, int max_dofs, int max_targets)
    : joints_(skeleton.joint_count()), max_dofs_(max_dofs), max_targets_(max_targets) {
  const int cols = max_dofs + kRootUnknowns;
  const int rows = 6 * max_targets;
  world_.resize(joints_);
  dof_axis_world_.resize(skeleton.dof_count());
  for (int i = 0; i < skeleton.dof_count(); ++i) axis_kind_.push_back(detail::axis_kind(skeleton.dof(i).axis));
  jacobian_.resize(static_cast<size_t>(rows) * stride_for(cols));
  residual_.resize(rows);
  normal_.resize(static_cast<size_t>(cols) * stride_for(cols));
  step_.resize(cols);
  rhs0_.resize(stride_for(cols));
  saved_.resize(cols);
  columns_.resize(static_cast<size_t>(max_targets) * cols);
  column_begin_.resize(max_targets);
  column_count_.resize(max_targets);
  runs_.resize(static_cast<size_t>(max_targets) * (cols + 2));
  solve_runs_.resize(runs_.size());
  run_begin_.resize(max_targets);
  run_count_.resize(max_targets);
  solve_run_count_.resize(max_targets);
  target_of_column_.resize(cols);
  reaching_first_.resize(cols);
  reaching_count_.resize(cols);
  reaching_rows_.resize(static_cast<size_t>(cols) * cols / 2 + 1);
  inv_diag_.resize(cols);
  listed_dofs_.resize(max_dofs);
  listed_joints_.resize(max_targets);
  position_of_.resize(max_dofs);
  dof_at_.resize(max_dofs);
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

// Row j of the factor is non-zero where any one target touching column j is, right of j.
struct SpansRightOf {
  const LeastSquaresIkContext* c;
  detail::ColumnSpans operator()(int j) const;
};

detail::ColumnSpans SpansRightOf::operator()(int j) const {
  const int t = c->target_of_column_[j];
  if (t < 0) return detail::ColumnSpans{c->rhs_span_.data(), 1};  // the right-hand side alone
  const int* r = c->solve_runs_.data() + c->run_begin_[t];
  int count = c->solve_run_count_[t];
  while (count > 0 && r[1] <= j + 1) r += 2, --count;
  return detail::ColumnSpans{r, count};
}

// The columns' order: a post-order of the skeleton — every joint's DOFs after those of all its
// descendants, each subtree's together, siblings by descending index (the trunk's branch after
// the limbs hanging from the same joint) — and the root's six last. A target's rows touch its
// joint's chain, so two columns are coupled in JᵀJ only when one's joint is an ancestor of the
// other's, and every target touching a column touches all the columns of its ancestors:
// eliminating children before parents then couples only columns already coupled — no fill-in,
// and row j of the factor is non-zero exactly where any one target touching j is (the Cholesky
// walks those runs). A chain's columns are its own limb's (one run), then the trunk's up to the
// root's six (a second run): the normal equations add whole runs. Fixed for one Run().
void LeastSquaresIkJob::ListColumns(int root_cols) {
  const Skeleton& s = *skeleton;
  LeastSquaresIkContext& c = *context;
  const int n_dofs = static_cast<int>(dofs.size());
  const int n_joints = s.joint_count();
  // Post-order rank of every joint: its subtree fills [first, first + size), itself last.
  int size[64], first[64], free_end[64], rank[64];
  for (int j = n_joints - 1; j >= 0; --j) size[j] = 1;
  for (int j = n_joints - 1; j > 0; --j)
    if (s.parent(j) >= 0) size[s.parent(j)] += size[j];
  int next_root = 0;
  for (int j = 0; j < n_joints; ++j) {
    const int p = s.parent(j);
    if (p < 0) {
      first[j] = next_root, next_root += size[j];
    } else {  // children fill their parent's range from its end: the lowest index nearest it
      free_end[p] -= size[j];
      first[j] = free_end[p];
    }
    free_end[j] = first[j] + size[j] - 1;
    rank[j] = first[j] + size[j] - 1;
  }
  // Counting sort of the DOFs by their joint's rank (stable: a joint's DOFs keep their order).
  int start[65] = {};
  for (int d : dofs) ++start[rank[s.dof(d).joint] + 1];
  for (int j = 1; j <= n_joints; ++j) start[j] += start[j - 1];
  for (int k = 0; k < n_dofs; ++k) {
    const int pos = start[rank[s.dof(dofs[k]).joint]]++;
    c.position_of_[k] = pos;
    c.dof_at_[pos] = k;
  }
  std::fill(c.target_of_column_.begin(), c.target_of_column_.begin() + n_dofs + root_cols, -1);
  int* list = c.columns_.data();
  int* runs = c.runs_.data();
  c.joint_mask_ = 0;
  for (size_t t = 0; t < targets.size(); ++t) {
    uint64_t mask = 0;
    for (int j = targets[t].joint; j >= 0; j = s.parent(j)) mask |= uint64_t{1} << j;
    c.joint_mask_ |= mask;
    int n = 0;
    c.column_begin_[t] = static_cast<int>(list - c.columns_.data());
    for (int pos = 0; pos < n_dofs; ++pos)
      if (mask >> s.dof(dofs[c.dof_at_[pos]]).joint & 1u) list[n++] = pos;
    for (int k = 0; k < root_cols; ++k) list[n++] = n_dofs + k;
    c.column_count_[t] = n;
    c.run_begin_[t] = static_cast<int>(runs - c.runs_.data());
    // Spans: runs of consecutive columns, merged across gaps narrower than a block.
    int n_runs = 0;
    for (int k = 0; k < n; ++k) {
      if (k == 0 || list[k] >= list[k - 1] + kLanes) runs[2 * n_runs++] = list[k];
      runs[2 * n_runs - 1] = list[k] + 1;
      c.target_of_column_[list[k]] = static_cast<int>(t);
    }
    c.run_count_[t] = n_runs;
    // The factorization's: the same, then the right-hand side's column, by the same rule.
    int* solve_runs = c.solve_runs_.data() + c.run_begin_[t];
    std::copy(runs, runs + 2 * n_runs, solve_runs);
    const int rhs = n_dofs + root_cols;
    if (n_runs > 0 && rhs < list[n - 1] + kLanes) {
      solve_runs[2 * n_runs - 1] = rhs + 1;
    } else {
      solve_runs[2 * n_runs] = rhs, solve_runs[2 * n_runs + 1] = rhs + 1;
      ++n_runs;
    }
    c.solve_run_count_[t] = n_runs;
    runs += 2 * n_runs;
    list += n;
  }
  c.rhs_span_ = {n_dofs + root_cols, n_dofs + root_cols + 1};
  detail::list_reaching_rows(n_dofs + root_cols, SpansRightOf{&c}, c.reaching_first_.data(), c.reaching_count_.data(),
                             c.reaching_rows_.data());
}

// Whether the last ListColumns() was for the same skeleton, DOFs and targets' joints (a layout
// changes only when a sensor comes or goes); records them when not.
bool LeastSquaresIkJob::ColumnsListed(int root_cols) {
  LeastSquaresIkContext& c = *context;
  LeastSquaresIkContext::ColumnKey& k = c.listed_for_;
  bool same = k.skeleton == skeleton && k.root_cols == root_cols && k.dof_count == static_cast<int>(dofs.size()) &&
              k.target_count == static_cast<int>(targets.size());
  for (size_t i = 0; same && i < dofs.size(); ++i) same = c.listed_dofs_[i] == dofs[i];
  for (size_t t = 0; same && t < targets.size(); ++t) same = c.listed_joints_[t] == targets[t].joint;
  if (same) return true;
  k = {skeleton, root_cols, static_cast<int>(dofs.size()), static_cast<int>(targets.size())};
  std::copy(dofs.begin(), dofs.end(), c.listed_dofs_.begin());
  for (size_t t = 0; t < targets.size(); ++t) c.listed_joints_[t] = targets[t].joint;
  return false;
}

// Weighted residuals plus the prior at the current pose: the quantity every accepted step lowers.
float LeastSquaresIkJob::Objective(float prior2) {
  LeastSquaresIkContext& c = *context;
  const Pose& p = *pose;
  evaluate(*skeleton, p, c.joint_mask_, c.axis_kind_, c.world_, c.dof_axis_world_);
  const int rows = fill_residual(targets, c.world_, c.residual_);
  float sum = 0;
  for (int r = 0; r < rows; ++r) sum += c.residual_[r] * c.residual_[r];
  if (prior2 > 0)
    for (int d : dofs) sum += prior2 * (p.dof_rad[d] - prior_rad[d]) * (p.dof_rad[d] - prior_rad[d]);
  return sum;
}

// The Jacobian at the current pose (world and axes evaluated there): per target its rows (3 or
// 6), each a whole padded row of the unknowns, non-zero only in the target's columns.
void LeastSquaresIkJob::FillJacobian(int root_cols) {
  const Skeleton& s = *skeleton;
  LeastSquaresIkContext& c = *context;
  const Pose& p = *pose;
  const int stride = stride_for(static_cast<int>(dofs.size()) + root_cols);
  float* row0 = c.jacobian_.data();
  for (size_t t = 0; t < targets.size(); ++t) {
    const IkTarget& tg = targets[t];
    const int n = c.column_count_[t];
    const int* list = c.columns_.data() + c.column_begin_[t];
    const bool pos = tg.position_weight > 0, rot = tg.rotation_weight > 0;
    const int n_rows = (pos ? 3 : 0) + (rot ? 3 : 0);
    std::fill(row0, row0 + static_cast<ptrdiff_t>(n_rows) * stride, 0.0f);
    // Column `col`: its position rows (w·∂e/∂θ), then its rotation rows (w·axis).
    auto put = [&](int col, const glm::vec3& dpos, const glm::vec3& drot) {
      float* v = row0 + col;
      if (pos) {
        const glm::vec3 w = tg.position_weight * dpos;
        v[0] = w.x, v[stride] = w.y, v[2 * stride] = w.z;
        v += 3 * stride;
      }
      if (rot) {
        const glm::vec3 w = tg.rotation_weight * drot;
        v[0] = w.x, v[stride] = w.y, v[2 * stride] = w.z;
      }
    };
    const glm::vec3 e = c.world_[tg.joint].translation;
    const int first_root = n - root_cols;
    for (int k = 0; k < first_root; ++k) {
      const int d = dofs[static_cast<size_t>(c.dof_at_[list[k]])];
      const glm::vec3& axis = c.dof_axis_world_[d];
      put(list[k], glm::cross(axis, e - c.world_[s.dof(d).joint].translation), axis);
    }
    if (root_cols > 0) {
      const glm::vec3 arm = e - p.root_position_m;
      for (int k = 0; k < 3; ++k) {
        glm::vec3 unit(0.0f);
        unit[k] = 1.0f;
        put(list[first_root + k], unit, glm::vec3(0.0f));
        put(list[first_root + 3 + k], glm::cross(unit, arm), unit);
      }
    }
    row0 += static_cast<ptrdiff_t>(n_rows) * stride;
  }
}

namespace {

// One target's share of JᵀJ (upper triangle) and Jᵀr: its R rows (padded, zero outside its
// columns) over its column spans. Per column i, row i of JᵀJ takes Σ_r J_ri·J_r over the spans
// from i on, in whole blocks (a block spilling past a span adds zeros).
template <int R>
void accumulate_rows(const float* rows, int stride, const float* res, const int* list, int n, const int* spans,
                     int n_spans, float* a0, float* g0) {
  int q = 0;  // the span holding column list[ii]
  for (int ii = 0; ii < n; ++ii) {
    const int i = list[ii];
    while (i >= spans[2 * q + 1]) ++q;
    float v[R];
    float g = 0;
    for (int r = 0; r < R; ++r) v[r] = rows[r * stride + i], g += v[r] * res[r];
    g0[i] += g;
    float* __restrict ai = a0 + static_cast<ptrdiff_t>(i) * stride;
    for (int w = q; w < n_spans; ++w)
      for (int k = std::max(i, spans[2 * w]); k < spans[2 * w + 1]; k += kLanes) {
        detail::Block sum, x;
        detail::load_block(x, rows + k);
        sum = v[0] * x;
        for (int r = 1; r < R; ++r) {
          detail::load_block(x, rows + r * stride + k);
          sum += v[r] * x;
        }
        detail::load_block(x, ai + k);
        x += sum;
        detail::store_block(ai + k, x);
      }
  }
}

}  // namespace

// Undamped normal equations JᵀJ·δ = Jᵀr (+ the prior) at the current pose, upper triangle in
// the elimination order, accumulated from each target's block over its own columns.
void LeastSquaresIkJob::BuildNormalEquations(int cols, float prior2) {
  const Skeleton& s = *skeleton;
  LeastSquaresIkContext& c = *context;
  const Pose& p = *pose;
  // The residual is the last objective's: it was evaluated at the current pose (the first, or
  // the step just accepted).
  FillJacobian(cols - static_cast<int>(dofs.size()));
  float* a0 = c.normal_.data();
  float* g0 = c.rhs0_.data();
  const int stride = stride_for(cols);
  std::fill(a0, a0 + static_cast<size_t>(cols) * stride, 0.0f);
  std::fill(g0, g0 + stride, 0.0f);
  const float* rows = c.jacobian_.data();
  const float* res = c.residual_.data();
  for (size_t t = 0; t < targets.size(); ++t) {
    const int n = c.column_count_[t];
    const int* list = c.columns_.data() + c.column_begin_[t];
    const int n_rows = (targets[t].position_weight > 0 ? 3 : 0) + (targets[t].rotation_weight > 0 ? 3 : 0);
    const int* spans = c.runs_.data() + c.run_begin_[t];
    if (n_rows == 3) accumulate_rows<3>(rows, stride, res, list, n, spans, c.run_count_[t], a0, g0);
    if (n_rows == 6) accumulate_rows<6>(rows, stride, res, list, n, spans, c.run_count_[t], a0, g0);
    rows += static_cast<ptrdiff_t>(n_rows) * stride;
    res += n_rows;
  }
  for (size_t k = 0; k < dofs.size(); ++k) {
    const int col = c.position_of_[k];
    const int d = dofs[k];
    if (prior2 > 0) {
      a0[col * stride + col] += prior2;
      g0[col] += prior2 * (prior_rad[d] - p.dof_rad[d]);
    }
    // A DOF pinned at a limit with the gradient pushing outwards leaves the step.
    const auto& f = s.dof(d);
    const bool at_min = p.dof_rad[d] <= f.min_rad + 1e-6f && g0[col] < 0;
    const bool at_max = p.dof_rad[d] >= f.max_rad - 1e-6f && g0[col] > 0;
    if (at_min || at_max) {
      for (int i = 0; i < col; ++i) a0[i * stride + col] = 0.0f;
      for (int i = col + 1; i < cols; ++i) a0[col * stride + i] = 0.0f;
      a0[col * stride + col] = 1.0f;
      g0[col] = 0.0f;
    }
  }
}

// The pose moved by the step δ (in column order: DOFs, then the root's six when it is an
// unknown), DOFs clamped to their limits.
void LeastSquaresIkJob::ApplyStep(std::span<const float> step, int root_cols) {
  const Skeleton& s = *skeleton;
  const LeastSquaresIkContext& c = *context;
  Pose& p = *pose;
  const size_t n_dofs = dofs.size();
  if (root_cols > 0) {
    p.root_position_m += glm::vec3(step[n_dofs + 0], step[n_dofs + 1], step[n_dofs + 2]);
    p.root_orientation = glm::normalize(exp_rotation(glm::vec3(step[n_dofs + 3], step[n_dofs + 4], step[n_dofs + 5])) *
                                        p.root_orientation);
  }
  for (size_t k = 0; k < n_dofs; ++k) {
    const int d = dofs[k];
    const auto& f = s.dof(d);
    p.dof_rad[d] = std::clamp(p.dof_rad[d] + step[static_cast<size_t>(c.position_of_[k])], f.min_rad, f.max_rad);
  }
}

bool LeastSquaresIkJob::Run() {
  if (!Validate()) return false;
  LeastSquaresIkContext& c = *context;
  Pose& p = *pose;
  const int root_cols = solve_root ? kRootUnknowns : 0;
  const int cols = root_cols + static_cast<int>(dofs.size());
  if (!ColumnsListed(root_cols)) ListColumns(root_cols);

  iterations = 0;
  const float prior2 = prior_rad.empty() ? 0.0f : prior_weight * prior_weight;
  float cost = Objective(prior2);
  // The damping carries over from the last solve with this context: after a hard frame the
  // next one starts with the step size that worked, instead of re-learning it.
  float lambda = std::clamp(c.lambda_, std::max(damping, 1e-4f), 1e3f);
  bool world_current = true;  // world and axes are those of the pose (the last objective's)
  const int stride = stride_for(cols);
  for (int it = 0; it < max_iterations && cols > 0; ++it) {
    // The factorization takes the system it solves: every step builds its own (a step undone is
    // rare, and rebuilding then costs less than keeping a copy of every system).
    BuildNormalEquations(cols, prior2);
    float* a = c.normal_.data();
    float* step = c.step_.data();
    for (int i = 0; i < cols; ++i) a[i * stride + i] += lambda * lambda, a[i * stride + cols] = c.rhs0_[i];
    ++iterations;
    const detail::ReachingRows reaching{c.reaching_first_.data(), c.reaching_count_.data(), c.reaching_rows_.data()};
    if (!detail::cholesky_solve(a, step, cols, stride, SpansRightOf{&c}, reaching, c.inv_diag_.data())) break;
    float biggest = 0;
    for (int i = 0; i < cols; ++i) biggest = std::max(biggest, std::abs(step[i]));
    if (!std::isfinite(biggest)) break;

    // Trial step; kept only if it lowers the objective (Levenberg–Marquardt), else undone with
    // more damping, so the solve never oscillates between limits.
    const glm::vec3 saved_root_pos = p.root_position_m;
    const glm::quat saved_root_rot = p.root_orientation;
    for (size_t k = 0; k < dofs.size(); ++k) c.saved_[k] = p.dof_rad[dofs[k]];
    ApplyStep(std::span<const float>(step, cols), root_cols);
    const float trial = Objective(prior2);
    world_current = trial < cost;
    if (trial < cost) {
      const float gain = cost - trial;
      cost = trial;
      // The gain the linear model promised, δ·g + λ²·|δ|² (from (JᵀJ + P + λ²)·δ = g).
      float promised = 0, step2 = 0;
      for (int i = 0; i < cols; ++i) promised += step[i] * c.rhs0_[i], step2 += step[i] * step[i];
      promised += lambda * lambda * step2;
      // Less damping by how well the model held (Nielsen's rule on λ²: ×1/3 when the step gained
      // what was promised, unchanged at half of it): a fixed cut overshot, and a quarter of the
      // frames then undid a step.
      const float t = 2.0f * (promised > 0 ? gain / promised : 1.0f) - 1.0f;
      lambda = std::max(std::max(damping, 1e-4f), lambda * std::sqrt(std::max(1.0f / 3.0f, 1.0f - t * t * t)));
      if (biggest < step_tolerance || gain < 1e-4f * cost) break;
      // When the step gained what the model promised to within model_tolerance of the cost left,
      // the model is good there, and the next step would only take back a part of the difference.
      if (model_tolerance > 0 && it + 1 >= model_min_iterations && std::abs(gain - promised) < model_tolerance * cost)
        break;
    } else {
      p.root_position_m = saved_root_pos;
      p.root_orientation = saved_root_rot;
      for (size_t k = 0; k < dofs.size(); ++k) p.dof_rad[dofs[k]] = c.saved_[k];
      lambda *= 4.0f;
      if (lambda > 1e3f || biggest < step_tolerance) break;
      cost = Objective(prior2);  // the world, axes and residual of the pose kept, for the next system
      world_current = true;
    }
  }
  c.lambda_ = lambda;
  if (!world_current) evaluate(*skeleton, p, c.joint_mask_, c.axis_kind_, c.world_, c.dof_axis_world_);
  const int rows = fill_residual(targets, c.world_, c.residual_);
  float sum = 0;
  for (int r = 0; r < rows; ++r) sum += c.residual_[r] * c.residual_[r];
  residual_norm = std::sqrt(sum);
  return true;
}

}  // namespace mimic::solver
