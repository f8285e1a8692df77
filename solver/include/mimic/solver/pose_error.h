// Accuracy of solved poses against ground truth, for `mimic eval-solver`, tests and benchmarks.
//
// Joints are matched by name between the truth skeleton and the solver's own (fitted) skeleton;
// the joint set is every joint both have except the toes (Mimic's skeleton has no fingers).
// All errors are in world space with no alignment: the solver must place the body, not only
// shape it.
//   mpjpe_cm         mean over frames and joints of |p_solved − p_true|
//   mpjre_deg        mean over frames and joints of the angle of R_solved · R_true⁻¹ (joint frames
//                    of both skeletons are parallel to the world in the zero posture)
//   end_effector_mm  mean over frames of the position error of head, wrists and ankles
//   jitter_mm        mean over frames and joints of |p[t+1] − 2·p[t] + p[t−1]| of the solved
//                    positions (second difference at the sample rate); jitter_truth_mm is the
//                    same for the ground truth, so the excess is what the solver adds
//   lag_ms           the time shift of the truth that the solved joint positions match best
//                    (mean position error over shifts of −2…+6 samples, refined by a parabola
//                    through the best three): what filters and solve add in delay
//   solve_us_*       wall time of one solve, percentiles over frames
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mimic/rig/skeleton.h"

namespace mimic::solver {

struct PoseErrorReport {
  int frames = 0;
  int joints = 0;
  double mpjpe_cm = 0;
  double mpjre_deg = 0;
  double end_effector_mm = 0;
  double end_effector_max_mm = 0;
  double jitter_mm = 0;
  double jitter_truth_mm = 0;
  double solve_us_p50 = 0;
  double solve_us_p99 = 0;
  double solve_us_max = 0;
  double lag_ms = 0;  // needs the sample rate: set_rate_hz()
  std::vector<std::string> joint_names;
  std::vector<double> joint_mpjpe_cm;   // per joint of the set
  std::vector<double> joint_jitter_mm;  // per joint of the set
};

// The joints end_effector_mm is taken over: head, wrists, ankles.
bool is_end_effector(std::string_view joint);

class PoseErrorAccumulator {
 public:
  // Allocates; the frame count is unbounded (solve times are kept for the percentiles).
  PoseErrorAccumulator(const rig::Skeleton& truth, const rig::Skeleton& solved);

  // World transforms of every joint of each skeleton for one frame; solve_us < 0 if untimed.
  void add(std::span<const rig::RigidTransform> truth_world, std::span<const rig::RigidTransform> solved_world,
           double solve_us = -1);
  PoseErrorReport report() const;
  void set_rate_hz(double rate_hz) { rate_hz_ = rate_hz; }

 private:
  struct Pair {
    int truth = -1, solved = -1;
    bool end_effector = false;
  };
  std::vector<Pair> pairs_;
  std::vector<std::string> names_;
  int end_effectors_ = 0;
  int frames_ = 0;
  double pos_sum_ = 0, rot_sum_ = 0, ee_sum_ = 0, ee_max_ = 0;
  std::vector<double> joint_sum_, joint_jitter_sum_;
  std::vector<glm::vec3> prev_solved_, prev2_solved_, prev_truth_, prev2_truth_;
  double jitter_sum_ = 0, jitter_truth_sum_ = 0;
  long jitter_terms_ = 0;
  std::vector<double> solve_us_;
  double rate_hz_ = 0;
  std::vector<glm::vec3> solved_track_, truth_track_;  // every frame's joint positions, for the lag
};

}  // namespace mimic::solver
