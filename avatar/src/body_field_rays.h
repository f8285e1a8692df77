// Constants and the metaball term shared by the body field's ray casters (not a public header): body_field.cpp,
// body_field_rays.cpp (one ray at a time) and body_field_lanes.cpp (eight rays in lock-step).
#pragma once

namespace mimic::avatar::field_detail {

inline constexpr int kMaxRayCandidates = 64;  // metaball terms a ray considers, at most
inline constexpr float kMinStep_m = 0.0005f;  // the march's shortest step along a ray

// Field of one metaball term at squared ellipsoidal distance s.
inline float term(float s, float inv_r2, float weight_norm) {
  const float u = 1.0f - s * inv_r2;
  return u > 0.0f ? weight_norm * u * u * u : 0.0f;
}

}  // namespace mimic::avatar::field_detail
