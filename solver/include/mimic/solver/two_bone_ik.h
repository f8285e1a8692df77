// Analytic two-bone IK (shoulder–elbow–wrist, hip–knee–ankle), world space, metres.
//
// The end joint is placed on the target when it lies within the chain's reach (given the middle
// joint's bend limits), otherwise at the nearest reachable point along the start→target ray.
// The middle joint lies on the circle of possible positions at the swivel angle that brings it
// closest to `pole_dir` (a direction from the start–target axis; e.g. elbows down, knees
// forward). Never allocates; Run() returns false (outputs untouched) when Validate() fails.
#pragma once

#include <glm/glm.hpp>

namespace mimic::solver {

struct TwoBoneIkJob {
  // [in]
  glm::vec3 start_m{0.0f};                // fixed start joint (shoulder, hip)
  glm::vec3 target_m{0.0f};               // wanted end joint position (wrist, ankle)
  glm::vec3 pole_dir{0.0f, -1.0f, 0.0f};  // where the middle joint should point; any length > 0
  float upper_m = 0;                      // start → middle link length
  float lower_m = 0;                      // middle → end link length
  float min_bend_rad = 0;                 // bend limits of the middle joint, 0 = straight, π = folded
  float max_bend_rad = 3.14159265f;
  // [out]
  glm::vec3 mid_m{0.0f};
  glm::vec3 end_m{0.0f};
  float bend_rad = 0;    // achieved middle bend
  bool reached = false;  // end_m == target_m (within 0.1 mm)

  bool Validate() const;
  bool Run();
};

}  // namespace mimic::solver
