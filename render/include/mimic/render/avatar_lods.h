// One avatar at every level of detail of the skin (avatar/skin_lod.h: LOD 0 the body's own
// layout, each next one fewer contours and fewer points per contour, down to a few hundred
// triangles), for drawing: a skin per LOD built at setup with its mesh uploaded to the
// renderer; a frame evaluates only the LOD in use and uploads its new positions. The skins are
// the full method (ray-cast contours, B-spline smoothing), so the method's overlays (contours,
// rays, primitives) can be drawn at any LOD.
//
// choose_lod() maps viewing distance to a level (the avatar library's rule, with hysteresis),
// the one place a viewer asks.
#pragma once

#include <memory>
#include <vector>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/skin.h"
#include "mimic/avatar/skin_lod.h"
#include "mimic/core/result.h"
#include "mimic/render/renderer.h"

namespace mimic::render {

inline constexpr int kLodCount = avatar::kSkinLodCount;

// The level for a body of `height_m` seen at `distance_m` through a vertical field of view of
// `fov_y_rad` on a viewport `viewport_height_px` tall, given the level in use (`current`, −1:
// none yet): finer the more pixels the body covers, with hysteresis so it does not flicker.
int choose_lod(float distance_m, float height_m, float fov_y_rad, int viewport_height_px, int current = -1);

class AvatarLods {
 public:
  // Skins for `model` (on `skeleton`, e.g. a fitted one, or the model's own when null); each
  // LOD's mesh goes to `renderer`. Fails when the model does not build a skin.
  static Result<AvatarLods> create(const avatar::BodyModel& model, const avatar::Skeleton* skeleton,
                                   Renderer& renderer);
  int count() const { return static_cast<int>(skins_.size()); }
  // Deforms LOD `lod` to `pose` and uploads it; returns that LOD's mesh.
  MeshId update(int lod, const avatar::Pose& pose, Renderer& renderer);
  const avatar::BodySkin& skin(int lod) const { return skins_[lod]; }
  const avatar::Skeleton& skeleton() const { return skins_[0].skeleton(); }
  const avatar::BodyModel& model() const { return model_; }
  size_t triangle_count(int lod) const { return skins_[lod].mesh().triangle_count(); }

 private:
  avatar::BodyModel model_;
  std::vector<avatar::BodySkin> skins_;
  std::vector<MeshId> meshes_;
};

}  // namespace mimic::render
