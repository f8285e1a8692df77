// End-to-end: the built `mimic calibrate` and `mimic eval-solver`.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "mimic_proc.h"
#include "run_mimic.h"
#include "test_data.h"

namespace solver_cli_test {

namespace {

using mimic::test::Outcome;
using mimic::test::run_mimic;

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / (name + "." + std::to_string(::getpid()))).string();
}

TEST(CalibrateCli, StandingStillWritesACalibrationTheSolverLoads) {
  const std::string out = temp_path("calib.json");
  std::filesystem::remove(out);
  // At the default stand-still limits and capture (3 cm, 6°, 2 s): the idle body stands as
  // still as a person asked to.
  const Outcome r = run_mimic("calibrate --source 'sim:idle?sensors=11' --out " + out + " --countdown 0");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("stand still"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("sensors 11/11"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("wrote " + out), std::string::npos) << r.output;
  ASSERT_TRUE(std::filesystem::exists(out));
  std::ifstream in(out);
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j["format"], "mimic-calibration");
  EXPECT_EQ(j["sensors"].size(), 11u);
  EXPECT_GT(j["height_m"].get<double>(), 1.4);
  EXPECT_LT(j["height_m"].get<double>(), 2.0);
  std::filesystem::remove(out);
}

// A Flock behind its extended range controller (birds at FBB addresses 2..7) is the layout's
// sensors 0..5 in address order: all six calibrate, through the real driver on a pty.
TEST(CalibrateCli, AFlockBehindItsRangeControllerIsTheLayoutsSensors) {
  mimic::test::Proc sim({"sim", "flock", "--birds", "6", "--motion", "idle", "--ert", "--busy", "0.05"});
  const std::string pty = sim.first_line(10.0);
  ASSERT_EQ(pty.rfind("/dev/", 0), 0u) << pty << sim.err();
  const std::string out = temp_path("calib_flock.json");
  std::filesystem::remove(out);
  const Outcome r = run_mimic("calibrate --source 'flock:" + pty + "?birds=6&erc=1' --out " + out +
                              " --countdown 0.5 --seconds 0.5 --max-motion-deg 15");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("sensors 6/6"), std::string::npos) << r.output;
  std::ifstream in(out);
  const auto j = nlohmann::json::parse(in);
  EXPECT_GT(j["height_m"].get<double>(), 1.4);
  EXPECT_LT(j["height_m"].get<double>(), 2.0);
  std::filesystem::remove(out);
}

TEST(CalibrateCli, RefusesAMovingWearerAndAMissingSensorAndWritesNothing) {
  const std::string out = temp_path("calib_refused.json");
  std::filesystem::remove(out);
  Outcome r = run_mimic("calibrate --source 'sim:walk?sensors=6' --out " + out + " --countdown 0 --seconds 0.3");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("wearer moved"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));
  // Layout 11 on a source with 6 sensors: the five others are missing, by name.
  r = run_mimic("calibrate --source 'sim:idle?sensors=6' --layout 11 --out " + out + " --countdown 0 --seconds 0.3");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("no data from l_upper_arm"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

// --move: after the stand-still, the motion's joint centres go into the file; a layout with no
// neighbouring sensors says there is nothing to refine.
TEST(CalibrateCli, MovingAfterTheStandStillRefinesTheJointCentres) {
  const std::string out = temp_path("calib_move.json"), still = temp_path("calib_still.json");
  const std::string common = " --countdown 0 --seconds 0.5 --max-motion-deg 15 --max-motion-cm 10";
  Outcome r = run_mimic("calibrate --source 'sim:idle?sensors=all' --out " + still + common);
  ASSERT_EQ(r.status, 0) << r.output;
  r = run_mimic("calibrate --source 'sim:idle?sensors=all' --out " + out + common + " --move 2");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("now move"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("refined from the motion: 22 joint centres"), std::string::npos) << r.output;
  // Both files load; the refined one differs (its joint offsets come from the motion).
  std::ifstream a(still), b(out);
  const auto ja = nlohmann::json::parse(a), jb = nlohmann::json::parse(b);
  EXPECT_EQ(jb["format"], "mimic-calibration");
  EXPECT_NE(ja["skeleton"], jb["skeleton"]);
  r = run_mimic("calibrate --source 'sim:idle?sensors=6' --out " + out + common + " --move 1");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("--move skipped"), std::string::npos) << r.output;
  EXPECT_EQ(run_mimic("calibrate --source sim:idle --out x.json --move -1").status, 2);
  std::filesystem::remove(out);
  std::filesystem::remove(still);
}

TEST(CalibrateCli, UsageErrors) {
  EXPECT_EQ(run_mimic("calibrate --out x.json").status, 2);
  EXPECT_EQ(run_mimic("calibrate --source sim:idle").status, 2);
  EXPECT_EQ(run_mimic("calibrate --source sim:idle --out x.json --pose sideways").status, 2);
  EXPECT_EQ(run_mimic("calibrate --source sim:idle --out x.json --layout 7").status, 2);
  const Outcome help = run_mimic("calibrate --help");
  EXPECT_EQ(help.status, 0);
  for (const char* word : {"--source", "--out", "--layout", "--pose", "--seconds", "--countdown", "--max-motion-cm",
                           "--max-motion-deg", "--floor-y", "T-pose", "refused"})
    EXPECT_NE(help.output.find(word), std::string::npos) << word;
}

