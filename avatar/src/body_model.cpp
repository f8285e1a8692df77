#include "mimic/avatar/body_model.h"

#include <cmath>
#include <set>

#include <nlohmann/json.hpp>

#include "mimic/core/file.h"
#include "mimic/core/json_io.h"
#include "mimic/rig/skeleton_json.h"

namespace mimic::avatar {

namespace {

constexpr const char* kGroupNames[kGroupCount] = {"upper_torso",     "lower_torso",     "hip",
                                                  "left_shoulder",   "right_shoulder",  "left_upper_arm",
                                                  "right_upper_arm", "left_lower_arm",  "right_lower_arm",
                                                  "left_upper_leg",  "right_upper_leg", "left_lower_leg",
                                                  "right_lower_leg", "left_ankle",      "right_ankle"};

constexpr const char* kPartNames[kRigidPartCount + 1] = {"none",       "head",      "left_hand",
                                                         "right_hand", "left_foot", "right_foot"};

constexpr int kFormatVersion = 1;

Group mirror(Group g) {
  switch (g) {
    case Group::left_shoulder: return Group::right_shoulder;
    case Group::left_upper_arm: return Group::right_upper_arm;
    case Group::left_lower_arm: return Group::right_lower_arm;
    case Group::left_upper_leg: return Group::right_upper_leg;
    case Group::left_lower_leg: return Group::right_lower_leg;
    case Group::left_ankle: return Group::right_ankle;
    default: return g;
  }
}

GroupMask mirror_mask(GroupMask m) {
  GroupMask out = 0;
  for (int g = 0; g < kGroupCount; ++g)
    if (m & (1u << g)) out |= group_bit(mirror(static_cast<Group>(g)));
  return out;
}

std::string mirror_name(const std::string& s) { return s.rfind("l_", 0) == 0 ? "r_" + s.substr(2) : s; }

PrimitiveState mirror_state(PrimitiveState s) {
  s.center_m.x = -s.center_m.x;
  // A reflection in x keeps the x rotation and negates the y and z rotations.
  s.orientation_rad.y = -s.orientation_rad.y;
  s.orientation_rad.z = -s.orientation_rad.z;
  return s;
}

using nlohmann::json;

double rounded(float v) { return json_rounded(v); }
json vec(const glm::vec3& v) { return json_vec3(v); }

// Defaults are left out: kind metaball, weight 1, zero orientation; a deformation state's centre
// and orientation when they equal G0's.
json state_json(const PrimitiveState& s, const PrimitiveState* base = nullptr) {
  json j{{"semi_axes", vec(s.semi_axes_m)}};
  if (!base || vec(s.center_m) != vec(base->center_m)) j["center"] = vec(s.center_m);
  const json o = vec(glm::degrees(s.orientation_rad));
  const json base_o = vec(base ? glm::degrees(base->orientation_rad) : glm::vec3(0));
  if (o != base_o) j["orientation_deg"] = o;
  return j;
}

json primitive_json(const Primitive& p) {
  json groups = json::array();
  for (int g = 0; g < kGroupCount; ++g)
    if (p.groups & (1u << g)) groups.push_back(kGroupNames[g]);
  json pj{{"name", p.name},
          {"joint", p.joint},
          {"influence", rounded(p.influence)},
          {"groups", groups},
          {"state", state_json(p.state)}};
  if (p.kind != PrimitiveKind::metaball) pj["kind"] = "ellipsoid";
  if (rounded(p.weight) != 1.0) pj["weight"] = rounded(p.weight);
  if (p.part != RigidPart::none) pj["part"] = rigid_part_name(p.part);
  if (p.deformation) {
    pj["deformation"] = json{{"dof", p.deformation->dof},
                             {"falloff", falloff_name(p.deformation->falloff)},
                             {"min", state_json(p.deformation->at_min, &p.state)},
                             {"max", state_json(p.deformation->at_max, &p.state)}};
  }
  return pj;
}

PrimitiveState read_state(JsonReader& r, const json& obj, const std::string& path, const PrimitiveState& fallback) {
  PrimitiveState s;
  s.semi_axes_m = r.vec3(obj, path, "semi_axes", fallback.semi_axes_m, true);
  s.center_m = r.vec3(obj, path, "center", fallback.center_m);
  s.orientation_rad = glm::radians(r.vec3(obj, path, "orientation_deg", glm::degrees(fallback.orientation_rad)));
  return s;
}

}  // namespace

Primitive mirrored(const Primitive& p) {
  Primitive q = p;
  q.name = mirror_name(p.name);
  q.joint = mirror_name(p.joint);
  q.groups = mirror_mask(p.groups);
  if (p.part == RigidPart::left_hand) q.part = RigidPart::right_hand;
  if (p.part == RigidPart::left_foot) q.part = RigidPart::right_foot;
  q.state = mirror_state(p.state);
  if (q.deformation) {
    q.deformation->dof = mirror_name(p.deformation->dof);
    q.deformation->at_min = mirror_state(p.deformation->at_min);
    q.deformation->at_max = mirror_state(p.deformation->at_max);
  }
  return q;
}

const char* group_name(Group g) { return kGroupNames[static_cast<int>(g)]; }

std::optional<Group> group_from_name(std::string_view name) {
  for (int i = 0; i < kGroupCount; ++i)
    if (name == kGroupNames[i]) return static_cast<Group>(i);
  return std::nullopt;
}

const char* rigid_part_name(RigidPart p) { return kPartNames[static_cast<int>(p)]; }

std::optional<RigidPart> rigid_part_from_name(std::string_view name) {
  for (int i = 0; i <= kRigidPartCount; ++i)
    if (name == kPartNames[i]) return static_cast<RigidPart>(i);
  return std::nullopt;
}

const char* falloff_name(Falloff f) {
  switch (f) {
    case Falloff::linear: return "linear";
    case Falloff::parabolic: return "parabolic";
    case Falloff::hyperbolic: return "hyperbolic";
  }
  return "linear";
}

float falloff_value(Falloff f, float t) {
  switch (f) {
    case Falloff::linear: return t;
    case Falloff::parabolic: return t * t;
    case Falloff::hyperbolic: return std::sqrt(t);
  }
  return t;
}

Status validate(const BodyModel& model) {
  auto skel = rig::Skeleton::build(model.skeleton);
  if (!skel) return fail(Errc::invalid_argument, "skeleton: " + skel.error().message);
  if (model.primitives.empty()) return fail(Errc::invalid_argument, "body has no primitives");
  std::set<std::string> names;
  GroupMask covered = 0;
  for (size_t i = 0; i < model.primitives.size(); ++i) {
    const Primitive& p = model.primitives[i];
    const std::string where = "primitive " + std::to_string(i) + " ('" + p.name + "')";
    if (p.name.empty()) return fail(Errc::invalid_argument, where + ": has no name");
    if (!names.insert(p.name).second) return fail(Errc::invalid_argument, where + ": duplicate name");
    const int j = skel->find_joint(p.joint);
    if (j < 0) return fail(Errc::invalid_argument, where + ": unknown joint '" + p.joint + "'");
    auto check_state = [&](const PrimitiveState& s, const char* which) -> Status {
      for (int k = 0; k < 3; ++k)
        if (!(s.semi_axes_m[k] > 1e-4f && s.semi_axes_m[k] < 2.0f))
          return fail(Errc::invalid_argument, where + ": " + which + " semi-axes must be in (0.1 mm, 2 m)");
      return {};
    };
    if (auto st = check_state(p.state, "G0"); !st) return st;
    if (!(p.weight > 0.0f && p.weight < 100.0f))
      return fail(Errc::invalid_argument, where + ": weight must be in (0, 100)");
    if (!(p.influence > 1.05f && p.influence < 10.0f))
      return fail(Errc::invalid_argument, where + ": influence must be in (1.05, 10)");
    if (p.groups == 0 && p.part == RigidPart::none)
      return fail(Errc::invalid_argument, where + ": belongs to no group and no rigid part");
    if (p.groups >> kGroupCount) return fail(Errc::invalid_argument, where + ": unknown group bits");
    covered |= p.groups;
    if (p.deformation) {
      const int d = skel->find_dof(p.deformation->dof);
      if (d < 0) return fail(Errc::invalid_argument, where + ": unknown DOF '" + p.deformation->dof + "'");
      if (auto st = check_state(p.deformation->at_min, "G_min"); !st) return st;
      if (auto st = check_state(p.deformation->at_max, "G_max"); !st) return st;
    }
  }
  for (int g = 0; g < kGroupCount; ++g)
    if (!(covered & (1u << g)))
      return fail(Errc::invalid_argument, std::string("group '") + kGroupNames[g] + "' has no primitive");
  const SkinLayout& s = model.skin;
  if (s.torso_points != 2 * s.chest_front_arc + 2 * s.chest_side_arc || s.chest_front_arc < 2 || s.chest_side_arc < 2)
    return fail(Errc::invalid_argument,
                "skin: torso_points must equal 2*chest_front_arc + 2*chest_side_arc (front and back "
                "arcs have chest_front_arc segments each), both at least 2");
  if (s.torso_points % 2 != 0 || s.torso_points < 8 || s.torso_points > 512)
    return fail(Errc::invalid_argument, "skin: torso_points must be even and in [8, 512]");
  if (s.shoulder_bridge < 2 || s.crotch_bridge < 1 || s.shoulder_bridge > 256 || s.crotch_bridge > 256)
    return fail(Errc::invalid_argument, "skin: bridges need 2..256 (shoulder) and 1..256 (crotch) segments");
  const int k = s.boundary_contours;
  if (k < 0 || k > 32) return fail(Errc::invalid_argument, "skin: boundary_contours must be in [0, 32]");
  for (auto [n, what] : {std::pair{s.lower_torso_contours, "lower_torso_contours"},
                         {s.upper_torso_contours, "upper_torso_contours"},
                         {s.neck_contours, "neck_contours"},
                         {s.upper_arm_contours, "upper_arm_contours"},
                         {s.lower_arm_contours, "lower_arm_contours"},
                         {s.upper_leg_contours, "upper_leg_contours"},
                         {s.lower_leg_contours, "lower_leg_contours"}})
    if (n < 3 || n > 256) return fail(Errc::invalid_argument, std::string("skin: ") + what + " must be in [3, 256]");
  for (auto [n, what] : {std::pair{s.neck_contours, "neck_contours"},
                         {s.upper_arm_contours, "upper_arm_contours"},
                         {s.upper_leg_contours, "upper_leg_contours"}})
    if (n < k + 3)
      return fail(Errc::invalid_argument, std::string("skin: ") + what + " must exceed boundary_contours + 2");
  for (auto [n, what] :
       {std::pair{s.neck_points, "neck_points"}, {s.arm_points, "arm_points"}, {s.leg_points, "leg_points"}})
    if (n != 0 && (n < 3 || n > 512))
      return fail(Errc::invalid_argument, std::string("skin: ") + what + " must be 0 (the loop's) or in [3, 512]");
  if (s.rigid_rings < 3 || s.rigid_points < 4 || s.rigid_rings > 256 || s.rigid_points > 256)
    return fail(Errc::invalid_argument, "skin: rigid meshes need 3..256 rings and 4..256 points");
  if (!(s.chest_ring >= 0.0f && s.chest_ring < 0.9f) || !(s.neck_start > 0.0f && s.neck_start < 1.0f) ||
      !(s.crotch_drop_m >= 0.0f && s.crotch_drop_m < 0.5f))
    return fail(Errc::invalid_argument, "skin: chest_ring, neck_start or crotch_drop_m out of range");
  return {};
}

std::string to_json(const BodyModel& model, bool pretty) {
  json j;
  j["format"] = "mimic-body";
  j["version"] = kFormatVersion;
  j["name"] = model.name;
  j["skeleton"] = rig::skeleton_json(model.skeleton);
  // A right-side primitive that is the exact mirror image of its left twin is written once,
  // on the left, as "mirror": true.
  std::vector<char> written_as_mirror(model.primitives.size(), 0);
  json prims = json::array();
  for (size_t i = 0; i < model.primitives.size(); ++i) {
    if (written_as_mirror[i]) continue;
    const Primitive& p = model.primitives[i];
    json pj = primitive_json(p);
    if (p.name.rfind("l_", 0) == 0) {
      const json twin = primitive_json(mirrored(p));
      for (size_t k = 0; k < model.primitives.size(); ++k)
        if (!written_as_mirror[k] && model.primitives[k].name == twin["name"] &&
            primitive_json(model.primitives[k]) == twin) {
          written_as_mirror[k] = 1;
          pj["mirror"] = true;
          break;
        }
    }
    prims.push_back(std::move(pj));
  }
  j["primitives"] = prims;
  const SkinLayout& s = model.skin;
  j["skin"] = json{{"pieces", json::array({"neck", "upper_torso", "lower_torso", "left_upper_arm", "right_upper_arm",
                                           "left_lower_arm", "right_lower_arm", "left_upper_leg", "right_upper_leg",
                                           "left_lower_leg", "right_lower_leg"})},
                   {"torso_points", s.torso_points},
                   {"chest_front_arc", s.chest_front_arc},
                   {"chest_side_arc", s.chest_side_arc},
                   {"shoulder_bridge", s.shoulder_bridge},
                   {"crotch_bridge", s.crotch_bridge},
                   {"lower_torso_contours", s.lower_torso_contours},
                   {"upper_torso_contours", s.upper_torso_contours},
                   {"neck_contours", s.neck_contours},
                   {"upper_arm_contours", s.upper_arm_contours},
                   {"lower_arm_contours", s.lower_arm_contours},
                   {"upper_leg_contours", s.upper_leg_contours},
                   {"lower_leg_contours", s.lower_leg_contours},
                   {"boundary_contours", s.boundary_contours},
                   {"rigid_rings", s.rigid_rings},
                   {"rigid_points", s.rigid_points},
                   {"crotch_drop_m", rounded(s.crotch_drop_m)},
                   {"chest_ring", rounded(s.chest_ring)},
                   {"neck_start", rounded(s.neck_start)}};
  // Per-limb point counts only when set (a layout made by skin_layout_for_lods), so files of
  // ordinary bodies stay as they were.
  for (auto [n, key] :
       {std::pair{s.neck_points, "neck_points"}, {s.arm_points, "arm_points"}, {s.leg_points, "leg_points"}})
    if (n != 0) j["skin"][key] = n;
  return j.dump(pretty ? 1 : -1, ' ');
}

// The optional "skin" section: the contour layout's counts (docs/body-model.md).
void read_skin_layout(const json& sj, JsonReader& r, SkinLayout& s) {
  const std::string path = "$.skin";
  s.torso_points = r.integer(sj, path, "torso_points", s.torso_points);
  s.chest_front_arc = r.integer(sj, path, "chest_front_arc", s.chest_front_arc);
  s.chest_side_arc = r.integer(sj, path, "chest_side_arc", s.chest_side_arc);
  s.shoulder_bridge = r.integer(sj, path, "shoulder_bridge", s.shoulder_bridge);
  s.crotch_bridge = r.integer(sj, path, "crotch_bridge", s.crotch_bridge);
  s.lower_torso_contours = r.integer(sj, path, "lower_torso_contours", s.lower_torso_contours);
  s.upper_torso_contours = r.integer(sj, path, "upper_torso_contours", s.upper_torso_contours);
  s.neck_contours = r.integer(sj, path, "neck_contours", s.neck_contours);
  s.upper_arm_contours = r.integer(sj, path, "upper_arm_contours", s.upper_arm_contours);
  s.lower_arm_contours = r.integer(sj, path, "lower_arm_contours", s.lower_arm_contours);
  s.upper_leg_contours = r.integer(sj, path, "upper_leg_contours", s.upper_leg_contours);
  s.lower_leg_contours = r.integer(sj, path, "lower_leg_contours", s.lower_leg_contours);
  s.boundary_contours = r.integer(sj, path, "boundary_contours", s.boundary_contours);
  s.neck_points = r.integer(sj, path, "neck_points", s.neck_points);
  s.arm_points = r.integer(sj, path, "arm_points", s.arm_points);
  s.leg_points = r.integer(sj, path, "leg_points", s.leg_points);
  s.rigid_rings = r.integer(sj, path, "rigid_rings", s.rigid_rings);
  s.rigid_points = r.integer(sj, path, "rigid_points", s.rigid_points);
  s.crotch_drop_m = r.number(sj, path, "crotch_drop_m", s.crotch_drop_m);
  s.chest_ring = r.number(sj, path, "chest_ring", s.chest_ring);
  s.neck_start = r.number(sj, path, "neck_start", s.neck_start);
}

Result<BodyModel> body_model_from_json(std::string_view text, std::string_view source_name) {
  const std::string src(source_name);
  json root;
  try {
    root = json::parse(text.begin(), text.end());
  } catch (const json::parse_error& e) {
    // nlohmann reports the byte offset; turn it into a line number for people.
    size_t line = 1;
    const size_t upto = std::min<size_t>(e.byte, text.size());
    for (size_t i = 0; i < upto; ++i) line += text[i] == '\n';
    return fail(Errc::parse_error, src + ":" + std::to_string(line) + ": invalid JSON (" + e.what() + ")");
  } catch (const json::exception& e) {
    // Well-formed but unreadable: a number no double holds (1e999) is out_of_range, not a parse error.
    return fail(Errc::parse_error, src + ": invalid JSON (" + e.what() + ")");
  }
  JsonReader r(src);
  BodyModel m;
  const std::string format = r.string(root, "$", "format", true);
  if (r.ok() && format != "mimic-body") r.fail_at("$.format", "expected \"mimic-body\", got \"" + format + "\"");
  const int version = r.integer(root, "$", "version", -1);
  if (r.ok() && version != kFormatVersion)
    r.fail_at("$.version", "unsupported version " + std::to_string(version) + " (this build reads " +
                               std::to_string(kFormatVersion) + ")");
  m.name = r.string(root, "$", "name", false, "unnamed");

  if (const json* sk = r.member(root, "$", "skeleton", true); sk && r.ok())
    m.skeleton = rig::read_skeleton_json(*sk, "$.skeleton", r);

  if (const json* prims = r.member(root, "$", "primitives", true); prims && r.ok()) {
    std::vector<Primitive> mirrors;  // right-side twins of "mirror": true primitives, appended
    if (!prims->is_array()) r.fail_at("$.primitives", "expected an array");
    for (size_t i = 0; r.ok() && prims->is_array() && i < prims->size(); ++i) {
      const json& pj = (*prims)[i];
      const std::string path = "$.primitives[" + std::to_string(i) + "]";
      Primitive p;
      p.name = r.string(pj, path, "name", true);
      p.joint = r.string(pj, path, "joint", true);
      const std::string kind = r.string(pj, path, "kind", false, "metaball");
      if (kind == "metaball")
        p.kind = PrimitiveKind::metaball;
      else if (kind == "ellipsoid")
        p.kind = PrimitiveKind::ellipsoid;
      else
        r.fail_at(path + ".kind", "expected \"metaball\" or \"ellipsoid\", got \"" + kind + "\"");
      p.weight = r.number(pj, path, "weight", 1.0f);
      p.influence = r.number(pj, path, "influence", 1.6f);
      if (const json* groups = r.member(pj, path, "groups", false); groups) {
        if (!groups->is_array()) r.fail_at(path + ".groups", "expected an array of group names");
        for (size_t g = 0; r.ok() && groups->is_array() && g < groups->size(); ++g) {
          const json& gj = (*groups)[g];
          auto grp = gj.is_string() ? group_from_name(gj.get<std::string>()) : std::nullopt;
          if (!grp)
            r.fail_at(path + ".groups[" + std::to_string(g) + "]", "unknown group " + gj.dump());
          else
            p.groups |= group_bit(*grp);
        }
      }
      const std::string part = r.string(pj, path, "part", false, "none");
      if (auto rp = rigid_part_from_name(part))
        p.part = *rp;
      else
        r.fail_at(path + ".part", "unknown rigid part \"" + part + "\"");
      if (const json* st = r.member(pj, path, "state", true); st && r.ok())
        p.state = read_state(r, *st, path + ".state", PrimitiveState{});
      if (const json* dj = r.member(pj, path, "deformation", false); dj && r.ok()) {
        Deformation d;
        d.dof = r.string(*dj, path + ".deformation", "dof", true);
        const std::string f = r.string(*dj, path + ".deformation", "falloff", false, "linear");
        if (f == "linear")
          d.falloff = Falloff::linear;
        else if (f == "parabolic")
          d.falloff = Falloff::parabolic;
        else if (f == "hyperbolic")
          d.falloff = Falloff::hyperbolic;
        else
          r.fail_at(path + ".deformation.falloff", "expected linear, parabolic or hyperbolic");
        if (const json* mn = r.member(*dj, path + ".deformation", "min", true); mn && r.ok())
          d.at_min = read_state(r, *mn, path + ".deformation.min", p.state);
        if (const json* mx = r.member(*dj, path + ".deformation", "max", true); mx && r.ok())
          d.at_max = read_state(r, *mx, path + ".deformation.max", p.state);
        p.deformation = d;
      }
      if (const json* mj = r.member(pj, path, "mirror", false); mj) {
        if (!mj->is_boolean())
          r.fail_at(path + ".mirror", "expected true or false");
        else if (mj->get<bool>() && p.name.rfind("l_", 0) != 0)
          r.fail_at(path + ".mirror", "only a left-side (\"l_…\") primitive can be mirrored");
        else if (mj->get<bool>())
          mirrors.push_back(mirrored(p));
      }
      m.primitives.push_back(std::move(p));
    }
    for (Primitive& q : mirrors) m.primitives.push_back(std::move(q));
  }

  if (const json* sj = r.member(root, "$", "skin", false); sj && r.ok()) read_skin_layout(*sj, r, m.skin);
  if (!r.ok()) return fail(Errc::parse_error, r.error());
  if (auto st = validate(m); !st) return fail(Errc::parse_error, src + ": " + st.error().message);
  return m;
}

Result<BodyModel> load_body_model(const std::string& path) {
  auto text = read_file(path);
  if (!text) return tl::unexpected(text.error());
  return body_model_from_json(*text, path);
}

Status save_body_model(const BodyModel& model, const std::string& path) {
  if (auto st = validate(model); !st) return st;
  return write_file_atomic(path, to_json(model) + "\n");
}

}  // namespace mimic::avatar
