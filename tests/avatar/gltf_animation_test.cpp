// The rigged, animated glTF read back by a decoder of our own (GLB chunks, accessors, node TRS,
// animation keys, linear blend skinning as a glTF player does it) and compared with Mimic's own
// realtime skin: vertices bound to one joint (the rigid head, hands, feet) must land where the
// realtime skin puts them, at every keyframe.
#include "mimic/avatar/gltf_animation.h"

#include <gtest/gtest.h>

#include <cstring>
#include <map>
#include <set>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>

#include "mimic/avatar/body_model.h"
#include "mimic/rig/motion.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin_lod.h"

namespace mimic::avatar::gltf_animation_test {
namespace {

using nlohmann::json;

struct Glb {
  json doc;
  std::string bin;
  // Accessor `i` as floats (float or unsigned short components).
  std::vector<float> floats(int i) const {
    const json& a = doc["accessors"][size_t(i)];
    const json& v = doc["bufferViews"][a["bufferView"].get<size_t>()];
    const std::map<std::string, int> comps = {{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4}, {"MAT4", 16}};
    const size_t n = a["count"].get<size_t>() * size_t(comps.at(a["type"].get<std::string>()));
    const size_t off = v.value("byteOffset", size_t(0));
    std::vector<float> out(n);
    for (size_t k = 0; k < n; ++k) {
      if (a["componentType"] == 5126)
        std::memcpy(&out[k], bin.data() + off + 4 * k, 4);
      else if (a["componentType"] == 5123) {
        uint16_t u;
        std::memcpy(&u, bin.data() + off + 2 * k, 2);
        out[k] = float(u);
      } else {
        uint32_t u;
        std::memcpy(&u, bin.data() + off + 4 * k, 4);
        out[k] = float(u);
      }
    }
    return out;
  }
};

Glb parse(const std::string& b) {
  Glb g;
  EXPECT_EQ(b.substr(0, 4), "glTF");
  uint32_t version, total, json_len, bin_len;
  std::memcpy(&version, b.data() + 4, 4);
  std::memcpy(&total, b.data() + 8, 4);
  std::memcpy(&json_len, b.data() + 12, 4);
  EXPECT_EQ(version, 2u);
  EXPECT_EQ(total, b.size());
  EXPECT_EQ(b.substr(16, 4), "JSON");
  g.doc = json::parse(b.substr(20, json_len));
  std::memcpy(&bin_len, b.data() + 20 + json_len, 4);
  EXPECT_EQ(b.substr(24 + json_len, 4), std::string("BIN\0", 4));
  g.bin = b.substr(28 + json_len, bin_len);
  EXPECT_EQ(28 + json_len + bin_len, b.size());
  return g;
}

struct Rig {
  BodyModel body = default_body_model();
  rig::Skeleton skeleton = *rig::Skeleton::build(body.skeleton);
  std::shared_ptr<const RealtimeBody> shared;
  std::unique_ptr<rig::Motion> motion;
  SkinnedAnimation anim;
  Rig() {
    RealtimeOptions o;
    o.lod = kSkinLodCount - 1;  // the coarsest: quick, same method
    shared = *RealtimeBody::create(body, skeleton, o);
    motion = *rig::make_builtin_motion("walk", skeleton);
    anim.bind_mesh = &shared->rest_mesh();
    anim.influences = shared->weights();
    anim.skeleton = &skeleton;
    anim.bind_pose = skeleton.zero_pose();
    rig::Pose p = skeleton.zero_pose();
    for (int k = 0; k < 12; ++k) {
      motion->sample(0.1 * k, p);
      anim.times_s.push_back(0.1 * k);
      anim.poses.push_back(p);
    }
  }
};

TEST(GltfAnimation, StructureSkinAndWeights) {
  Rig r;
  auto bytes = encode_skinned_glb(r.anim);
  ASSERT_TRUE(bytes) << bytes.error().what();
  const Glb g = parse(*bytes);
  const size_t nj = size_t(r.skeleton.joint_count()), nv = r.anim.bind_mesh->positions.size();
  // Joint nodes, then one node holding the one skinned mesh: a primitive and a material per part,
  // named after it.
  size_t parts = 0;
  for (const auto& part : r.anim.bind_mesh->parts) parts += part.triangle_count > 0;
  ASSERT_EQ(g.doc["nodes"].size(), nj + 1);
  ASSERT_EQ(g.doc["meshes"].size(), 1u);
  const json& body = g.doc["nodes"][nj];
  EXPECT_EQ(body["skin"], 0);
  EXPECT_EQ(body["mesh"], 0);
  const json& primitives = g.doc["meshes"][0]["primitives"];
  ASSERT_EQ(primitives.size(), parts);
  ASSERT_EQ(g.doc["materials"].size(), parts);
  for (size_t m = 0; m < parts; ++m) {
    const std::string part = primitives[m]["extras"]["name"];
    EXPECT_EQ(g.doc["materials"][primitives[m]["material"].get<size_t>()]["name"], part);
  }
  EXPECT_EQ(primitives[0]["extras"]["name"], r.anim.bind_mesh->parts[0].name);
  // Node names are unique (players rename duplicates).
  std::set<std::string> names;
  for (const auto& n : g.doc["nodes"]) EXPECT_TRUE(names.insert(n["name"].get<std::string>()).second) << n["name"];
  // The bind pose stands on the floor: its lowest vertex at y = 0 (the rest mesh is made with the
  // pelvis at the origin, the feet under the floor).
  const json& pos_acc = g.doc["accessors"][primitives[0]["attributes"]["POSITION"].get<size_t>()];
  EXPECT_NEAR(pos_acc["min"][1].get<double>(), 0.0, 1e-6);
  float lowest = 1e9f;
  for (const auto& p : r.anim.bind_mesh->positions) lowest = std::min(lowest, p.y);
  ASSERT_LT(lowest, -0.5f) << "the rest mesh this test starts from is under the floor";
  rig::Pose lifted = r.anim.bind_pose;
  lifted.root_position_m.y -= lowest;
  const json& skin = g.doc["skins"][0];
  ASSERT_EQ(skin["joints"].size(), nj);
  // The hierarchy is the skeleton's.
  for (size_t j = 0; j < nj; ++j) {
    EXPECT_EQ(g.doc["nodes"][j]["name"], r.skeleton.joint_name(int(j)));
    for (const auto& c : g.doc["nodes"][j].value("children", json::array()))
      EXPECT_EQ(r.skeleton.parent(c.get<int>()), int(j));
  }
  // Inverse bind matrices undo the joints' bind-pose world transforms.
  const auto ibm = g.floats(skin["inverseBindMatrices"].get<int>());
  std::vector<rig::RigidTransform> bind(nj);
  rig::forward_kinematics(r.skeleton, lifted, bind);
  for (size_t j = 0; j < nj; ++j) {
    const glm::mat4 m = glm::make_mat4(ibm.data() + 16 * j);
    const glm::vec4 origin = m * glm::vec4(bind[j].translation, 1.0f);
    EXPECT_NEAR(glm::length(glm::vec3(origin)), 0.0f, 1e-5f) << r.skeleton.joint_name(int(j));
  }
  // At most four influences, weights summing to 1, joints in range.
  const json& attrs = g.doc["meshes"][0]["primitives"][0]["attributes"];
  const auto joints = g.floats(attrs["JOINTS_0"].get<int>()), weights = g.floats(attrs["WEIGHTS_0"].get<int>());
  ASSERT_EQ(weights.size(), nv * 4);
  for (size_t v = 0; v < nv; ++v) {
    float sum = 0;
    for (int k = 0; k < 4; ++k) {
      sum += weights[v * 4 + size_t(k)];
      EXPECT_LT(joints[v * 4 + size_t(k)], float(nj));
    }
    EXPECT_NEAR(sum, 1.0f, 1e-5f);
  }
  // Every part is a primitive; the animation has the root's translation and the rotations.
  size_t triangles = 0;
  for (const auto& m : g.doc["meshes"])
    for (const auto& p : m["primitives"])
      triangles += g.doc["accessors"][p["indices"].get<size_t>()]["count"].get<size_t>() / 3;
  EXPECT_EQ(triangles, r.anim.bind_mesh->triangle_count());
  const json& anim = g.doc["animations"][0];
  EXPECT_EQ(anim["channels"][0]["target"]["path"], "translation");
  EXPECT_GT(anim["channels"].size(), nj / 2);
  const json& input = g.doc["accessors"][anim["samplers"][0]["input"].get<size_t>()];
  EXPECT_EQ(input["count"], 12);
  EXPECT_NEAR(input["max"][0].get<double>(), 1.1, 1e-6);
}

// A glTF player's linear blend skinning, from the file alone, against Mimic's realtime skin.
TEST(GltfAnimation, PlaybackMovesRigidPartsWithTheRealtimeSkin) {
  Rig r;
  const Glb g = parse(*encode_skinned_glb(r.anim));
  const size_t nj = size_t(r.skeleton.joint_count());
  const auto ibm = g.floats(g.doc["skins"][0]["inverseBindMatrices"].get<int>());
  const json& attrs = g.doc["meshes"][0]["primitives"][0]["attributes"];
  const auto pos = g.floats(attrs["POSITION"].get<int>());
  const auto joints = g.floats(attrs["JOINTS_0"].get<int>()), weights = g.floats(attrs["WEIGHTS_0"].get<int>());
  // The rigid parts' vertices (head, hands, feet move rigidly with their joint in the realtime
  // skin, and are bound to that joint alone).
  std::vector<bool> rigid(r.shared->vertex_count(), false);
  for (const json& p : g.doc["meshes"][0]["primitives"]) {
    const std::string name = p["extras"]["name"];
    if (name != "head" && name != "left_hand" && name != "right_hand" && name != "left_foot" && name != "right_foot")
      continue;
    for (float v : g.floats(p["indices"].get<int>())) rigid[size_t(v)] = true;
  }
  RealtimeSkin skin(r.shared);
  std::vector<glm::vec3> expected(r.shared->vertex_count());
  size_t rigid_checked = 0;
  for (size_t key : {size_t(0), size_t(5), size_t(11)}) {
    // Node TRS: the bind values, replaced by the animation's key where a channel targets them.
    std::vector<glm::vec3> t(nj);
    std::vector<glm::quat> q(nj);
    for (size_t j = 0; j < nj; ++j) {
      const json& n = g.doc["nodes"][j];
      t[j] = {n["translation"][0], n["translation"][1], n["translation"][2]};
      q[j] = glm::quat(n["rotation"][3].get<float>(), n["rotation"][0].get<float>(), n["rotation"][1].get<float>(),
                       n["rotation"][2].get<float>());
    }
    const json& anim = g.doc["animations"][0];
    for (const auto& ch : anim["channels"]) {
      const auto out = g.floats(anim["samplers"][ch["sampler"].get<size_t>()]["output"].get<int>());
      const size_t node = ch["target"]["node"].get<size_t>();
      if (ch["target"]["path"] == "translation")
        t[node] = {out[key * 3], out[key * 3 + 1], out[key * 3 + 2]};
      else
        q[node] = glm::quat(out[key * 4 + 3], out[key * 4], out[key * 4 + 1], out[key * 4 + 2]);
    }
    std::vector<glm::mat4> world(nj);
    for (size_t j = 0; j < nj; ++j) {  // parents first, as the skeleton is ordered
      const glm::mat4 local = glm::translate(glm::mat4(1.0f), t[j]) * glm::mat4_cast(q[j]);
      const int p = r.skeleton.parent(int(j));
      world[j] = p < 0 ? local : world[size_t(p)] * local;
    }
    skin.evaluate(r.anim.poses[key], expected);
    for (size_t v = 0; v < expected.size(); ++v) {
      if (!rigid[v]) continue;
      // One joint, or a forefoot's two (the ankle's and the toes', each rigid): blending the
      // two rigid motions is exactly what the realtime skin does there.
      glm::vec4 p(0.0f);
      for (int k = 0; k < 4; ++k) {
        const float w = weights[v * 4 + size_t(k)];
        if (w <= 0) continue;
        EXPECT_LT(k, 2) << "a rigid part's vertex " << v << " follows one joint or two";
        const size_t j = size_t(joints[v * 4 + size_t(k)]);
        p += w * (world[j] * glm::make_mat4(ibm.data() + 16 * j) *
                  glm::vec4(pos[v * 3], pos[v * 3 + 1], pos[v * 3 + 2], 1.0f));
      }
      EXPECT_NEAR(glm::distance(glm::vec3(p), expected[v]), 0.0f, 2e-4f) << "vertex " << v << " key " << key;
      ++rigid_checked;
    }
  }
  EXPECT_GT(rigid_checked, 100u);
}

TEST(GltfAnimation, RefusesBadInput) {
  Rig r;
  SkinnedAnimation a = r.anim;
  a.times_s.clear();
  a.poses.clear();
  EXPECT_FALSE(encode_skinned_glb(a));
  a = r.anim;
  a.times_s[3] = a.times_s[2];
  EXPECT_FALSE(encode_skinned_glb(a));
  a = r.anim;
  a.influences = a.influences.subspan(1);
  EXPECT_FALSE(encode_skinned_glb(a));
  a = r.anim;
  a.poses[1].dof_rad.pop_back();
  EXPECT_FALSE(encode_skinned_glb(a));
}

}  // namespace
}  // namespace mimic::avatar::gltf_animation_test
