// BVH clip -> Mimic skeleton fitted to the performer + one Pose per frame (see retarget.h).
#include "mimic/rig/retarget.h"

#include <array>
#include <cmath>
#include <optional>

#include <glm/gtx/quaternion.hpp>

#include "mimic/rig/joint_angles.h"

namespace mimic::rig {

namespace {

struct NamePair {
  const char* mimic;
  const char* cmu;
};

constexpr NamePair kCmuNames[] = {
    {"pelvis", "Hips"},         {"spine_lower", "LowerBack"},
    {"spine_mid", "Spine"},     {"spine_upper", "Spine1"},
    {"neck", "Neck"},           {"neck_upper", "Neck1"},
    {"head", "Head"},           {"l_clavicle", "LeftShoulder"},
    {"l_shoulder", "LeftArm"},  {"l_elbow", "LeftForeArm"},
    {"l_wrist", "LeftHand"},    {"l_hip", "LeftUpLeg"},
    {"l_knee", "LeftLeg"},      {"l_ankle", "LeftFoot"},
    {"l_toes", "LeftToeBase"},  {"r_clavicle", "RightShoulder"},
    {"r_shoulder", "RightArm"}, {"r_elbow", "RightForeArm"},
    {"r_wrist", "RightHand"},   {"r_hip", "RightUpLeg"},
    {"r_knee", "RightLeg"},     {"r_ankle", "RightFoot"},
    {"r_toes", "RightToeBase"},
};

// Two-bone chains: upper (3 DOFs), lower (hinge first, maybe a twist), end.
constexpr std::array<std::array<const char*, 3>, 4> kChains = {{{"l_shoulder", "l_elbow", "l_wrist"},
                                                                {"r_shoulder", "r_elbow", "r_wrist"},
                                                                {"l_hip", "l_knee", "l_ankle"},
                                                                {"r_hip", "r_knee", "r_ankle"}}};

enum class Solve : std::uint8_t { root, none, rotation, aim, chain_upper, chain_member };

struct Plan {
  Skeleton skeleton;
  std::vector<int> bvh;
  std::vector<glm::dquat> align;  // A_m
  bool t_pose = false;            // aligned on the frame-0 T-pose
  std::vector<Solve> kind;
  std::vector<int> lower, end;  // for chain uppers
};

bool orthogonal_triple(const Skeleton& s, int j) {
  if (s.dof_end(j) - s.dof_begin(j) != 3) return false;
  const glm::vec3 a = s.dof(s.dof_begin(j)).axis, b = s.dof(s.dof_begin(j) + 1).axis,
                  c = s.dof(s.dof_begin(j) + 2).axis;
  return std::abs(glm::dot(a, b)) < 1e-5f && std::abs(glm::dot(b, c)) < 1e-5f && std::abs(glm::dot(a, c)) < 1e-5f;
}

glm::dquat local_rotation_d(const Skeleton& s, int j, std::span<const float> dof_rad) {
  glm::dquat r(1, 0, 0, 0);
  for (int i = s.dof_begin(j); i < s.dof_end(j); ++i)
    r = r * glm::angleAxis(double(dof_rad[i]), glm::dvec3(s.dof(i).axis));
  return r;
}

// Rotation taking unit `from` onto unit `to` by the shortest arc (identity for zero vectors).
glm::dquat align_dirs(const glm::dvec3& from, const glm::dvec3& to) {
  if (glm::length(from) < 1e-12 || glm::length(to) < 1e-12) return glm::dquat(1, 0, 0, 0);
  return glm::rotation(glm::normalize(from), glm::normalize(to));
}

// The performer's heading when frame 0 is a T-pose (upper arms within 30° of level and out to
// the sides, thighs within 20° of straight down, heading from the shoulders), else nothing.
// `w0`: the clip's joints at frame 0.
std::optional<glm::dquat> t_pose_heading(std::span<const RigidTransform> w0, const Skeleton& t,
                                         const std::vector<int>& bvh, const std::vector<glm::dvec3>& link) {
  auto dir = [&](const char* name) {
    const int m = t.find_joint(name);
    const glm::dvec3 v = glm::dquat(w0[bvh[m]].rotation) * link[m];
    return glm::length(v) > 1e-9 ? glm::normalize(v) : v;
  };
  auto at = [&](const char* name) { return glm::dvec3(w0[bvh[t.find_joint(name)]].translation); };
  glm::dvec3 left = at("l_shoulder") - at("r_shoulder");
  left.y = 0;
  if (glm::length(left) < 1e-6) return std::nullopt;
  left = glm::normalize(left);
  const glm::dvec3 up(0, 1, 0);
  const double cos30 = std::cos(glm::radians(30.0)), cos20 = std::cos(glm::radians(20.0));
  if (glm::dot(dir("l_shoulder"), left) < cos30 || glm::dot(dir("r_shoulder"), -left) < cos30) return std::nullopt;
  if (glm::dot(dir("l_hip"), -up) < cos20 || glm::dot(dir("r_hip"), -up) < cos20) return std::nullopt;
  // Facing: +Z when the left is +X.
  return glm::angleAxis(std::atan2(-left.z, left.x), up);
}

// Which clip joint plays each Mimic joint: by Mimic's own names (our export) or CMU's; the
// mapped joints must keep Mimic's ancestry.
Status map_joints(const BvhClip& clip, const Skeleton& t, Plan& plan) {
  const int n = t.joint_count();
  // Naming convention: Mimic's own (our export) or CMU's.
  const bool own = clip.find_joint("pelvis") >= 0;
  for (int m = 0; m < n; ++m) {
    std::string want = t.joint_name(m);
    if (!own) {
      want.clear();
      for (const auto& p : kCmuNames)
        if (t.joint_name(m) == p.mimic) want = p.cmu;
      if (want.empty())
        return fail(Errc::unsupported, "retarget: no CMU joint for Mimic joint '" + t.joint_name(m) + "'");
    }
    plan.bvh[m] = clip.find_joint(want);
    if (plan.bvh[m] < 0)
      return fail(Errc::unsupported, clip.source_name + ": not a CMU or Mimic skeleton: no joint named '" + want +
                                         "' (" + (own ? "Mimic" : "CMU") + " naming expected)");
  }
  // The mapped joints must keep Mimic's ancestry (a mapped parent is an ancestor in the clip).
  for (int m = 1; m < n; ++m) {
    int a = clip.joints[plan.bvh[m]].parent;
    while (a >= 0 && a != plan.bvh[t.parent(m)]) a = clip.joints[a].parent;
    if (a < 0)
      return fail(Errc::unsupported, clip.source_name + ": joint '" + clip.joints[plan.bvh[m]].name +
                                         "' is not below '" + clip.joints[plan.bvh[t.parent(m)]].name +
                                         "' as the skeleton needs");
  }

  return {};
}

// How each joint of the fitted skeleton is solved: the root, joints without DOFs, exact Euler
// triples, aim joints, and the two-bone chains (hip-knee-ankle, shoulder-elbow-wrist).
void classify_joints(Plan& plan) {
  const Skeleton& s = plan.skeleton;
  const int n = s.joint_count();
  plan.kind.assign(n, Solve::rotation);
  plan.lower.assign(n, -1);
  plan.end.assign(n, -1);
  for (int m = 0; m < n; ++m) {
    const int dofs = s.dof_end(m) - s.dof_begin(m);
    if (m == 0)
      plan.kind[m] = Solve::root;
    else if (dofs == 0)
      plan.kind[m] = Solve::none;
    else if (orthogonal_triple(s, m))
      plan.kind[m] = Solve::rotation;
    else if (dofs <= 2 && glm::length(s.tip_m(m)) > 1e-6f)
      plan.kind[m] = Solve::aim;
  }
  for (const auto& chain : kChains) {
    const int u = s.find_joint(chain[0]), l = s.find_joint(chain[1]), e = s.find_joint(chain[2]);
    if (u < 0 || l < 0 || e < 0 || s.parent(l) != u || s.parent(e) != l || !orthogonal_triple(s, u)) continue;
    if (s.dof_end(l) == s.dof_begin(l)) continue;
    const glm::vec3 h = s.dof(s.dof_begin(l)).axis;
    const int extra = (s.dof_end(l) - s.dof_begin(l) - 1) + (s.dof_end(e) - s.dof_begin(e));
    // The hinge must be normal to both links, and what follows it must fit one decomposition.
    if (std::abs(glm::dot(h, glm::normalize(s.offset_m(l)))) > 1e-4f ||
        std::abs(glm::dot(h, glm::normalize(s.offset_m(e)))) > 1e-4f || extra > kMaxJointDofs)
      continue;
    plan.kind[u] = Solve::chain_upper;
    plan.kind[l] = plan.kind[e] = Solve::chain_member;
    plan.lower[u] = l;
    plan.end[u] = e;
  }
}

Result<Plan> make_plan(const BvhClip& clip) {
  auto tmpl = Skeleton::build(default_skeleton_desc());
  if (!tmpl) return tl::unexpected(tmpl.error());
  const Skeleton& t = *tmpl;
  const int n = t.joint_count();
  Plan plan;
  plan.bvh.assign(n, -1);

  if (auto st = map_joints(clip, t, plan); !st) return tl::unexpected(st.error());
  const bool own = clip.find_joint("pelvis") >= 0;

  // Clip rest positions (all channels zero), metres.
  const double mpu = clip.metres_per_unit;
  std::vector<glm::dvec3> rest(clip.joints.size());
  for (size_t j = 0; j < clip.joints.size(); ++j) {
    const int p = clip.joints[j].parent;
    rest[j] = (p < 0 ? glm::dvec3(0.0) : rest[p]) + clip.joints[j].offset * mpu;
  }
  // Far end of a clip joint's link when no mapped child defines it: its End Site, else down
  // its first child (a hand's finger chain).
  auto tip_chain = [&](int j) {
    glm::dvec3 v(0.0);
    for (int guard = 0; guard < 64; ++guard) {
      if (!clip.joints[j].end_sites.empty()) return v + clip.joints[j].end_sites[0] * mpu;
      int child = -1;
      for (size_t c = j + 1; c < clip.joints.size() && child < 0; ++c)
        if (clip.joints[c].parent == j) child = static_cast<int>(c);
      if (child < 0) return v;
      v += clip.joints[child].offset * mpu;
      j = child;
    }
    return v;
  };
  std::vector<int> main_child(n, -1);
  for (int c = 1; c < n; ++c)
    if (glm::length(t.offset_m(c) - t.tip_m(t.parent(c))) < 1e-6f && main_child[t.parent(c)] < 0)
      main_child[t.parent(c)] = c;
  // The clip's link vector for Mimic joint m (zero-length links defer to the next one).
  std::vector<glm::dvec3> link(n);
  for (int m = n - 1; m >= 0; --m) {  // children after parents, so walk backwards
    const int c = main_child[m];
    if (c < 0) {
      link[m] = tip_chain(plan.bvh[m]);
    } else {
      link[m] = rest[plan.bvh[c]] - rest[plan.bvh[m]];
      if (glm::length(link[m]) < 1e-9) link[m] = link[c];
    }
  }
  // Joints with fewer than three DOFs (clavicles, elbows, wrists, knees, toes) keep their
  // parent's alignment: a constant rotation between the two rest directions could not be
  // absorbed by their DOFs, and the difference is one of origin (a CMU clavicle starts at the
  // thorax centre, lower than Mimic's), not of posture. Their fitted links simply point where
  // the performer's do.
  //
  // A clip whose frame 0 is a T-pose (the MotionBuilder-friendly CMU conversions) is
  // characterised on it: there every segment takes the orientation it has in Mimic's own T-pose —
  // limbs and spine turned by the shortest arc onto the performer's links, head level, feet
  // flat, all from the performer's heading. Aligned at the rest pose instead (all channels
  // zero, legs splayed), the feet that frame 0 turns down to stand on would stand 20° on their
  // edges in every stance, and the head would tilt by whatever the neck's rest angles leave.
  plan.align.assign(n, glm::dquat(1, 0, 0, 0));
  std::vector<RigidTransform> w0(clip.joints.size());
  if (!own) bvh_forward_kinematics(clip, 0, w0);
  const std::optional<glm::dquat> heading = own ? std::nullopt : t_pose_heading(w0, t, plan.bvh, link);
  plan.t_pose = heading.has_value();
  for (int m = 1; m < n; ++m) {
    const int dofs = t.dof_end(m) - t.dof_begin(m);
    if (own) {
      continue;  // Mimic's own frames: its rest pose is the zero posture
    } else if (dofs > 0 && dofs < 3) {
      plan.align[m] = plan.align[t.parent(m)];
    } else if (!heading) {
      plan.align[m] = align_dirs(glm::dvec3(t.tip_m(m)), link[m]);
    } else {
      const glm::dquat g0(w0[plan.bvh[m]].rotation);
      const std::string& name = t.joint_name(m);
      const bool level = name == "head" || name == "l_ankle" || name == "r_ankle";
      const glm::dquat at_t_pose =
          level ? *heading : *heading * align_dirs(glm::dvec3(t.tip_m(m)), glm::inverse(*heading) * (g0 * link[m]));
      plan.align[m] = glm::inverse(g0) * at_t_pose;
    }
  }

  SkeletonDesc desc = t.desc();  // packed order, so desc.joints[m] is joint m
  for (int m = 0; m < n; ++m) {
    const int p = t.parent(m);
    desc.joints[m].offset_m =
        p < 0 ? glm::vec3(0) : glm::vec3(glm::inverse(plan.align[p]) * (rest[plan.bvh[m]] - rest[plan.bvh[p]]));
  }
  for (int m = 0; m < n; ++m) {
    const int c = main_child[m];
    desc.joints[m].tip_m = (c >= 0 && glm::length(desc.joints[c].offset_m) > 1e-6f)
                               ? desc.joints[c].offset_m
                               : glm::vec3(glm::inverse(plan.align[m]) * link[m]);
  }
  auto fitted = Skeleton::build(desc);
  if (!fitted) return tl::unexpected(fitted.error());
  plan.skeleton = std::move(*fitted);
  classify_joints(plan);
  return plan;
}

struct Scratch {
  std::vector<RigidTransform> bvh_world;
  std::vector<glm::dquat> rot;  // Mimic segment world rotations actually produced
  std::vector<glm::dvec3> pos;  // Mimic joint world positions actually produced
};

// Solves one frame. pose.dof_rad holds the previous frame's values on entry (continuity).
void solve_frame(const Plan& plan, const BvhClip& clip, int frame, Scratch& sc, Pose& pose) {
  const Skeleton& s = plan.skeleton;
  bvh_forward_kinematics(clip, frame, sc.bvh_world);
  auto target = [&](int m) { return glm::dquat(sc.bvh_world[plan.bvh[m]].rotation) * plan.align[m]; };
  auto bvh_pos = [&](int m) { return glm::dvec3(sc.bvh_world[plan.bvh[m]].translation); };
  std::span<float> dofs(pose.dof_rad);

  for (int m = 0; m < s.joint_count(); ++m) {
    const int p = s.parent(m);
    const glm::dvec3 offset(s.offset_m(m));
    if (plan.kind[m] == Solve::root) {
      const glm::dquat g = glm::normalize(target(m));
      pose.root_orientation = glm::quat(g);
      sc.rot[m] = glm::dquat(glm::normalize(pose.root_orientation)) * local_rotation_d(s, m, dofs);
      const glm::dvec3 root_pos = bvh_pos(m) - glm::dquat(pose.root_orientation) * offset;
      pose.root_position_m = glm::vec3(root_pos);
      sc.pos[m] = glm::dvec3(pose.root_position_m) + glm::dquat(pose.root_orientation) * offset;
      continue;
    }
    if (plan.kind[m] == Solve::chain_member) continue;  // done with its chain's upper joint
    sc.pos[m] = sc.pos[p] + sc.rot[p] * offset;
    const glm::dquat parent_inv = glm::inverse(sc.rot[p]);
    switch (plan.kind[m]) {
      case Solve::root:
      case Solve::chain_member:
      case Solve::none: break;
      case Solve::rotation: solve_joint_dofs(s, m, parent_inv * target(m), dofs); break;
      case Solve::aim: {
        const int begin = s.dof_begin(m), count = s.dof_end(m) - begin;
        std::array<glm::dvec3, 2> axes;
        std::array<double, 2> prev, out;
        for (int i = 0; i < count; ++i) {
          axes[i] = glm::dvec3(s.dof(begin + i).axis);
          prev[i] = dofs[begin + i];
        }
        const glm::dvec3 from(s.tip_m(m));
        const glm::dvec3 to = parent_inv * (target(m) * from);
        dofs_aim(std::span(axes.data(), count), from, to, std::span(prev.data(), count), std::span(out.data(), count));
        for (int i = 0; i < count; ++i) dofs[begin + i] = static_cast<float>(out[i]);
        break;
      }
      case Solve::chain_upper: {
        const int lo = plan.lower[m], en = plan.end[m];
        const glm::dvec3 off_lo(s.offset_m(lo)), off_en(s.offset_m(en));
        const double l1 = glm::length(off_lo), l2 = glm::length(off_en);
        const glm::dvec3 a = off_lo / l1, b = off_en / l2;
        const glm::dvec3 h(s.dof(s.dof_begin(lo)).axis);
        const glm::dquat g_target = target(m);
        const glm::dvec3 S = sc.pos[m], E_t = bvh_pos(lo), W_t = bvh_pos(en);
        // Wrist/ankle exactly on its clip position (as far as the bone lengths reach), elbow/knee
        // on the circle of solutions at the point nearest the clip's.
        glm::dvec3 d = W_t - S;
        double dist = glm::length(d);
        const glm::dvec3 dh = dist > 1e-9 ? d / dist : g_target * a;
        dist = std::clamp(dist, std::abs(l1 - l2) + 1e-9, l1 + l2 - 1e-9);
        const double ca = std::clamp((l1 * l1 + dist * dist - l2 * l2) / (2 * l1 * dist), -1.0, 1.0);
        const double sa = std::sqrt(1 - ca * ca);
        // Swivel: towards the clip's elbow/knee, plus a 5 mm pull towards where the clip's upper
        // segment would bend it. A nearly straight limb leaves the clip's elbow/knee a few
        // millimetres off the line, in a direction that is noise; the pull then keeps the
        // upper segment's own twist instead of an arbitrary one the wrist/ankle must undo.
        // It moves the joint by at most a few millimetres.
        const glm::dvec3 bend_ref = g_target * glm::cross(a, h);
        glm::dvec3 nrm = (E_t - S) + 0.005 * bend_ref;
        nrm -= glm::dot(nrm, dh) * dh;
        if (glm::length(nrm) < 1e-9) nrm = bend_ref - glm::dot(bend_ref, dh) * dh;
        nrm = glm::normalize(nrm);
        const glm::dvec3 E = S + l1 * (ca * dh + sa * nrm), W = S + dist * dh;
        const glm::dvec3 u = glm::normalize(E - S), v = glm::normalize(W - E);
        // Hinge axis normal to both links; its sign follows the clip's upper segment so the
        // joint bends the way the performer's does (and may hyperextend a little).
        const glm::dvec3 hinge_ref = g_target * h;
        glm::dvec3 hw = glm::cross(u, v);
        if (glm::length(hw) > 1e-9) {
          hw = glm::normalize(hw);
          if (glm::dot(hw, hinge_ref) < 0) hw = -hw;
        } else {
          hw = glm::normalize(hinge_ref - glm::dot(hinge_ref, u) * u);
        }
        const glm::dmat3 world(u, hw, glm::cross(u, hw)), local(a, h, glm::cross(a, h));
        const glm::dquat g_upper = glm::quat_cast(world * glm::transpose(local));
        solve_joint_dofs(s, m, parent_inv * g_upper, dofs);
        sc.rot[m] = sc.rot[p] * local_rotation_d(s, m, dofs);
        // Hinge angle from the upper segment the DOFs actually give.
        sc.pos[lo] = sc.pos[m] + sc.rot[m] * off_lo;
        const glm::dvec3 v_act = glm::normalize(W - sc.pos[lo]);
        const glm::dvec3 hinge_w = sc.rot[m] * h, b_w = sc.rot[m] * b;
        const double theta = std::atan2(glm::dot(hinge_w, glm::cross(b_w, v_act)), glm::dot(b_w, v_act));
        const int hinge = s.dof_begin(lo);
        dofs[hinge] = static_cast<float>(unwrap_near(theta, dofs[hinge]));
        // The remaining DOFs of lower (forearm twist) and end (wrist, ankle) take the end
        // segment's orientation together.
        std::array<glm::dvec3, kMaxJointDofs> axes;
        std::array<double, kMaxJointDofs> prev, out;
        std::array<int, kMaxJointDofs> index;
        int count = 0;
        for (int i = hinge + 1; i < s.dof_end(lo); ++i) index[count++] = i;
        for (int i = s.dof_begin(en); i < s.dof_end(en); ++i) index[count++] = i;
        if (count > 0) {
          for (int k = 0; k < count; ++k) {
            axes[k] = glm::dvec3(s.dof(index[k]).axis);
            prev[k] = dofs[index[k]];
          }
          const glm::dquat after_hinge = sc.rot[m] * glm::angleAxis(double(dofs[hinge]), h);
          dofs_from_rotation(std::span(axes.data(), count), glm::inverse(after_hinge) * target(en),
                             std::span(prev.data(), count), std::span(out.data(), count));
          for (int k = 0; k < count; ++k) dofs[index[k]] = static_cast<float>(out[k]);
        }
        sc.rot[lo] = sc.rot[m] * local_rotation_d(s, lo, dofs);
        sc.pos[en] = sc.pos[lo] + sc.rot[lo] * off_en;
        sc.rot[en] = sc.rot[lo] * local_rotation_d(s, en, dofs);
        continue;
      }
    }
    sc.rot[m] = sc.rot[p] * local_rotation_d(s, m, dofs);
  }
}

}  // namespace

Result<RetargetedClip> retarget_bvh(const BvhClip& clip) {
  if (clip.frame_count <= 0) return fail(Errc::invalid_argument, clip.source_name + ": clip has no frames");
  auto plan = make_plan(clip);
  if (!plan) return tl::unexpected(plan.error());
  const Skeleton& s = plan->skeleton;
  RetargetedClip out{s, {}, clip.frame_time_s, plan->bvh, clip.source_name, plan->t_pose};
  Scratch sc{std::vector<RigidTransform>(clip.joints.size()), std::vector<glm::dquat>(s.joint_count()),
             std::vector<glm::dvec3>(s.joint_count())};
  out.poses.reserve(clip.frame_count);
  Pose pose = s.zero_pose();
  for (int f = 0; f < clip.frame_count; ++f) {
    solve_frame(*plan, clip, f, sc, pose);
    out.poses.push_back(pose);
  }
  return out;
}

Pose transfer_pose(const Skeleton& from, const Pose& pose, const Skeleton& to) {
  Pose out = to.rest_pose();
  for (int i = 0; i < to.dof_count(); ++i) {
    const int k = from.find_dof(to.dof(i).name);
    if (k >= 0) out.dof_rad[i] = pose.dof_rad[k];
  }
  const float h_from = standing_root_height_m(from), h_to = standing_root_height_m(to);
  out.root_position_m = pose.root_position_m * (h_from > 0 ? h_to / h_from : 1.0f);
  out.root_orientation = pose.root_orientation;
  return out;
}

}  // namespace mimic::rig
