// Foot contact quality of solved poses against ground truth, for `mimic eval-solver` and tests:
// what a wearer sees of the legs, which MPJPE averages away.
//
// A foot (ankle joint) is planted on a frame when it moves slower than
// `planted_speed_mps` and is within `planted_height_m` of the lowest that foot reaches in the
// sequence; a run of planted frames is a stance, and a stance that follows a swing in which the
// foot travelled at least `min_step_m` counts as a step. The same detector runs on the truth and
// on the solved poses.
//   lower_body_mpjpe_cm   mean position error of hips, knees and ankles
//   foot_skate_mm         per stance of the truth's foot, the largest horizontal slide of the
//                         solved foot relative to the truth's since the stance began; mean over
//                         stances (a foot that stays put while the truth's does scores 0)
//   floor_penetration_mm  deepest point of a solved foot (ankle, toes, toe tip) under the floor,
//                         the floor being the lowest the truth's foot points reach
//   steps_solved / steps_truth
//   largest_ankle_move_mm the largest distance a solved ankle moves from one sample to the next
//                         (a foot that jumps; the truth's own largest is beside it)
// Feed every frame with add(), then call report() (after the last frame). Allocates.
#pragma once

#include <span>
#include <vector>

#include "mimic/rig/skeleton.h"

namespace mimic::solver {

struct GaitReport {
  double lower_body_mpjpe_cm = 0;
  double foot_skate_mm = 0;
  int stances_truth = 0;
  double floor_penetration_mm = 0;
  int steps_solved = 0;
  int steps_truth = 0;
  double largest_ankle_move_mm = 0;
  double largest_ankle_move_truth_mm = 0;
};

struct GaitOptions {
  float planted_speed_mps = 0.25f;
  float planted_height_m = 0.10f;
  float min_step_m = 0.10f;
  int min_stance_frames = 6;
};

class GaitAccumulator {
 public:
  GaitAccumulator(const rig::Skeleton& truth, const rig::Skeleton& solved, double rate_hz, GaitOptions options = {});
  void add(std::span<const rig::RigidTransform> truth_world, std::span<const rig::RigidTransform> solved_world);
  GaitReport report() const;

 private:
  struct Foot {
    int truth_ankle = -1, truth_toes = -1, solved_ankle = -1, solved_toes = -1;
    glm::vec3 truth_tip{0.0f}, solved_tip{0.0f};  // toe tip in the toes joint's frame
  };
  std::vector<std::pair<int, int>> lower_pairs_;  // truth, solved joint
  std::vector<Foot> feet_;
  double rate_hz_;
  GaitOptions options_;
  double lower_sum_ = 0;
  long lower_n_ = 0;
  // Per foot, per frame: ankle positions (truth, solved); lowest foot point of each.
  std::vector<std::vector<glm::vec3>> truth_ankle_, solved_ankle_;
  std::vector<float> truth_low_y_, solved_low_y_;
};

}  // namespace mimic::solver
