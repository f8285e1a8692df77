// Levels of detail: the contour layout scaled in points per contour and contours per link, for
// the whole body or piece by piece, and the choice of a level from the avatar's size on screen.
#include "mimic/avatar/skin_lod.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>

#include "skin_impl.h"

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

int scaled(int n, float f, int at_least) {
  return std::max(at_least, static_cast<int>(std::lround(static_cast<float>(n) * f)));
}
LodScale scale_of(int lod) { return kScale[std::clamp(lod, 0, kSkinLodCount - 1)]; }

// The torso's rings and the bridges at points factor p (the loops follow from them).
void scale_torso_points(SkinLayout& l, const SkinLayout& base, float p) {
  if (p >= 1.0f) return;
  // Even: the front arc is halved about the front-centre point, and an odd one
  // left the ring lopsided, with no back-centre point (LOD 2's 3 segments put the crotch bridge's
  // end 3.5 cm right of the middle, its point on the right thigh's ring, which folded in every
  // stride of the built-in walk).
  l.chest_front_arc = 2 * scaled(base.chest_front_arc, 0.5f * p, 1);
  l.chest_side_arc = scaled(base.chest_side_arc, p, 2);
  l.torso_points = 2 * (l.chest_front_arc + l.chest_side_arc);
  l.shoulder_bridge = scaled(base.shoulder_bridge, p, 2);
  l.crotch_bridge = scaled(base.crotch_bridge, p, 1);
}

// A limb's own points per contour at `lod`: its loop's count in the whole body at that LOD (so a
// limb at the torso's LOD needs no transition), or the base layout's own count scaled.
int limb_points(const SkinLayout& base, int base_points, int LoopPoints::*limb, int lod) {
  const float p = scale_of(lod).points;
  if (base_points > 0) return p < 1.0f ? scaled(base_points, p, 3) : base_points;
  SkinLayout at = base;
  scale_torso_points(at, base, p);
  return loop_points(at).*limb;
}

}  // namespace

SkinLayout skin_layout_for_lods(const SkinLayout& base, const SkinPieceLods& lods) {
  if (lods == SkinPieceLods{}) return base;
  SkinLayout l = base;
  scale_torso_points(l, base, scale_of(lods.torso).points);
  // Each limb's own points; 0 where they equal its loop's (no transition band).
  const LoopPoints loops = loop_points(l);
  auto own = [&](int base_points, int LoopPoints::*limb, int lod) {
    const int n = limb_points(base, base_points, limb, lod);
    return n == loops.*limb ? 0 : n;
  };
  l.neck_points = own(base.neck_points, &LoopPoints::neck, lods.neck);
  l.arm_points = own(base.arm_points, &LoopPoints::arm, lods.arms);
  l.leg_points = own(base.leg_points, &LoopPoints::leg, lods.legs);
  // Boundary-driven rings belong to every limb and the neck: they follow the finest of them.
  const float k = scale_of(std::min({lods.neck, lods.arms, lods.legs})).contours;
  l.boundary_contours = k < 1.0f ? scaled(base.boundary_contours, k, 1) : base.boundary_contours;
  const int limb_min = l.boundary_contours + 3;
  auto contours = [](int n, float f, int at_least) {
    return f < 1.0f ? scaled(n, f, at_least) : std::max(n, at_least);
  };
  l.lower_torso_contours = contours(base.lower_torso_contours, scale_of(lods.torso).contours, 3);
  l.upper_torso_contours = contours(base.upper_torso_contours, scale_of(lods.torso).contours, 3);
  l.neck_contours = contours(base.neck_contours, scale_of(lods.neck).contours, limb_min);
  l.upper_arm_contours = contours(base.upper_arm_contours, scale_of(lods.arms).contours, limb_min);
  l.lower_arm_contours = contours(base.lower_arm_contours, scale_of(lods.arms).contours, 3);
  l.upper_leg_contours = contours(base.upper_leg_contours, scale_of(lods.legs).contours, limb_min);
  l.lower_leg_contours = contours(base.lower_leg_contours, scale_of(lods.legs).contours, 3);
  const float r = scale_of(lods.rigid).points;
  if (r < 1.0f) {
    l.rigid_rings = scaled(base.rigid_rings, r, 3);
    l.rigid_points = scaled(base.rigid_points, r, 4);
  }
  return l;
}

SkinLayout skin_layout_for_lod(const SkinLayout& base, int lod) {
  return skin_layout_for_lods(base, SkinPieceLods::whole(std::clamp(lod, 0, kSkinLodCount - 1)));
}

BodyModel with_skin_lod(BodyModel model, int lod) {
  model.skin = skin_layout_for_lod(model.skin, lod);
  return model;
}

BodyModel with_skin_lods(BodyModel model, const SkinPieceLods& lods) {
  model.skin = skin_layout_for_lods(model.skin, lods);
  return model;
}

namespace {

constexpr std::array<std::pair<const char*, int SkinPieceLods::*>, 5> kPieces = {{{"torso", &SkinPieceLods::torso},
                                                                                  {"neck", &SkinPieceLods::neck},
                                                                                  {"arms", &SkinPieceLods::arms},
                                                                                  {"legs", &SkinPieceLods::legs},
                                                                                  {"rigid", &SkinPieceLods::rigid}}};

Result<int> parse_level(std::string_view text, std::string_view what) {
  int v = -1;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || v < 0 || v >= kSkinLodCount)
    return fail(Errc::invalid_argument, (what.empty() ? std::string() : std::string(what) + ": ") + "LOD must be 0.." +
                                            std::to_string(kSkinLodCount - 1) + ", not '" + std::string(text) + "'");
  return v;
}

}  // namespace

Result<SkinPieceLods> parse_skin_lods(std::string_view text) {
  if (text.find('=') == std::string_view::npos) {
    auto v = parse_level(text, "");
    if (!v) return tl::unexpected(v.error());
    return SkinPieceLods::whole(*v);
  }
  SkinPieceLods out;
  std::array<bool, kPieces.size()> named{};
  int all = -1;
  while (!text.empty()) {
    const size_t comma = text.find(',');
    const std::string_view item = text.substr(0, comma);
    text = comma == std::string_view::npos ? std::string_view() : text.substr(comma + 1);
    const size_t eq = item.find('=');
    if (eq == std::string_view::npos)
      return fail(Errc::invalid_argument, "LOD item '" + std::string(item) + "' must be PIECE=N");
    const std::string_view key = item.substr(0, eq);
    auto v = parse_level(item.substr(eq + 1), key);
    if (!v) return tl::unexpected(v.error());
    if (key == "all") {
      all = *v;
      continue;
    }
    size_t i = 0;
    while (i < kPieces.size() && key != kPieces[i].first) ++i;
    if (i == kPieces.size())
      return fail(Errc::invalid_argument,
                  "unknown skin piece '" + std::string(key) + "' (torso, neck, arms, legs, rigid, all)");
    if (named[i]) return fail(Errc::invalid_argument, "skin piece '" + std::string(key) + "' named twice");
    named[i] = true;
    out.*kPieces[i].second = *v;
  }
  for (size_t i = 0; i < kPieces.size(); ++i)
    if (!named[i] && all >= 0) out.*kPieces[i].second = all;
  return out;
}

std::string skin_lods_name(const SkinPieceLods& lods) {
  if (lods.uniform()) return std::to_string(lods.torso);
  std::string s;
  for (const auto& [name, member] : kPieces) {
    if (!s.empty()) s += ',';
    s.append(name).append("=").append(std::to_string(lods.*member));
  }
  return s;
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
