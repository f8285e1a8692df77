// `mimic export --vrm`: a VRM 1.0 avatar, read back as JSON and loaded by third-party readers
// (three.js with @pixiv/three-vrm, the Khronos glTF validator) when npm can provide them.
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include "node_tools.h"
#include "glb_json.h"
#include "run_mimic.h"

namespace vrm_export_test {

namespace {

using ::mimic::test::glb_json;

// The JSON line a gltf_check.mjs run printed (three.js may warn on lines before it).
nlohmann::json check_json(const std::string& output) {
  std::istringstream in(output);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty() && line[0] == '{') last = line;
  return last.empty() ? nlohmann::json() : nlohmann::json::parse(last, nullptr, false);
}

struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& tag)
      : path(std::filesystem::temp_directory_path() / ("mimic-" + tag + "-" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(path);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};

const char* kRequired[] = {"hips",         "spine",         "head",          "leftUpperLeg",  "leftLowerLeg",
                           "leftFoot",     "rightUpperLeg", "rightLowerLeg", "rightFoot",     "leftUpperArm",
                           "leftLowerArm", "leftHand",      "rightUpperArm", "rightLowerArm", "rightHand"};

TEST(VrmExport, TheBodyIsAVrm1Avatar) {
  const TempDir dir("vrm");
  const std::string out = dir / "body.vrm";
  const auto r = mimic::test::run_mimic("export --vrm '" + out + "' --lod 3 --author 'A. Tester'");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("VRM 1.0"), std::string::npos) << r.output;
  const auto j = glb_json(out);
  ASSERT_TRUE(j.contains("extensions")) << r.output;
  EXPECT_EQ(j["extensionsUsed"], nlohmann::json::array({"VRMC_vrm"}));
  const auto& vrm = j["extensions"]["VRMC_vrm"];
  EXPECT_EQ(vrm["specVersion"], "1.0");
  const auto& meta = vrm["meta"];
  EXPECT_FALSE(meta["name"].get<std::string>().empty());
  EXPECT_EQ(meta["authors"], nlohmann::json::array({"A. Tester"}));
  EXPECT_EQ(meta["licenseUrl"], "https://vrm.dev/licenses/1.0/");
  for (const char* field : {"avatarPermission", "commercialUsage", "creditNotation", "modification",
                            "allowRedistribution", "allowExcessivelyViolentUsage", "allowExcessivelySexualUsage",
                            "allowPoliticalOrReligiousUsage", "allowAntisocialOrHateUsage"})
    EXPECT_TRUE(meta.contains(field)) << field;

  // Every required bone, and every bone the skeleton has (22 of its 23 joints: neck_upper is a
  // plain node between neck and head), each on the joint node of that name.
  const auto& bones = vrm["humanoid"]["humanBones"];
  for (const char* b : kRequired) EXPECT_TRUE(bones.contains(b)) << b;
  EXPECT_EQ(bones.size(), 22u);
  const std::map<std::string, std::string> expect = {{"hips", "pelvis"},
                                                     {"spine", "spine_lower"},
                                                     {"chest", "spine_mid"},
                                                     {"upperChest", "spine_upper"},
                                                     {"neck", "neck"},
                                                     {"head", "head"},
                                                     {"leftUpperArm", "l_shoulder"},
                                                     {"rightHand", "r_wrist"},
                                                     {"leftUpperLeg", "l_hip"},
                                                     {"rightLowerLeg", "r_knee"},
                                                     {"leftFoot", "l_ankle"},
                                                     {"rightToes", "r_toes"}};
  for (const auto& [bone, joint] : expect)
    EXPECT_EQ(j["nodes"][bones[bone]["node"].get<size_t>()]["name"], joint) << bone;

  // One skinned mesh with a material per primitive, no animation, T-pose nodes (no rotation),
  // standing on the floor.
  ASSERT_EQ(j["meshes"].size(), 1u);
  EXPECT_EQ(j["skins"].size(), 1u);
  EXPECT_FALSE(j.contains("animations"));
  EXPECT_EQ(j["materials"].size(), j["meshes"][0]["primitives"].size());
  for (const auto& n : j["nodes"]) {
    if (n.contains("rotation")) {
      EXPECT_EQ(n["rotation"], nlohmann::json::array({0.0, 0.0, 0.0, 1.0})) << n["name"];
    }
  }
  const auto& position = j["accessors"][j["meshes"][0]["primitives"][0]["attributes"]["POSITION"].get<size_t>()];
  EXPECT_NEAR(position["min"][1].get<double>(), 0.0, 1e-6);
  EXPECT_GT(position["max"][1].get<double>(), 1.5);

  EXPECT_EQ(mimic::test::run_mimic("export --author X --out '" + (dir / "x.glb") + "' --motion walk").status, 2);
  EXPECT_EQ(mimic::test::run_mimic("export --lod 3").status, 2);
}

