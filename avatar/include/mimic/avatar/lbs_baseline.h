// Linear blend skinning, as the yardstick the metaball skin is measured against: each vertex of
// a rest-posture mesh bound to its two nearest joint links by inverse-distance weights; per frame
// v' = w·M0·v0 + (1 − w)·M1·v1. Not used to draw anything: `mimic bench` and bench/avatar time
// it on the same vertices as the skin, so the two can be compared in one run.
#pragma once

#include <span>
#include <vector>

#include "mimic/avatar/skeleton.h"

namespace mimic::avatar {

class LinearBlendBaseline {
 public:
  // `rest_positions`: the mesh in the skeleton's zero posture (world space). Allocates.
  LinearBlendBaseline(const Skeleton& skeleton, std::span<const glm::vec3> rest_positions);

  size_t vertex_count() const { return binds_.size(); }
  // Writes every vertex for the joints' world transforms (forward_kinematics output). No
  // allocation; `out` holds vertex_count() positions.
  void deform(std::span<const RigidTransform> world_from_joint, std::span<glm::vec3> out) const;

 private:
  struct Bind {
    int j0 = 0, j1 = 0;
    float w0 = 1;
    glm::vec3 l0{0.0f}, l1{0.0f};  // the vertex in each joint's frame at rest
  };
  std::vector<Bind> binds_;
};

}  // namespace mimic::avatar
