// Folds (pairs of intersecting triangles inside one skin piece) of the full method's skin
// (every ring ray-cast each frame), exactly (CGAL), on sampled frames of the shared clips. Not
// yet fold-free: the thighs and upper arms fold in the band between the torso's loop and the
// limb's first ring S (docs/skin.md, "Folds in the junction bands"). These bounds hold what the
// limb's leaning first ring planes and the driven rays' closing
// search windows have reached; the full sweep is `mimic intersect --method full`.
#include <gtest/gtest.h>

#include <cstdio>

#include "mimic/avatar/self_intersection.h"
#include "mimic/avatar/skin.h"
#include "mimic/avatar/skin_lod.h"
#include "shared_clip_poses.h"

namespace mimic::avatar::full_junction_folds_test {
namespace {

using Folds = ::mimic::test::FrameTally;

// Every `every`-th frame of every shared clip (each clip's opening T-pose included), the full
// method at the realtime method's resolution (subdivision 0, as `mimic intersect` checks it).
Folds clip_folds(int lod, size_t every) {
  Folds folds;
  const BodyModel model = with_skin_lod(default_body_model(), lod);
  auto skin = ImplicitSkin::create(model, SkinOptions{.subdivision = 0, .rigid_parts = true, .normals = false});
  EXPECT_TRUE(skin) << skin.error().what();
  if (!skin) return folds;
  auto checker = SelfIntersectionChecker::create(skin->mesh());
  EXPECT_TRUE(checker) << checker.error().what();
  if (!checker) return folds;
  ::mimic::test::for_each_shared_clip_pose(skin->skeleton(), every, [&](const rig::Pose& pose) {
    skin->evaluate(pose);
    folds.add(checker->check(skin->mesh().positions).fold_pairs);
  });
  return folds;
}

// Mean folds a frame over every 80th frame of the clips, per LOD: 135.5 / 46.4 / 29.3 / 7.8
// before the limbs' first ring planes leaned with the hip's and shoulder's bends and the driven
// rays' windows closed as the root bends and the column is squeezed; 52.9 / 22.1 / 18.3 / 6.2
// now. The bounds sit between.
TEST(FullJunctionFolds, FullMethodFoldsOverTheSharedClipsStayUnderTheirBound) {
  const double bound[kSkinLodCount] = {60.0, 25.0, 22.0, 7.0};
  for (int lod = 0; lod < kSkinLodCount; ++lod) {
    const Folds f = clip_folds(lod, 80);
    std::printf("full LOD %d, %zu clip frames: %.1f folds a frame, at most %zu\n", lod, f.frames, f.mean(), f.worst);
    EXPECT_GT(f.frames, 100u);
    EXPECT_LT(f.mean(), bound[lod]) << "LOD " << lod;
  }
}

}  // namespace
}  // namespace mimic::avatar::full_junction_folds_test
