#include "mimic/service/solve_log.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "feed_on_clock.h"

namespace mimic::service {

namespace {

// Solves the same samples again, warm-started each time, until no DOF moves by more than
// kSettled_rad (or kMaxRounds passes).
void settle(PoseFeed& feed, rig::Pose& pose) {
  constexpr int kMaxRounds = 200;
  constexpr float kSettled_rad = 1e-4f;
  rig::Pose before = pose;
  for (int round = 0; round < kMaxRounds; ++round) {
    double capture_s = 0;
    bool stale = false;
    feed.solve(pose, capture_s, stale);
    float moved = glm::length(pose.root_position_m - before.root_position_m);
    for (size_t d = 0; d < pose.dof_rad.size(); ++d)
      moved = std::max(moved, std::abs(pose.dof_rad[d] - before.dof_rad[d]));
    if (moved < kSettled_rad) return;
    before = pose;
  }
}

}  // namespace

Result<SolvedTake> solve_log(const std::string& log_path, const std::string& calibration_path, double fps,
                             const rig::Skeleton* body, double max_seconds) {
  if (!(fps > 0 && fps <= 1000)) return fail(Errc::invalid_argument, "frame rate must be in (0, 1000]");
  auto clock = std::make_shared<ManualClock>(0.0);
  auto feed = open_feed_on_clock("replay:" + log_path, calibration_path, body, clock);
  if (!feed) return tl::unexpected(feed.error());
  if (auto st = (*feed)->start(); !st) return tl::unexpected(st.error());
  SolvedTake take{(*feed)->skeleton(), {}, {}, (*feed)->describe(), 0};
  rig::Pose pose = take.skeleton.zero_pose();
  const double dt_s = 1.0 / fps;
  // A log longer than a day is not a take; the bound keeps a stuck replay from spinning.
  const long max_steps = static_cast<long>(std::ceil((max_seconds > 0 ? max_seconds : 86400.0) * fps)) + 1;
  long first_step = -1;
  for (long step = 0; step - std::max(first_step, 0L) < max_steps; ++step) {
    clock->set(static_cast<double>(step) * dt_s);
    take.samples += (*feed)->read();
    if (take.samples == 0) {
      if ((*feed)->status().state == devices::DeviceState::disconnected)
        return fail(Errc::invalid_argument,
                    log_path + ": no samples to solve" +
                        ((*feed)->status().last_error.empty() ? "" : ": " + (*feed)->status().last_error));
      continue;
    }
    if (first_step < 0) first_step = step;
    double capture_s = 0;
    bool stale = false;
    (*feed)->solve(pose, capture_s, stale);
    // The live solver takes a few iterations per frame from where the last frame left it; the
    // first frame starts from the zero posture, so live it settles over the first frames. A
    // take has no such excuse: its first key is solved to convergence on its own samples.
    if (take.poses.empty()) settle(**feed, pose);
    take.times_s.push_back(static_cast<double>(step - first_step) * dt_s);
    take.poses.push_back(pose);
    if ((*feed)->status().state == devices::DeviceState::disconnected) break;
  }
  return take;
}

}  // namespace mimic::service
