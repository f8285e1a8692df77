// Arm and leg link lengths refined from the live stream (functional calibration).
//
// A stand-still shows where the hands and feet are, not where along the limb the elbow or knee
// bends. Once the wearer moves, it does: seen from the upper segment (upper arm, thigh), the
// far joint (wrist, ankle) turns about the middle joint's hinge, so its positions lie on a
// circle whose centre is the elbow (knee) and whose radius is the lower link. The estimator
// keeps running moments of those positions — no sample is stored — and fits the plane and the
// circle (Kåsa) from them: upper link = hinge centre to the upper joint, lower link = radius.
//
// Observable for a limb whose upper segment and end segment (hand, foot) carry sensors and the
// middle one does not (layout 11; with a sensor on every segment joint_centres.h sees more).
// Positions are kept in the upper sensor's frame, so a model refined meanwhile loses nothing. A fit is used only once
// the arc is wide enough and the points lie in a plane; the lengths then replace the calibrated ones (`refine`), in
// place, without allocating.
#pragma once

#include <array>
#include <span>

#include "mimic/devices/sample.h"
#include "mimic/solver/body_solver.h"

namespace mimic::solver {

struct LimbFit {
  bool valid = false;  // wide enough arc, points in a plane, lengths within a body's range
  int samples = 0;
  float upper_m = 0;       // upper joint to hinge centre
  float lower_m = 0;       // hinge centre to the end joint (circle radius)
  float arc_spread_m = 0;  // spread of the end joint across the arc (its narrower in-plane axis)
  float off_plane_m = 0;   // spread of the end joint out of the fitted plane (noise, wrong hinge)
};

struct LimbRefinementOptions {
  float min_arc_spread_m = 0.01f;  // standard deviation across the arc
  float min_plane_ratio = 3.0f;    // arc spread over off-plane spread: the plane is known
  float max_off_plane_m = 0.012f;
  int min_samples = 60;
  float min_link_m = 0.12f, max_link_m = 0.75f;
};

class LimbLengthEstimator {
 public:
  explicit LimbLengthEstimator(const SolverModel& model, LimbRefinementOptions options = {});

  // Chains are those of SolverModel: 0 l arm, 1 r arm, 2 l leg, 3 r leg.
  bool observable(int chain) const { return chain >= 0 && chain < 4 && chains_[chain].upper_slot >= 0; }
  int observable_count() const;

  // One frame of samples (filtered or raw; invalid, stale and outlier samples are skipped).
  // No allocation.
  void add(std::span<const devices::SensorSample> samples, const SolverModel& model);
  LimbFit fit(int chain, const SolverModel& model) const;
  // Writes the valid fits into `model`. Returns how many chains changed. No allocation.
  int refine(SolverModel& model) const;
  void reset();

 private:
  struct Moments {
    int n = 0;
    std::array<double, 3> s1{};  // Σx
    std::array<double, 6> s2{};  // Σ x xᵀ (xx xy xz yy yz zz)
    std::array<double, 3> s3{};  // Σ x |x|²
    double s4 = 0;               // Σ |x|²
  };
  struct ChainState {
    int upper_slot = -1, end_slot = -1;  // mount indices
    Moments m;
  };
  LimbRefinementOptions options_;
  std::array<ChainState, 4> chains_{};
};

}  // namespace mimic::solver
