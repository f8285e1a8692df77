// An arm or leg (shoulder–elbow–wrist, hip–knee–ankle) reaching for its end target: the
// analytic two-bone chain for a swivel, turned into DOF values inside the limits, and the search
// for the swivel the limits allow nearest to a hinted one. Part of SolveJob (body_solver.cpp).
#pragma once

#include <array>
#include <limits>
#include <span>

#include "mimic/solver/body_solver.h"

namespace mimic::solver::detail {

inline glm::vec3 perpendicular_part(const glm::vec3& v, const glm::vec3& unit_axis) {
  return v - unit_axis * glm::dot(v, unit_axis);
}

struct ChainInput {
  const rig::Skeleton* s;
  const SolverModel::Chain* ch;
  const rig::RigidTransform* parent_w;
  glm::vec3 start;
  const rig::RigidTransform* end_t;
  std::span<const float> warm;  // current DOF values (warm start of the decompositions)
  glm::vec3 hinge_hint{0.0f};   // which way the hinge should face when over-extension is possible
  const glm::vec3* last_bend = nullptr;
  const glm::quat* upper_rot = nullptr;  // the upper segment's measured orientation, if any
};

// One evaluation of the chain for a given swivel: DOF values (clamped), with how far the limits
// had to cut them.
struct ChainSolution {
  bool ok = false;
  std::array<float, 3> upper{}, end{};
  float bend = 0;
  glm::vec3 bend_world{0.0f};
  float violation = 0;  // radians cut off by the limits, summed
};

// Where the two-bone solution puts the upper segment (world) and how far the middle joint bends,
// before the limits. `turns_with_swivel`: the limb is bent (its bend plane follows the middle
// joint) and not in the over-extension range (where a hint picks the plane): then the same chain
// at another swivel is this one turned about the start→target axis.
struct ChainGeometry {
  bool ok = false;
  bool turns_with_swivel = false;
  glm::quat upper_world{1, 0, 0, 0};
  glm::vec3 bend_world{0.0f};  // unit, where the lower link swings as the bend grows
  float bend = 0;
};

// The chain's geometry with its middle joint towards `pole`.
ChainGeometry chain_geometry(const ChainInput& in, const glm::vec3& pole);

// The chain's DOFs from its geometry (ok false when the geometry is not).
ChainSolution solve_chain(const ChainInput& in, const ChainGeometry& g);

// The chain with its middle joint towards `pole`. `phi` and `give_up_at`: a swivel search's
// candidate stops (not ok) as soon as the violation so far makes its cost reach give_up_at.
ChainSolution solve_chain(const ChainInput& in, const glm::vec3& pole, float phi = 0.0f,
                          float give_up_at = std::numeric_limits<float>::infinity());

// How finely a swivel search looks: samples round the axis, then halving steps about the best
// down to `finest_rad`.
struct SwivelGrid {
  int samples = 16;
  float finest_rad = 0.005f;
};

// The swivel the limits allow nearest to the hinted one (e1; e2 = axis × e1), starting from
// `best`, the chain at the hinted swivel, whose geometry is `hinted` (chain_geometry(in, e1)).
ChainSolution search_swivel(const ChainInput& in, const ChainGeometry& hinted, const glm::vec3& e1, const glm::vec3& e2,
                            ChainSolution best, SwivelGrid grid = {});

}  // namespace mimic::solver::detail
