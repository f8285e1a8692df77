// The wearer's own body: the proportions `mimic calibrate` measures (height, spine origin,
// shoulder and hip width, upper arm, forearm, thigh and shin) turned into the five scaling
// operators of the paper's §5 plus the four limb lengths, applied to a body (the built-in one
// usually). docs/body-model.md, "The wearer's body".
#pragma once

#include "mimic/avatar/body_model.h"
#include "mimic/rig/skeleton.h"

namespace mimic::avatar {

// Heights and lengths of a skeleton standing in its zero posture, metres.
struct SkeletonBuild {
  float height_m = 0;       // floor (as standing_root_height_m puts it) to the top of the head link
  float root_height_m = 0;  // floor to the root (the spine origin)
  rig::Proportions limbs;   // shoulder and hip width, upper arm, forearm, thigh, shin, …
};
SkeletonBuild measure_build(const rig::Skeleton& skeleton);

// The wearer's build against a reference skeleton (the body's own: the calibrated skeleton's
// joints are where the sensors mark the wearer's), as ratios wearer / reference. A stand-still
// does not show where along a limb the elbow and knee bend: upper arm and forearm both take the
// whole arm's ratio, thigh and shin the whole leg's.
struct WearerRatios {
  float height = 1, root_height = 1, shoulder_width = 1, hip_width = 1;
  float upper_arm = 1, forearm = 1, thigh = 1, shin = 1;
};
WearerRatios wearer_ratios(const SkeletonBuild& wearer, const SkeletonBuild& reference);

// The operators that give those ratios: total_height the height's, spine_origin_ratio the root
// height's over it, the lateral scalings the shoulder and hip widths' over it; the frontal
// scaling, which no tracker sees, the mean of the two lateral ones.
BodyScaling scaling_for(const WearerRatios& r);

// `base` scaled by scaling_for(r), then its upper arms, forearms, thighs and shins set to the
// base's lengths times their ratios (primitives follow their links: the part of a centre and a
// semi-axis along the link scale with it). Fails on a ratio that is not finite and positive.
Result<BodyModel> wearer_body(const BodyModel& base, const WearerRatios& r);

}  // namespace mimic::avatar
