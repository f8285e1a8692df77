#include "mimic/render/avatar_lods.h"

#include <algorithm>
#include <cmath>

#include "mimic/avatar/appearance.h"

namespace mimic::render {

int choose_lod(float distance_m, float height_m, float fov_y_rad, int viewport_height_px, int current) {
  avatar::LodView view;
  view.viewport_height_px = static_cast<float>(std::max(viewport_height_px, 1));
  view.vertical_fov_rad = fov_y_rad;
  view.body_height_m = height_m;
  return std::clamp(avatar::choose_lod_at_distance(distance_m, current, view), 0, kLodCount - 1);
}

Result<AvatarLods> AvatarLods::create(const avatar::BodyModel& model, const rig::Skeleton* skeleton, Renderer& renderer,
                                      avatar::SkinMethod method) {
  AvatarLods lods;
  lods.model_ = model;
  lods.method_ = method;
  for (int lod = 0; lod < kLodCount; ++lod) {
    avatar::SkinOptions options;  // B-spline smoothing, one sample per span
    const avatar::BodyModel at_lod = avatar::with_skin_lod(model, lod);
    auto skin = skeleton ? avatar::ImplicitSkin::create(at_lod, *skeleton, options)
                         : avatar::ImplicitSkin::create(at_lod, options);
    if (!skin) return tl::unexpected(skin.error());
    const rig::Skeleton& bones = skin->skeleton();
    // The clothes are laid out on the zero posture, where the skeleton's landmarks are.
    if (method == avatar::SkinMethod::realtime) {
      avatar::RealtimeOptions ro;
      ro.lod = lod;
      auto body = avatar::RealtimeBody::shared(model, bones, ro);
      if (!body) return tl::unexpected(body.error());
      avatar::Mesh mesh = (*body)->rest_mesh();
      mesh.normals.resize(mesh.positions.size());
      lods.realtime_.emplace_back(std::move(*body));
      lods.realtime_.back().evaluate(bones.zero_pose(), mesh.positions, mesh.normals);
      const std::vector<glm::vec3> albedo = avatar::clothing_albedo(bones, mesh.positions);
      lods.realtime_.back().evaluate(bones.rest_pose(), mesh.positions, mesh.normals);
      lods.meshes_.push_back(renderer.add_mesh(mesh, albedo));
      lods.realtime_meshes_.push_back(std::move(mesh));
    } else {
      skin->evaluate(bones.zero_pose());
      const std::vector<glm::vec3> albedo = avatar::clothing_albedo(bones, skin->mesh().positions);
      lods.meshes_.push_back(renderer.add_mesh(skin->mesh(), albedo));
    }
    skin->evaluate(bones.rest_pose());
    lods.skins_.push_back(std::move(*skin));
  }
  return lods;
}

MeshId AvatarLods::update(int lod, const rig::Pose& pose, Renderer& renderer) {
  lod = std::clamp(lod, 0, count() - 1);
  if (method_ == avatar::SkinMethod::realtime) {
    avatar::Mesh& mesh = realtime_meshes_[lod];
    realtime_[lod].evaluate(pose, mesh.positions, mesh.normals);
    renderer.update_mesh(meshes_[lod], mesh);
  } else {
    skins_[lod].evaluate(pose);
    renderer.update_mesh(meshes_[lod], skins_[lod].mesh());
  }
  return meshes_[lod];
}

const avatar::Mesh& AvatarLods::mesh(int lod) const {
  lod = std::clamp(lod, 0, count() - 1);
  return method_ == avatar::SkinMethod::realtime ? realtime_meshes_[lod] : skins_[lod].mesh();
}

const avatar::ImplicitSkin& AvatarLods::overlay_skin(int lod, const rig::Pose& pose) {
  lod = std::clamp(lod, 0, count() - 1);
  if (method_ == avatar::SkinMethod::realtime) skins_[lod].evaluate(pose);
  return skins_[lod];
}

}  // namespace mimic::render
