// The built-in body: the authored one with the fitted overrides applied (body_overrides.h).
#include "mimic/avatar/body_overrides.h"

#include <nlohmann/json.hpp>

#include "mimic/core/json_io.h"

namespace mimic::avatar {

namespace {

using nlohmann::json;

// Fifty micrometres: well under the fit's step and a tessellation's error, and far above float
// noise, so an unchanged value is not listed.
constexpr float kSame_m = 5e-5f;

bool differs(const glm::vec3& a, const glm::vec3& b) {
  const glm::vec3 d = glm::abs(a - b);
  return d.x > kSame_m || d.y > kSame_m || d.z > kSame_m;
}
bool differs(const PrimitiveState& a, const PrimitiveState& b) {
  return differs(a.center_m, b.center_m) || differs(a.semi_axes_m, b.semi_axes_m);
}

json state_json(const PrimitiveState& s) {
  return json{{"center", json_vec3(s.center_m)}, {"semi_axes", json_vec3(s.semi_axes_m)}};
}

bool read_vec3(const json& obj, const char* key, glm::vec3& out) {
  const auto it = obj.find(key);
  if (it == obj.end()) return true;  // kept as it is
  if (!it->is_array() || it->size() != 3) return false;
  for (int i = 0; i < 3; ++i) {
    if (!(*it)[size_t(i)].is_number()) return false;
    out[i] = (*it)[size_t(i)].get<float>();
  }
  return true;
}

bool read_state(const json& obj, PrimitiveState& st) {
  return obj.is_object() && read_vec3(obj, "center", st.center_m) && read_vec3(obj, "semi_axes", st.semi_axes_m);
}

// Applies one primitive entry; false on a malformed one.
bool apply_primitive(const json& e, Primitive& p) {
  if (!read_state(e, p.state)) return false;
  if (!p.deformation) return true;
  for (auto [key, st] : {std::pair{"min", &p.deformation->at_min}, std::pair{"max", &p.deformation->at_max}})
    if (e.contains(key) && !read_state(e[key], *st)) return false;
  return true;
}

glm::vec3 mirror_x(glm::vec3 v) { return {-v.x, v.y, v.z}; }

// The left state and the mirrored right one made their mean, the right its mirror image.
void symmetrise(PrimitiveState& left, PrimitiveState& right) {
  left.center_m = 0.5f * (left.center_m + mirror_x(right.center_m));
  left.semi_axes_m = 0.5f * (left.semi_axes_m + right.semi_axes_m);
  right.center_m = mirror_x(left.center_m);
  right.semi_axes_m = left.semi_axes_m;
}

}  // namespace

BodyModel symmetrised(const BodyModel& model) {
  BodyModel out = model;
  auto twin = [](const std::string& left) { return "r_" + left.substr(2); };
  for (rig::JointDesc& l : out.skeleton.joints) {
    if (l.name.rfind("l_", 0) != 0) continue;
    for (rig::JointDesc& r : out.skeleton.joints) {
      if (r.name != twin(l.name)) continue;
      l.offset_m = 0.5f * (l.offset_m + mirror_x(r.offset_m));
      l.tip_m = 0.5f * (l.tip_m + mirror_x(r.tip_m));
      r.offset_m = mirror_x(l.offset_m);
      r.tip_m = mirror_x(l.tip_m);
    }
  }
  for (Primitive& l : out.primitives) {
    if (l.name.rfind("l_", 0) != 0 || l.part != RigidPart::none) continue;
    for (Primitive& r : out.primitives) {
      if (r.name != twin(l.name)) continue;
      symmetrise(l.state, r.state);
      if (l.deformation && r.deformation) {
        symmetrise(l.deformation->at_min, r.deformation->at_min);
        symmetrise(l.deformation->at_max, r.deformation->at_max);
      }
    }
  }
  return out;
}

std::string body_overrides_json(const BodyModel& authored, const BodyModel& fitted) {
  std::string joints, prims;
  auto append = [](std::string& to, const json& entry) { to += (to.empty() ? "\n    " : ",\n    ") + entry.dump(); };
  for (const rig::JointDesc& j : fitted.skeleton.joints)
    for (const rig::JointDesc& a : authored.skeleton.joints)
      if (a.name == j.name && (differs(a.offset_m, j.offset_m) || differs(a.tip_m, j.tip_m)))
        append(joints, json{{"name", j.name}, {"offset", json_vec3(j.offset_m)}, {"tip", json_vec3(j.tip_m)}});
  for (const Primitive& p : fitted.primitives) {
    if (p.part != RigidPart::none) continue;
    for (const Primitive& a : authored.primitives) {
      if (a.name != p.name) continue;
      const bool moved = differs(a.state, p.state) || (a.deformation && p.deformation &&
                                                       (differs(a.deformation->at_min, p.deformation->at_min) ||
                                                        differs(a.deformation->at_max, p.deformation->at_max)));
      if (!moved) continue;
      json e = state_json(p.state);
      e["name"] = p.name;
      if (p.deformation) e["min"] = state_json(p.deformation->at_min), e["max"] = state_json(p.deformation->at_max);
      append(prims, e);
    }
  }
  return "{\"format\": \"mimic-body-overrides\", \"version\": 1,\n  \"joints\": [" + joints +
         "\n  ],\n  \"primitives\": [" + prims + "\n  ]\n}\n";
}

Result<BodyModel> apply_body_overrides(const BodyModel& base, std::string_view text,
                                       std::vector<std::string>* unmatched) {
  const json root = json::parse(text.begin(), text.end(), nullptr, false);
  if (root.is_discarded() || !root.is_object() || root.value("format", "") != "mimic-body-overrides" ||
      root.value("version", 0) != 1)
    return fail(Errc::parse_error, "body overrides: not a version 1 mimic-body-overrides table");
  BodyModel out = base;
  auto skipped = [&](const std::string& name) {
    if (unmatched) unmatched->push_back(name);
  };
  for (const json& e : root.value("joints", json::array())) {
    const std::string name = e.is_object() ? e.value("name", "") : "";
    rig::JointDesc* joint = nullptr;
    for (rig::JointDesc& j : out.skeleton.joints)
      if (j.name == name) joint = &j;
    if (!joint) {
      skipped(name);
      continue;
    }
    if (!read_vec3(e, "offset", joint->offset_m) || !read_vec3(e, "tip", joint->tip_m))
      return fail(Errc::parse_error, "body overrides: joint '" + name + "' is malformed");
  }
  for (const json& e : root.value("primitives", json::array())) {
    const std::string name = e.is_object() ? e.value("name", "") : "";
    Primitive* prim = nullptr;
    for (Primitive& p : out.primitives)
      if (p.name == name) prim = &p;
    if (!prim || prim->part != RigidPart::none) {
      skipped(name);
      continue;
    }
    if (!apply_primitive(e, *prim))
      return fail(Errc::parse_error, "body overrides: primitive '" + name + "' is malformed");
  }
  if (auto st = validate(out); !st) return tl::unexpected(st.error());
  return out;
}

BodyModel default_body_model() {
  BodyModel authored = authored_body_model();
  auto fitted = apply_body_overrides(authored, default_body_fit_json());
  // The table is compiled in and tested (body_overrides_test.cpp); the authored body is the
  // fallback should it ever not apply.
  return fitted ? std::move(*fitted) : authored;
}

}  // namespace mimic::avatar
