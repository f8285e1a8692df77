// Offline solves of recorded sessions: a log made by `mimic record` from the simulated rig,
// solved on a stepped clock.
#include "mimic/service/solve_log.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "mimic/rig/motion.h"
#include "mimic/sim/log.h"
#include "run_mimic.h"

namespace mimic::service::solve_log_test {
namespace {

std::string recorded_walk(double seconds) {
  const std::string path =
      (std::filesystem::temp_directory_path() / ("mimic_solve_log_" + std::to_string(::getpid()) + ".mlog")).string();
  const test::Outcome r = test::run_mimic("record --source 'sim:walk?sensors=all' --duration " +
                                          std::to_string(seconds) + " --out '" + path + "'");
  EXPECT_EQ(r.status, 0) << r.output;
  return path;
}

TEST(SolveLog, ARecordedWalkSolvesFrameByFrameLikeTheMotion) {
  const std::string log = recorded_walk(2.0);
  auto take = solve_log(log, "", 50.0);
  ASSERT_TRUE(take) << take.error().what();
  // One pose per step of 20 ms over the samples' span: two seconds, a little more when the
  // recorder ran late on a loaded machine.
  auto recorded = sim::read_log(log);
  ASSERT_TRUE(recorded) << recorded.error().what();
  ASSERT_FALSE(recorded->samples.empty());
  double first_s = recorded->samples.front().host_time_s, last_s = first_s;
  for (const auto& smp : recorded->samples) {
    first_s = std::min(first_s, smp.host_time_s);
    last_s = std::max(last_s, smp.host_time_s);
  }
  const double span_s = last_s - first_s;
  EXPECT_GE(span_s, 1.9);
  ASSERT_GE(take->poses.size(), 95u);
  ASSERT_LE(static_cast<double>(take->poses.size()), std::ceil(span_s / 0.02) + 2) << span_s;
  ASSERT_EQ(take->times_s.size(), take->poses.size());
  for (size_t i = 1; i < take->times_s.size(); ++i) EXPECT_NEAR(take->times_s[i] - take->times_s[i - 1], 0.02, 1e-9);
  EXPECT_GT(take->samples, 1000u);
  // The solved root follows the walk (all sensors worn: the solver tracks the body to
  // millimetres once it has settled, a few frames in). The rig's device time is the motion's:
  // frame k holds the samples up to the first recorded one's time plus times_s[k].
  auto contents = sim::read_log(log);
  ASSERT_TRUE(contents) << contents.error().what();
  ASSERT_FALSE(contents->samples.empty());
  const double t0_s = contents->samples.front().device_time_s;
  auto motion = rig::make_builtin_motion("walk", take->skeleton);
  ASSERT_TRUE(motion);
  rig::Pose truth = take->skeleton.zero_pose();
  float worst_m = 0;
  for (size_t k = 10; k < take->poses.size(); ++k) {
    (*motion)->sample(t0_s + take->times_s[k], truth);
    worst_m = std::max(worst_m, glm::length(take->poses[k].root_position_m - truth.root_position_m));
  }
  EXPECT_LT(worst_m, 0.05f);
  (*motion)->sample(t0_s + take->times_s.back(), truth);
  EXPECT_GT(glm::length(truth.root_position_m - take->poses.front().root_position_m), 1.0f);  // it walked
  // The stepped clock makes the solve a function of the log: the same take twice.
  auto again = solve_log(log, "", 50.0);
  ASSERT_TRUE(again);
  ASSERT_EQ(again->poses.size(), take->poses.size());
  for (size_t i = 0; i < take->poses.size(); ++i) {
    EXPECT_EQ(again->poses[i].root_position_m, take->poses[i].root_position_m) << i;
    EXPECT_EQ(again->poses[i].dof_rad, take->poses[i].dof_rad) << i;
  }
  // --seconds: at most that much of the session.
  auto half = solve_log(log, "", 50.0, nullptr, 1.0);
  ASSERT_TRUE(half);
  EXPECT_NEAR(half->times_s.back(), 1.0, 0.021);
  std::filesystem::remove(log);
}

TEST(SolveLog, BadInputsAreRefusedByName) {
  auto missing = solve_log("/nonexistent/session.mlog", "", 30.0);
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find("/nonexistent/session.mlog"), std::string::npos) << missing.error().message;
  EXPECT_FALSE(solve_log("/nonexistent/session.mlog", "", 0.0));
  const std::string log = recorded_walk(0.5);
  auto bad_calibration = solve_log(log, "/nonexistent/calibration.json", 30.0);
  EXPECT_FALSE(bad_calibration);
  std::filesystem::remove(log);
}

}  // namespace
}  // namespace mimic::service::solve_log_test
