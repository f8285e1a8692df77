// The arms keep off the body (realtime_contact.h, ContactTables::Arm; docs/skin.md, "The arms
// keep off the body").
#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <utility>
#include <vector>

#include <glm/gtx/euler_angles.hpp>
#include <glm/gtx/norm.hpp>

#include "contact_field.h"

namespace mimic::avatar::realtime_detail {

namespace {

using G = Group;

// One probe (centre `c`, semi-axes `axes` in the world) against one volume's `balls`: its centre
// and the ends of its axes, each inside taken to the volume's level, add the least turns about
// the shoulder that move them so, weighted by the fourth power of their size. Fixed points, so the pushes change with
// the pose continuously (a point taken up the field's gradient swung round the probe where the
// field is faint, and the turn jumped).
void add_probe_turns(const ContactTables& t, const ContactState& st, std::span<const uint16_t> balls,
                     const glm::vec3& c, const glm::mat3& axes, const glm::vec3& shoulder, glm::vec3& turn_sum,
                     float& weight_sum) {
  glm::vec3 sample[7];
  for (int e = 0; e < 7; ++e) sample[e] = e == 0 ? c : c + (e % 2 ? 1.0f : -1.0f) * axes[(e - 1) / 2];
  float value_at[8];
#ifdef MIMIC_SIMD_AVX2
  alignas(32) float xs[8], ys[8], zs[8];
  for (int e = 0; e < 7; ++e) xs[e] = sample[e].x, ys[e] = sample[e].y, zs[e] = sample[e].z;
  xs[7] = ys[7] = zs[7] = 1e6f;  // far from every ball
  _mm256_storeu_ps(value_at, field_values8(t, st, balls, xs, ys, zs));
#else
  for (int e = 0; e < 7; ++e) value_at[e] = field_value(t, balls, st, sample[e]);
#endif
  for (int e = 0; e < 7; ++e) {
    if (value_at[e] <= t.arm_iso) continue;
    const glm::vec3 s = sample[e];
    FieldAt f = field_at(t, balls, st, s);
    glm::vec3 q = s;
    for (int step = 0; step < ContactTables::kArmNewtonSteps && f.value > t.arm_iso; ++step) {
      const float g2 = glm::dot(f.gradient, f.gradient);
      if (!(g2 > 1e-12f)) break;
      q -= ((f.value - t.arm_iso) / g2) * f.gradient;
      if (step + 1 < ContactTables::kArmNewtonSteps) f = field_at(t, balls, st, q);
    }
    glm::vec3 push = q - s;
    const float push_m = glm::length(push);
    if (push_m > t.arm_full_push_m)
      push *= std::max(0.0f, (t.arm_no_push_m - push_m) / (t.arm_no_push_m - t.arm_full_push_m));
    const glm::vec3 r = s - shoulder;
    const float r2 = glm::dot(r, r);
    if (!(r2 > 1e-8f)) continue;
    const glm::vec3 turn = glm::cross(r, push) / r2;
    const float t2 = glm::dot(turn, turn);
    turn_sum += (t2 * t2) * turn, weight_sum += t2 * t2;
  }
}

}  // namespace

// ContactTables::arms, probes and volumes (build_contact).
void build_arm_clearance(const BodyModel& model, const rig::Skeleton& skeleton, std::span<const int> ball_of_primitive,
                         ContactTables& t) {
  const GroupMask volumes[ContactTables::kArmVolumes] = {group_bits({G::upper_torso, G::lower_torso, G::hip}),
                                                         group_bits({G::left_upper_leg}),
                                                         group_bits({G::right_upper_leg})};
  // A thigh's hip primitives are the torso's: the thighs' volumes leave them out.
  const GroupMask left_out[ContactTables::kArmVolumes] = {
      group_bits({G::left_shoulder, G::right_shoulder, G::left_upper_arm, G::right_upper_arm}), group_bits({G::hip}),
      group_bits({G::hip})};
  for (int v = 0; v < ContactTables::kArmVolumes; ++v) {
    t.volume_first[static_cast<size_t>(v)] = static_cast<uint32_t>(t.volume_balls.size());
    for (size_t i = 0; i < model.primitives.size(); ++i) {
      const GroupMask g = model.primitives[i].groups;
      if (ball_of_primitive[i] >= 0 && (g & volumes[v]) && !(g & left_out[v]))
        t.volume_balls.push_back(static_cast<uint16_t>(ball_of_primitive[i]));
    }
  }
  t.volume_first[ContactTables::kArmVolumes] = static_cast<uint32_t>(t.volume_balls.size());
  const struct {
    const char* shoulder;
    RigidPart hand;
    Group forearm;
  } sides[] = {{"l_shoulder", RigidPart::left_hand, G::left_lower_arm},
               {"r_shoulder", RigidPart::right_hand, G::right_lower_arm}};
  for (const auto& side : sides) {
    ContactTables::Arm arm;
    arm.shoulder = skeleton.find_joint(side.shoulder);
    if (arm.shoulder < 0) continue;
    arm.joint_first = static_cast<uint32_t>(t.arm_joints.size());
    for (int j = 0; j < skeleton.joint_count(); ++j) {
      int a = j;
      while (a >= 0 && a != arm.shoulder) a = skeleton.parent(a);
      if (a != arm.shoulder) continue;
      t.arm_joints.push_back(j);
      if (j < 64) arm.joint_mask |= uint64_t{1} << j;
    }
    arm.joint_count = static_cast<uint32_t>(t.arm_joints.size()) - arm.joint_first;
    std::vector<std::pair<int, ContactTables::Probe>> probes;  // (joint, probe)
    for (const Primitive& p : model.primitives) {
      if (p.kind != PrimitiveKind::metaball) continue;
      if (p.part != side.hand && !(p.part == RigidPart::none && (p.groups & group_bit(side.forearm)))) continue;
      const int joint = skeleton.find_joint(p.joint);
      if (joint < 0) continue;
      const PrimitiveState& s = p.state;
      const glm::mat3 rot = primitive_rotation(s);
      ContactTables::Probe pr;
      pr.centre_joint = s.center_m;
      pr.radius_m = std::max({s.semi_axes_m.x, s.semi_axes_m.y, s.semi_axes_m.z});
      pr.axes_joint = rot * glm::mat3(glm::vec3(s.semi_axes_m.x, 0, 0), glm::vec3(0, s.semi_axes_m.y, 0),
                                      glm::vec3(0, 0, s.semi_axes_m.z));
      probes.emplace_back(joint, pr);
    }
    std::stable_sort(probes.begin(), probes.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    // Per joint, its probes and a sphere round them.
    arm.probe_joint_first = static_cast<uint32_t>(t.probe_joints.size());
    for (size_t k = 0; k < probes.size();) {
      ContactTables::ProbeJoint pj;
      pj.joint = probes[k].first;
      pj.probe_first = static_cast<uint32_t>(t.probes.size());
      glm::vec3 lo(1e30f), hi(-1e30f);
      for (; k < probes.size() && probes[k].first == pj.joint; ++k) {
        const ContactTables::Probe& pr = probes[k].second;
        t.probes.push_back(pr);
        lo = glm::min(lo, pr.centre_joint - pr.radius_m);
        hi = glm::max(hi, pr.centre_joint + pr.radius_m);
      }
      pj.probe_count = static_cast<uint32_t>(t.probes.size()) - pj.probe_first;
      pj.centre_joint = 0.5f * (lo + hi);
      for (uint32_t i = pj.probe_first; i < pj.probe_first + pj.probe_count; ++i)
        pj.radius_m =
            std::max(pj.radius_m, glm::distance(t.probes[i].centre_joint, pj.centre_joint) + t.probes[i].radius_m);
      t.probe_joints.push_back(pj);
    }
    arm.probe_joint_count = static_cast<uint32_t>(t.probe_joints.size()) - arm.probe_joint_first;
    if (arm.probe_joint_count > 0) t.arms.push_back(arm);
  }
}

void clear_arms(const ContactTables& t, ContactState& st, std::span<rig::RigidTransform> world_from_joint) {
  pose_balls(t, st, world_from_joint);
  for (const ContactTables::Arm& arm : t.arms) {
    const glm::vec3 shoulder = world_from_joint[arm.shoulder].translation;
    // A second round: the first turn can bring another probe into a volume.
    for (int round = 0; round < ContactTables::kArmRounds; ++round) {
      // The deep points' turns blended by the fourth power of their size: nearly the largest, but
      // where two points with pushes in different directions are as deep the turn goes between
      // them instead of jumping from one to the other (the largest alone moved a hand 60–80 mm
      // between two samples).
      glm::vec3 turn_sum(0.0f);
      float weight_sum = 0;
      for (uint32_t j = arm.probe_joint_first; j < arm.probe_joint_first + arm.probe_joint_count; ++j) {
        const ContactTables::ProbeJoint& pj = t.probe_joints[j];
        const rig::RigidTransform& w = world_from_joint[pj.joint];
        const glm::vec3 joint_centre = w.apply(pj.centre_joint);
        for (int v = 0; v < ContactTables::kArmVolumes; ++v) {
          // The volume's balls that reach this joint's probes (a few near a hand), evaluated a
          // ball at a time: filling eight-lane rows cost more than the tests.
          uint32_t n = 0;
          for (uint32_t k = t.volume_first[v]; k < t.volume_first[v + 1]; ++k) {
            const uint16_t i = t.volume_balls[k];
            const float reach = t.balls[i].bound_m + pj.radius_m;
            if (glm::distance2(st.centre[i], joint_centre) < reach * reach) st.active[n++] = i;
          }
          const std::span<const uint16_t> balls(st.active.data(), n);
          const auto far = [&](const glm::vec3& c, float r) { return field_bound(t, balls, st, c, r) <= t.arm_iso; };
          if (n == 0 || far(joint_centre, pj.radius_m)) continue;
          for (uint32_t k = pj.probe_first; k < pj.probe_first + pj.probe_count; ++k) {
            const ContactTables::Probe& pr = t.probes[k];
            const glm::vec3 c = w.apply(pr.centre_joint);
            if (far(c, pr.radius_m)) continue;
            add_probe_turns(t, st, balls, c, glm::mat3_cast(w.rotation) * pr.axes_joint, shoulder, turn_sum,
                            weight_sum);
          }
        }
      }
      if (!(weight_sum > 0.0f)) break;
      const glm::vec3 turn = turn_sum / weight_sum;
      const float angle = glm::length(turn);
      if (!(angle > 1e-7f)) break;
      const glm::quat q = glm::angleAxis(std::min(angle, t.arm_turn_max_rad), turn / angle);
      for (uint32_t k = arm.joint_first; k < arm.joint_first + arm.joint_count; ++k) {
        rig::RigidTransform& w = world_from_joint[t.arm_joints[k]];
        w.rotation = glm::normalize(q * w.rotation);
        w.translation = shoulder + q * (w.translation - shoulder);
      }
      pose_balls(t, st, world_from_joint, arm.joint_mask);
    }
  }
}

}  // namespace mimic::avatar::realtime_detail
