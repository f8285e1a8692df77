// The built-in body is the authored one fitted to the MakeHuman base mesh (body_overrides.h):
// the compiled-in table applies whole, leaves the rigid parts as authored, and puts the body
// within 5 mm of the mesh both ways with its girths within 3 %.
#include "mimic/avatar/body_overrides.h"

#include <gtest/gtest.h>

#include "mimic/avatar/body_fit.h"
#include "mimic/avatar/mesh_io.h"
#include "mimic/avatar/skin.h"
#include "test_data.h"

namespace mimic::avatar::default_body_fit_test {
namespace {

TEST(DefaultBodyFit, TheTableAppliesWholeAndLeavesTheRigidPartsAsAuthored) {
  std::vector<std::string> unmatched;
  const BodyModel authored = authored_body_model();
  auto fitted = apply_body_overrides(authored, default_body_fit_json(), &unmatched);
  ASSERT_TRUE(fitted) << fitted.error().what();
  EXPECT_TRUE(unmatched.empty()) << unmatched.front();
  EXPECT_EQ(to_json(*fitted, false), to_json(default_body_model(), false));
  ASSERT_EQ(fitted->primitives.size(), authored.primitives.size());
  int moved = 0;
  for (size_t i = 0; i < authored.primitives.size(); ++i) {
    const Primitive &a = authored.primitives[i], &f = fitted->primitives[i];
    const bool same = glm::length(a.state.center_m - f.state.center_m) < 1e-7f &&
                      glm::length(a.state.semi_axes_m - f.state.semi_axes_m) < 1e-7f;
    if (a.part != RigidPart::none) EXPECT_TRUE(same) << a.name;
    moved += same ? 0 : 1;
  }
  EXPECT_GT(moved, 40);  // the fit moved most of the soft primitives
}

TEST(DefaultBodyFit, OverridesRoundTrip) {
  const BodyModel authored = authored_body_model(), fitted = default_body_model();
  auto again = apply_body_overrides(authored, body_overrides_json(authored, fitted));
  ASSERT_TRUE(again) << again.error().what();
  const BodyModel& b = *again;
  for (size_t i = 0; i < b.primitives.size(); ++i) {
    EXPECT_LT(glm::length(b.primitives[i].state.center_m - fitted.primitives[i].state.center_m), 1e-4f);
    EXPECT_LT(glm::length(b.primitives[i].state.semi_axes_m - fitted.primitives[i].state.semi_axes_m), 1e-4f);
  }
  std::vector<std::string> unmatched;
  auto bad = apply_body_overrides(authored,
                                  "{\"format\": \"mimic-body-overrides\", \"version\": 1, \"primitives\": "
                                  "[{\"name\": \"l_palm\", \"center\": [0, 0, 0]}, {\"name\": \"nope\"}]}",
                                  &unmatched);
  ASSERT_TRUE(bad);  // a rigid primitive and an unknown one are skipped, named
  EXPECT_EQ(unmatched, (std::vector<std::string>{"l_palm", "nope"}));
  EXPECT_FALSE(apply_body_overrides(authored, "{\"format\": \"other\"}"));
}

TEST(DefaultBodyFit, WithinFiveMillimetresOfTheMakeHumanMeshBothWays) {
  auto mesh = read_mesh(::mimic::test::shared_data("mesh/makehuman_base_body.obj"), 0.1f);
  auto ref = load_makehuman_joints(::mimic::test::shared_data("mesh/makehuman_base_joints.csv"));
  ASSERT_TRUE(mesh && ref);
  auto posed = pose_body_like(default_body_model(), *ref);
  ASSERT_TRUE(posed) << posed.error().what();
  EXPECT_TRUE(posed->closed);
  const SurfaceDistance d = surface_distance(posed->mesh, posed->landmarks, *mesh, *ref);
  // Refitted with the girths held (both sides as mirror images, refined from the table before,
  // docs/fit.md): 3.82 / 3.99 mm with the modelled head, hands and feet (the table before: 3.84 /
  // 4.00; on the mitten-and-egg rigid parts it was 4.52 / 5.06, when the bound was 5.5 mm). The
  // issue's 5 mm leaves a millimetre for the skin's later changes.
  EXPECT_LT(d.body_to_reference.mean_m, 0.005);
  EXPECT_LT(d.reference_to_body.mean_m, 0.005);
  // Girths, as `mimic compare` takes them, within 3 % of the mesh's (fitted: chest −1.0 %, waist
  // −0.3 %, hips −0.3 %, thigh +1.5 %, calf −0.6 %, upper arm +0.7 %; the thigh was +3.4 % before
  // the fit held the girths).
  const BodyMeasurements ours = measure_body(posed->mesh, posed->landmarks), theirs = measure_body(*mesh, *ref);
  for (auto [a, b, what] : {std::tuple{ours.chest_girth_m, theirs.chest_girth_m, "chest"},
                            std::tuple{ours.waist_girth_m, theirs.waist_girth_m, "waist"},
                            std::tuple{ours.hip_girth_m, theirs.hip_girth_m, "hips"},
                            std::tuple{ours.thigh_girth_m, theirs.thigh_girth_m, "thigh"},
                            std::tuple{ours.calf_girth_m, theirs.calf_girth_m, "calf"},
                            std::tuple{ours.upper_arm_girth_m, theirs.upper_arm_girth_m, "upper arm"}}) {
    ASSERT_TRUE(a && b) << what;
    EXPECT_NEAR(*a / *b, 1.0f, 0.03f) << what;
  }
}

}  // namespace
}  // namespace mimic::avatar::default_body_fit_test
