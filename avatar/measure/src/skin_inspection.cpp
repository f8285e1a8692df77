#include "mimic/avatar/skin_inspection.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include "mimic/avatar/baselines/baseline_skinner.h"
#include "mimic/avatar/joint_zone.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin.h"
#include "mimic/avatar/skin_lod.h"

namespace mimic::avatar {

std::vector<JointSweep> standard_joint_sweeps(const BodyModel& model) {
  auto half = [&](const char* joint) {
    auto s = rig::Skeleton::build(model.skeleton);
    if (!s) return 0.08f;
    const int j = s->find_joint(joint);
    if (j < 0 || s->parent(j) < 0) return 0.08f;
    return 0.35f * std::min(glm::length(s->tip_m(j)), glm::length(s->tip_m(s->parent(j))));
  };
  std::vector<float> flexion, twist;
  for (int a = 0; a <= 150; a += 10) flexion.push_back(float(a));
  twist.push_back(0);
  for (int a = 15; a <= 90; a += 15) {
    twist.push_back(float(-a));
    twist.push_back(float(a));
  }
  return {
      {"elbow_flexion", "l_elbow_flexion", "l_elbow", {"left_upper_arm", "left_lower_arm"}, half("l_elbow"), flexion},
      {"knee_flexion", "l_knee_flexion", "l_knee", {"left_upper_leg", "left_lower_leg"}, half("l_knee"), flexion},
      {"forearm_twist", "l_forearm_twist", "l_elbow", {"left_upper_arm", "left_lower_arm"}, half("l_elbow"), twist}};
}

namespace {

constexpr float kDeg = 3.14159265f / 180.0f;

struct Measures {
  double volume = 0;
  std::array<double, 5> sections{};
};

Measures measure(std::span<const glm::vec3> positions, const Mesh& topology, std::span<const uint32_t> tris,
                 const JointZone& zone) {
  Measures m;
  m.volume = joint_zone_volume(positions, topology.indices, tris, zone);
  const auto stations = joint_zone_stations(zone);
  for (size_t k = 0; k < stations.size(); ++k)
    m.sections[k] =
        joint_zone_section_area(positions, topology.indices, tris, zone, stations[k].first, stations[k].second);
  return m;
}

// Distance from p to the segment [a, b].
float to_segment(const glm::vec3& p, const glm::vec3& a, const glm::vec3& b) {
  const glm::vec3 ab = b - a;
  const float t = std::clamp(glm::dot(p - a, ab) / std::max(glm::dot(ab, ab), 1e-12f), 0.0f, 1.0f);
  return glm::length(p - (a + t * ab));
}

// The vertices of `tris` and their distance to the two links (parent joint → joint → the joint's
// tip), the zone's vertices marked.
struct StandOff {
  std::vector<uint32_t> vertices;
  std::vector<float> distance;
  std::vector<uint8_t> in_zone;
};

StandOff stand_off(std::span<const glm::vec3> positions, const Mesh& topology, std::span<const uint32_t> tris,
                   const JointZone& zone, const glm::vec3& parent, const glm::vec3& tip) {
  StandOff s;
  std::vector<uint8_t> seen(positions.size(), 0);
  for (uint32_t t : tris)
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = topology.indices[3 * t + k];
      if (!seen[v]) seen[v] = 1, s.vertices.push_back(v);
    }
  std::sort(s.vertices.begin(), s.vertices.end());
  for (uint32_t v : s.vertices) {
    const glm::vec3& p = positions[v];
    s.distance.push_back(std::min(to_segment(p, parent, zone.center_m), to_segment(p, zone.center_m, tip)));
    const glm::vec3 d = p - zone.center_m;
    s.in_zone.push_back(glm::dot(d, zone.proximal_dir) <= zone.half_length_m &&
                        glm::dot(d, zone.distal_dir) <= zone.half_length_m);
  }
  return s;
}

}  // namespace

