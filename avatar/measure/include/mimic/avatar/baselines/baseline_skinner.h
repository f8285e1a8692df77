// The three baseline skinnings of one rest mesh, ready to run: weights, centres of rotation and
// the joints' rest inverses computed once, per-frame joint transforms converted into reused
// buffers. What `mimic bench`, `mimic inspect` and bench/avatar use to compare the contour skin
// with linear blend (LBS), dual quaternion (DQS) and optimized-centres-of-rotation (CoR)
// skinning of the same vertices.
#pragma once

#include <span>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/avatar/baselines/skin_weights.h"
#include "mimic/avatar/baselines/skinning_transforms.h"
#include "mimic/avatar/mesh.h"
#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"

namespace mimic::avatar::baselines {

enum class SkinningMethod { lbs, dqs, cor };
const char* method_name(SkinningMethod method);  // "lbs", "dqs", "cor"

class BaselineSkinner {
 public:
  // `rest`: the mesh (positions in metres; normals optional) in the posture `world_from_joint_rest`
  // of `skeleton`; `weights`: one set per rest position. Fails when the weights do not validate.
  // Allocates (the centres of rotation cost most).
  static Result<BaselineSkinner> create(const rig::Skeleton& skeleton,
                                        std::span<const rig::RigidTransform> world_from_joint_rest, const Mesh& rest,
                                        SkinWeights weights);

  size_t vertex_count() const { return rest_positions_.size(); }
  const SkinWeights& weights() const { return weights_; }
  std::span<const glm::vec3> centers_of_rotation() const { return centers_; }

  // Converts this frame's joint transforms (forward_kinematics output) once; then deform() may
  // run any method on them. Never allocates.
  void set_pose(std::span<const rig::RigidTransform> world_from_joint);
  // Writes vertex_count() positions (and normals, when `out_normals` is not empty and the rest
  // mesh had normals). Never allocates.
  void deform(SkinningMethod method, std::span<glm::vec3> out_positions, std::span<glm::vec3> out_normals = {}) const;

 private:
  BaselineSkinner() = default;
  std::vector<glm::vec3> rest_positions_, rest_normals_, centers_;
  SkinWeights weights_;
  std::vector<rig::RigidTransform> joint_from_rest_;
  std::vector<SkinningMatrix> matrices_;
  std::vector<DualQuat> dual_quats_;
  std::vector<glm::quat> rotations_;
};

// A skinner for `rest` posed as `rest_pose` of `skeleton`, bound by weights_from_links (for a
// mesh that comes without weights of its own). Allocates.
Result<BaselineSkinner> bind_to_links(const rig::Skeleton& skeleton, const rig::Pose& rest_pose, const Mesh& rest,
                                      float blend_band_m = 0.06f);

}  // namespace mimic::avatar::baselines
