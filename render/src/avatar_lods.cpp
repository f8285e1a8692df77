#include "mimic/render/avatar_lods.h"

#include <algorithm>
#include <cmath>

namespace mimic::render {

int choose_lod(float distance_m, float height_m, float fov_y_rad, int viewport_height_px, int current) {
  avatar::LodView view;
  view.viewport_height_px = static_cast<float>(std::max(viewport_height_px, 1));
  view.vertical_fov_rad = fov_y_rad;
  view.body_height_m = height_m;
  return std::clamp(avatar::choose_lod_at_distance(distance_m, current, view), 0, kLodCount - 1);
}

Result<AvatarLods> AvatarLods::create(const avatar::BodyModel& model, const avatar::Skeleton* skeleton,
                                      Renderer& renderer) {
  AvatarLods lods;
  lods.model_ = model;
  for (int lod = 0; lod < kLodCount; ++lod) {
    avatar::SkinOptions options;  // B-spline smoothing, one sample per span
    const avatar::BodyModel at_lod = avatar::with_skin_lod(model, lod);
    auto skin = skeleton ? avatar::BodySkin::create(at_lod, *skeleton, options) : avatar::BodySkin::create(at_lod, options);
    if (!skin) return tl::unexpected(skin.error());
    skin->evaluate(skin->skeleton().rest_pose());
    lods.meshes_.push_back(renderer.add_mesh(skin->mesh()));
    lods.skins_.push_back(std::move(*skin));
  }
  return lods;
}

MeshId AvatarLods::update(int lod, const avatar::Pose& pose, Renderer& renderer) {
  lod = std::clamp(lod, 0, count() - 1);
  skins_[lod].evaluate(pose);
  renderer.update_mesh(meshes_[lod], skins_[lod].mesh());
  return meshes_[lod];
}

}  // namespace mimic::render
