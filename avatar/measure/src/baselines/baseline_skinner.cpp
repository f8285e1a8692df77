#include "mimic/avatar/baselines/baseline_skinner.h"

#include "mimic/avatar/baselines/cor_skinning.h"
#include "mimic/avatar/baselines/dual_quaternion_skinning.h"
#include "mimic/avatar/baselines/linear_blend_skinning.h"

namespace mimic::avatar::baselines {

const char* method_name(SkinningMethod m) {
  switch (m) {
    case SkinningMethod::lbs: return "lbs";
    case SkinningMethod::dqs: return "dqs";
    case SkinningMethod::cor: return "cor";
  }
  return "?";
}

Result<BaselineSkinner> BaselineSkinner::create(const rig::Skeleton& skeleton,
                                                std::span<const rig::RigidTransform> rest_w, const Mesh& rest,
                                                SkinWeights weights) {
  if (rest_w.size() != static_cast<size_t>(skeleton.joint_count()))
    return fail(Errc::invalid_argument, "baseline skinning: one rest transform per joint is needed");
  if (weights.vertex_count() != rest.positions.size())
    return fail(Errc::invalid_argument, "baseline skinning: one weight set per rest vertex is needed");
  if (auto st = validate_weights(weights, skeleton.joint_count()); !st) return tl::unexpected(st.error());
  BaselineSkinner s;
  s.rest_positions_ = rest.positions;
  if (rest.normals.size() == rest.positions.size()) s.rest_normals_ = rest.normals;
  s.weights_ = std::move(weights);
  s.centers_.resize(rest.positions.size());
  compute_centers_of_rotation(s.rest_positions_, rest.indices, s.weights_, s.centers_);
  s.joint_from_rest_.resize(rest_w.size());
  invert_transforms(rest_w, s.joint_from_rest_);
  s.matrices_.resize(rest_w.size());
  s.dual_quats_.resize(rest_w.size());
  s.rotations_.resize(rest_w.size());
  s.set_pose(rest_w);
  return s;
}

void BaselineSkinner::set_pose(std::span<const rig::RigidTransform> world_from_joint) {
  skinning_transforms(world_from_joint, joint_from_rest_, matrices_, dual_quats_, rotations_);
}

void BaselineSkinner::deform(SkinningMethod method, std::span<glm::vec3> out_p, std::span<glm::vec3> out_n) const {
  const std::span<const glm::vec3> in_n =
      out_n.empty() ? std::span<const glm::vec3>{} : std::span<const glm::vec3>(rest_normals_);
  switch (method) {
    case SkinningMethod::lbs:
      LinearBlendSkinningJob{matrices_, weights_.joints, weights_.weights, rest_positions_, in_n, out_p, out_n}.Run();
      break;
    case SkinningMethod::dqs:
      DualQuaternionSkinningJob{dual_quats_, weights_.joints, weights_.weights, rest_positions_, in_n, out_p, out_n}
          .Run();
      break;
    case SkinningMethod::cor:
      CorSkinningJob{matrices_, rotations_, weights_.joints, weights_.weights, centers_, rest_positions_, in_n,
                     out_p,     out_n}
          .Run();
      break;
  }
}

Result<BaselineSkinner> bind_to_links(const rig::Skeleton& skeleton, const rig::Pose& rest_pose, const Mesh& rest,
                                      float band_m) {
  std::vector<rig::RigidTransform> rest_w(skeleton.joint_count());
  rig::forward_kinematics(skeleton, rest_pose, rest_w);
  return BaselineSkinner::create(skeleton, rest_w, rest, weights_from_links(skeleton, rest_w, rest.positions, band_m));
}

}  // namespace mimic::avatar::baselines
