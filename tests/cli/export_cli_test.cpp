// `mimic export`: a rigged, animated .glb from a built-in motion and from a CMU clip, read back.
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "replay_csv.h"
#include "glb_json.h"
#include "run_mimic.h"
#include "test_data.h"

namespace export_cli_test {

namespace {

using ::mimic::test::glb_json;

// The floats of accessor `index` of a .glb (every component, in order).
std::vector<float> glb_floats(const std::string& path, size_t index) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string b = ss.str();
  uint32_t n = 0;
  std::memcpy(&n, b.data() + 12, 4);
  const auto j = nlohmann::json::parse(b.substr(20, n));
  const size_t bin = 20 + n + 8;
  const auto& a = j["accessors"][index];
  const auto& view = j["bufferViews"][a["bufferView"].get<size_t>()];
  const std::string type = a["type"];
  const size_t comps = type == "SCALAR" ? 1 : type == "VEC3" ? 3 : type == "VEC4" ? 4 : 16;
  std::vector<float> out(a["count"].get<size_t>() * comps);
  std::memcpy(out.data(), b.data() + bin + view.value("byteOffset", size_t(0)) + a.value("byteOffset", size_t(0)),
              out.size() * 4);
  return out;
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
  EXPECT_EQ(input["count"].get<int>(), 67);               // 10 keys a second, both ends

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

TEST(ExportCli, EveryFrameOfAClipIsAKey) {
  // 07_01: 317 frames at the file's 0.0083333 s, so 2.63332 s, not a whole number of 1/120 s:
  // the last frame is a key too.
  const auto dir = std::filesystem::temp_directory_path() / ("mimic-export-keys-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string out = (dir / "clip.glb").string();
  const auto r = mimic::test::run_mimic("export --bvh '" + mimic::test::clip_path("07_01") +
                                        "' --fps 120 --lod 3 --out '" + out + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = glb_json(out);
  const auto& input = j["accessors"][j["animations"][0]["samplers"][0]["input"].get<size_t>()];
  EXPECT_EQ(input["count"].get<int>(), 317);
  EXPECT_NEAR(input["max"][0].get<double>(), 316 * 0.0083333, 1e-5);
  std::filesystem::remove_all(dir);
}

TEST(ExportCli, ARecordedTakeStartsInStep) {
  // The first key of a solved take is as close to the second as later keys are to each other:
  // no joint turns more than 10° and the root moves less than 5 cm between keys 0 and 1 (a
  // take solved from the zero posture in one frame's iterations was 23–52° off).
  const auto dir = std::filesystem::temp_directory_path() / ("mimic-export-first-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string log = (dir / "walk.mlog").string(), out = (dir / "walk.glb").string();
  auto r = mimic::test::run_mimic("record --source 'sim:walk?sensors=11' --duration 1 --out '" + log + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  r = mimic::test::run_mimic("export --log '" + log + "' --fps 30 --lod 3 --out '" + out + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = glb_json(out);
  const auto& anim = j["animations"][0];
  int rotations = 0;
  for (const auto& ch : anim["channels"]) {
    const auto keys = glb_floats(out, anim["samplers"][ch["sampler"].get<size_t>()]["output"].get<size_t>());
    const std::string joint = j["nodes"][ch["target"]["node"].get<size_t>()]["name"];
    if (ch["target"]["path"] == "translation") {
      ASSERT_GE(keys.size(), 6u);
      const double step_m = std::hypot(keys[3] - keys[0], keys[4] - keys[1], keys[5] - keys[2]);
      EXPECT_LT(step_m, 0.05) << "root between keys 0 and 1";
      continue;
    }
    ASSERT_GE(keys.size(), 8u);
    const double dot = std::abs(keys[0] * keys[4] + keys[1] * keys[5] + keys[2] * keys[6] + keys[3] * keys[7]);
    const double step_deg = 2 * std::acos(std::min(1.0, dot)) * 180 / 3.14159265358979;
    EXPECT_LT(step_deg, 10.0) << joint << " between keys 0 and 1";
    ++rotations;
  }
  EXPECT_GT(rotations, 10);
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
  // Out-of-range numbers are usage errors (2), like --fps 0, not failures of the export.
  EXPECT_EQ(mimic::test::run_mimic("export --motion walk --lod 9 --out /tmp/x.glb").status, 2);
  EXPECT_EQ(mimic::test::run_mimic("export --motion walk --lod -1 --out /tmp/x.glb").status, 2);
  EXPECT_EQ(mimic::test::run_mimic("export --motion walk --seconds nan --out /tmp/x.glb").status, 2);
  EXPECT_EQ(mimic::test::run_mimic("export --motion walk --fps nan --out /tmp/x.glb").status, 2);
  const auto missing =
      mimic::test::run_mimic("export --motion walk --lod 3 --fps 5 --out /nonexistent-mimic-dir/x.glb");
  EXPECT_EQ(missing.status, 1);
  EXPECT_NE(missing.output.find("/nonexistent-mimic-dir/x.glb:"), std::string::npos) << missing.output;
  EXPECT_EQ(missing.output.find(".tmp"), std::string::npos) << missing.output;
}

}  // namespace

}  // namespace export_cli_test
