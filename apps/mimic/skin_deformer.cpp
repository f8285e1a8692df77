#include "skin_deformer.h"

#include "mimic/avatar/body_model.h"

namespace mimic::app {

namespace {

class SkinDeformer final : public Deformer {
 public:
  explicit SkinDeformer(avatar::BodySkin skin) : skin_(std::move(skin)) {}
  void deform(const avatar::Pose& pose) override { skin_.evaluate(pose); }

 private:
  avatar::BodySkin skin_;
};

}  // namespace

Result<std::string> body_model_text(const std::string& path) {
  if (path.empty()) return avatar::to_json(avatar::default_body_model(), false);
  auto model = avatar::load_body_model(path);
  if (!model) return tl::unexpected(model.error());
  return avatar::to_json(*model, false);
}

Result<std::unique_ptr<Deformer>> make_skin_deformer(const std::string& model_json, const avatar::Skeleton& skeleton) {
  auto model = avatar::body_model_from_json(model_json, "body model");
  if (!model) return tl::unexpected(model.error());
  avatar::SkinOptions options;
  options.normals = false;
  auto skin = avatar::BodySkin::create(*model, skeleton, options);
  if (!skin) return tl::unexpected(skin.error());
  return std::unique_ptr<Deformer>(new SkinDeformer(std::move(*skin)));
}

}  // namespace mimic::app
