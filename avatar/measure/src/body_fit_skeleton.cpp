// The fit's first step (the skeleton to the reference's joints) and what every step measures:
// the body skinned in the reference's posture, its folds and closure.
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <glm/gtx/euler_angles.hpp>

#include "body_fit_internal.h"
#include "mimic/avatar/body_fit.h"
#include "mimic/avatar/mesh_check.h"

namespace mimic::avatar {

namespace fit_detail {

Result<SkinnedLike> skin_like(const BodyModel& model, const BodyLandmarks& reference, int subdivision) {
  SkinOptions options;
  options.subdivision = subdivision;
  auto skin = ImplicitSkin::create(model, options);
  if (!skin) return tl::unexpected(skin.error());
  rig::Pose pose = pose_to_match(skin->skeleton(), reference);
  skin->evaluate(pose);
  return SkinnedLike{std::move(*skin), std::move(pose)};
}

}  // namespace fit_detail

int count_folds(const Mesh& mesh, float min_area_m2, std::vector<int>* per_part, std::vector<glm::vec3>* where) {
  const size_t n = mesh.triangle_count();
  std::vector<glm::vec3> normal(n);
  std::vector<float> area(n);
  for (size_t t = 0; t < n; ++t) {
    const glm::vec3 a = mesh.positions[mesh.indices[3 * t]], b = mesh.positions[mesh.indices[3 * t + 1]],
                    c = mesh.positions[mesh.indices[3 * t + 2]];
    const glm::vec3 cr = glm::cross(b - a, c - a);
    area[t] = 0.5f * glm::length(cr);
    normal[t] = area[t] > 0.0f ? cr / (2.0f * area[t]) : glm::vec3(0.0f);
  }
  // Edge → the first triangle seen on it; the second one closes the pair.
  std::unordered_map<uint64_t, uint32_t> first;
  first.reserve(3 * n);
  int folds = 0;
  if (per_part) per_part->assign(mesh.parts.size(), 0);
  if (where) where->clear();
  const float cos_150 = -0.8660254f;
  for (size_t t = 0; t < n; ++t)
    for (int e = 0; e < 3; ++e) {
      const uint32_t i = mesh.indices[3 * t + e], j = mesh.indices[3 * t + (e + 1) % 3];
      const uint64_t key = (uint64_t(std::min(i, j)) << 32) | std::max(i, j);
      auto [it, inserted] = first.emplace(key, static_cast<uint32_t>(t));
      if (inserted) continue;
      const uint32_t u = it->second;
      if (!(area[u] >= min_area_m2 && area[t] >= min_area_m2 && glm::dot(normal[u], normal[t]) < cos_150)) continue;
      ++folds;
      if (where) where->push_back(0.5f * (mesh.positions[i] + mesh.positions[j]));
      if (per_part)
        for (size_t k = 0; k < mesh.parts.size(); ++k)
          if (t >= mesh.parts[k].first_triangle && t < mesh.parts[k].first_triangle + mesh.parts[k].triangle_count)
            (*per_part)[k]++;
    }
  return folds;
}

Result<PosedBody> pose_body_like(const BodyModel& model, const BodyLandmarks& reference, int subdivision) {
  auto s = fit_detail::skin_like(model, reference, subdivision);
  if (!s) return tl::unexpected(s.error());
  PosedBody b;
  b.mesh = s->skin.mesh();
  b.landmarks = landmarks_from_skeleton(s->skin.skeleton(), s->pose);
  b.pose = s->pose;
  b.folds = count_folds(b.mesh, 1e-5f, &b.part_folds, &b.fold_points);
  b.closed = is_closed_oriented_manifold(analyze_topology(b.mesh));
  b.missed_rays = s->skin.stats().missed_rays;
  return b;
}

namespace {

rig::JointDesc* find(rig::SkeletonDesc& d, const std::string& name) {
  for (auto& j : d.joints)
    if (j.name == name) return &j;
  return nullptr;
}

// Each primitive follows its joint's link from `old_tip` to `new_tip`: the part of its centre
// along the link, and a semi-axis lying along it, scale with the link's length.
void follow_link(PrimitiveState& st, const glm::vec3& old_tip, const glm::vec3& new_tip) {
  const float old_len = glm::length(old_tip), new_len = glm::length(new_tip);
  if (!(old_len > 1e-6f) || !(new_len > 1e-6f)) return;
  const glm::vec3 u = old_tip / old_len;
  const float s = new_len / old_len;
  st.center_m += (s - 1.0f) * glm::dot(st.center_m, u) * u;
  const glm::mat3 r = glm::mat3(glm::eulerAngleZ(st.orientation_rad.z) * glm::eulerAngleY(st.orientation_rad.y) *
                                glm::eulerAngleX(st.orientation_rad.x));
  for (int a = 0; a < 3; ++a)
    if (std::abs(glm::dot(r[a], u)) > 0.8f) st.semi_axes_m[a] *= s;
}

glm::vec3 with_length(const glm::vec3& v, float length) {
  const float l = glm::length(v);
  return l > 1e-9f ? v * (length / l) : v;
}

}  // namespace

Result<BodyModel> fit_skeleton(const BodyModel& model, const BodyLandmarks& ref, bool hold_rigid) {
  auto skeleton = rig::Skeleton::build(model.skeleton);
  if (!skeleton) return tl::unexpected(skeleton.error());
  BodyModel out = model;
  rig::SkeletonDesc& d = out.skeleton;
  for (const char* name : {"pelvis",     "spine_lower", "spine_mid", "spine_upper", "neck",  "neck_upper", "head",
                           "l_clavicle", "l_shoulder",  "l_elbow",   "l_wrist",     "l_hip", "l_knee",     "l_ankle",
                           "r_clavicle", "r_shoulder",  "r_elbow",   "r_wrist",     "r_hip", "r_knee",     "r_ankle"})
    if (!find(d, name))
      return fail(Errc::invalid_argument, std::string("fit: the skeleton has no joint '") + name + "'");

  // Zero posture, root at the origin: joint frames are parallel to the world, so offsets are
  // world vectors.
  auto world_of = [](const rig::SkeletonDesc& desc) -> Result<std::unordered_map<std::string, glm::vec3>> {
    auto s = rig::Skeleton::build(desc);
    if (!s) return tl::unexpected(s.error());
    std::vector<rig::RigidTransform> w(s->joint_count());
    rig::forward_kinematics(*s, s->zero_pose(), w);
    std::unordered_map<std::string, glm::vec3> pos;
    for (int j = 0; j < s->joint_count(); ++j) pos[s->joint_name(j)] = w[j].translation;
    return pos;
  };
  auto before = world_of(d);
  if (!before) return tl::unexpected(before.error());
  std::unordered_map<std::string, glm::vec3> old_tip;
  std::unordered_map<std::string, std::string> main_child;  // a child whose offset is the tip
  for (const auto& j : d.joints) {
    old_tip[j.name] = j.tip_m;
    if (!j.parent.empty() && glm::length(j.offset_m - find(d, j.parent)->tip_m) < 1e-6f && !main_child.count(j.parent))
      main_child[j.parent] = j.name;
  }
  auto& b = *before;
  auto ratio = [](float want, float have) { return have > 1e-6f && want > 1e-6f ? want / have : 1.0f; };
  const float spine = ratio(ref.neck_m.y - ref.pelvis_m.y, b["neck"].y - b["pelvis"].y);
  for (const char* j : {"spine_lower", "spine_mid", "spine_upper", "neck"}) find(d, j)->offset_m *= spine;
  const float neck = ratio(ref.head_m.y - ref.neck_m.y, b["head"].y - b["neck"].y);
  for (const char* j : {"neck_upper", "head"}) find(d, j)->offset_m *= neck;
  find(d, "head")->tip_m = with_length(find(d, "head")->tip_m, glm::length(ref.head_top_m - ref.head_m));
  for (auto [p, limb] : {std::pair{"l_", &ref.left}, std::pair{"r_", &ref.right}}) {
    const std::string s = p;
    find(d, s + "hip")->offset_m = limb->hip_m - ref.pelvis_m;
    find(d, s + "knee")->offset_m = with_length(find(d, s + "knee")->offset_m, glm::length(limb->knee_m - limb->hip_m));
    find(d, s + "ankle")->offset_m =
        with_length(find(d, s + "ankle")->offset_m, glm::length(limb->ankle_m - limb->knee_m));
    find(d, s + "elbow")->offset_m =
        with_length(find(d, s + "elbow")->offset_m, glm::length(limb->elbow_m - limb->shoulder_m));
    find(d, s + "wrist")->offset_m =
        with_length(find(d, s + "wrist")->offset_m, glm::length(limb->wrist_m - limb->elbow_m));
  }
  // The shoulders last: where the clavicles now start depends on the spine above.
  auto moved = world_of(d);
  if (!moved) return tl::unexpected(moved.error());
  for (auto [p, limb] : {std::pair{"l_", &ref.left}, std::pair{"r_", &ref.right}}) {
    const std::string s = p;
    find(d, s + "shoulder")->offset_m = (limb->shoulder_m - ref.pelvis_m) - (*moved)[s + "clavicle"];
  }
  for (auto& j : d.joints)
    if (auto it = main_child.find(j.name); it != main_child.end()) j.tip_m = find(d, it->second)->offset_m;

  for (Primitive& prim : out.primitives) {
    const rig::JointDesc* j = find(d, prim.joint);
    if (!j || (hold_rigid && prim.part != RigidPart::none)) continue;
    follow_link(prim.state, old_tip[prim.joint], j->tip_m);
    if (prim.deformation) {
      follow_link(prim.deformation->at_min, old_tip[prim.joint], j->tip_m);
      follow_link(prim.deformation->at_max, old_tip[prim.joint], j->tip_m);
    }
  }
  if (auto st = validate(out); !st) return tl::unexpected(st.error());
  return out;
}

}  // namespace mimic::avatar
