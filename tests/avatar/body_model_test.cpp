#include <gtest/gtest.h>

#include <filesystem>

#include "mimic/avatar/body_model.h"
#include "mimic/core/file.h"

#include <nlohmann/json.hpp>

namespace mimic::avatar::body_model_test {
namespace {

TEST(BodyModel, DefaultIsValidAndRich) {
  const BodyModel m = default_body_model();
  ASSERT_TRUE(validate(m)) << validate(m).error().what();
  EXPECT_GE(m.primitives.size(), 60u);
  // Visibly deforming muscles, named as a user would look for them.
  for (const char* muscle : {"l_biceps", "r_triceps", "l_forearm_muscles", "r_quadriceps", "l_calf", "r_deltoid",
                             "l_pectoral", "r_gluteal", "l_hamstring"}) {
    auto it =
        std::find_if(m.primitives.begin(), m.primitives.end(), [&](const Primitive& p) { return p.name == muscle; });
    ASSERT_NE(it, m.primitives.end()) << muscle;
    EXPECT_TRUE(it->deformation.has_value()) << muscle;
  }
  int hard = 0;
  for (const auto& p : m.primitives) hard += p.kind == PrimitiveKind::ellipsoid;
  EXPECT_GT(hard, 0);
}

TEST(BodyModel, JsonRoundTripsExactly) {
  const BodyModel m = default_body_model();
  const std::string text = to_json(m);
  auto back = body_model_from_json(text, "default.json");
  ASSERT_TRUE(back) << back.error().what();
  EXPECT_EQ(to_json(*back), text);
  EXPECT_EQ(back->primitives.size(), m.primitives.size());
  // Compact enough to send once per avatar over the network.
  EXPECT_LT(to_json(m, false).size(), 80u * 1024u);
}

TEST(BodyModel, MirroredTwinsAreWrittenOnceAndComeBackInPlace) {
  const BodyModel m = default_body_model();
  const std::string text = to_json(m, false);
  EXPECT_EQ(text.find("\"r_biceps\""), std::string::npos) << "written once, as the left twin";
  EXPECT_NE(text.find("\"mirror\":true"), std::string::npos);
  auto back = body_model_from_json(text);
  ASSERT_TRUE(back) << back.error().what();
  // Joints (and so DOF indices, which pose frames rely on) keep their order.
  auto a = rig::Skeleton::build(m.skeleton), b = rig::Skeleton::build(back->skeleton);
  ASSERT_TRUE(a && b);
  ASSERT_EQ(a->dof_count(), b->dof_count());
  for (int i = 0; i < a->dof_count(); ++i) {
    EXPECT_EQ(a->dof(i).name, b->dof(i).name);
    EXPECT_EQ(a->dof(i).axis, b->dof(i).axis);
  }
  auto r = std::find_if(back->primitives.begin(), back->primitives.end(),
                        [](const Primitive& p) { return p.name == "r_biceps"; });
  ASSERT_NE(r, back->primitives.end());
  EXPECT_LT(r->state.center_m.x, 0.0f) << "the twin is on the right (-x)";
  EXPECT_TRUE(r->deformation && r->deformation->dof == "r_elbow_flexion");
  EXPECT_EQ(back->primitives.size(), m.primitives.size());
}

TEST(BodyModel, SaveAndLoadThroughAFile) {
  const auto path = (std::filesystem::temp_directory_path() / "mimic_body_test.json").string();
  ASSERT_TRUE(save_body_model(default_body_model(), path));
  auto m = load_body_model(path);
  ASSERT_TRUE(m) << m.error().what();
  EXPECT_EQ(m->name, "mimic-default");
  std::filesystem::remove(path);
}

struct Bad {
  const char* what;
  std::string text;
  const char* expect;  // substring of the error
};

// The default body as JSON with one change applied.
template <class F>
std::string edited(F change) {
  nlohmann::json j = nlohmann::json::parse(to_json(default_body_model()));
  change(j);
  return j.dump(1);
}

TEST(BodyModel, MalformedFilesAreRejectedWithAClearMessage) {
  using J = nlohmann::json;
  const std::vector<Bad> cases = {
      {"not json", "{\"format\": \"mimic-body\",\n  \"version\": 1,\n  oops }", "body.json:3: invalid JSON"},
      {"empty", "", "invalid JSON"},
      // Well-formed JSON whose number no double holds: nlohmann throws out_of_range, not parse_error.
      {"number overflow", "{\"format\": \"mimic-body\", \"version\": 666666660000000000e0676926}", "invalid JSON"},
      {"truncated", to_json(default_body_model()).substr(0, 5000), "invalid JSON"},
      {"wrong format", edited([](J& j) { j["format"] = "something"; }), "$.format"},
      {"future version", edited([](J& j) { j["version"] = 99; }), "unsupported version 99"},
      {"unknown group", edited([](J& j) { j["primitives"][0]["groups"][0] = "tail"; }), "unknown group \"tail\""},
      {"unknown joint", edited([](J& j) { j["primitives"][1]["joint"] = "tail"; }), "unknown joint 'tail'"},
      {"negative axis", edited([](J& j) { j["primitives"][2]["state"]["semi_axes"][0] = -0.1; }), "semi-axes"},
      {"axes not numbers", edited([](J& j) { j["primitives"][2]["state"]["semi_axes"][1] = "x"; }),
       "$.primitives[2].state.semi_axes[1]: expected a finite number"},
      {"axes not a triple", edited([](J& j) {
         j["primitives"][2]["state"]["semi_axes"] = J::array({1, 2});
       }),
       "expected an array of 3 numbers"},
      {"axis beyond a float", edited([](J& j) { j["primitives"][2]["state"]["semi_axes"][0] = 1e300; }),
       "$.primitives[2].state.semi_axes[0]: expected a finite number"},
      {"torso points beyond an int", edited([](J& j) { j["skin"]["torso_points"] = 1LL << 40; }),
       "integer out of range"},
      {"bad falloff", edited([](J& j) {
         for (auto& p : j["primitives"])
           if (p.contains("deformation")) p["deformation"]["falloff"] = "cubic";
       }),
       "falloff"},
      {"unknown DOF", edited([](J& j) {
         for (auto& p : j["primitives"])
           if (p.contains("deformation")) p["deformation"]["dof"] = "l_tail_wag";
       }),
       "unknown DOF 'l_tail_wag'"},
      {"inconsistent skin", edited([](J& j) { j["skin"]["torso_points"] = 30; }), "torso_points"},
      {"missing primitives", edited([](J& j) { j.erase("primitives"); }), "missing \"primitives\""},
      {"bad influence", edited([](J& j) { j["primitives"][0]["influence"] = 0.5; }), "influence"},
      {"skeleton cycle", edited([](J& j) { j["skeleton"]["joints"][0]["parent"] = "head"; }), "skeleton"},
      {"wrong type", edited([](J& j) { j["primitives"] = 3; }), "$.primitives: expected an array"},
      {"mirror of a centre primitive", edited([](J& j) { j["primitives"][0]["mirror"] = true; }), "only a left-side"},
      {"mirror and explicit twin", edited([](J& j) {
         for (auto& p : j["primitives"])
           if (p.value("mirror", false)) {
             J twin = p;
             twin.erase("mirror");
             twin["name"] = "r_" + p["name"].get<std::string>().substr(2);
             j["primitives"].push_back(twin);
             break;
           }
       }),
       "duplicate name"},
  };
  for (const Bad& b : cases) {
    auto r = body_model_from_json(b.text, "body.json");
    ASSERT_FALSE(r) << b.what;
    EXPECT_NE(r.error().message.find(b.expect), std::string::npos) << b.what << ": " << r.error().message;
    EXPECT_NE(r.error().message.find("body.json"), std::string::npos) << b.what << ": names the file";
  }
}

TEST(BodyModel, MissingFileIsAnIoError) {
  auto r = load_body_model("/nonexistent/body.json");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, Errc::io_error);
}

}  // namespace
}  // namespace mimic::avatar::body_model_test
