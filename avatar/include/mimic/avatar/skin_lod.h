// Levels of detail of the skin (the paper's §4.3): fewer contours per link and fewer points per
// contour, for every piece at once (the torso, bridges, limbs, neck and rigid parts all scale
// together, so the loops where pieces meet stay shared points and no LOD can crack). LOD 0 is
// the body's own layout (about 10,000 triangles for the default body), LOD 3 about 300.
#pragma once

#include "mimic/avatar/body_model.h"

namespace mimic::avatar {

inline constexpr int kSkinLodCount = 4;

// The layout of `base` at `lod` (clamped to 0..kSkinLodCount − 1). Valid whenever base is.
SkinLayout skin_layout_for_lod(const SkinLayout& base, int lod);

// Per piece: the contours per link of each piece at its own LOD. Points per contour are one
// LOD for the whole envelope (the torso's rings, the bridges and every limb share the points of
// the loops where they meet, so pieces at different contour LODs still close without a crack).
struct SkinPieceLods {
  int points = 0;  // points per contour (torso, bridges, so every limb's loop)
  int torso = 0, neck = 0, arms = 0, legs = 0;  // contours per link
  int rigid = 0;   // head, hands, feet
};
SkinLayout skin_layout_for_lods(const SkinLayout& base, const SkinPieceLods& lods);
// The model with its skin layout at `lod`.
BodyModel with_skin_lod(BodyModel model, int lod);

// Picks the LOD for the avatar's height on screen, in pixels: thresholds 500, 200 and 80 px
// (LOD 0 above 500 px), with ±10% hysteresis around each so an avatar hovering at a threshold
// does not flip every frame; `current` is the LOD in use (−1: none yet).
int choose_lod(float projected_height_px, int current = -1);

struct LodView {
  float viewport_height_px = 1080.0f;
  float vertical_fov_rad = 1.0471976f;  // 60°
  float body_height_m = 1.7f;
};
// The same from the camera distance (metres), through a pinhole view.
int choose_lod_at_distance(float distance_m, int current = -1, const LodView& view = {});

}  // namespace mimic::avatar
