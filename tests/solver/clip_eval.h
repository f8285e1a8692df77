// Test and benchmark harness: a retargeted BVH clip worn with virtual sensors synthesised by
// forward kinematics (mounting offsets askew, Gaussian noise, one seed), calibrated on the clip's
// frame-0 T-pose, then solved frame by frame. `mimic eval-solver` does the same through the
// simulator's SensorRig.
#pragma once

#include <chrono>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "mimic/rig/retarget.h"
#include "mimic/solver/body_solver.h"
#include "mimic/solver/calibration.h"
#include "mimic/solver/filters.h"
#include "mimic/solver/model_refiner.h"
#include "mimic/solver/pose_error.h"
#include "synthetic_sensors.h"

namespace mimic::solver::testing {

struct ClipEvalConfig {
  std::string layout = "6";
  float noise_mm = 1.0f;
  float noise_deg = 0.5f;
  float mount_tilt_deg = 20.0f;
  int first_frame = 1;  // frame 0 is the T-pose
  int max_frames = -1;  // all
  int stride = 1;
  uint64_t seed = 1;
  bool filter = true;
  SensorFilterConfig filter_config{};
  bool oracle = false;  // solve with the true skeleton and mounts (isolates calibration error)
  bool refine = true;   // functional calibration from the stream (model_refiner.h)
  double rate_hz = 120.0;
};

struct ClipEval {
  PoseErrorReport report;
  std::string error;  // empty on success
};

inline ClipEval evaluate_clip(const rig::RetargetedClip& clip, const ClipEvalConfig& cfg) {
  ClipEval out;
  const rig::Skeleton& truth = clip.skeleton;
  // Where the straps really are (the wearer's own links) and where the calibration is told they
  // are (the instructions, drawn on the tracking skeleton).
  auto worn = standard_layout(cfg.layout, truth);
  if (!worn) return {{}, worn.error().what()};
  const auto mounts = mounts_for(*worn, glm::radians(cfg.mount_tilt_deg), cfg.seed);
  auto layout = standard_layout(cfg.layout, *rig::Skeleton::build(tracking_skeleton_desc()));
  if (!layout) return {{}, layout.error().what()};
  std::mt19937_64 rng(cfg.seed);
  const float noise_m = cfg.noise_mm / 1000.0f, noise_rad = glm::radians(cfg.noise_deg);
  // Calibration: one second standing in the frame-0 T-pose.
  std::vector<devices::SensorSample> capture, tick;
  for (int k = 0; k < 100; ++k) {
    sense(truth, clip.poses[0], mounts, tick, &rng, noise_m, noise_rad, 0.01 * k);
    capture.insert(capture.end(), tick.begin(), tick.end());
  }
  auto cal = calibrate(tracking_skeleton_desc(), *layout, capture);
  if (!cal) return {{}, cal.error().what()};
  auto first = cfg.oracle ? SolverModel::create(truth, mounts) : make_solver_model(*cal);
  if (!first) return {{}, first.error().what()};
  auto model = std::make_unique<SolverModel>(std::move(*first));
  auto ctx = std::make_unique<SolverContext>(*model);
  ModelRefiner refiner(*cal, *model, cfg.rate_hz / cfg.stride);
  SensorFilterConfig fc = cfg.filter_config;
  fc.enabled = cfg.filter;
  SensorFilterBank filters(static_cast<int>(mounts.size()), fc);
  rig::Pose pose = model->skeleton().zero_pose();
  PoseErrorAccumulator acc(truth, model->skeleton());
  std::vector<rig::RigidTransform> wt(truth.joint_count()), ws(model->skeleton().joint_count());
  const int last = cfg.max_frames < 0 ? static_cast<int>(clip.poses.size())
                                      : std::min<int>(static_cast<int>(clip.poses.size()),
                                                      cfg.first_frame + cfg.max_frames * cfg.stride);
  for (int f = cfg.first_frame; f < last; f += cfg.stride) {
    sense(truth, clip.poses[f], mounts, tick, &rng, noise_m, noise_rad, f * clip.frame_time_s);
    const auto t0 = std::chrono::steady_clock::now();
    if (cfg.refine && !cfg.oracle && refiner.add(tick, *model))
      if (auto next = refiner.rebuild()) {
        model = std::move(*next);
        ctx = std::make_unique<SolverContext>(*model);
      }
    filters.process(tick);
    SolveJob job{model.get(), tick, ctx.get(), &pose};
    job.Run();
    const auto t1 = std::chrono::steady_clock::now();
    rig::forward_kinematics(truth, clip.poses[f], wt);
    rig::forward_kinematics(model->skeleton(), pose, ws);
    acc.add(wt, ws, std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  out.report = acc.report();
  return out;
}

}  // namespace mimic::solver::testing
