// The deform stage: forward kinematics alone, or the skin (realtime or full method) at a mesh LOD.
#include <memory>
#include <vector>

#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin.h"
#include "mimic/avatar/texture_layout.h"
#include "mimic/service/pipeline.h"

namespace mimic::service {

namespace {

class FkDeformer final : public Deformer {
 public:
  explicit FkDeformer(const rig::Skeleton& s) : skeleton_(s), frames_(size_t(s.joint_count())) {}
  void deform(const rig::Pose& pose) override { rig::forward_kinematics(skeleton_, pose, frames_); }

 private:
  rig::Skeleton skeleton_;
  std::vector<rig::RigidTransform> frames_;
};

class SkinDeformer final : public Deformer {
 public:
  SkinDeformer(avatar::ImplicitSkin skin, uint8_t lod)
      : skin_(std::move(skin)), texture_(avatar::texture_layout(skin_)), lod_(lod) {}
  void deform(const rig::Pose& pose) override { skin_.evaluate(pose); }
  const avatar::Mesh* mesh() const override { return &skin_.mesh(); }
  uint8_t lod() const override { return lod_; }
  const avatar::TextureLayout* texture() const override { return &texture_; }

 private:
  avatar::ImplicitSkin skin_;
  avatar::TextureLayout texture_;
  uint8_t lod_;
};

// The realtime method: the contours measured once in the shared body, moved every frame.
class RealtimeDeformer final : public Deformer {
 public:
  explicit RealtimeDeformer(std::shared_ptr<const avatar::RealtimeBody> body)
      : body_(body), skin_(body), mesh_(body->rest_mesh()), lod_(static_cast<uint8_t>(body->lod())) {
    mesh_.normals.clear();  // receivers that want normals compute them from the fixed topology
  }
  void deform(const rig::Pose& pose) override { skin_.evaluate(pose, mesh_.positions); }
  const avatar::Mesh* mesh() const override { return &mesh_; }
  uint8_t lod() const override { return lod_; }
  const avatar::TextureLayout* texture() const override { return &body_->texture_layout(); }

 private:
  std::shared_ptr<const avatar::RealtimeBody> body_;
  avatar::RealtimeSkin skin_;
  avatar::Mesh mesh_;
  uint8_t lod_;
};

}  // namespace

std::unique_ptr<Deformer> make_fk_deformer(const rig::Skeleton& skeleton) {
  return std::make_unique<FkDeformer>(skeleton);
}

Result<std::unique_ptr<Deformer>> make_skin_deformer(const avatar::BodyModel& model, const rig::Skeleton& skeleton,
                                                     int lod, avatar::SkinMethod method) {
  if (lod < 0 || lod >= kMeshLodCount)
    return fail(Errc::out_of_range, "mesh LOD must be in 0.." + std::to_string(kMeshLodCount - 1));
  if (method == avatar::SkinMethod::realtime) {
    avatar::RealtimeOptions o;
    o.lod = lod;
    auto body = avatar::RealtimeBody::shared(model, skeleton, o);  // avatars of one body share it
    if (!body) return tl::unexpected(body.error());
    return std::unique_ptr<Deformer>(new RealtimeDeformer(*body));
  }
  avatar::SkinOptions o;
  o.subdivision = 0;
  o.normals = false;  // receivers that want normals compute them from the fixed topology
  auto skin = avatar::ImplicitSkin::create(avatar::with_skin_lod(model, lod), skeleton, o);
  if (!skin) return tl::unexpected(skin.error());
  return std::unique_ptr<Deformer>(new SkinDeformer(std::move(*skin), static_cast<uint8_t>(lod)));
}

}  // namespace mimic::service
