#include "mimic/avatar/gltf_animation.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>

#include "gltf_document.h"
#include "mesh_io_internal.h"
#include "mimic/avatar/mesh_io.h"

namespace mimic::avatar {

namespace {

using nlohmann::json;

constexpr int kFloat = 5126, kUnsignedShort = 5123, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

// The binary chunk and the accessors over it, one buffer view each (4-byte aligned).
class BinaryBuilder {
 public:
  int add(const void* data, size_t bytes, int component, int count, const char* type, int target,
          const json& extra = json::object()) {
    while (bin_.size() % 4) bin_.push_back(0);
    json view = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", bytes}};
    if (target) view["target"] = target;
    const auto* p = static_cast<const uint8_t*>(data);
    bin_.insert(bin_.end(), p, p + bytes);
    views_.push_back(view);
    json acc = {{"bufferView", views_.size() - 1}, {"componentType", component}, {"count", count}, {"type", type}};
    acc.update(extra);
    accessors_.push_back(acc);
    return int(accessors_.size() - 1);
  }
  std::vector<uint8_t>& bin() { return bin_; }
  json& views() { return views_; }
  json& accessors() { return accessors_; }

 private:
  std::vector<uint8_t> bin_;
  json views_ = json::array(), accessors_ = json::array();
};

json vec_json(const glm::vec3& v) { return json::array({v.x, v.y, v.z}); }

Status check_animation(const SkinnedAnimation& a, bool animate) {
  if (!a.bind_mesh || !a.skeleton) return fail(Errc::invalid_argument, "glTF: no mesh or no skeleton");
  const Mesh& mesh = *a.bind_mesh;
  const rig::Skeleton& sk = *a.skeleton;
  if (auto st = validate_mesh(mesh); !st) return tl::unexpected(st.error());
  const size_t nv = mesh.positions.size();
  if (a.bind_pose.dof_rad.size() != size_t(sk.dof_count()))
    return fail(Errc::invalid_argument, "glTF: bind pose of another skeleton");
  if (a.influences.size() != nv)
    return fail(Errc::invalid_argument,
                "glTF: " + std::to_string(a.influences.size()) + " influences for " + std::to_string(nv) + " vertices");
  if (!animate) return {};
  if (a.times_s.empty() || a.times_s.size() != a.poses.size())
    return fail(Errc::invalid_argument, "glTF: the animation needs one pose per keyframe time, at least one");
  for (size_t k = 1; k < a.times_s.size(); ++k)
    if (!(a.times_s[k] > a.times_s[k - 1])) return fail(Errc::invalid_argument, "glTF: keyframe times must increase");
  for (const rig::Pose& p : a.poses)
    if (p.dof_rad.size() != size_t(sk.dof_count()))
      return fail(Errc::invalid_argument, "glTF: a pose of another skeleton");
  return {};
}

// POSITION (the bind mesh raised by `lift`), NORMAL, JOINTS_0 and WEIGHTS_0.
Result<json> vertex_attributes(const SkinnedAnimation& a, const glm::vec3& lift, BinaryBuilder& b) {
  const Mesh& mesh = *a.bind_mesh;
  const size_t nv = mesh.positions.size(), nj = size_t(a.skeleton->joint_count());
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
  std::vector<glm::vec3> positions(mesh.positions);
  for (auto& p : positions) {
    p += lift;
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  json attributes;
  attributes["POSITION"] = b.add(positions.data(), nv * 12, kFloat, int(nv), "VEC3", kArrayBuffer,
                                 {{"min", vec_json(lo)}, {"max", vec_json(hi)}});
  if (mesh.normals.size() == nv) {
    std::vector<glm::vec3> n(nv);
    for (size_t i = 0; i < nv; ++i) {
      const float len = glm::length(mesh.normals[i]);
      n[i] = len > 1e-12f ? mesh.normals[i] / len : glm::vec3(0, 1, 0);
    }
    attributes["NORMAL"] = b.add(n.data(), nv * 12, kFloat, int(nv), "VEC3", kArrayBuffer);
  }
  std::vector<uint16_t> joints(nv * 4);
  std::vector<float> weights(nv * 4);
  for (size_t v = 0; v < nv; ++v) {
    const JointInfluences& in = a.influences[v];
    float sum = 0;
    for (int k = 0; k < 4; ++k) {
      if (in.weight[size_t(k)] > 0 && in.joint[size_t(k)] >= nj)
        return fail(Errc::invalid_argument, "glTF: vertex " + std::to_string(v) + " names joint " +
                                                std::to_string(in.joint[size_t(k)]) + " of a skeleton of " +
                                                std::to_string(nj));
      sum += std::max(0.0f, in.weight[size_t(k)]);
    }
    if (!(sum > 0)) return fail(Errc::invalid_argument, "glTF: vertex " + std::to_string(v) + " has no weight");
    for (int k = 0; k < 4; ++k) {
      const float w = std::max(0.0f, in.weight[size_t(k)]) / sum;
      // Unused slots: joint 0 with weight 0, as the specification asks.
      joints[v * 4 + size_t(k)] = w > 0 ? in.joint[size_t(k)] : 0;
      weights[v * 4 + size_t(k)] = w;
    }
  }
  attributes["JOINTS_0"] = b.add(joints.data(), joints.size() * 2, kUnsignedShort, int(nv), "VEC4", kArrayBuffer);
  attributes["WEIGHTS_0"] = b.add(weights.data(), weights.size() * 4, kFloat, int(nv), "VEC4", kArrayBuffer);
  return attributes;
}

// One mesh, a primitive per part sharing the vertex attributes, each with a material of the
// part's own colour and named after it: engines import one skinned mesh with its submeshes.
void body_mesh(const SkinnedAnimation& a, const json& attributes, BinaryBuilder& b, json& meshes, json& materials) {
  const Mesh& mesh = *a.bind_mesh;
  json primitives = json::array();
  materials = json::array();
  for (const auto& part : covering_parts(mesh)) {
    if (part.triangle_count == 0) continue;
    const int acc = b.add(mesh.indices.data() + size_t(part.first_triangle) * 3, size_t(part.triangle_count) * 12,
                          kUnsignedInt, int(part.triangle_count * 3), "SCALAR", kElementArrayBuffer);
    const glm::vec3 rgb = detail::part_colour(materials.size());
    materials.push_back({{"name", part.name},
                         {"pbrMetallicRoughness",
                          {{"baseColorFactor", json::array({rgb.x, rgb.y, rgb.z, 1.0f})},
                           {"metallicFactor", 0.0},
                           {"roughnessFactor", 0.8}}}});
    primitives.push_back({{"attributes", attributes},
                          {"indices", acc},
                          {"mode", 4},
                          {"material", materials.size() - 1},
                          {"extras", {{"name", part.name}}}});
  }
  meshes = primitives.empty() ? json::array() : json::array({{{"name", a.name + "_body"}, {"primitives", primitives}}});
}

// The joints as nodes in the bind pose (the skeleton's hierarchy), and their inverse bind
// matrices' accessor.
int joint_nodes(const rig::Skeleton& sk, const rig::Pose& bind_pose, BinaryBuilder& b, json& nodes) {
  const size_t nj = size_t(sk.joint_count());
  std::vector<rig::RigidTransform> bind(nj);
  rig::forward_kinematics(sk, bind_pose, bind);
  std::vector<float> ibm(nj * 16);
  for (size_t j = 0; j < nj; ++j) {
    const glm::mat4 world = glm::translate(glm::mat4(1.0f), bind[j].translation) * glm::mat4_cast(bind[j].rotation);
    const glm::mat4 inv = glm::inverse(world);
    std::memcpy(ibm.data() + j * 16, glm::value_ptr(inv), 64);
  }
  const int ibm_acc = b.add(ibm.data(), ibm.size() * 4, kFloat, int(nj), "MAT4", 0);
  const std::span<const float> bind_dofs(bind_pose.dof_rad);
  nodes = json::array();
  for (size_t j = 0; j < nj; ++j) {
    const int jj = int(j);
    glm::vec3 t = sk.offset_m(jj);
    glm::quat r = sk.local_rotation(jj, bind_dofs);
    if (sk.parent(jj) < 0) {
      t = bind_pose.root_position_m + bind_pose.root_orientation * t;
      r = glm::normalize(bind_pose.root_orientation) * r;
    }
    json node = {
        {"name", sk.joint_name(jj)}, {"translation", vec_json(t)}, {"rotation", json::array({r.x, r.y, r.z, r.w})}};
    json children = json::array();
    for (size_t c = 0; c < nj; ++c)
      if (sk.parent(int(c)) == jj) children.push_back(c);
    if (!children.empty()) node["children"] = children;
    nodes.push_back(node);
  }
  return ibm_acc;
}

// The keyframes: the root's translation and every joint's rotation that can change.
json motion(const SkinnedAnimation& a, int root, BinaryBuilder& b) {
  const rig::Skeleton& sk = *a.skeleton;
  const size_t nk = a.times_s.size(), nj = size_t(sk.joint_count());
  std::vector<float> times(nk);
  for (size_t k = 0; k < nk; ++k) times[k] = float(a.times_s[k] - a.times_s[0]);
  const int input = b.add(times.data(), nk * 4, kFloat, int(nk), "SCALAR", 0,
                          {{"min", json::array({times.front()})}, {"max", json::array({times.back()})}});
  json samplers = json::array(), channels = json::array();
  {
    std::vector<glm::vec3> tr(nk);
    for (size_t k = 0; k < nk; ++k)
      tr[k] = a.poses[k].root_position_m + a.poses[k].root_orientation * sk.offset_m(root);
    const int out = b.add(tr.data(), nk * 12, kFloat, int(nk), "VEC3", 0);
    samplers.push_back({{"input", input}, {"output", out}, {"interpolation", "LINEAR"}});
    channels.push_back({{"sampler", samplers.size() - 1}, {"target", {{"node", root}, {"path", "translation"}}}});
  }
  std::vector<glm::quat> rot(nk);
  for (size_t j = 0; j < nj; ++j) {
    const int jj = int(j);
    if (sk.dof_end(jj) == sk.dof_begin(jj) && sk.parent(jj) >= 0) continue;  // never rotates
    for (size_t k = 0; k < nk; ++k) {
      glm::quat q = sk.local_rotation(jj, a.poses[k].dof_rad);
      if (sk.parent(jj) < 0) q = glm::normalize(a.poses[k].root_orientation) * q;
      q = glm::normalize(q);
      if (k > 0 && glm::dot(q, rot[k - 1]) < 0) q = -q;  // the short way from key to key
      rot[k] = q;
    }
    std::vector<float> xyzw(nk * 4);
    for (size_t k = 0; k < nk; ++k) {
      xyzw[k * 4 + 0] = rot[k].x;
      xyzw[k * 4 + 1] = rot[k].y;
      xyzw[k * 4 + 2] = rot[k].z;
      xyzw[k * 4 + 3] = rot[k].w;
    }
    const int out = b.add(xyzw.data(), xyzw.size() * 4, kFloat, int(nk), "VEC4", 0);
    samplers.push_back({{"input", input}, {"output", out}, {"interpolation", "LINEAR"}});
    channels.push_back({{"sampler", samplers.size() - 1}, {"target", {{"node", jj}, {"path", "rotation"}}}});
  }

  return json::array({{{"name", "motion"}, {"samplers", samplers}, {"channels", channels}}});
}

}  // namespace

namespace detail {

Result<GltfDocument> skinned_gltf(const SkinnedAnimation& a, bool animate) {
  if (auto st = check_animation(a, animate); !st) return tl::unexpected(st.error());
  const rig::Skeleton& sk = *a.skeleton;
  const size_t nj = size_t(sk.joint_count());
  // The bind pose raised (or lowered) so it stands on the floor.
  float lowest = std::numeric_limits<float>::max();
  for (const auto& p : a.bind_mesh->positions) lowest = std::min(lowest, p.y);
  const glm::vec3 lift(0.0f, -lowest, 0.0f);
  rig::Pose bind_pose = a.bind_pose;
  bind_pose.root_position_m += lift;

  BinaryBuilder b;
  auto attributes = vertex_attributes(a, lift, b);
  if (!attributes) return tl::unexpected(attributes.error());
  json meshes, materials, nodes;
  body_mesh(a, *attributes, b, meshes, materials);
  if (meshes.empty()) return fail(Errc::invalid_argument, "glTF: the mesh has no triangles");
  const int ibm_acc = joint_nodes(sk, bind_pose, b, nodes);
  int root = 0;
  for (size_t j = 0; j < nj; ++j)
    if (sk.parent(int(j)) < 0) root = int(j);
  json skin_joints = json::array();
  for (size_t j = 0; j < nj; ++j) skin_joints.push_back(j);
  json scene_nodes = json::array({root, nodes.size()});
  nodes.push_back({{"name", a.name + "_body"}, {"mesh", 0}, {"skin", 0}});

  GltfDocument out;
  out.doc = {
      {"asset", {{"version", "2.0"}, {"generator", "Mimic"}}},
      {"scene", 0},
      {"scenes", json::array({{{"name", a.name}, {"nodes", scene_nodes}}})},
      {"nodes", nodes},
      {"meshes", meshes},
      {"materials", materials},
      {"skins", json::array({{{"name", a.name + "_skeleton"},
                              {"joints", skin_joints},
                              {"skeleton", root},
                              {"inverseBindMatrices", ibm_acc}}})},
  };
  if (animate) out.doc["animations"] = motion(a, root, b);
  while (b.bin().size() % 4) b.bin().push_back(0);
  out.doc["accessors"] = b.accessors();
  out.doc["bufferViews"] = b.views();
  out.doc["buffers"] = json::array({{{"byteLength", b.bin().size()}}});
  out.bin = std::move(b.bin());
  return out;
}

}  // namespace detail

Result<std::string> encode_skinned_glb(const SkinnedAnimation& a) {
  auto gltf = detail::skinned_gltf(a, true);
  if (!gltf) return tl::unexpected(gltf.error());
  return detail::glb_container(gltf->doc.dump(),
                               std::string_view(reinterpret_cast<const char*>(gltf->bin.data()), gltf->bin.size()));
}

}  // namespace mimic::avatar
