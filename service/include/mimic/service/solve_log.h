// A recorded tracker session (mimic record) solved offline into a take: the log is replayed on
// a clock stepped at a fixed rate, and every step reads and solves as the realtime loop does
// (the same filters, calibration and body solver), so an export sees what `mimic run --source
// replay:` would have streamed, frame by frame, without waiting for the session's real time.
#pragma once

#include <string>
#include <vector>

#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"

namespace mimic::service {

struct SolvedTake {
  rig::Skeleton skeleton;       // what the poses are for: the calibration's fitted skeleton,
                                // else the body's (or the default one)
  std::vector<double> times_s;  // from the first solved frame, 1/fps apart
  std::vector<rig::Pose> poses;
  std::string description;  // the source, for reports
  size_t samples = 0;       // samples read from the log
};

// Steps at `fps` (0 < fps ≤ 1000) from the first sample to the last, at most `max_seconds` of
// the session (0: all of it). Fails on an unreadable log or calibration, a log without
// samples, or a body the calibration does not fit.
Result<SolvedTake> solve_log(const std::string& log_path, const std::string& calibration_path, double fps,
                             const rig::Skeleton* body = nullptr, double max_seconds = 0);

}  // namespace mimic::service
