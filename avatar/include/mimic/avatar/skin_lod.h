// Levels of detail of the skin (the paper's §4.3): fewer contours per link and fewer points per
// contour, for the whole body or piece by piece. LOD 0 is the body's own layout (about 14,600
// triangles for the default body, a third of them the head, hands and feet), LOD 3 about 700.
//
// Per piece: the torso's LOD sets its rings and the bridges, so the loops where the limbs begin;
// each limb (neck, arms, legs) takes its own contours per link and points per contour. A limb
// whose points differ from its loop's keeps the loop's count through its boundary-driven rings
// and its first ray-cast ring (the transition band, at the junction's resolution), then a zipper
// strip joins that ring to the limb's own: every combination is one closed envelope whose
// pieces share their boundary points, with no crack and no T-junction.
#pragma once

#include <string>
#include <string_view>

#include "mimic/avatar/body_model.h"

namespace mimic::avatar {

inline constexpr int kSkinLodCount = 4;

// The LOD of each piece, 0 (finest) .. kSkinLodCount − 1.
struct SkinPieceLods {
  int torso = 0;                     // torso rings and bridges: their points per contour make the limbs' loops
  int neck = 0, arms = 0, legs = 0;  // each limb's contours per link and points per contour
  int rigid = 0;                     // head, hands, feet

  static constexpr SkinPieceLods whole(int lod) { return {lod, lod, lod, lod, lod}; }
  bool uniform() const { return neck == torso && arms == torso && legs == torso && rigid == torso; }
  bool operator==(const SkinPieceLods&) const = default;
};

// The layout of `base` at `lod` (clamped to 0..kSkinLodCount − 1). Valid whenever base is.
SkinLayout skin_layout_for_lod(const SkinLayout& base, int lod);
// The layout with each piece at its own LOD (each clamped); all 0 returns `base` itself.
SkinLayout skin_layout_for_lods(const SkinLayout& base, const SkinPieceLods& lods);
// The model with its skin layout at `lod`, or with each piece at its own.
BodyModel with_skin_lod(BodyModel model, int lod);
BodyModel with_skin_lods(BodyModel model, const SkinPieceLods& lods);

// "2" (the whole body) or "torso=0,neck=1,arms=2,legs=1,rigid=0" (pieces not named take `all=N`
// when given, else 0); what `mimic mesh --lod` takes. Errors name the bad item.
Result<SkinPieceLods> parse_skin_lods(std::string_view text);
// The same form back: "2" when uniform, else every piece named.
std::string skin_lods_name(const SkinPieceLods& lods);

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
