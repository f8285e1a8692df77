// Joint-zone sweeps on the built-in body: the baselines show the failures they are known for,
// and the contour methods measure on the same zones.
#include <gtest/gtest.h>

#include <cmath>

#include "mimic/avatar/skin_inspection.h"

namespace mimic::avatar::skin_inspection_test {
namespace {

const std::vector<SweepResult>& results() {
  static const std::vector<SweepResult> r = [] {
    auto out = inspect_joint_zones(default_body_model(), standard_joint_sweeps(default_body_model()));
    EXPECT_TRUE(out) << out.error().what();
    return out ? *out : std::vector<SweepResult>{};
  }();
  return r;
}

const SweepSample& at(const std::string& sweep, const std::string& method, float angle_deg) {
  for (const auto& r : results())
    if (r.sweep.name == sweep)
      for (const auto& m : r.methods)
        if (m.method == method)
          for (const auto& s : m.samples)
            if (std::abs(s.angle_deg - angle_deg) < 0.5f) return s;
  static const SweepSample none{NAN, NAN, NAN};
  ADD_FAILURE() << sweep << " " << method << " " << angle_deg;
  return none;
}

TEST(SkinInspection, SweepsEveryMethodOverTheStandardJoints) {
  ASSERT_EQ(results().size(), 3u);
  for (const auto& r : results()) {
    ASSERT_EQ(r.methods.size(), 5u) << r.sweep.name;
    for (const auto& m : r.methods) {
      ASSERT_EQ(m.samples.size(), r.sweep.angles_deg.size());
      EXPECT_EQ(m.samples[0].volume_change_pct, 0.0);  // the relaxed pose is the reference
      EXPECT_NEAR(m.samples[0].min_section_fraction, 1.0, 1e-12);
      EXPECT_EQ(m.samples[0].stand_off_mm, 0.0);
      for (const auto& s : m.samples) EXPECT_GE(s.stand_off_mm, 0.0) << r.sweep.name << " " << m.method;
    }
  }
  EXPECT_EQ(results()[0].sweep.angles_deg.back(), 150.0f);
}

TEST(SkinInspection, LinearBlendLosesVolumeAtFullFlexionAndCollapsesUnderTwist) {
  for (const char* sweep : {"elbow_flexion", "knee_flexion"}) {
    EXPECT_LT(at(sweep, "lbs", 150).volume_change_pct, -15) << sweep;
    // Volume falls monotonically with flexion for LBS.
    EXPECT_LT(at(sweep, "lbs", 90).volume_change_pct, at(sweep, "lbs", 45 + 5).volume_change_pct) << sweep;
  }
  EXPECT_LT(at("forearm_twist", "lbs", 90).volume_change_pct, -20);
  EXPECT_LT(at("forearm_twist", "lbs", -90).min_section_fraction, 0.6);
  // Dual quaternions and centres of rotation keep the twisted elbow's volume and sections.
  for (const char* m : {"dqs", "cor"}) {
    EXPECT_LT(std::abs(at("forearm_twist", m, 90).volume_change_pct), 3) << m;
    EXPECT_GT(at("forearm_twist", m, -90).min_section_fraction, 0.95) << m;
    EXPECT_GT(at("elbow_flexion", m, 150).volume_change_pct, at("elbow_flexion", "lbs", 150).volume_change_pct) << m;
  }
}

TEST(SkinInspection, TheContourMethodsDoNotCollapseUnderTwist) {
  for (const char* m : {"full", "realtime"})
    for (float a : {-90.0f, 90.0f}) {
      EXPECT_LT(std::abs(at("forearm_twist", m, a).volume_change_pct), 3) << m << " " << a;
      EXPECT_GT(at("forearm_twist", m, a).min_section_fraction, 0.9) << m << " " << a;
    }
}

TEST(SkinInspection, UnknownDofIsAnError) {
  auto sweeps = standard_joint_sweeps(default_body_model());
  sweeps[0].dof = "l_elbow_wiggle";
  auto r = inspect_joint_zones(default_body_model(), sweeps);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("elbow_flexion"), std::string::npos);
}

}  // namespace
}  // namespace mimic::avatar::skin_inspection_test