// three-vrm (what three.js VRM apps use) finds the humanoid where the body is; the validator
// finds no error in the VRM nor in the animated glTFs (a motion, a recorded take).
TEST(VrmExport, ThreeVrmLoadsItAndTheValidatorFindsNoError) {
  const auto tools = mimic::test::node_tools();
  if (tools.modules.empty()) GTEST_SKIP() << tools.why_not;
  const TempDir dir("vrm-readers");
  const std::string vrm = dir / "body.vrm", walk = dir / "walk.glb", log = dir / "walk.mlog", take = dir / "take.glb";
  auto r = mimic::test::run_mimic("export --vrm '" + vrm + "' --motion walk --fps 10 --lod 2 --out '" + walk + "'");
  ASSERT_EQ(r.status, 0) << r.output;

  r = mimic::test::gltf_check(tools, "vrm", vrm);
  ASSERT_EQ(r.status, 0) << r.output;
  const auto loaded = check_json(r.output);
  ASSERT_TRUE(loaded.is_object()) << r.output;
  ASSERT_EQ(loaded["vrm"], true) << r.output;
  EXPECT_EQ(loaded["metaVersion"], "1");
  EXPECT_EQ(loaded["licenseUrl"], "https://vrm.dev/licenses/1.0/");
  const auto& bones = loaded["bones"];
  for (const char* b : kRequired) EXPECT_TRUE(bones.contains(b)) << b << ": " << r.output;
  EXPECT_EQ(bones.size(), 22u) << r.output;
  // World positions as three-vrm sees them: a standing body facing +Z, its left at +X.
  const auto y = [&](const char* b) { return bones[b]["world"][1].get<double>(); };
  const auto x = [&](const char* b) { return bones[b]["world"][0].get<double>(); };
  EXPECT_GT(y("hips"), 0.8);
  EXPECT_LT(y("hips"), 1.2);
  EXPECT_GT(y("head"), y("neck"));
  EXPECT_GT(y("neck"), y("hips"));
  EXPECT_LT(y("leftFoot"), 0.15);
  EXPECT_GT(x("leftHand"), 0.5);
  EXPECT_LT(x("rightHand"), -0.5);
  EXPECT_GE(loaded["skinnedMeshes"].get<int>(), 1);
  EXPECT_GT(loaded["vertices"].get<int>(), 100);

  r = mimic::test::run_mimic("record --source 'sim:walk?sensors=11' --duration 1 --out '" + log + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  r = mimic::test::run_mimic("export --log '" + log + "' --fps 30 --lod 3 --out '" + take + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const std::string& file : {vrm, walk, take}) {
    r = mimic::test::gltf_check(tools, "validate", file);
    ASSERT_EQ(r.status, 0) << r.output;
    const auto report = check_json(r.output);
    ASSERT_TRUE(report.is_object()) << r.output;
    EXPECT_EQ(report["errors"], 0) << file << ": " << r.output;
    // The validator does not know VRMC_vrm: an unsupported extension is its only remark.
    for (const auto& m : report["messages"])
      EXPECT_NE(m.get<std::string>().find("UNSUPPORTED_EXTENSION"), std::string::npos) << file << ": " << m;
  }
}

}  // namespace

}  // namespace vrm_export_test
