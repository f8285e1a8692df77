// Shared by the fit's sources (body_fit_skeleton.cpp, body_fit_girths.cpp, body_fit.cpp).
#pragma once

#include <array>
#include <optional>

#include "mimic/avatar/body_fit.h"
#include "mimic/avatar/skin.h"

namespace mimic::avatar::fit_detail {

// The skin of `model` evaluated in the reference's posture (pose_to_match).
struct SkinnedLike {
  ImplicitSkin skin;
  rig::Pose pose;
};
Result<SkinnedLike> skin_like(const BodyModel& model, const BodyLandmarks& reference, int subdivision);

// The girths the fit holds to the reference's, as `mimic compare` takes them (measure_body):
// chest, waist, hips, then the left thigh, calf and upper arm, then the right ones (taken on the
// mirror image, so each side of the body is held on its own, as the fit moves it).
constexpr int kGirths = 9;
struct Girths {
  std::array<std::optional<float>, kGirths> value;
  std::array<std::optional<GirthTape>, kGirths> tape;
};
Girths measure_girths(const Mesh& mesh, const BodyLandmarks& landmarks);

// How far a girth lies beyond ±band (relative) of the reference's, as a radius: (G − G_ref)/2π
// less band·G_ref/2π towards zero, metres; 0 within the band.
float girth_excess_m(float girth_m, float reference_m, float band);

// The girths' part of a body's score (metres, added to the mean distances both ways): each
// girth's |excess| counted as `options.girth_weight` of one side's samples. Also the
// largest relative girth error, if `largest` is given.
double girth_penalty_m(const Girths& ours, const Girths& reference, const FitOptions& options,
                       float* largest = nullptr);

}  // namespace mimic::avatar::fit_detail
