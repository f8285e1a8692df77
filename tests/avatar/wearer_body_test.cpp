// The wearer's proportions turned into the five operators plus limb lengths: given a preset's
// skeleton as the wearer, the built-in body becomes a body of the preset's heights and lengths.
#include "mimic/avatar/wearer_body.h"

#include <gtest/gtest.h>

#include "mimic/avatar/body_presets.h"
#include "mimic/avatar/mesh_check.h"
#include "mimic/avatar/skin.h"

namespace mimic::avatar::wearer_body_test {
namespace {

SkeletonBuild build_of(const BodyModel& body) { return measure_build(*rig::Skeleton::build(body.skeleton)); }

TEST(WearerBody, APresetsBuildIsReproducedFromItsProportions) {
  const BodyModel base = default_body_model();
  for (const BodyPreset& p : body_presets()) {
    auto wearer = preset_body(p);
    ASSERT_TRUE(wearer);
    const SkeletonBuild want = build_of(*wearer);
    auto body = wearer_body(base, wearer_ratios(want, build_of(base)));
    ASSERT_TRUE(body) << body.error().what();
    const SkeletonBuild got = build_of(*body);
    for (auto [g, w] :
         {std::pair{got.height_m, want.height_m}, std::pair{got.root_height_m, want.root_height_m},
          std::pair{got.limbs.upper_arm_m, want.limbs.upper_arm_m},
          std::pair{got.limbs.forearm_m, want.limbs.forearm_m}, std::pair{got.limbs.thigh_m, want.limbs.thigh_m},
          std::pair{got.limbs.shin_m, want.limbs.shin_m},
          std::pair{got.limbs.shoulder_width_m, want.limbs.shoulder_width_m},
          std::pair{got.limbs.hip_width_m, want.limbs.hip_width_m}})
      EXPECT_NEAR(g / w, 1.0f, 0.01f) << p.name;
    // And it skins closed.
    SkinOptions o;
    o.rigid_parts = false;
    auto skin = ImplicitSkin::create(*body, o);
    ASSERT_TRUE(skin) << p.name;
    skin->evaluate(skin->skeleton().rest_pose());
    EXPECT_TRUE(is_closed_oriented_manifold(analyze_topology(skin->mesh()))) << p.name;
  }
}

TEST(WearerBody, LongerArmsAloneLengthenTheArmsAndTheirMuscles) {
  const BodyModel base = default_body_model();
  WearerRatios r;
  r.upper_arm = 1.1f;
  auto body = wearer_body(base, r);
  ASSERT_TRUE(body);
  EXPECT_NEAR(build_of(*body).limbs.upper_arm_m / build_of(base).limbs.upper_arm_m, 1.1f, 1e-3f);
  EXPECT_NEAR(build_of(*body).height_m, build_of(base).height_m, 1e-4f);
  for (size_t i = 0; i < base.primitives.size(); ++i) {
    if (base.primitives[i].name == "l_humerus") {
      EXPECT_NEAR(body->primitives[i].state.semi_axes_m.x / base.primitives[i].state.semi_axes_m.x, 1.1f, 1e-3f);
    }
  }
  r.shin = -1;
  EXPECT_FALSE(wearer_body(base, r));
}

}  // namespace
}  // namespace mimic::avatar::wearer_body_test
