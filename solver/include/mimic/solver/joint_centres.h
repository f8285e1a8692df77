// Joint centres from motion (functional calibration) between segments that both carry sensors.
//
// A joint is the one point that two neighbouring segments share however they turn:
//   world_from_parent_sensor · c_parent = world_from_child_sensor · c_child
// with c_parent, c_child the joint centre in each sensor's frame (O'Brien et al., "Automatic
// joint parameter estimation from magnetic motion capture data", 2000). Every frame adds three
// linear equations in the six unknowns; the estimator keeps their normal equations (a 3×3
// block and two 3-vectors per joint, nothing per sample) and solves them with a weak pull
// towards the stand-still calibration, which settles the directions the motion never excited
// (along a hinge's axis, or everything for a joint that never turned).
//
// `refine` rewrites a Calibration with the centres found: each sensored segment's origin moves
// to its proximal joint centre, its offsets to its distal ones, and a segment with one child
// turns its frame so that the link lies along the skeleton's axis (which also corrects the
// strap's mounting rotation up to the twist about the link). Layouts with neighbouring sensors
// gain from it: every joint with one sensor per segment, the hips with thighs and pelvis.
#pragma once

#include <span>
#include <vector>

#include "mimic/core/result.h"
#include "mimic/devices/sample.h"
#include "mimic/solver/calibration.h"

namespace mimic::solver {

struct JointCentreOptions {
  double prior_weight = 2.0;  // pull towards the calibrated centres, in samples' worth
  int min_samples = 120;      // per joint before it is used
};

struct JointCentreFit {
  int joint = -1;  // skeleton joint (the child segment of the pair)
  int samples = 0;
  glm::vec3 in_parent_sensor{0.0f}, in_child_sensor{0.0f};
  float rms_m = 0;           // residual: how far the two sensors disagree about the centre
  float min_excitation = 0;  // smallest eigenvalue of the normal matrix per sample, 0..2
};

class JointCentreEstimator {
 public:
  // Pairs: every joint whose segment and parent segment both carry sensors. Allocates.
  JointCentreEstimator(const Calibration& calibration, JointCentreOptions options = {});

  int pair_count() const { return static_cast<int>(pairs_.size()); }
  // Raw samples (the filters' lag differs between segments); invalid, stale and outlier
  // samples are skipped. No allocation.
  void add(std::span<const devices::SensorSample> samples);
  // The fitted centres (joints with too few samples are left out).
  std::vector<JointCentreFit> fits() const;
  // The calibration with the fitted centres applied (see above); `changed` counts the joints.
  Result<Calibration> refine(const Calibration& calibration, int* changed = nullptr) const;

 private:
  struct Pair {
    int joint = -1;
    uint16_t parent_sensor = 0, child_sensor = 0;
    glm::dvec3 prior_parent{0.0}, prior_child{0.0};  // calibrated centre in each sensor frame
    int n = 0;
    glm::dmat3 sum_pt_c{0.0};  // Σ R_pᵀ R_c
    glm::dvec3 sum_pt_b{0.0};  // Σ R_pᵀ (p_c − p_p)
    glm::dvec3 sum_ct_b{0.0};  // Σ R_cᵀ (p_c − p_p)
    double sum_bb = 0;         // Σ |p_c − p_p|²
  };
  JointCentreOptions options_;
  std::vector<Pair> pairs_;
  std::vector<int> slot_of_sensor_;  // sensor id → index into latest_, or -1
  std::vector<const devices::SensorSample*> latest_;
};

}  // namespace mimic::solver
