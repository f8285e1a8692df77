// Functional calibration while the wearer moves: the stand-still calibration refined from the
// live stream, for the layouts whose sensors can show more than a stand-still does.
//
//   - limb lengths (limb_refinement.h): twice a second, in place, no allocation;
//   - joint centres between neighbouring sensors (joint_centres.h): after 1, 2, 4, 8, 16 and
//     32 s of stream, a new SolverModel built from the refined calibration (allocates: done
//     off the realtime path by whoever owns the loop, or accepted by offline tools).
//
// Feed it the raw samples (before the filters: their lag differs from segment to segment).
#pragma once

#include <memory>
#include <span>

#include "mimic/solver/calibration.h"
#include "mimic/solver/joint_centres.h"
#include "mimic/solver/limb_refinement.h"

namespace mimic::solver {

class ModelRefiner {
 public:
  // `model` must be the one make_solver_model(calibration) built. Allocates.
  ModelRefiner(Calibration calibration, const SolverModel& model, double rate_hz);

  // Accumulates one tick of raw samples and refines the limb lengths of `model` in place when
  // it is time. No allocation. Returns true when it is time for rebuild().
  bool add(std::span<const devices::SensorSample> raw, SolverModel& model);
  // The model with the joint centres found so far (and the limb lengths), or an error when
  // nothing new was found. Allocates.
  Result<std::unique_ptr<SolverModel>> rebuild() const;
  // The calibration with everything found so far (to save it: `mimic calibrate --move`);
  // `joints` and `limbs` count what was refined. Allocates.
  Result<Calibration> refined_calibration(int* joints = nullptr, int* limbs = nullptr) const;

  int refined_limbs() const { return refined_limbs_; }
  int refined_joints() const { return refined_joints_; }
  const LimbLengthEstimator& limbs() const { return limbs_; }
  const JointCentreEstimator& centres() const { return centres_; }
  const Calibration& calibration() const { return calibration_; }

 private:
  Calibration calibration_;
  LimbLengthEstimator limbs_;
  JointCentreEstimator centres_;
  long limb_every_ = 60, next_rebuild_ = 120, last_rebuild_ = 0, tick_ = 0;
  int refined_limbs_ = 0;
  mutable int refined_joints_ = 0;
};

}  // namespace mimic::solver
