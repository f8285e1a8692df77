// End-to-end: `mimic inspect` prints the joint-zone table and its JSON form.
#include <gtest/gtest.h>

#include <string>

#include <nlohmann/json.hpp>

#include "run_mimic.h"

namespace inspect_cli_test {

namespace {

using mimic::test::Outcome;
using mimic::test::run_mimic;

TEST(InspectCli, JsonHasEverySweepMethodAndSummary) {
  const Outcome r = run_mimic("inspect --json", true);
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  ASSERT_EQ(j["sweeps"].size(), 3u);
  for (const auto& s : j["sweeps"]) {
    for (const char* m : {"full", "realtime", "lbs", "dqs", "cor"}) {
      ASSERT_TRUE(s["methods"].contains(m)) << s["name"] << " " << m;
      EXPECT_EQ(s["methods"][m]["volume_change_pct"].size(), s["angles_deg"].size());
      EXPECT_EQ(s["methods"][m]["min_section_fraction"].size(), s["angles_deg"].size());
      EXPECT_EQ(s["methods"][m]["stand_off_mm"].size(), s["angles_deg"].size());
    }
  }
  // The realtime elbow and knee wrap round the joint: their skin stands off the bones no more
  // than the full method's does (the mitre's needle stood 156 mm off at the knee).
  EXPECT_LE(j["summary"]["realtime"]["stand_off_mm"].get<double>(), j["summary"]["full"]["stand_off_mm"].get<double>());
  EXPECT_EQ(j["sweeps"][0]["name"], "elbow_flexion");
  EXPECT_GT(j["summary"]["lbs"]["twist_90_abs_volume_change_pct"].get<double>(), 20.0);
  EXPECT_LT(j["summary"]["dqs"]["twist_90_abs_volume_change_pct"].get<double>(), 3.0);
  EXPECT_EQ(j["targets"]["flexion_150_abs_volume_change_pct"], 2.0);
}

TEST(InspectCli, TableAndOptions) {
  Outcome r = run_mimic("inspect --sweep forearm_twist --lod 2 --no-muscles");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("forearm_twist (l_forearm_twist"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("elbow_flexion ("), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("LOD 2, realtime muscles off"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("target realtime"), std::string::npos) << r.output;
  r = run_mimic("inspect --sweep wiggle");
  EXPECT_EQ(r.status, 2);
  r = run_mimic("inspect --lod 9");
  EXPECT_EQ(r.status, 2);
}

}  // namespace

}  // namespace inspect_cli_test
