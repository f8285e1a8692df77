// The presets across human variety: each meshes closed, and its height and tape girths move
// the way its scaling operators say.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <string_view>

#include "mimic/avatar/body_presets.h"
#include "mimic/avatar/measure.h"
#include "mimic/avatar/mesh_check.h"
#include "mimic/rig/motion.h"
#include "mimic/avatar/skin.h"

namespace mimic::avatar::body_presets_test {
namespace {

struct Measured {
  BodyMeasurements m;
  bool closed_standing = false, closed_walking = false;
};

Measured measure(const BodyModel& model) {
  Measured out;
  SkinOptions o;
  o.rigid_parts = false;  // the envelope alone is the closed surface
  auto skin = ImplicitSkin::create(model, o);
  EXPECT_TRUE(skin) << skin.error().what();
  const rig::Skeleton& s = skin->skeleton();
  rig::Pose p = s.zero_pose();
  p.root_position_m.y = rig::standing_root_height_m(s);
  skin->evaluate(p);
  out.m = measure_body(skin->mesh(), landmarks_from_skeleton(s, p));
  out.closed_standing = is_closed_oriented_manifold(analyze_topology(skin->mesh()));
  auto walk = rig::make_builtin_motion("walk", s);
  EXPECT_TRUE(walk);
  rig::Pose q = s.zero_pose();
  (*walk)->sample(0.37, q);
  skin->evaluate(q);
  out.closed_walking = is_closed_oriented_manifold(analyze_topology(skin->mesh()));
  return out;
}

const std::map<std::string, Measured>& all() {
  static const std::map<std::string, Measured> m = [] {
    std::map<std::string, Measured> r;
    r["default"] = measure(default_body_model());
    for (const BodyPreset& p : body_presets()) {
      auto body = scale_body(default_body_model(), p.scaling);
      EXPECT_TRUE(body) << p.name;
      r[std::string(p.name)] = measure(*body);
    }
    return r;
  }();
  return m;
}

TEST(BodyPresets, TheFiveAreThereByName) {
  std::vector<std::string> names;
  for (const BodyPreset& p : body_presets()) names.emplace_back(p.name);
  EXPECT_EQ(names, (std::vector<std::string>{"child", "adult_female", "adult_male", "tall", "heavy"}));
  EXPECT_EQ(find_body_preset("heavy")->scaling.frontal_scaling, body_presets()[4].scaling.frontal_scaling);
  EXPECT_EQ(find_body_preset("giant"), nullptr);
}

TEST(BodyPresets, EveryPresetMeshesClosedStandingAndWalking) {
  for (const auto& [name, m] : all()) {
    EXPECT_TRUE(m.closed_standing) << name;
    EXPECT_TRUE(m.closed_walking) << name;
  }
}

TEST(BodyPresets, HeightsFollowTotalHeight) {
  const Measured& d = all().at("default");
  for (const BodyPreset& p : body_presets())
    EXPECT_NEAR(all().at(std::string(p.name)).m.height_m / d.m.height_m, p.scaling.total_height, 0.02) << p.name;
  auto h = [](const char* n) { return all().at(n).m.height_m; };
  EXPECT_LT(h("child"), h("adult_female"));
  EXPECT_LT(h("adult_female"), h("adult_male"));
  EXPECT_LT(h("adult_male"), h("tall"));
}

// A tape girth is a convex perimeter: scaled by s_lateral across and s_frontal front to back, it
// lands between the smaller and the larger of the two ratios. Slack of 5%: the girths are searched
// at fixed fractions of the height, so where spine_origin_ratio moves the pelvis (the child) the
// waist is read a little higher or lower on the torso; and the field blends where regions meet.
// The thigh's widest loop lies at the top of its band, where the leg's boundary-driven rings take
// the hips' shape, and the child's spine_origin_ratio moves that junction against the band: 8%.
TEST(BodyPresets, GirthsMoveBetweenTheirLateralAndFrontalRatios) {
  const Measured& d = all().at("default");
  for (const BodyPreset& p : body_presets()) {
    const BodyScaling& s = p.scaling;
    const float lo = s.total_height * std::min({s.frontal_scaling, s.high_lateral_scaling, s.low_lateral_scaling});
    const float hi = s.total_height * std::max({s.frontal_scaling, s.high_lateral_scaling, s.low_lateral_scaling});
    const BodyMeasurements& m = all().at(std::string(p.name)).m;
    for (auto [ours, base, what] :
         {std::tuple{m.chest_girth_m, d.m.chest_girth_m, "chest"},
          std::tuple{m.waist_girth_m, d.m.waist_girth_m, "waist"}, std::tuple{m.hip_girth_m, d.m.hip_girth_m, "hips"},
          std::tuple{m.thigh_girth_m, d.m.thigh_girth_m, "thigh"}}) {
      ASSERT_TRUE(ours && base) << p.name << " " << what;
      const float r = *ours / *base;
      const float slack = std::string_view(what) == "thigh" ? 0.08f : 0.05f;
      EXPECT_GE(r, lo * (1.0f - slack)) << p.name << " " << what;
      EXPECT_LE(r, hi * (1.0f + slack)) << p.name << " " << what;
    }
  }
}

TEST(BodyPresets, HeavyIsWiderThanTheAdultMaleByItsRatios) {
  const BodyScaling& h = find_body_preset("heavy")->scaling;
  const BodyScaling& a = find_body_preset("adult_male")->scaling;
  const BodyMeasurements& heavy = all().at("heavy").m;
  const BodyMeasurements& male = all().at("adult_male").m;
  const float lo = std::min({h.frontal_scaling / a.frontal_scaling, h.high_lateral_scaling / a.high_lateral_scaling,
                             h.low_lateral_scaling / a.low_lateral_scaling});
  const float hi = std::max({h.frontal_scaling / a.frontal_scaling, h.high_lateral_scaling / a.high_lateral_scaling,
                             h.low_lateral_scaling / a.low_lateral_scaling});
  const float waist = *heavy.waist_girth_m / *male.waist_girth_m;
  EXPECT_GE(waist, lo * 0.97f);
  EXPECT_LE(waist, hi * 1.03f);
  EXPECT_NEAR(heavy.height_m, male.height_m, 0.01f);  // same skeleton height
  EXPECT_GT(heavy.volume_m3, 1.4 * male.volume_m3);
}

TEST(BodyPresets, APresetOrAFileByName) {
  auto tall = load_body_or_preset("preset:tall");
  ASSERT_TRUE(tall) << tall.error().what();
  EXPECT_EQ(tall->name, "tall");
  auto direct = scale_body(default_body_model(), find_body_preset("tall")->scaling);
  ASSERT_TRUE(direct);
  direct->name = "tall";
  EXPECT_EQ(to_json(*tall, false), to_json(*direct, false));
  auto unknown = load_body_or_preset("preset:giant");
  ASSERT_FALSE(unknown);
  EXPECT_NE(unknown.error().message.find("adult_female"), std::string::npos) << unknown.error().message;
  // Anything else is a file path.
  auto missing = load_body_or_preset("/nonexistent/body.json");
  EXPECT_FALSE(missing);
}

}  // namespace
}  // namespace mimic::avatar::body_presets_test
