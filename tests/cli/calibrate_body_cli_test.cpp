// The wearer's own body, end to end: `mimic calibrate --body-out` on simulated wearers of known
// build (the child, tall and heavy presets worn by the simulated body, sim:…&body=preset:NAME)
// writes a body whose heights and limb lengths are the wearer's within 3 %, the calibration
// names it, and `mimic run --calibration` serves it unless --body says otherwise.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "mimic/avatar/body_presets.h"
#include "mimic/avatar/wearer_body.h"
#include "mimic_proc.h"
#include "run_mimic.h"

namespace calibrate_body_cli_test {

namespace {

using mimic::test::Outcome;
using mimic::test::Proc;
using mimic::test::run_mimic;
namespace avatar = mimic::avatar;

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / (name + "." + std::to_string(::getpid()))).string();
}

avatar::SkeletonBuild build_of(const avatar::BodyModel& body) {
  auto s = mimic::rig::Skeleton::build(body.skeleton);
  EXPECT_TRUE(s);
  return avatar::measure_build(*s);
}

TEST(CalibrateBodyCli, TheWearersHeightsAndLengthsWithinThreePercent) {
  for (const char* preset : {"child", "tall", "heavy"}) {
    const std::string cal = temp_path(std::string("wearer_cal_") + preset + ".json");
    const std::string body = temp_path(std::string("wearer_body_") + preset + ".json");
    const Outcome r = run_mimic("calibrate --source 'sim:idle?sensors=11&body=preset:" + std::string(preset) +
                                "' --out " + cal + " --body-out " + body + " --countdown 0 --seconds 1");
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("wearer's body"), std::string::npos) << r.output;
    auto fitted = avatar::load_body_model(body);
    ASSERT_TRUE(fitted) << fitted.error().what();
    auto truth = avatar::load_body_or_preset(std::string("preset:") + preset);
    ASSERT_TRUE(truth);
    const avatar::SkeletonBuild got = build_of(*fitted), want = build_of(*truth);
    for (auto [g, w, what] : {std::tuple{got.height_m, want.height_m, "height"},
                              std::tuple{got.root_height_m, want.root_height_m, "spine origin height"},
                              std::tuple{got.limbs.upper_arm_m, want.limbs.upper_arm_m, "upper arm"},
                              std::tuple{got.limbs.forearm_m, want.limbs.forearm_m, "forearm"},
                              std::tuple{got.limbs.thigh_m, want.limbs.thigh_m, "thigh"},
                              std::tuple{got.limbs.shin_m, want.limbs.shin_m, "shin"},
                              std::tuple{got.limbs.shoulder_width_m, want.limbs.shoulder_width_m, "shoulders"},
                              std::tuple{got.limbs.hip_width_m, want.limbs.hip_width_m, "hips"}})
      EXPECT_NEAR(g / w, 1.0f, 0.03f) << preset << " " << what << ": " << g << " m against " << w << " m";
    std::ifstream in(cal);
    const auto j = nlohmann::json::parse(in, nullptr, false);
    ASSERT_FALSE(j.is_discarded());
    EXPECT_EQ(j.value("body", ""), std::filesystem::path(body).filename().string());
    std::filesystem::remove(cal);
    std::filesystem::remove(body);
  }
}

TEST(CalibrateBodyCli, RunServesTheCalibrationsBodyUnlessBodySaysOtherwise) {
  const std::string cal = temp_path("wearer_cal_run.json"), body = temp_path("wearer_body_run.json");
  const Outcome r = run_mimic("calibrate --source 'sim:idle?sensors=6&body=preset:tall' --out " + cal + " --body-out " +
                              body + " --countdown 0 --seconds 1");
  ASSERT_EQ(r.status, 0) << r.output;
  Proc run(
      {"run", "--listen", "127.0.0.1:0", "--source", "sim:walk?sensors=6", "--calibration", cal, "--duration", "1"});
  ASSERT_EQ(run.wait(60.0), 0) << run.err();
  EXPECT_NE(run.err().find("body 'wearer'"), std::string::npos) << run.err();
  Proc chosen({"run", "--listen", "127.0.0.1:0", "--source", "sim:walk?sensors=6", "--body", "preset:child",
               "--calibration", cal, "--duration", "1"});
  ASSERT_EQ(chosen.wait(60.0), 0) << chosen.err();
  EXPECT_NE(chosen.err().find("body 'child'"), std::string::npos) << chosen.err();
  // A simulated wearer of a body that does not exist is a clear usage error.
  const Outcome bad =
      run_mimic("calibrate --source 'sim:idle?sensors=6&body=preset:giant' --out " + cal + " --countdown 0");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.output.find("giant"), std::string::npos) << bad.output;
  std::filesystem::remove(cal);
  std::filesystem::remove(body);
}

}  // namespace

}  // namespace calibrate_body_cli_test
