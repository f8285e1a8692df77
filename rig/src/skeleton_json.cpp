#include "mimic/rig/skeleton_json.h"

#include <nlohmann/json.hpp>

#include "mimic/core/json_io.h"

namespace mimic::rig {

namespace {

using nlohmann::json;

std::string mirror_name(const std::string& s) { return s.rfind("l_", 0) == 0 ? "r_" + s.substr(2) : s; }

json dof_json(const DofDesc& d) {
  return json{{"name", d.name},
              {"axis", json_vec3(d.axis)},
              {"min_deg", json_rounded(glm::degrees(d.min_rad))},
              {"max_deg", json_rounded(glm::degrees(d.max_rad))},
              {"rest_deg", json_rounded(glm::degrees(d.rest_rad))}};
}

json joint_json(const JointDesc& jd) {
  json dofs = json::array();
  for (const auto& d : jd.dofs) dofs.push_back(dof_json(d));
  return json{{"name", jd.name},
              {"parent", jd.parent},
              {"offset", json_vec3(jd.offset_m)},
              {"tip", json_vec3(jd.tip_m)},
              {"dofs", dofs}};
}

DofDesc read_dof(const json& dj, const std::string& path, JsonReader& r) {
  DofDesc d;
  d.name = r.string(dj, path, "name", true);
  d.axis = r.vec3(dj, path, "axis", {1, 0, 0}, true);
  d.min_rad = glm::radians(r.number(dj, path, "min_deg", -180, true));
  d.max_rad = glm::radians(r.number(dj, path, "max_deg", 180, true));
  d.rest_rad = glm::radians(r.number(dj, path, "rest_deg", 0));
  return d;
}

// One joint, and whether its right twin follows it.
JointDesc read_joint(const json& jj, const std::string& path, JsonReader& r, bool& mirror) {
  JointDesc jd;
  jd.name = r.string(jj, path, "name", true);
  jd.parent = r.string(jj, path, "parent", false);
  jd.offset_m = r.vec3(jj, path, "offset", {0, 0, 0});
  jd.tip_m = r.vec3(jj, path, "tip", {0, 0, 0});
  if (const json* dofs = r.member(jj, path, "dofs", false); dofs) {
    if (!dofs->is_array()) r.fail_at(path + ".dofs", "expected an array");
    for (size_t k = 0; r.ok() && dofs->is_array() && k < dofs->size(); ++k)
      jd.dofs.push_back(read_dof((*dofs)[k], path + ".dofs[" + std::to_string(k) + "]", r));
  }
  mirror = false;
  if (const json* mj = r.member(jj, path, "mirror", false); mj) {
    if (!mj->is_boolean())
      r.fail_at(path + ".mirror", "expected true or false");
    else if (mj->get<bool>() && jd.name.rfind("l_", 0) != 0)
      r.fail_at(path + ".mirror", "only a left-side (\"l_…\") joint can be mirrored");
    else
      mirror = mj->get<bool>();
  }
  return jd;
}

}  // namespace

JointDesc mirrored(const JointDesc& left) {
  JointDesc j = left;
  j.name = mirror_name(left.name);
  j.parent = mirror_name(left.parent);
  j.offset_m.x = -j.offset_m.x;
  j.tip_m.x = -j.tip_m.x;
  for (auto& d : j.dofs) {
    d.name = mirror_name(d.name);
    d.axis = {d.axis.x, -d.axis.y, -d.axis.z};
  }
  return j;
}

SkeletonDesc read_skeleton_json(const json& skeleton, const std::string& path, JsonReader& r) {
  SkeletonDesc desc;
  const json* joints = r.member(skeleton, path, "joints", true);
  if (joints && !joints->is_array()) r.fail_at(path + ".joints", "expected an array");
  if (!joints || !joints->is_array()) return desc;
  for (size_t i = 0; i < joints->size() && r.ok(); ++i) {
    bool mirror = false;
    JointDesc jd = read_joint((*joints)[i], path + ".joints[" + std::to_string(i) + "]", r, mirror);
    JointDesc twin = mirror ? mirrored(jd) : JointDesc{};
    desc.joints.push_back(std::move(jd));
    if (mirror) desc.joints.push_back(std::move(twin));
  }
  return desc;
}

json skeleton_json(const SkeletonDesc& desc) {
  // A right joint right after its exact mirror image on the left is written once, on the left,
  // as "mirror": true (the reader puts the twin back in the same place).
  json joints = json::array();
  const auto& js = desc.joints;
  for (size_t i = 0; i < js.size(); ++i) {
    json jj = joint_json(js[i]);
    if (js[i].name.rfind("l_", 0) == 0 && i + 1 < js.size() && joint_json(js[i + 1]) == joint_json(mirrored(js[i]))) {
      jj["mirror"] = true;
      ++i;
    }
    joints.push_back(std::move(jj));
  }
  return json{{"joints", joints}};
}

Result<Skeleton> skeleton_from_body_json(std::string_view text, std::string_view source_name) {
  const json root = json::parse(text.begin(), text.end(), nullptr, false);
  const std::string src(source_name);
  if (root.is_discarded()) return fail(Errc::parse_error, src + ": invalid JSON");
  JsonReader r(src);
  SkeletonDesc desc;
  if (const json* sk = r.member(root, "$", "skeleton", true); sk) desc = read_skeleton_json(*sk, "$.skeleton", r);
  if (!r.ok()) return fail(Errc::parse_error, r.error());
  return Skeleton::build(desc);
}

}  // namespace mimic::rig
