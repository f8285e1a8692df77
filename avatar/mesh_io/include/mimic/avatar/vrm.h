// A VRM 1.0 avatar (.vrm): the skinned glTF of encode_skinned_glb in its bind pose (one skinned
// mesh, a material per part, the joints as nodes, standing on the floor, facing +Z as VRM 1.0
// wants) with the VRMC_vrm extension: the humanoid bone map (Mimic's joints under VRM's names)
// and the meta (name, authors, the licence's permissions), so VRM apps (three-vrm, VSeeFace,
// UniVRM) load Mimic's body as an avatar they can drive. No animation: a VRM is a model.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "mimic/avatar/gltf_animation.h"
#include "mimic/core/result.h"
#include "mimic/rig/skeleton.h"

namespace mimic::avatar {

// The meta block of VRMC_vrm 1.0. The defaults are the VRM Public License 1.0 with everything
// an open body allows: anyone may perform as it, commercially, redistribute and modify it.
struct VrmMeta {
  std::string name = "Mimic body";
  std::string version;
  std::vector<std::string> authors = {"Mimic"};
  std::string copyright_information;
  std::string license_url = "https://vrm.dev/licenses/1.0/";
  std::string avatar_permission = "everyone";    // onlyAuthor | onlySeparatelyLicensedPerson | everyone
  std::string commercial_usage = "corporation";  // personalNonProfit | personalProfit | corporation
  std::string credit_notation = "unnecessary";   // required | unnecessary
  std::string modification = "allowModificationRedistribution";
  bool allow_redistribution = true;
  bool allow_excessively_violent_usage = false, allow_excessively_sexual_usage = false;
  bool allow_political_or_religious_usage = false, allow_antisocial_or_hate_usage = false;
};

// VRM 1.0's humanoid bones for the joints `skeleton` has, as (joint index, bone name):
// pelvis -> hips, spine_lower -> spine, spine_mid -> chest, spine_upper -> upperChest,
// neck -> neck, head -> head, l_clavicle -> leftShoulder, l_shoulder -> leftUpperArm,
// l_elbow -> leftLowerArm, l_wrist -> leftHand, l_hip -> leftUpperLeg, l_knee -> leftLowerLeg,
// l_ankle -> leftFoot, l_toes -> leftToes, and the right side alike (neck_upper has no bone:
// it stays a plain node between neck and head, which VRM allows).
std::vector<std::pair<int, std::string>> vrm_humanoid_bones(const rig::Skeleton& skeleton);

// The VRM 1.0 bones every avatar must map (hips, spine, head, the arms' and legs' three bones).
const std::vector<std::string>& vrm_required_bones();

// The .vrm bytes (a GLB). `model`'s times_s and poses are not used; its bind pose must be the
// T-pose VRM asks for (Mimic's zero posture is). Fails (invalid_argument) as
// encode_skinned_glb does, when a required humanoid bone has no joint (naming the bones), or
// on a meta without a name, an author or a licence URL.
Result<std::string> encode_vrm(const SkinnedAnimation& model, const VrmMeta& meta);

}  // namespace mimic::avatar
