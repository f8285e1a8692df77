// The VRM 1.0 writer: the humanoid map a skeleton gets, and what it refuses (a skeleton without a
// required bone, a meta VRM apps would reject).
#include "mimic/avatar/vrm.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>

#include <nlohmann/json.hpp>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/realtime_skin.h"

namespace mimic::avatar::vrm_test {
namespace {

struct Model {
  BodyModel body = default_body_model();
  rig::Skeleton skeleton;
  std::shared_ptr<const RealtimeBody> shared;
  SkinnedAnimation anim;
  explicit Model(const rig::SkeletonDesc& desc) : skeleton(*rig::Skeleton::build(desc)) {
    RealtimeOptions o;
    o.lod = 3;
    shared = *RealtimeBody::create(body, skeleton, o);
    anim.bind_mesh = &shared->rest_mesh();
    anim.influences = shared->weights();
    anim.skeleton = &skeleton;
    anim.bind_pose = skeleton.zero_pose();
  }
};

nlohmann::json json_chunk(const std::string& glb) {
  uint32_t n = 0;
  std::memcpy(&n, glb.data() + 12, 4);
  return nlohmann::json::parse(glb.substr(20, n));
}

TEST(Vrm, EveryRequiredBoneOnItsJoint) {
  const Model m(default_body_model().skeleton);
  const auto bones = vrm_humanoid_bones(m.skeleton);
  EXPECT_EQ(bones.size(), 22u);
  for (const auto& name : vrm_required_bones())
    EXPECT_TRUE(std::any_of(bones.begin(), bones.end(), [&](const auto& b) { return b.second == name; })) << name;
  const auto vrm = encode_vrm(m.anim, VrmMeta{});
  ASSERT_TRUE(vrm) << vrm.error().what();
  const auto j = json_chunk(*vrm);
  for (const auto& [joint, name] : bones) {
    EXPECT_EQ(j["extensions"]["VRMC_vrm"]["humanoid"]["humanBones"][name]["node"], joint) << name;
    EXPECT_EQ(j["nodes"][size_t(joint)]["name"], m.skeleton.joint_name(joint)) << name;
  }
  // The VRM is the skinned glTF without its animation.
  EXPECT_FALSE(j.contains("animations"));
  EXPECT_EQ(j["meshes"].size(), 1u);
}

TEST(Vrm, ASkeletonWithoutARequiredBoneIsRefusedNamingIt) {
  rig::SkeletonDesc desc = default_body_model().skeleton;
  for (auto& jd : desc.joints) {
    if (jd.name == "l_wrist") jd.name = "l_hand_base";
    for (auto& other : desc.joints)
      if (other.parent == "l_wrist") other.parent = "l_hand_base";
  }
  // The bone map is checked before the mesh: a skeleton alone is enough.
  const rig::Skeleton skeleton = *rig::Skeleton::build(desc);
  SkinnedAnimation anim;
  anim.skeleton = &skeleton;
  const auto vrm = encode_vrm(anim, VrmMeta{});
  ASSERT_FALSE(vrm);
  EXPECT_NE(std::string(vrm.error().what()).find("leftHand"), std::string::npos) << vrm.error().what();
}

TEST(Vrm, AMetaVrmAppsWouldRejectIsRefused) {
  const Model m(default_body_model().skeleton);
  VrmMeta meta;
  meta.name.clear();
  EXPECT_FALSE(encode_vrm(m.anim, meta));
  meta = VrmMeta{};
  meta.authors.clear();
  EXPECT_FALSE(encode_vrm(m.anim, meta));
  meta.authors = {""};
  EXPECT_FALSE(encode_vrm(m.anim, meta));
  meta = VrmMeta{};
  meta.license_url.clear();
  EXPECT_FALSE(encode_vrm(m.anim, meta));
}

}  // namespace
}  // namespace mimic::avatar::vrm_test
