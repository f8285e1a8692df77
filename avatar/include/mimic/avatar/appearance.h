// What the body wears, as a colour per vertex: one skin material over every part (skin pieces
// and the rigid head, hands and feet alike), with a short-sleeved top and shorts (shoes if asked) laid on
// it as regions of the body whose edges blend over a few centimetres. The regions are placed by
// the skeleton's landmarks (waist between the lower and middle spine, hems part way down the
// thigh and the upper arm, a neckline round the neck, shoes up to the ankle), measured on the
// zero posture (the T-pose the body is authored in), so every body and preset dresses alike and
// the colours stay with the skin as it moves. Viewers (render/, the browser page) draw these
// colours instead of one flat colour per part, which left hard steps where parts met.
#pragma once

#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/rig/skeleton.h"

namespace mimic::avatar {

struct Wardrobe {
  glm::vec3 skin{0.88f, 0.67f, 0.55f};  // display RGB, 0..1
  glm::vec3 top{0.28f, 0.47f, 0.64f};
  glm::vec3 shorts{0.23f, 0.25f, 0.31f};
  glm::vec3 shoes{0.20f, 0.17f, 0.15f};
  bool wear_shoes = false;  // the built-in feet are modelled bare, toes and all
  float edge_m = 0.03f;     // width over which a garment's edge blends into what lies next to it
};

// The colour of each vertex of a body mesh, given its positions in the zero posture
// (skeleton.zero_pose(); metres, the skeleton's frame) and the skeleton it was built on.
std::vector<glm::vec3> clothing_albedo(const rig::Skeleton& skeleton, std::span<const glm::vec3> zero_pose_positions_m,
                                       const Wardrobe& wardrobe = {});

}  // namespace mimic::avatar