// Head and hands alone, over every shared clip: the stepped feet (a heel lifted behind a stride,
// a foot the ankle's limits pitch) stay on or above the floor the clip's own feet stand on.
TEST(EvalSolverCli, SteppedFeetStayAboveTheFloorOnEverySharedClip) {
  for (const char* id : {"02_04", "02_05", "02_06", "05_02", "06_04", "07_01", "09_11", "13_26"}) {
    const std::string clip = mimic::test::clip_path(id);
    if (!std::filesystem::exists(clip)) GTEST_SKIP() << "shared data not found";
    const Outcome r = run_mimic("eval-solver --bvh " + clip + " --sensors 3 --json", true);
    ASSERT_EQ(r.status, 0) << r.output;
    const auto j = nlohmann::json::parse(r.output.substr(0, r.output.find('\n')));
    std::printf("  %s: deepest foot point %.1f mm under the floor\n", id, j["floor_penetration_mm"].get<double>());
    EXPECT_LE(j["floor_penetration_mm"].get<double>(), 10.0) << id;
  }
}

TEST(EvalSolverCli, PrintsOneJsonObjectPerLayoutWithTheRequiredKeys) {
  const std::string clip = mimic::test::clip_path("07_01");
  if (!std::filesystem::exists(clip)) GTEST_SKIP() << "shared data not found";
  const Outcome r = run_mimic("eval-solver --bvh " + clip + " --sensors 3,6 --frames 120 --json", true);
  ASSERT_EQ(r.status, 0) << r.output;
  std::istringstream lines(r.output);
  std::string line;
  int objects = 0;
  while (std::getline(lines, line)) {
    const auto j = nlohmann::json::parse(line);
    for (const char* key :
         {"clip", "sensors", "frames", "mpjpe_cm", "mpjre_deg", "end_effector_mm", "jitter", "jitter_definition",
          "solve_us_p50", "solve_us_p99", "lower_body_mpjpe_cm", "foot_skate_mm", "floor_penetration_mm", "steps"})
      EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_GE(j["steps"]["solved"].get<int>(), 0);
    EXPECT_GE(j["steps"]["truth"].get<int>(), 0);
    EXPECT_GE(j["floor_penetration_mm"].get<double>(), 0.0);
    EXPECT_GT(j["lower_body_mpjpe_cm"].get<double>(), 0.0);
    EXPECT_EQ(j["clip"], "07_01");
    EXPECT_EQ(j["frames"], 120);
    EXPECT_GT(j["mpjpe_cm"].get<double>(), 0.0);
    EXPECT_LT(j["mpjpe_cm"].get<double>(), objects == 0 ? 20.0 : 10.0);
    EXPECT_EQ(j["sensors"], objects == 0 ? "3" : "6");
    // The IK reaches what its sensors say within a few millimetres; the rest of the
    // end-effector error is the calibration's.
    ASSERT_TRUE(j.contains("end_effector_reach_mm"));
    EXPECT_LT(j["end_effector_reach_mm"].get<double>(), 5.0);
    EXPECT_LT(j["end_effector_reach_mm"].get<double>(), j["end_effector_mm"].get<double>());
    ++objects;
  }
  EXPECT_EQ(objects, 2);
}

TEST(EvalSolverCli, SmoothingTakesTheShakeWithoutLag) {
  const std::string clip = mimic::test::clip_path("07_01");
  if (!std::filesystem::exists(clip)) GTEST_SKIP() << "shared data not found";
  const std::string args = "eval-solver --bvh " + clip + " --sensors 6 --frames 240 --json";
  const Outcome on = run_mimic(args, true), off = run_mimic(args + " --no-smooth", true);
  ASSERT_EQ(on.status, 0) << on.output;
  ASSERT_EQ(off.status, 0) << off.output;
  const auto a = nlohmann::json::parse(on.output), b = nlohmann::json::parse(off.output);
  EXPECT_EQ(a["smooth"], true);
  EXPECT_EQ(b["smooth"], false);
  // The sensors' noise is most of the shake: the smoother takes well over half of it, stays on
  // time (under a quarter of a 120 Hz sample later) and costs the accuracy nothing visible.
  EXPECT_LT(a["jitter_mm"].get<double>(), 0.5 * b["jitter_mm"].get<double>());
  EXPECT_LT(a["lag_ms"].get<double>() - b["lag_ms"].get<double>(), 2.0);
  EXPECT_LT(a["mpjpe_cm"].get<double>(), b["mpjpe_cm"].get<double>() + 0.2);
}

TEST(EvalSolverCli, TableNamesTheJointSetAndJitterAndRejectsBadOptions) {
  const std::string clip = mimic::test::clip_path("07_01");
  if (!std::filesystem::exists(clip)) GTEST_SKIP() << "shared data not found";
  const Outcome r = run_mimic("eval-solver --bvh " + clip + " --sensors 11 --frames 60 --noise 2,1");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("joint set: every joint but the toes"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("jitter = mean |p[t+1]-2p[t]+p[t-1]|"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("noise 2.00 mm / 1.00 deg"), std::string::npos) << r.output;
  // Latency (predicted away by the filters) and dropouts (bridged) still give a sane result.
  const Outcome lat =
      run_mimic("eval-solver --bvh " + clip + " --sensors 6 --frames 120 --latency 20 --dropout 0.05 --json", true);
  ASSERT_EQ(lat.status, 0) << lat.output;
  const auto j = nlohmann::json::parse(lat.output);
  EXPECT_EQ(j["latency_ms"], 20.0);
  EXPECT_LT(j["mpjpe_cm"].get<double>(), 10.0);
  EXPECT_EQ(run_mimic("eval-solver --bvh " + clip + " --dropout 2").status, 2);
  EXPECT_EQ(run_mimic("eval-solver --bvh " + clip + " --sensors 5").status, 2);
  EXPECT_EQ(run_mimic("eval-solver --bvh " + clip + " --noise 1").status, 2);
  EXPECT_EQ(run_mimic("eval-solver").status, 2);
  EXPECT_EQ(run_mimic("eval-solver --bvh /nonexistent.bvh").status, 1);
}

}  // namespace

}  // namespace solver_cli_test
