// Levels of detail: the contour layout scaled in points per contour and contours per link, and
// the choice of a level from the avatar's size on screen.
#include "mimic/avatar/skin_lod.h"

#include <algorithm>
#include <cmath>

namespace mimic::avatar {

namespace {

// Points-per-contour and contours-per-link factors of each LOD relative to the body's layout.
struct LodScale {
  float points, contours;
};
constexpr LodScale kScale[kSkinLodCount] = {{1.0f, 1.0f}, {0.55f, 0.6f}, {0.32f, 0.4f}, {0.14f, 0.2f}};
// Screen-height thresholds (pixels) between LOD i and i + 1.
constexpr float kThreshold_px[kSkinLodCount - 1] = {500.0f, 200.0f, 80.0f};
constexpr float kHysteresis = 0.1f;

int scaled(int n, float f, int at_least) { return std::max(at_least, static_cast<int>(std::lround(static_cast<float>(n) * f))); }

}  // namespace

SkinLayout skin_layout_for_lods(const SkinLayout& base, const SkinPieceLods& lods) {
  auto scale = [](int lod) { return kScale[std::clamp(lod, 0, kSkinLodCount - 1)]; };
  SkinLayout l = base;
  const float p = scale(lods.points).points;
  if (p < 1.0f) {
    l.chest_front_arc = scaled(base.chest_front_arc, p, 2);
    l.chest_side_arc = scaled(base.chest_side_arc, p, 2);
    l.torso_points = 2 * (l.chest_front_arc + l.chest_side_arc);
    l.shoulder_bridge = scaled(base.shoulder_bridge, p, 2);
    l.crotch_bridge = scaled(base.crotch_bridge, p, 1);
  }
  // Boundary-driven rings belong to every limb and the neck: they follow the finest of them.
  const float k = scale(std::min({lods.neck, lods.arms, lods.legs})).contours;
  l.boundary_contours = k < 1.0f ? scaled(base.boundary_contours, k, 1) : base.boundary_contours;
  const int limb_min = l.boundary_contours + 3;
  auto contours = [](int n, float f, int at_least) { return f < 1.0f ? scaled(n, f, at_least) : std::max(n, at_least); };
  l.lower_torso_contours = contours(base.lower_torso_contours, scale(lods.torso).contours, 3);
  l.upper_torso_contours = contours(base.upper_torso_contours, scale(lods.torso).contours, 3);
  l.neck_contours = contours(base.neck_contours, scale(lods.neck).contours, limb_min);
  l.upper_arm_contours = contours(base.upper_arm_contours, scale(lods.arms).contours, limb_min);
  l.lower_arm_contours = contours(base.lower_arm_contours, scale(lods.arms).contours, 3);
  l.upper_leg_contours = contours(base.upper_leg_contours, scale(lods.legs).contours, limb_min);
  l.lower_leg_contours = contours(base.lower_leg_contours, scale(lods.legs).contours, 3);
  const float r = scale(lods.rigid).points;
  if (r < 1.0f) {
    l.rigid_rings = scaled(base.rigid_rings, r, 3);
    l.rigid_points = scaled(base.rigid_points, r, 4);
  }
  return l;
}

SkinLayout skin_layout_for_lod(const SkinLayout& base, int lod) {
  lod = std::clamp(lod, 0, kSkinLodCount - 1);
  return skin_layout_for_lods(base, {lod, lod, lod, lod, lod, lod});
}

BodyModel with_skin_lod(BodyModel model, int lod) {
  model.skin = skin_layout_for_lod(model.skin, lod);
  return model;
}

int choose_lod(float projected_height_px, int current) {
  if (!std::isfinite(projected_height_px)) return current >= 0 ? current : kSkinLodCount - 1;
  int lod = kSkinLodCount - 1;
  for (int i = 0; i < kSkinLodCount - 1; ++i)
    if (projected_height_px >= kThreshold_px[i]) {
      lod = i;
      break;
    }
  if (current < 0 || current >= kSkinLodCount || lod == current) return lod;
  // Keep the current level until the size is clearly past the threshold between the two.
  if (lod < current) {  // finer: must exceed the threshold above `current` by the margin
    return projected_height_px >= kThreshold_px[current - 1] * (1.0f + kHysteresis) ? lod : current;
  }
  return projected_height_px < kThreshold_px[current] * (1.0f - kHysteresis) ? lod : current;
}

int choose_lod_at_distance(float distance_m, int current, const LodView& view) {
  if (!(distance_m > 0.0f)) return choose_lod(1e9f, current);
  const float focal_px = 0.5f * view.viewport_height_px / std::tan(0.5f * view.vertical_fov_rad);
  return choose_lod(view.body_height_m * focal_px / distance_m, current);
}

}  // namespace mimic::avatar