Result<std::vector<SweepResult>> inspect_joint_zones(const BodyModel& base_model, const std::vector<JointSweep>& sweeps,
                                                     const InspectOptions& options) {
  const BodyModel model = with_skin_lod(base_model, options.lod);
  SkinOptions so;
  so.subdivision = 0;  // the realtime resolution: contour points are the vertices
  so.rigid_parts = false;
  so.normals = false;
  auto full = ImplicitSkin::create(model, so);
  if (!full) return tl::unexpected(full.error());
  const rig::Skeleton& skeleton = full->skeleton();
  RealtimeOptions ro;
  ro.rigid_parts = false;
  // The joint's own deformation, as the other methods have it: no contact (which turns an arm
  // whose folded forearm reaches the chest, out of the frames the zone is measured in).
  ro.contact = false;
  auto body = RealtimeBody::create(model, skeleton, ro);
  if (!body) return tl::unexpected(body.error());
  RealtimeSkin realtime(*body);
  const Mesh& rest = (*body)->rest_mesh();
  std::vector<rig::RigidTransform> w(skeleton.joint_count());
  rig::forward_kinematics(skeleton, skeleton.zero_pose(), w);
  auto baselines =
      baselines::BaselineSkinner::create(skeleton, w, rest, baselines::from_influences((*body)->weights()));
  if (!baselines) return tl::unexpected(baselines.error());
  std::vector<glm::vec3> positions(rest.positions.size());

  struct Method {
    const char* name;
    const Mesh* topology;
    std::function<std::span<const glm::vec3>(const rig::Pose&)> pose;
  };
  std::vector<Method> methods{
      {"full", nullptr,
       [&](const rig::Pose& p) {
         full->evaluate(p);
         return std::span<const glm::vec3>(full->mesh().positions);
       }},
      {"realtime", &rest,
       [&](const rig::Pose& p) {
         realtime.evaluate(p, positions, {}, options.muscles);
         return std::span<const glm::vec3>(positions);
       }},
  };
  for (auto m : {baselines::SkinningMethod::lbs, baselines::SkinningMethod::dqs, baselines::SkinningMethod::cor})
    methods.push_back({baselines::method_name(m), &rest, [&, m](const rig::Pose& p) {
                         rig::forward_kinematics(skeleton, p, w);
                         baselines->set_pose(w);
                         baselines->deform(m, positions);
                         return std::span<const glm::vec3>(positions);
                       }});

  std::vector<SweepResult> results;
  for (const JointSweep& sweep : sweeps) {
    const int dof = skeleton.find_dof(sweep.dof), joint = skeleton.find_joint(sweep.joint);
    if (dof < 0 || joint < 0 || skeleton.parent(joint) < 0)
      return fail(Errc::not_found, "inspect: sweep " + sweep.name + " names an unknown DOF or joint");
    if (sweep.angles_deg.empty())
      return fail(Errc::invalid_argument, "inspect: sweep " + sweep.name + " has no angles");
    SweepResult r{sweep, {}};
    for (Method& method : methods) {
      const Mesh& topology = method.topology ? *method.topology : full->mesh();
      const std::vector<uint32_t> tris = part_triangles(topology, sweep.parts);
      if (tris.empty()) return fail(Errc::not_found, "inspect: the skin has none of the parts of sweep " + sweep.name);
      MethodSweep ms{method.name, {}};
      Measures relaxed;
      StandOff relaxed_off;
      for (size_t k = 0; k < sweep.angles_deg.size(); ++k) {
        rig::Pose p = skeleton.zero_pose();
        p.dof_rad[dof] = sweep.angles_deg[k] * kDeg;
        std::vector<rig::RigidTransform> pw(skeleton.joint_count());
        rig::forward_kinematics(skeleton, p, pw);
        const glm::vec3 c = pw[joint].translation;
        const JointZone zone{c, glm::normalize(pw[skeleton.parent(joint)].translation - c),
                             glm::normalize(pw[joint].apply(skeleton.tip_m(joint)) - c), sweep.half_length_m};
        const std::span<const glm::vec3> posed = method.pose(p);
        const Measures m = measure(posed, topology, tris, zone);
        const StandOff off = stand_off(posed, topology, tris, zone, pw[skeleton.parent(joint)].translation,
                                       pw[joint].apply(skeleton.tip_m(joint)));
        if (k == 0) relaxed = m, relaxed_off = off;
        SweepSample s{sweep.angles_deg[k], 100.0 * (m.volume / relaxed.volume - 1.0), INFINITY};
        for (size_t i = 0; i < off.vertices.size(); ++i)
          if (off.in_zone[i])
            s.stand_off_mm = std::max(s.stand_off_mm, 1000.0 * (off.distance[i] - relaxed_off.distance[i]));
        for (size_t i = 0; i < m.sections.size(); ++i)
          if (relaxed.sections[i] > 0)
            s.min_section_fraction = std::min(s.min_section_fraction, m.sections[i] / relaxed.sections[i]);
        if (!std::isfinite(s.min_section_fraction)) s.min_section_fraction = 0;
        ms.samples.push_back(s);
      }
      r.methods.push_back(std::move(ms));
    }
    results.push_back(std::move(r));
  }
  return results;
}

}  // namespace mimic::avatar
