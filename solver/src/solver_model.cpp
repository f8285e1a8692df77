// SolverModel: the skeleton's trunk, limb chains and sensor mounts as the body solve wants them,
// checked and precomputed once at setup; the SolverContext sized for it.
#include <algorithm>
#include <cmath>

#include "mimic/solver/body_solver.h"

namespace mimic::solver {

using rig::RigidTransform;
using rig::Skeleton;

namespace {

constexpr const char* kTrunk[] = {"spine_lower", "spine_mid", "spine_upper", "neck", "neck_upper", "head"};
constexpr const char* kChains[4][3] = {{"l_shoulder", "l_elbow", "l_wrist"},
                                       {"r_shoulder", "r_elbow", "r_wrist"},
                                       {"l_hip", "l_knee", "l_ankle"},
                                       {"r_hip", "r_knee", "r_ankle"}};

}  // namespace

Result<SolverModel> SolverModel::create(Skeleton skeleton, std::vector<SensorMount> mounts, SolverOptions options) {
  SolverModel m;
  m.skeleton_ = std::move(skeleton);
  m.mounts_ = std::move(mounts);
  m.options_ = options;
  const Skeleton& s = m.skeleton_;
  if (s.joint_count() > 64) return fail(Errc::unsupported, "solver: more than 64 joints");
  if (s.dof_begin(0) != s.dof_end(0)) return fail(Errc::unsupported, "solver: the root joint must have no DOFs");

  int max_id = -1;
  for (const auto& mt : m.mounts_) max_id = std::max(max_id, int{mt.sensor});
  m.slot_of_sensor_.assign(static_cast<size_t>(max_id + 1), -1);
  for (size_t i = 0; i < m.mounts_.size(); ++i) {
    const auto& mt = m.mounts_[i];
    const int j = s.find_joint(mt.segment);
    if (j < 0)
      return fail(Errc::not_found,
                  "solver: sensor " + std::to_string(mt.sensor) + " is on unknown segment '" + mt.segment + "'");
    if (m.slot_of_sensor_[mt.sensor] >= 0)
      return fail(Errc::invalid_argument, "solver: sensor id " + std::to_string(mt.sensor) + " mounted twice");
    m.slot_of_sensor_[mt.sensor] = static_cast<int>(i);
    m.mount_joint_.push_back(j);
    m.sensor_from_segment_.push_back(mt.segment_from_sensor.inverse());
  }

  for (const char* name : kTrunk) {
    const int j = s.find_joint(name);
    if (j < 0) continue;
    m.trunk_joints_.push_back(j);
    for (int d = s.dof_begin(j); d < s.dof_end(j); ++d) m.trunk_dofs_.push_back(d);
  }
  m.head_ = s.find_joint("head");
  if (m.head_ < 0) return fail(Errc::not_found, "solver: the skeleton has no 'head' joint");

  m.chain_of_joint_.assign(s.joint_count(), -1);
  for (int c = 0; c < 4; ++c) {
    Chain& ch = m.chains_[c];
    ch.upper = s.find_joint(kChains[c][0]);
    ch.mid = s.find_joint(kChains[c][1]);
    ch.end = s.find_joint(kChains[c][2]);
    if (ch.upper < 0 || ch.mid < 0 || ch.end < 0 || s.parent(ch.mid) != ch.upper || s.parent(ch.end) != ch.mid)
      return fail(Errc::not_found, std::string("solver: the skeleton lacks the chain ") + kChains[c][0] + "–" +
                                       kChains[c][1] + "–" + kChains[c][2]);
    if (s.dof_begin(ch.mid) == s.dof_end(ch.mid))
      return fail(Errc::invalid_argument, std::string("solver: joint ") + kChains[c][1] + " has no bend DOF");
    ch.flex_dof = s.dof_begin(ch.mid);
    // DOF indices are packed per joint, parents first, so the middle's and the end's are apart.
    if ((s.dof_end(ch.mid) - ch.flex_dof - 1) + (s.dof_end(ch.end) - s.dof_begin(ch.end)) > 3)
      return fail(Errc::unsupported, std::string("solver: more than 3 DOFs below the bend of ") + kChains[c][1]);
    for (int d = ch.flex_dof + 1; d < s.dof_end(ch.mid); ++d) ch.end_dofs[ch.end_dof_count++] = d;
    if (s.dof_end(ch.upper) - s.dof_begin(ch.upper) > 3)
      return fail(Errc::unsupported, std::string("solver: more than 3 DOFs at ") + kChains[c][0]);
    for (int d = s.dof_begin(ch.upper); d < s.dof_end(ch.upper); ++d) ch.upper_dofs[ch.upper_dof_count++] = d;
    for (int d = s.dof_begin(ch.end); d < s.dof_end(ch.end); ++d) ch.end_dofs[ch.end_dof_count++] = d;
    ch.upper_m = glm::length(s.offset_m(ch.mid));
    ch.lower_m = glm::length(s.offset_m(ch.end));
    if (ch.upper_m <= 0 || ch.lower_m <= 0)
      return fail(Errc::invalid_argument, std::string("solver: zero-length link in the chain from ") + kChains[c][0]);
    ch.upper_dir = s.offset_m(ch.mid) / ch.upper_m;
    const glm::vec3 lower_dir = s.offset_m(ch.end) / ch.lower_m;
    ch.hinge = s.dof(ch.flex_dof).axis;
    ch.bend_dir = glm::cross(ch.hinge, ch.upper_dir);
    if (std::abs(glm::dot(ch.hinge, ch.upper_dir)) > 1e-3f || glm::dot(lower_dir, ch.upper_dir) < 0.999f)
      return fail(Errc::unsupported, std::string("solver: the chain from ") + kChains[c][0] +
                                         " must be straight in the zero posture with its bend axis across it");
    // Elbows hang down and a little back, knees point forward.
    ch.default_pole = c < 2 ? glm::normalize(glm::vec3(0, -1, -0.3f)) : glm::vec3(0, 0, 1);
    if (c < 2) {
      const int clavicle = s.parent(ch.upper);
      if (clavicle > 0 && std::find(m.trunk_joints_.begin(), m.trunk_joints_.end(), clavicle) == m.trunk_joints_.end())
        for (int d = s.dof_begin(clavicle); d < s.dof_end(clavicle); ++d) m.arm_dofs_[c].push_back(d);
      for (int d = s.dof_begin(ch.upper); d < s.dof_end(ch.upper); ++d) m.arm_dofs_[c].push_back(d);
      m.arm_dofs_[c].push_back(ch.flex_dof);
    }
    m.chain_of_joint_[ch.upper] = m.chain_of_joint_[ch.mid] = m.chain_of_joint_[ch.end] = static_cast<int8_t>(c);
    if (c >= 2)
      for (int j : {ch.upper, ch.mid})
        for (int d = s.dof_begin(j); d < s.dof_end(j); ++d) m.leg_dofs_.push_back(d);
  }
  {
    std::vector<RigidTransform> w(s.joint_count());
    forward_kinematics(s, s.rest_pose(), w);
    m.head_from_root_rest_ = w[m.head_].translation - w[0].translation;
    for (int leg = 0; leg < 2; ++leg) {
      m.ankle_below_root_rest_[leg] = w[0].translation.y - w[m.chains_[2 + leg].end].translation.y;
      const int toes = s.find_joint(leg == 0 ? "l_toes" : "r_toes");
      if (toes >= 0 && s.parent(toes) == m.chains_[2 + leg].end) {
        m.ball_in_ankle_[leg] = s.offset_m(toes), m.toes_[leg] = toes;
        m.toe_tip_below_root_rest_[leg] = w[0].translation.y - w[toes].apply(s.tip_m(toes)).y;
        m.ball_below_root_rest_[leg] = w[0].translation.y - w[toes].translation.y;
      }
    }
  }
  m.prior_rad_.resize(s.dof_count());
  for (int d = 0; d < s.dof_count(); ++d) m.prior_rad_[d] = s.dof(d).rest_rad;
  for (int leg = 2; leg < 4; ++leg) {
    const int d = m.chains_[leg].flex_dof;
    m.prior_rad_[d] = std::clamp(options.relaxed_knee_bend_rad, s.dof(d).min_rad, s.dof(d).max_rad);
  }
  return m;
}

bool SolverModel::set_chain_lengths(int chain, float upper_m, float lower_m) {
  if (chain < 0 || chain >= 4 || !(upper_m > 0) || !(lower_m > 0) || !std::isfinite(upper_m) || !std::isfinite(lower_m))
    return false;
  Chain& ch = chains_[chain];
  const glm::vec3 old_mid = skeleton_.offset_m(ch.mid), old_end = skeleton_.offset_m(ch.end);
  const glm::vec3 mid = ch.upper_dir * upper_m, end = glm::normalize(old_end) * lower_m;
  skeleton_.set_offset_m(ch.mid, mid);
  skeleton_.set_offset_m(ch.end, end);
  if (glm::length(skeleton_.tip_m(ch.upper) - old_mid) < 1e-6f) skeleton_.set_tip_m(ch.upper, mid);
  if (glm::length(skeleton_.tip_m(ch.mid) - old_end) < 1e-6f) skeleton_.set_tip_m(ch.mid, end);
  ch.upper_m = upper_m;
  ch.lower_m = lower_m;
  return true;
}

SolverContext::SolverContext(const SolverModel& model)
    : ls_(model.skeleton(),
          static_cast<int>(model.trunk_dofs_.size() + model.leg_dofs_.size() + model.arm_dofs_[0].size() +
                           model.arm_dofs_[1].size()),
          static_cast<int>(model.trunk_joints_.size()) + 10) {
  const int n = model.skeleton().joint_count();
  targets_.reserve(model.trunk_joints_.size() + 10);
  ls_dofs_.reserve(model.trunk_dofs_.size() + model.leg_dofs_.size() + model.arm_dofs_[0].size() +
                   model.arm_dofs_[1].size());
  segment_target_.resize(n);
  prior_.resize(model.skeleton().dof_count());
  has_target_.resize(n);
  world_.resize(n);
}

}  // namespace mimic::solver
