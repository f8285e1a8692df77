// Forward kinematics of a BVH clip (the standard reading: T(offset + position) · R(ch1) · R(ch2) …).
#include <cassert>
#include <cmath>

#include "mimic/rig/bvh.h"

namespace mimic::rig {

namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

struct LocalTransform {
  glm::dquat rotation{1, 0, 0, 0};
  glm::dvec3 translation{0.0};  // file units
};

LocalTransform local_transform(const BvhJoint& joint, std::span<const double> row) {
  LocalTransform t;
  t.translation = joint.offset;
  for (size_t k = 0; k < joint.channels.size(); ++k) {
    const double v = row[joint.first_channel + k];
    switch (joint.channels[k]) {
      case BvhChannel::x_position: t.translation.x += v; break;
      case BvhChannel::y_position: t.translation.y += v; break;
      case BvhChannel::z_position: t.translation.z += v; break;
      case BvhChannel::x_rotation: t.rotation = t.rotation * glm::angleAxis(v * kDegToRad, glm::dvec3(1, 0, 0)); break;
      case BvhChannel::y_rotation: t.rotation = t.rotation * glm::angleAxis(v * kDegToRad, glm::dvec3(0, 1, 0)); break;
      case BvhChannel::z_rotation: t.rotation = t.rotation * glm::angleAxis(v * kDegToRad, glm::dvec3(0, 0, 1)); break;
    }
  }
  return t;
}

}  // namespace

glm::dquat bvh_local_rotation(const BvhClip& clip, int joint, int frame) {
  return local_transform(clip.joints[joint], clip.frame(frame)).rotation;
}

void bvh_forward_kinematics(const BvhClip& clip, int frame, std::span<RigidTransform> world_from_joint) {
  assert(world_from_joint.size() == clip.joints.size());
  assert(frame >= 0 && frame < clip.frame_count);
  const std::span<const double> row = clip.frame(frame);
  // Accumulate in double (long chains, large root coordinates), report float metres.
  constexpr size_t kStack = 128;
  glm::dquat rot_stack[kStack];
  glm::dvec3 pos_stack[kStack];
  const size_t n = clip.joints.size();
  for (size_t j = 0; j < n; ++j) {
    const BvhJoint& joint = clip.joints[j];
    const LocalTransform local = local_transform(joint, row);
    glm::dquat rot;
    glm::dvec3 pos;
    if (joint.parent < 0) {
      rot = local.rotation;
      pos = local.translation * clip.metres_per_unit;
    } else {
      const size_t p = static_cast<size_t>(joint.parent);
      const glm::dquat prot = p < kStack ? rot_stack[p] : glm::dquat(world_from_joint[p].rotation);
      const glm::dvec3 ppos = p < kStack ? pos_stack[p] : glm::dvec3(world_from_joint[p].translation);
      rot = prot * local.rotation;
      pos = ppos + prot * (local.translation * clip.metres_per_unit);
    }
    if (j < kStack) {
      rot_stack[j] = rot;
      pos_stack[j] = pos;
    }
    world_from_joint[j].rotation = glm::quat(glm::normalize(rot));
    world_from_joint[j].translation = glm::vec3(pos);
  }
}

}  // namespace mimic::rig
