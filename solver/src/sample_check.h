// Internal to the solver: whether a sensor sample's values can be used at all (finite position,
// a finite orientation not near zero length). Validity flags are the caller's to check.
#pragma once

#include <glm/glm.hpp>

#include "mimic/core/finite.h"
#include "mimic/devices/sample.h"

namespace mimic::solver::detail {

inline bool finite_sample(const devices::SensorSample& s) noexcept {
  return all_finite(s.position_m) && all_finite(s.orientation) && glm::dot(s.orientation, s.orientation) > 0.25f;
}

}  // namespace mimic::solver::detail
