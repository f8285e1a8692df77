// Damped least-squares IK (Levenberg–Marquardt) over a chosen set of a skeleton's DOFs, and
// optionally its root, towards world-space position and orientation targets on joints.
//
// Warm-started from the pose passed in; each iteration linearises the forward kinematics,
// solves (JᵀJ + (λ² + w_prior²)·I)·δ = Jᵀr + w_prior²·(θ_prior − θ) by Cholesky and clamps every
// DOF into its limits (a DOF held at a limit by the gradient drops out of the step). A step is
// kept only if it lowers |r|² + w_prior²·|θ − θ_prior|²; otherwise it is undone and λ grows, so
// the result never oscillates between limits and never gets worse than the warm start. Frames:
// world, metres, radians. Scratch lives in a caller-owned LeastSquaresIkContext sized once;
// Run() never allocates and returns false when Validate() fails.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "mimic/rig/skeleton.h"

namespace mimic::solver {

struct IkTarget {
  int joint = -1;                              // skeleton joint index
  glm::vec3 position_m{0.0f};                  // wanted world_from_joint translation
  glm::quat rotation{1.0f, 0.0f, 0.0f, 0.0f};  // wanted world_from_joint rotation
  float position_weight = 0;                   // residual weight per metre; 0 ignores position
  float rotation_weight = 0;                   // residual weight per radian; 0 ignores rotation
};

namespace detail {
// A DOF's axis as the FK turns about it: a coordinate axis (0, 1, 2 for x, y, z, with its sign),
// whose rotation and world direction take half the arithmetic of a general one, or general (3).
struct AxisKind {
  uint8_t axis = 3;
  float sign = 1.0f;
};
}  // namespace detail

class LeastSquaresIkContext {
 public:
  LeastSquaresIkContext() = default;
  // Scratch for `skeleton` (at most 64 joints), up to max_dofs DOF unknowns (+ 6 for the root)
  // and max_targets targets. Allocates; call at setup.
  LeastSquaresIkContext(const rig::Skeleton& skeleton, int max_dofs, int max_targets);

  int joint_count() const { return joints_; }
  int max_dofs() const { return max_dofs_; }
  int max_targets() const { return max_targets_; }
  // World transforms of the last evaluated pose (valid after Run()) for the joints the targets
  // hang from (the targets' joints and their ancestors); the others are not evaluated.
  std::span<const rig::RigidTransform> world_from_joint() const { return world_; }
  // Per skeleton DOF, how the FK turns about its axis.
  std::span<const detail::AxisKind> axis_kinds() const { return axis_kind_; }

 private:
  friend struct LeastSquaresIkJob;
  friend struct SpansRightOf;
  int joints_ = 0, max_dofs_ = 0, max_targets_ = 0;
  std::vector<rig::RigidTransform> world_;
  std::vector<glm::vec3> dof_axis_world_;    // per skeleton DOF
  std::vector<detail::AxisKind> axis_kind_;  // per skeleton DOF
  std::vector<float> jacobian_;              // per target its rows (3 or 6), each padded to a whole row
  std::vector<float> residual_;
  std::vector<float> normal_;                     // cols × cols, upper triangle (in elimination order)
  std::vector<float> step_;                       // the step a solve found, in column order
  std::vector<float> rhs0_;                       // the undamped right-hand side (Jᵀr + the prior's pull)
  std::vector<float> saved_;                      // DOF values before a trial step
  std::vector<int> columns_;                      // per target, its non-zero Jacobian columns, ascending
  std::vector<int> column_begin_, column_count_;  // per target: where its columns start, how many
  // Per target, its columns as spans (sparse_cholesky.h): pairs (first, one past the last); for
  // the factorization, with the right-hand side's column.
  std::vector<int> runs_, solve_runs_;
  std::vector<int> run_begin_, run_count_, solve_run_count_;  // per target: where its spans start (pairs), how many
  std::vector<int> target_of_column_;                         // per column, a target touching it (−1: none)
  std::array<int, 2> rhs_span_{};                             // the right-hand side's column as a span
  // Per column, the earlier rows whose spans reach it (sparse_cholesky.h): where its list starts
  // in reaching_rows_, how long it is.
  std::vector<int> reaching_first_, reaching_count_, reaching_rows_;
  std::vector<float> inv_diag_;  // Cholesky scratch: the factor's diagonal's reciprocals
  // Elimination order: DOFs of children before their parent's, each subtree's DOFs together,
  // the root's six last, so that the Cholesky factor of the normal equations has no fill-in and
  // a target's columns form one or two runs (see least_squares_ik.cpp).
  std::vector<int> position_of_;  // per entry of `dofs`, its column
  std::vector<int> dof_at_;       // per DOF column, its entry of `dofs`
  uint64_t joint_mask_ = 0;       // joints the targets hang from (evaluated by the FK)
  // What the lists above were made for: they are kept while it stays the same.
  struct ColumnKey {
    const rig::Skeleton* skeleton = nullptr;
    int root_cols = -1, dof_count = -1, target_count = -1;
  } listed_for_;
  std::vector<int> listed_dofs_, listed_joints_;
  float lambda_ = 0;  // damping the last solve ended with
};

struct LeastSquaresIkJob {
  // [in]
  const rig::Skeleton* skeleton = nullptr;
  std::span<const int> dofs;  // skeleton DOF indices to solve for (distinct)
  bool solve_root = false;    // root position and orientation are unknowns too
  std::span<const IkTarget> targets;
  std::span<const float> prior_rad;  // empty, or one preferred value per skeleton DOF
  float prior_weight = 0.05f;        // pull towards prior_rad, per radian
  float damping = 0.02f;             // smallest λ (grows on rejected steps)
  int max_iterations = 10;
  float step_tolerance = 5e-4f;  // stop when no unknown moves more than this (or the
                                 // objective drops by less than 0.01 %)
  // Stop too when a step (the model_min_iterations-th or later) gained what the linear model
  // promised to within this fraction of the objective left (0: never).
  float model_tolerance = 0.0f;
  int model_min_iterations = 2;
  LeastSquaresIkContext* context = nullptr;
  // [in, out] warm start in, solution (inside the joint limits) out
  rig::Pose* pose = nullptr;
  // [out]
  int iterations = 0;       // linear solves done
  float residual_norm = 0;  // weighted residual after the last iteration

  bool Validate() const;
  bool Run();

 private:
  // The stages of Run().
  bool ColumnsListed(int root_cols);
  void ListColumns(int root_cols);
  float Objective(float prior2);
  void FillJacobian(int root_cols);
  void BuildNormalEquations(int cols, float prior2);
  void ApplyStep(std::span<const float> step, int root_cols);
};

}  // namespace mimic::solver
