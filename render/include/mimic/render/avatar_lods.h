// One avatar at every level of detail the skin offers, for drawing: a skin per LOD built at
// setup with its mesh uploaded to the renderer; a frame evaluates only the LOD in use and
// uploads its new positions. LOD 0 is the finest: 0 = B-spline skin with 2 samples per span,
// 1 = one sample per span, 2 = the paper's realtime mode (contour points are the vertices) —
// the same levels `mimic run` streams to thin clients.
//
// choose_lod() is the one place that maps viewing distance to a level, so a finer LOD table
// (more levels, a realtime contour deformer) plugs in here without touching the viewer.
#pragma once

#include <memory>
#include <vector>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/skin.h"
#include "mimic/core/result.h"
#include "mimic/render/renderer.h"

namespace mimic::render {

inline constexpr int kLodCount = 3;
int lod_subdivision(int lod);  // B-spline samples per span of a LOD

// The level for a body of `height_m` seen at `distance_m` through a vertical field of view of
// `fov_y_rad` on a viewport `viewport_height_px` tall: finer the more pixels the body covers
// (≥ 400 px: 0, ≥ 150 px: 1, else 2), clamped to [0, lod_count).
int choose_lod(float distance_m, float height_m, float fov_y_rad, int viewport_height_px, int lod_count = kLodCount);

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
