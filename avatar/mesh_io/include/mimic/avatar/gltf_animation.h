// A rigged, animated glTF 2.0 binary (.glb): the skin of a body in its bind pose, a skin
// (the skeleton's joints as a node hierarchy, inverse bind matrices, up to four joint influences
// per vertex) and the motion as an animation, so that glTF players (three.js, Blender, the
// Khronos validator) play the avatar without Mimic.
//
// Layout: node j is skeleton joint j (same names, same parents; translation = the joint's
// offset, rotation identity: Mimic's zero posture is the bind pose), then one node holding the
// one skinned mesh ("<name>_body"); the scene's roots are the root joint and that node. The
// mesh has a primitive per non-empty part of the body ("lower_torso", "left_foot" ...), each
// with a material of the part's name and colour (the name also in the primitive's
// extras.name), all sharing POSITION, NORMAL (when present), JOINTS_0 (unsigned short) and
// WEIGHTS_0 (float). The animation "motion" has a
// LINEAR translation channel on the root joint and a LINEAR rotation channel on every joint
// that has DOFs, one keyframe per pose, quaternions kept on one hemisphere from key to key.
// Frames: metres, +Y up, the body faces +Z (glTF's own axes: +Y up, +Z forward).
#pragma once

#include <span>
#include <string>
#include <vector>

#include "mimic/avatar/mesh.h"
#include "mimic/rig/skeleton.h"
#include "mimic/avatar/skin_weights.h"
#include "mimic/core/result.h"

namespace mimic::avatar {

struct SkinnedAnimation {
  const Mesh* bind_mesh = nullptr;              // positions in the bind pose
  std::span<const JointInfluences> influences;  // one per vertex of bind_mesh
  const rig::Skeleton* skeleton = nullptr;
  rig::Pose bind_pose;           // the pose bind_mesh was made in
  std::vector<double> times_s;   // strictly increasing, from 0
  std::vector<rig::Pose> poses;  // one per time, of `skeleton`
  std::string name = "mimic";
};

// The .glb bytes, as engines load them: one skinned mesh (a primitive and a material per part,
// the part's name in the primitive's extras), the joint nodes, the inverse bind matrices and
// one animation. The bind pose stands on the floor: the bind mesh and its pose are raised (or
// lowered) together so its lowest vertex is at y = 0; the animation's poses are kept as given.
// Fails (invalid_argument) on a mesh that does not validate, influences of
// another count than the vertices or naming joints beyond the skeleton, no keyframe, times not
// increasing, or poses of another DOF count.
Result<std::string> encode_skinned_glb(const SkinnedAnimation& animation);

}  // namespace mimic::avatar
