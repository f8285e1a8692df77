// `mimic export`: a rigged, animated .glb from a built-in motion and from a CMU clip, read back.
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "replay_csv.h"
#include "run_mimic.h"
#include "test_data.h"

namespace {

nlohmann::json glb_json(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string b = ss.str();
  if (b.size() < 20 || b.compare(0, 4, "glTF") != 0) return {};
  uint32_t n = 0;
  std::memcpy(&n, b.data() + 12, 4);
  return nlohmann::json::parse(b.substr(20, n));
}

TEST(ExportCli, WalkAndClipBecomeSkinnedAnimations) {
  const auto dir = std::filesystem::temp_directory_path() / ("mimic-export-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string walk = (dir / "walk.glb").string(), clip = (dir / "clip.glb").string();
  auto r = mimic::test::run_mimic("export --motion walk --lod 3 --fps 10 --out '" + walk + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("23 joints"), std::string::npos) << r.output;
  auto j = glb_json(walk);
  ASSERT_TRUE(j.contains("skins")) << walk;
  EXPECT_EQ(j["skins"][0]["joints"].size(), 23u);
  ASSERT_EQ(j["animations"].size(), 1u);
  const auto& input = j["accessors"][j["animations"][0]["samplers"][0]["input"].get<size_t>()];
  EXPECT_NEAR(input["max"][0].get<double>(), 6.6, 0.05);  // one lap of the walk
  EXPECT_EQ(input["count"].get<int>(), 67);                 // 10 keys a second, both ends

  r = mimic::test::run_mimic("export --bvh '" + mimic::test::clip_path("07_01") + "' --seconds 2 --lod 3 --out '" +
                             clip + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  j = glb_json(clip);
  ASSERT_TRUE(j.contains("animations"));
  const auto& clip_input = j["accessors"][j["animations"][0]["samplers"][0]["input"].get<size_t>()];
  EXPECT_NEAR(clip_input["max"][0].get<double>(), 2.0, 1e-6);
  std::filesystem::remove_all(dir);
}

TEST(ExportCli, ARecordedSessionBecomesAnAnimation) {
  const auto dir = std::filesystem::temp_directory_path() / ("mimic-export-log-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string log = (dir / "walk.mlog").string(), out = (dir / "walk.glb").string();
  auto r = mimic::test::run_mimic("record --source 'sim:walk?sensors=11' --duration 1.5 --out '" + log + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  // The session's own length, from its samples' times: a busy machine records a little longer.
  const auto cycles = mimic::test::cycle_times(mimic::test::replay_csv(log));
  ASSERT_FALSE(cycles.empty());
  const double session_s = *cycles.rbegin() - *cycles.begin();
  ASSERT_GT(session_s, 1.4);
  r = mimic::test::run_mimic("export --log '" + log + "' --fps 20 --lod 3 --body preset:tall --out '" + out + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("samples solved"), std::string::npos) << r.output;
  const auto j = glb_json(out);
  ASSERT_TRUE(j.contains("skins"));
  EXPECT_EQ(j["skins"][0]["joints"].size(), 23u);
  ASSERT_EQ(j["animations"].size(), 1u);
  const auto& input = j["accessors"][j["animations"][0]["samplers"][0]["input"].get<size_t>()];
  EXPECT_NEAR(input["max"][0].get<double>(), session_s, 0.06);  // the session's length, 20 keys a second
  EXPECT_NEAR(input["count"].get<int>(), 1 + session_s * 20, 1.5);
  EXPECT_EQ(mimic::test::run_mimic("export --motion walk --calibration c.json --out /tmp/x.glb").status, 2);
  EXPECT_EQ(mimic::test::run_mimic("export --log '" + log + "' --motion walk --out /tmp/x.glb").status, 2);
  EXPECT_EQ(mimic::test::run_mimic("export --log /nonexistent.mlog --out /tmp/x.glb").status, 1);
  std::filesystem::remove_all(dir);
}

TEST(ExportCli, UsageErrors) {
  EXPECT_EQ(mimic::test::run_mimic("export --out /tmp/x.glb").status, 2);
  EXPECT_EQ(mimic::test::run_mimic("export --motion walk --bvh x.bvh --out /tmp/x.glb").status, 2);
  EXPECT_EQ(mimic::test::run_mimic("export --motion walk").status, 2);
  EXPECT_EQ(mimic::test::run_mimic("export --motion walk --fps 0 --out /tmp/x.glb").status, 2);
  const auto r = mimic::test::run_mimic("export --motion dance --out /tmp/x.glb");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("dance"), std::string::npos) << r.output;
  EXPECT_EQ(mimic::test::run_mimic("export --bvh /nonexistent.bvh --out /tmp/x.glb").status, 1);
}

}  // namespace
