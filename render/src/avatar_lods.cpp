#include "mimic/render/avatar_lods.h"

#include <algorithm>
#include <cmath>

namespace mimic::render {

int lod_subdivision(int lod) {
  static constexpr int kSubdivision[kLodCount] = {2, 1, 0};
  return kSubdivision[std::clamp(lod, 0, kLodCount - 1)];
}

int choose_lod(float distance_m, float height_m, float fov_y_rad, int viewport_height_px, int lod_count) {
  const float view_height_m = 2.0f * std::max(distance_m, 1e-3f) * std::tan(0.5f * fov_y_rad);
  const float body_px = height_m / view_height_m * static_cast<float>(viewport_height_px);
  const int lod = body_px >= 400.0f ? 0 : body_px >= 150.0f ? 1 : 2;
  return std::clamp(lod, 0, std::max(lod_count - 1, 0));
}

Result<AvatarLods> AvatarLods::create(const avatar::BodyModel& model, const avatar::Skeleton* skeleton,
                                      Renderer& renderer) {
  AvatarLods lods;
  lods.model_ = model;
  for (int lod = 0; lod < kLodCount; ++lod) {
    avatar::SkinOptions options;
    options.subdivision = lod_subdivision(lod);
    auto skin = skeleton ? avatar::BodySkin::create(model, *skeleton, options) : avatar::BodySkin::create(model, options);
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
