#include "mimic/solver/model_refiner.h"

#include <algorithm>
#include <cmath>

namespace mimic::solver {

ModelRefiner::ModelRefiner(Calibration calibration, const SolverModel& model, double rate_hz)
    : calibration_(std::move(calibration)), limbs_(model), centres_(calibration_) {
  const double rate = std::isfinite(rate_hz) && rate_hz > 0 ? rate_hz : 120.0;
  limb_every_ = std::max(1L, std::lround(rate / 2.0));
  next_rebuild_ = std::max(1L, std::lround(rate));
  last_rebuild_ = std::lround(32.0 * rate);
}

bool ModelRefiner::add(std::span<const devices::SensorSample> raw, SolverModel& model) {
  ++tick_;
  limbs_.add(raw, model);
  centres_.add(raw);
  if (tick_ % limb_every_ == 0) refined_limbs_ = std::max(refined_limbs_, limbs_.refine(model));
  if (centres_.pair_count() == 0 || tick_ != next_rebuild_ || tick_ > last_rebuild_) return false;
  next_rebuild_ *= 2;
  return true;
}

Result<Calibration> ModelRefiner::refined_calibration(int* joints, int* limbs) const {
  int found_joints = 0;
  auto refined = centres_.refine(calibration_, &found_joints);
  if (!refined) return tl::unexpected(refined.error());
  auto model = make_solver_model(*refined);
  if (!model) return tl::unexpected(model.error());
  const int found_limbs = limbs_.refine(*model);
  // The limb lengths live in the model's skeleton now: back into the calibration's.
  const rig::Skeleton& s = model->skeleton();
  for (auto& jd : refined->skeleton.joints) {
    const int j = s.find_joint(jd.name);
    if (j < 0) continue;
    jd.offset_m = s.offset_m(j);
    jd.tip_m = s.tip_m(j);
  }
  if (joints) *joints = found_joints;
  if (limbs) *limbs = found_limbs;
  return refined;
}

Result<std::unique_ptr<SolverModel>> ModelRefiner::rebuild() const {
  int joints = 0;
  auto refined = refined_calibration(&joints);
  if (!refined) return tl::unexpected(refined.error());
  if (joints == 0) return fail(Errc::not_found, "no joint centre has enough samples yet");
  auto model = make_solver_model(*refined);
  if (!model) return tl::unexpected(model.error());
  refined_joints_ = std::max(refined_joints_, joints);
  return std::make_unique<SolverModel>(std::move(*model));
}

}  // namespace mimic::solver
