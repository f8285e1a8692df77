// End-to-end: `mimic intersect` over the built-in walk and a shared clip, its lines, its JSON and
// its usage errors. The command exists in builds with CGAL (avatar/exact).
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "run_mimic.h"

namespace intersect_cli_test {

namespace {

using mimic::test::Outcome;
using mimic::test::run_mimic;

bool built() { return run_mimic("--help", true).output.find("intersect") != std::string::npos; }

std::vector<nlohmann::json> json_lines(const std::string& text) {
  std::vector<nlohmann::json> lines;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line))
    if (!line.empty()) lines.push_back(nlohmann::json::parse(line));
  return lines;
}

TEST(IntersectCli, JsonLinesForEachFrameThenTheSummary) {
  if (!built()) GTEST_SKIP() << "built without CGAL";
  const Outcome r = run_mimic("intersect --motion walk --every 15 --frames 2 --json", true);
  ASSERT_EQ(r.status, 0) << r.output;
  const auto lines = json_lines(r.output);
  ASSERT_EQ(lines.size(), 3u) << r.output;
  for (int k = 0; k < 2; ++k) {
    const auto& f = lines[size_t(k)];
    EXPECT_EQ(f["source"], "walk");
    EXPECT_EQ(f["method"], "realtime");
    EXPECT_EQ(f["lod"], 0);
    EXPECT_EQ(f["frame"], 15 * k);
    EXPECT_EQ(f["triangles"], 14610);
    EXPECT_GT(f["by_design_pairs"].get<int>(), 100) << "the head, hands and feet sink into their pieces";
    EXPECT_GE(f["deepest_mm"].get<double>(), f["deepest_envelope_mm"].get<double>());
    for (const char* key : {"fold_pairs", "between_pairs", "sharpest_crease_deg", "by_parts"})
      EXPECT_TRUE(f.contains(key)) << key;
  }
  const auto& s = lines[2];
  EXPECT_EQ(s["summary"], "walk");
  EXPECT_EQ(s["frames"], 2);
  EXPECT_DOUBLE_EQ(s["fold_pairs_mean"].get<double>(),
                   (lines[0]["fold_pairs"].get<double>() + lines[1]["fold_pairs"].get<double>()) / 2);
}

// The realtime skin's contact is on unless --no-contact: 07_01's left upper arm is 21 mm into
// the chest at frame 40 without it, 18 mm with it.
TEST(IntersectCli, NoContactMeasuresTheSkinWithoutContact) {
  if (!built()) GTEST_SKIP() << "built without CGAL";
  const std::string clip = mimic::test::clip_path("07_01");
  const std::string args = "intersect --bvh '" + clip + "' --every 40 --frames 3 --summary --json";
  const Outcome on = run_mimic(args, true), off = run_mimic(args + " --no-contact", true);
  ASSERT_EQ(on.status, 0) << on.output;
  ASSERT_EQ(off.status, 0) << off.output;
  const auto a = json_lines(on.output), b = json_lines(off.output);
  ASSERT_FALSE(a.empty() || b.empty());
  EXPECT_LT(a[0]["deepest_envelope_mm_max"].get<double>(), b[0]["deepest_envelope_mm_max"].get<double>() - 2);
  EXPECT_LT(a[0]["deepest_envelope_mm_mean"].get<double>(), b[0]["deepest_envelope_mm_mean"].get<double>());
}

TEST(IntersectCli, AClipAtTwoLodsWithBothMethods) {
  if (!built()) GTEST_SKIP() << "built without CGAL";
  const std::string clip = mimic::test::clip_path("07_01");
  const Outcome r = run_mimic("intersect --bvh '" + clip + "' --every 200 --frames 2 --lod 0,3 --method both", true);
  ASSERT_EQ(r.status, 0) << r.output;
  // Frame 0 of a CMU clip is its T-pose: nothing passes through anything.
  EXPECT_NE(r.output.find("07_01 realtime lod 0 frame 0: folds 0, between 0"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("07_01 full lod 3 frame 200:"), std::string::npos) << r.output;
  for (const char* row : {"07_01      realtime   0  14610      2 |", "07_01      full       3    770      2 |"})
    EXPECT_NE(r.output.find(row), std::string::npos) << row << "\n" << r.output;
}

TEST(IntersectCli, TheAuthoredPostureIsClean) {
  if (!built()) GTEST_SKIP() << "built without CGAL";
  const Outcome r = run_mimic("intersect --pose zero --method both --json", true);
  ASSERT_EQ(r.status, 0) << r.output;
  const auto lines = json_lines(r.output);
  ASSERT_EQ(lines.size(), 4u) << r.output;  // a frame and a summary a method
  for (const auto& f : {lines[0], lines[1]}) {
    EXPECT_EQ(f["source"], "zero");
    EXPECT_EQ(f["fold_pairs"], 0) << f.dump();
    EXPECT_EQ(f["between_pairs"], 0) << f.dump();
    EXPECT_EQ(f["deepest_mm"], 0.0) << f.dump();
  }
}

// --where names the rings each fold lies between: every fold pair once, as the two triangles'
// strips ("ring+ring:column"), and the summary sums them by ring pair.
TEST(IntersectCli, WhereNamesTheRingsOfEveryFold) {
  if (!built()) GTEST_SKIP() << "built without CGAL";
  const std::string clip = mimic::test::clip_path("02_06");
  const Outcome r = run_mimic("intersect --bvh '" + clip + "' --every 150 --frames 12 --where --json", true);
  ASSERT_EQ(r.status, 0) << r.output;
  const auto lines = json_lines(r.output);
  ASSERT_EQ(lines.size(), 13u) << r.output;
  size_t folds = 0, named = 0;
  for (size_t k = 0; k < 12; ++k) {
    const auto& f = lines[k];
    size_t sum = 0;
    for (const auto& place : f["folds_where"]) {
      const std::string where = place[0];
      const size_t gap = where.find(' ');
      ASSERT_NE(gap, std::string::npos) << where;
      for (const std::string& t : {where.substr(0, gap), where.substr(gap + 1)})
        EXPECT_NE(t.find(':'), std::string::npos) << "a triangle's ring and column: " << where;
      sum += place[1].get<size_t>();
    }
    EXPECT_EQ(sum, f["fold_pairs"].get<size_t>()) << f.dump();
    folds += f["fold_pairs"].get<size_t>(), named += sum;
  }
  EXPECT_GT(folds, 0u) << "02_06's crouch folds the thighs' bands";
  double by_ring = 0;
  for (const auto& [ring, per_frame] : lines[12]["folds_per_frame_by_ring"].items()) by_ring += per_frame.get<double>();
  EXPECT_NEAR(by_ring, double(named) / 12, 1e-9);
}

TEST(IntersectCli, UsageErrorsAndBadInput) {
  if (!built()) GTEST_SKIP() << "built without CGAL";
  for (const char* args :
       {"intersect", "intersect --motion walk --lod 4", "intersect --motion walk --lod 0,x",
        "intersect --motion walk --method lbs", "intersect --motion walk --every 0",
        "intersect --motion walk --bvh x.bvh", "intersect --pose zero --motion walk", "intersect --pose sitting"}) {
    const Outcome r = run_mimic(args);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find("mimic intersect"), std::string::npos) << args << "\n" << r.output;
  }
  const Outcome r = run_mimic("intersect --bvh /nonexistent-mimic-dir/x.bvh");
  EXPECT_EQ(r.status, 1) << r.output;
}

}  // namespace

}  // namespace intersect_cli_test
