#include "mimic/avatar/vrm.h"

#include <algorithm>
#include <string_view>

#include <nlohmann/json.hpp>

#include "gltf_document.h"
#include "mesh_io_internal.h"

namespace mimic::avatar {

namespace {

using nlohmann::json;

struct BoneName {
  const char* joint;
  const char* vrm;
};

// The same correspondence as the VMC feed's Unity names (VRM's are their lowerCamelCase).
constexpr BoneName kBones[] = {
    {"pelvis", "hips"},
    {"spine_lower", "spine"},
    {"spine_mid", "chest"},
    {"spine_upper", "upperChest"},
    {"neck", "neck"},
    {"head", "head"},
    {"l_clavicle", "leftShoulder"},
    {"l_shoulder", "leftUpperArm"},
    {"l_elbow", "leftLowerArm"},
    {"l_wrist", "leftHand"},
    {"r_clavicle", "rightShoulder"},
    {"r_shoulder", "rightUpperArm"},
    {"r_elbow", "rightLowerArm"},
    {"r_wrist", "rightHand"},
    {"l_hip", "leftUpperLeg"},
    {"l_knee", "leftLowerLeg"},
    {"l_ankle", "leftFoot"},
    {"l_toes", "leftToes"},
    {"r_hip", "rightUpperLeg"},
    {"r_knee", "rightLowerLeg"},
    {"r_ankle", "rightFoot"},
    {"r_toes", "rightToes"},
};

json meta_json(const VrmMeta& m) {
  json meta = {
      {"name", m.name},
      {"authors", m.authors},
      {"licenseUrl", m.license_url},
      {"avatarPermission", m.avatar_permission},
      {"allowExcessivelyViolentUsage", m.allow_excessively_violent_usage},
      {"allowExcessivelySexualUsage", m.allow_excessively_sexual_usage},
      {"commercialUsage", m.commercial_usage},
      {"allowPoliticalOrReligiousUsage", m.allow_political_or_religious_usage},
      {"allowAntisocialOrHateUsage", m.allow_antisocial_or_hate_usage},
      {"creditNotation", m.credit_notation},
      {"allowRedistribution", m.allow_redistribution},
      {"modification", m.modification},
  };
  if (!m.version.empty()) meta["version"] = m.version;
  if (!m.copyright_information.empty()) meta["copyrightInformation"] = m.copyright_information;
  return meta;
}

Status check_meta(const VrmMeta& m) {
  if (m.name.empty()) return fail(Errc::invalid_argument, "VRM: the meta needs a name");
  const bool no_author =
      m.authors.empty() || std::any_of(m.authors.begin(), m.authors.end(), [](const auto& a) { return a.empty(); });
  if (no_author) return fail(Errc::invalid_argument, "VRM: the meta needs at least one author, none empty");
  if (m.license_url.empty()) return fail(Errc::invalid_argument, "VRM: the meta needs a licence URL");
  return {};
}

}  // namespace

std::vector<std::pair<int, std::string>> vrm_humanoid_bones(const rig::Skeleton& skeleton) {
  std::vector<std::pair<int, std::string>> bones;
  for (const auto& b : kBones)
    if (const int j = skeleton.find_joint(b.joint); j >= 0) bones.emplace_back(j, b.vrm);
  return bones;
}

const std::vector<std::string>& vrm_required_bones() {
  static const std::vector<std::string> kRequired = {"hips",          "spine",         "head",          "leftUpperLeg",
                                                     "leftLowerLeg",  "leftFoot",      "rightUpperLeg", "rightLowerLeg",
                                                     "rightFoot",     "leftUpperArm",  "leftLowerArm",  "leftHand",
                                                     "rightUpperArm", "rightLowerArm", "rightHand"};
  return kRequired;
}

Result<std::string> encode_vrm(const SkinnedAnimation& model, const VrmMeta& meta) {
  if (auto st = check_meta(meta); !st) return tl::unexpected(st.error());
  if (!model.skeleton) return fail(Errc::invalid_argument, "VRM: no skeleton");
  const auto bones = vrm_humanoid_bones(*model.skeleton);
  std::string missing;
  for (const auto& name : vrm_required_bones())
    if (std::none_of(bones.begin(), bones.end(), [&](const auto& b) { return b.second == name; }))
      missing += (missing.empty() ? "" : ", ") + name;
  if (!missing.empty())
    return fail(Errc::invalid_argument, "VRM: the skeleton has no joint for the required humanoid bones " + missing);
  auto gltf = detail::skinned_gltf(model, false);
  if (!gltf) return tl::unexpected(gltf.error());
  // Node j is joint j in the skinned document.
  json human_bones = json::object();
  for (const auto& [joint, name] : bones) human_bones[name] = {{"node", joint}};
  gltf->doc["extensionsUsed"] = json::array({"VRMC_vrm"});
  gltf->doc["extensions"] = {
      {"VRMC_vrm", {{"specVersion", "1.0"}, {"meta", meta_json(meta)}, {"humanoid", {{"humanBones", human_bones}}}}}};
  return detail::glb_container(gltf->doc.dump(),
                               std::string_view(reinterpret_cast<const char*>(gltf->bin.data()), gltf->bin.size()));
}

}  // namespace mimic::avatar
