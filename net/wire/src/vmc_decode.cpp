#include "mimic/net/vmc_decode.h"

#include <cmath>
#include <cstring>

#include "mimic/rig/joint_angles.h"
#include "mimic/core/finite.h"

namespace mimic::net {

namespace {

constexpr float kDegToRad = 3.14159265358979f / 180.0f;

// Unity (left-handed, +X right) to Mimic (right-handed, +X left): mirror x.
glm::vec3 from_unity(glm::vec3 p) { return {-p.x, p.y, p.z}; }
glm::quat from_unity(glm::quat q) { return glm::quat(q.w, q.x, -q.y, -q.z); }

// "<name> px py pz qx qy qz qw" (trailing arguments ignored). False on other arguments, or a
// rotation that cannot be normalised.
bool read_named_pose(const osc::Message& m, std::string_view& name, glm::vec3& p, glm::quat& q, bool& non_finite) {
  osc::Args a(m);
  float v[7];
  if (!a.get(name)) return false;
  for (float& f : v)
    if (!a.get(f)) return false;
  p = {v[0], v[1], v[2]};
  q = glm::quat(v[6], v[3], v[4], v[5]);
  const float len = glm::length(q);
  non_finite = !all_finite(p) || !std::isfinite(len) || len < 1e-6f;
  if (!non_finite) q /= len;
  return true;
}

bool read_vec3(const osc::Message& m, glm::vec3& out) {
  osc::Args a(m);
  return a.get(out.x) && a.get(out.y) && a.get(out.z);
}

// Unity's Quaternion.Euler(x, y, z): Z first, then X, then Y (degrees, Unity's frame).
glm::quat unity_euler_deg(glm::vec3 e) {
  const glm::quat qx = glm::angleAxis(e.x * kDegToRad, glm::vec3(1, 0, 0));
  const glm::quat qy = glm::angleAxis(e.y * kDegToRad, glm::vec3(0, 1, 0));
  const glm::quat qz = glm::angleAxis(e.z * kDegToRad, glm::vec3(0, 0, 1));
  return qy * qx * qz;
}

void set(TrackedPose& t, glm::vec3 p, glm::quat q, double now_s) {
  t.present = true;
  t.position_m = from_unity(p);
  t.orientation = from_unity(q);
  t.received_s = now_s;
}

void apply_device(char kind, std::string_view serial, glm::vec3 p, glm::quat q, double now_s, VmcState& s,
                  VmcReceiveStats& stats) {
  for (size_t i = 0; i < s.device_count; ++i) {
    auto& d = s.devices[i];
    if (d.kind == kind && std::string_view(d.serial.data()) == serial.substr(0, d.serial.size() - 1)) {
      set(d.pose, p, q, now_s);
      return;
    }
  }
  if (s.device_count >= s.devices.size()) {
    stats.devices_dropped++;
    return;
  }
  auto& d = s.devices[s.device_count++];
  d.kind = kind;
  const size_t n = std::min(serial.size(), d.serial.size() - 1);
  std::memcpy(d.serial.data(), serial.data(), n);
  d.serial[n] = '\0';
  set(d.pose, p, q, now_s);
}

// /tracking/trackers/<1..8|head>/<position|rotation>
bool apply_osc_tracker(const osc::Message& m, double now_s, VmcState& s, VmcReceiveStats& stats) {
  constexpr std::string_view kPrefix = "/tracking/trackers/";
  if (m.address.substr(0, kPrefix.size()) != kPrefix) return false;
  const std::string_view rest = m.address.substr(kPrefix.size());
  const size_t slash = rest.find('/');
  if (slash == std::string_view::npos) return false;
  const std::string_view which = rest.substr(0, slash), what = rest.substr(slash + 1);
  size_t index = 0;
  if (which == "head")
    index = 0;
  else if (which.size() == 1 && which[0] >= '1' && which[0] <= '8')
    index = size_t(which[0] - '0');
  else
    return false;
  if (what != "position" && what != "rotation") return false;
  glm::vec3 v;
  if (!read_vec3(m, v)) {
    stats.refused[size_t(osc::Error::wrong_arguments)]++;
    return true;
  }
  if (!all_finite(v)) {
    stats.non_finite++;
    return true;
  }
  TrackedPose& t = s.osc_trackers[index];
  // A tracker is placed once its position has come: a rotation alone (its position's datagram
  // lost, or a receiver started between the two) would stand it at the origin.
  if (what == "position") {
    t.position_m = from_unity(v);
    t.present = true;
  } else {
    t.orientation = from_unity(unity_euler_deg(v));
  }
  t.received_s = now_s;
  stats.osc_tracker_messages++;
  return true;
}

void apply_message(const osc::Message& m, double now_s, VmcState& s, VmcReceiveStats& stats) {
  stats.messages++;
  if (apply_osc_tracker(m, now_s, s, stats)) return;
  const std::string_view a = m.address;
  if (a == "/VMC/Ext/OK") {
    s.frames++;
    return;
  }
  if (a == "/VMC/Ext/T") {
    float t = 0;
    osc::Args args(m);
    if (args.get(t) && std::isfinite(t))
      s.sender_time_s = t;
    else
      stats.refused[size_t(osc::Error::wrong_arguments)]++;
    return;
  }
  const bool bone = a == "/VMC/Ext/Bone/Pos", root = a == "/VMC/Ext/Root/Pos";
  const char device = a == "/VMC/Ext/Tra/Pos" ? 'T' : a == "/VMC/Ext/Hmd/Pos" ? 'H' : a == "/VMC/Ext/Con/Pos" ? 'C' : 0;
  if (!bone && !root && !device) {
    stats.other_addresses++;
    return;
  }
  std::string_view name;
  glm::vec3 p;
  glm::quat q;
  bool non_finite = false;
  if (!read_named_pose(m, name, p, q, non_finite)) {
    stats.refused[size_t(osc::Error::wrong_arguments)]++;
    return;
  }
  if (non_finite) {
    stats.non_finite++;
    return;
  }
  if (root) {
    set(s.root, p, q, now_s);
  } else if (bone) {
    const int b = unity_bone_index(name);
    if (b < 0) {
      stats.unknown_bones++;
      return;
    }
    set(s.bones[size_t(b)], p, q, now_s);
    stats.bones++;
  } else {
    apply_device(device, name, p, q, now_s, s, stats);
    stats.devices++;
  }
}

}  // namespace

int unity_bone_index(std::string_view name) {
  for (size_t i = 0; i < kUnityBodyBones.size(); ++i)
    if (kUnityBodyBones[i] == name) return int(i);
  return -1;
}

void apply_vmc_packet(std::span<const uint8_t> packet, double now_s, VmcState& state, VmcReceiveStats& stats) {
  stats.datagrams++;
  stats.bytes += packet.size();
  const osc::Error e =
      osc::for_each_message(packet, [&](const osc::Message& m) { apply_message(m, now_s, state, stats); });
  if (e != osc::Error::ok) stats.refused[size_t(e)]++;
}

bool pose_from_vmc(const VmcState& state, const rig::Skeleton& skeleton, const std::vector<VmcBone>& bones,
                   rig::Pose& pose) {
  const TrackedPose& hips = state.bones[kHipsBone];
  if (!hips.present || pose.dof_rad.size() != size_t(skeleton.dof_count())) return false;
  const std::span<float> dofs(pose.dof_rad);
  for (const auto& b : bones) {
    const int index = unity_bone_index(b.unity_name);
    if (index < 0 || !state.bones[size_t(index)].present) continue;
    glm::dquat local(state.bones[size_t(index)].orientation);
    if (skeleton.parent(b.joint) < 0) {
      // The hips carry the body's placement: Root/Pos (identity unless the sender moves its
      // model's root) then the Hips' own.
      const glm::quat root_q = state.root.present ? state.root.orientation : glm::quat(1, 0, 0, 0);
      const glm::vec3 root_p = state.root.present ? state.root.position_m : glm::vec3(0);
      pose.root_position_m = root_p + root_q * hips.position_m;
      pose.root_orientation = glm::normalize(root_q * hips.orientation);
      local = glm::dquat(1, 0, 0, 0);
    }
    if (b.fold_joint >= 0) {
      const glm::dquat half = glm::slerp(glm::dquat(1, 0, 0, 0), local, 0.5);
      rig::solve_joint_dofs(skeleton, b.joint, half, dofs);
      rig::solve_joint_dofs(skeleton, b.fold_joint, half, dofs);
      continue;
    }
    if (skeleton.dof_end(b.joint) > skeleton.dof_begin(b.joint)) rig::solve_joint_dofs(skeleton, b.joint, local, dofs);
  }
  return true;
}

}  // namespace mimic::net
