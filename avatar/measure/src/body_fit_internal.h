// Shared by the fit's sources (body_fit_skeleton.cpp, body_fit.cpp).
#pragma once

#include "mimic/avatar/body_fit.h"
#include "mimic/avatar/skin.h"

namespace mimic::avatar::fit_detail {

// The skin of `model` evaluated in the reference's posture (pose_to_match).
struct SkinnedLike {
  ImplicitSkin skin;
  rig::Pose pose;
};
Result<SkinnedLike> skin_like(const BodyModel& model, const BodyLandmarks& reference, int subdivision);

}  // namespace mimic::avatar::fit_detail
