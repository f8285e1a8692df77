// One avatar at every level of detail of the skin (avatar/skin_lod.h: LOD 0 the body's own
// layout, each next one fewer contours and fewer points per contour, down to a few hundred
// triangles), for drawing: a skin per LOD built at setup with its mesh uploaded to the
// renderer; a frame evaluates only the LOD in use and uploads its new positions. The drawn skin
// is the full method (ray-cast contours, B-spline smoothing) or the realtime one (contours
// measured once and moved, avatar/realtime_skin.h); the method's overlays (contours, rays,
// primitives) always come from the full method's skin at that LOD, evaluated when asked.
//
// choose_lod() maps viewing distance to a level (the avatar library's rule, with hysteresis),
// the one place a viewer asks.
#pragma once

#include <memory>
#include <vector>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/realtime_skin.h"
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
  static Result<AvatarLods> create(const avatar::BodyModel& model, const rig::Skeleton* skeleton, Renderer& renderer,
                                   avatar::SkinMethod method = avatar::SkinMethod::full);
  int count() const { return static_cast<int>(skins_.size()); }
  avatar::SkinMethod method() const { return method_; }
  // Deforms LOD `lod` to `pose` by the method and uploads it; returns that LOD's mesh.
  MeshId update(int lod, const rig::Pose& pose, Renderer& renderer);
  // The drawn mesh of LOD `lod` as last updated.
  const avatar::Mesh& mesh(int lod) const;
  // The full method's skin of LOD `lod` at `pose`, for the overlays (with the realtime method it
  // is evaluated here, a ray-cast frame: only when overlays are drawn).
  const avatar::ImplicitSkin& overlay_skin(int lod, const rig::Pose& pose);
  const rig::Skeleton& skeleton() const { return skins_[0].skeleton(); }
  const avatar::BodyModel& model() const { return model_; }
  size_t triangle_count(int lod) const { return mesh(lod).triangle_count(); }

 private:
  avatar::BodyModel model_;
  avatar::SkinMethod method_ = avatar::SkinMethod::full;
  std::vector<avatar::ImplicitSkin> skins_;
  std::vector<avatar::RealtimeSkin> realtime_;  // realtime method: one per LOD
  std::vector<avatar::Mesh> realtime_meshes_;
  std::vector<MeshId> meshes_;
};

}  // namespace mimic::render
