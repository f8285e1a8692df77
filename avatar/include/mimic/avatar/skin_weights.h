// Skinning weights derived from the contours: for every vertex of a skin in the realtime
// resolution (contour points are the vertices), up to four (joint, weight) influences.
//
// A star ring's weight follows its position along its chain of links: a ring well inside a link
// moves with that link's joint alone; rings within kBlendHalfWidth of a joint (in units of the
// link length) blend the two links linearly, 50/50 at the joint's bisector ring. A boundary-
// driven ring P = S + α(G − S) takes (1 − α)·S's weights + α·G's (the loop on the torso), a
// bridge point blends its two ends on the torso and, over a shoulder, the clavicle. Caps take
// their ring's weights; the rigid head, hands and feet their joint's alone.
//
// These are what linear blend, dual quaternion and centre-of-rotation skinning baselines bind
// the realtime rest mesh with (the same vertices, in the same order, as ImplicitSkin::mesh()), and
// what a skinned glTF export carries.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "mimic/core/result.h"

namespace mimic::avatar {

class ContourLayout;
class ImplicitSkin;

struct JointInfluences {
  static constexpr int kMax = 4;
  std::array<uint16_t, kMax> joint{};  // skeleton joint indices (the layout's skeleton)
  std::array<float, kMax> weight{};    // descending, summing to 1; unused slots hold 0
};

// Half-width of the blend around a joint, as a fraction of each link's length.
inline constexpr float kBlendHalfWidth = 0.3f;

// One entry per vertex of the layout's mesh, in order. Fails unless its vertices are its contour
// points (subdivision 0, which the realtime method always uses).
Result<std::vector<JointInfluences>> contour_skin_weights(const ContourLayout& layout);
// The same for skin.layout().
Result<std::vector<JointInfluences>> contour_skin_weights(const ImplicitSkin& skin);

}  // namespace mimic::avatar
