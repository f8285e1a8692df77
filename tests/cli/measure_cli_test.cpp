// End-to-end: the built `mimic measure` on the shared MakeHuman mesh.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdio>
#include <string>

#include <nlohmann/json.hpp>

#include "run_mimic.h"
#include "test_data.h"

namespace measure_cli_test {

namespace {

using mimic::test::Outcome;
using mimic::test::run_mimic;

TEST(MeasureCli, MeasuresTheSharedMakeHumanMeshByDefault) {
  const Outcome r = run_mimic("measure");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("closed oriented manifold, genus 0"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("height                       166.74"), std::string::npos) << r.output;
  for (const char* row : {"chest girth", "waist girth", "hip girth", "thigh girth", "calf girth", "upper arm girth",
                          "volume", "surface area"})
    EXPECT_NE(r.output.find(row), std::string::npos) << row;
}

TEST(MeasureCli, JsonMatchesTheSharedMeshFigures) {
  const std::string data = mimic::test::shared_data("mesh/");
  const Outcome r = run_mimic("measure --json --obj '" + data + "makehuman_base_body.obj' --joints '" + data +
                              "makehuman_base_joints.csv' --units-per-metre=10");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["vertices"], 13380);
  EXPECT_EQ(j["closed_oriented_manifold"], true);
  const auto& m = j["measurements"];
  EXPECT_NEAR(m["height_cm"].get<double>(), 166.74, 0.05);
  EXPECT_NEAR(m["volume_dm3"].get<double>(), 54.9, 0.05);
  EXPECT_NEAR(m["waist_girth_cm"].get<double>(), 66.9, 1.0);
  // Other units scale every length: the same file read as centimetres is 10x smaller.
  const Outcome cm = run_mimic("measure --json --units-per-metre 100");
  ASSERT_EQ(cm.status, 0) << cm.output;
  EXPECT_NEAR(nlohmann::json::parse(cm.output)["measurements"]["height_cm"].get<double>(), 16.674, 0.01);
}

TEST(MeasureCli, BadUsageAndBadInputAreReported) {
  Outcome r = run_mimic("measure --units-per-metre ten");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("expects a finite number"), std::string::npos) << r.output;
  r = run_mimic("measure --units-per-metre -1");
  EXPECT_EQ(r.status, 2);
  r = run_mimic("measure --colour red");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("unknown option --colour"), std::string::npos) << r.output;
  r = run_mimic("measure --obj /nonexistent/body.obj --joints /nonexistent/j.csv");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("/nonexistent/body.obj"), std::string::npos) << r.output;
  r = run_mimic("measure --obj body.stl --joints j.csv");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("unknown extension"), std::string::npos) << r.output;
}

TEST(MeasureCli, MeshWithoutJointsGetsEstimatedLandmarks) {
  const Outcome r =
      run_mimic("measure --json --obj '" + mimic::test::shared_data("mesh/makehuman_base_body.obj") + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["joints"], "estimated");
  const auto& m = j["measurements"];
  EXPECT_NEAR(m["chest_girth_cm"].get<double>(), 85.1, 2.0);
  EXPECT_NEAR(m["waist_girth_cm"].get<double>(), 66.9, 2.0);
  EXPECT_FALSE(m.contains("upper_arm_girth_cm"));
  const Outcome text = run_mimic("measure --obj '" + mimic::test::shared_data("mesh/makehuman_base_body.obj") + "'");
  EXPECT_NE(text.output.find("estimated from the mesh"), std::string::npos) << text.output;
}

TEST(MeasureCli, HelpListsEveryOption) {
  const Outcome r = run_mimic("measure --help");
  ASSERT_EQ(r.status, 0);
  for (const char* opt : {"--obj", "--joints", "--units-per-metre", "--json", "--help"})
    EXPECT_NE(r.output.find(opt), std::string::npos) << opt;
}

}  // namespace

}  // namespace measure_cli_test
