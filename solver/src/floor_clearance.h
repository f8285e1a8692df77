// The turn of one angle that lifts a point onto the floor: the toes bending up at the ball
// (body_solver.cpp), the ankle turning a stepped foot toes-up (locomotion.cpp).
#pragma once

namespace mimic::solver::detail {

// `height(angle)` is the point's height with the joint at `angle`. From `now`, the smallest turn
// towards whichever limit raises the point that puts it on `floor_y` or above (10 halvings), or
// that limit when none does; `now` when the point is not below the floor.
template <typename Height>
float turn_to_clear_floor(float now, float min_rad, float max_rad, float floor_y, const Height& height) {
  if (!(height(now) < floor_y)) return now;
  const float raise = height(now + 0.01f) > height(now) ? 1.0f : -1.0f;
  float lo = now, hi = raise > 0 ? max_rad : min_rad;
  if (height(hi) < floor_y) return hi;
  for (int i = 0; i < 10; ++i) {
    const float mid = 0.5f * (lo + hi);
    (height(mid) < floor_y ? lo : hi) = mid;
  }
  return hi;
}

}  // namespace mimic::solver::detail
