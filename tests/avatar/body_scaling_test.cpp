#include <gtest/gtest.h>

#include <algorithm>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/mesh_check.h"
#include "mimic/avatar/skin.h"

namespace mimic::avatar::body_scaling_test {
namespace {

struct Figures {
  float height, pelvis, shoulder_width, hip_width;
  double volume;
};

Figures figures(const BodyModel& m) {
  auto skin = ImplicitSkin::create(m);
  EXPECT_TRUE(skin) << skin.error().what();
  const rig::Skeleton& s = skin->skeleton();
  rig::Pose p = s.zero_pose();
  p.root_position_m.y = rig::standing_root_height_m(s);
  skin->evaluate(p);
  float top = 0;
  for (const glm::vec3& v : skin->mesh().positions) top = std::max(top, v.y);
  std::vector<rig::RigidTransform> w(s.joint_count());
  rig::forward_kinematics(s, p, w);
  auto x = [&](const char* j) { return w[s.find_joint(j)].translation.x; };
  return {top, p.root_position_m.y, x("l_shoulder") - x("r_shoulder"), x("l_hip") - x("r_hip"),
          analyze_topology(skin->mesh()).signed_volume};
}

TEST(BodyScaling, IdentityKeepsTheBody) {
  const BodyModel m = default_body_model();
  auto same = scale_body(m, {});
  ASSERT_TRUE(same);
  EXPECT_EQ(to_json(*same), to_json(m));
}

TEST(BodyScaling, TotalHeightScalesUniformly) {
  const Figures a = figures(default_body_model());
  auto tall = scale_body(default_body_model(), BodyScaling{.total_height = 1.1f});
  ASSERT_TRUE(tall);
  const Figures b = figures(*tall);
  EXPECT_NEAR(b.height / a.height, 1.1f, 0.01f);
  EXPECT_NEAR(b.shoulder_width / a.shoulder_width, 1.1f, 1e-3f);
  EXPECT_NEAR(b.volume / a.volume, 1.331, 0.03);
}

TEST(BodyScaling, SpineOriginMovesThePelvisAndKeepsTheHeight) {
  const Figures a = figures(default_body_model());
  auto longer_legs = scale_body(default_body_model(), BodyScaling{.spine_origin_ratio = 1.06f});
  ASSERT_TRUE(longer_legs);
  const Figures b = figures(*longer_legs);
  EXPECT_NEAR(b.pelvis / a.pelvis, 1.06f, 0.01f);
  EXPECT_NEAR(b.height, a.height, 0.01f);
}

TEST(BodyScaling, LateralScalingsActAboveAndBelowTheSpineOrigin) {
  const Figures a = figures(default_body_model());
  auto broad = scale_body(default_body_model(), BodyScaling{.high_lateral_scaling = 1.2f});
  ASSERT_TRUE(broad);
  const Figures b = figures(*broad);
  EXPECT_NEAR(b.shoulder_width / a.shoulder_width, 1.2f, 1e-3f);
  EXPECT_NEAR(b.hip_width, a.hip_width, 1e-5f);
  auto wide_hips = scale_body(default_body_model(), BodyScaling{.low_lateral_scaling = 1.2f});
  ASSERT_TRUE(wide_hips);
  const Figures c = figures(*wide_hips);
  EXPECT_NEAR(c.hip_width / a.hip_width, 1.2f, 1e-3f);
  EXPECT_NEAR(c.shoulder_width, a.shoulder_width, 1e-5f);
  EXPECT_GT(c.volume, a.volume);
}

TEST(BodyScaling, LateralScalingWidensTheArmsWithoutLengtheningThem) {
  // The operators act with the arms at the sides, so a wider body keeps its arm length.
  const BodyModel m = default_body_model();
  auto broad = scale_body(m, BodyScaling{.frontal_scaling = 1.2f, .high_lateral_scaling = 1.3f});
  ASSERT_TRUE(broad);
  auto joint = [](const BodyModel& b, const char* name) {
    for (const auto& j : b.skeleton.joints)
      if (j.name == name) return j;
    return rig::JointDesc{};
  };
  EXPECT_NEAR(glm::length(joint(*broad, "l_elbow").offset_m), glm::length(joint(m, "l_elbow").offset_m), 1e-5f);
  EXPECT_NEAR(glm::length(joint(*broad, "l_wrist").offset_m), glm::length(joint(m, "l_wrist").offset_m), 1e-5f);
  // The upper arm's primitives: the axis along the arm kept, the two across it scaled by the
  // lateral (x once lowered: the arm's z stays z, its y turns to x) and frontal ratios.
  int checked = 0;
  for (size_t i = 0; i < m.primitives.size(); ++i) {
    if (m.primitives[i].joint != "l_shoulder") continue;
    const glm::vec3 a = m.primitives[i].state.semi_axes_m, b = broad->primitives[i].state.semi_axes_m;
    const glm::vec3 ratio = b / a;
    std::vector<float> r{ratio.x, ratio.y, ratio.z};
    std::sort(r.begin(), r.end());
    EXPECT_NEAR(r[0], 1.0f, 1e-5f) << m.primitives[i].name;
    EXPECT_NEAR(r[2], 1.3f, 1e-5f) << m.primitives[i].name;
    ++checked;
  }
  EXPECT_GT(checked, 0);
}

TEST(BodyScaling, StandingPostureLowersTheArms) {
  auto s = rig::Skeleton::build(rig::default_skeleton_desc());
  ASSERT_TRUE(s);
  std::vector<rig::RigidTransform> w(s->joint_count());
  rig::forward_kinematics(*s, standing_posture(*s), w);
  for (const char* side : {"l_", "r_"}) {
    const int shoulder = s->find_joint(std::string(side) + "shoulder"),
              wrist = s->find_joint(std::string(side) + "wrist");
    const glm::vec3 down = glm::normalize(w[wrist].translation - w[shoulder].translation);
    EXPECT_LT(down.y, -0.99f) << side;
  }
  EXPECT_EQ(scaling_tag({0.2f, -0.9f, 0.3f}), 1);
  EXPECT_EQ(scaling_tag({-0.7f, 0.1f, 0.69f}), 0);
  EXPECT_EQ(scaling_tag({0, 0.1f, -0.5f}), 2);
}

TEST(BodyScaling, RejectsNonsense) {
  EXPECT_FALSE(scale_body(default_body_model(), BodyScaling{.total_height = 0.0f}));
  EXPECT_FALSE(scale_body(default_body_model(), BodyScaling{.frontal_scaling = -1.0f}));
  EXPECT_FALSE(scale_body(default_body_model(), BodyScaling{.spine_origin_ratio = 3.0f}));
}

}  // namespace
}  // namespace mimic::avatar::body_scaling_test
