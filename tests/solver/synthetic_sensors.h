// Test helpers: sensor samples synthesised by forward kinematics of a known pose, and random
// natural poses. No noise unless asked for.
#pragma once

#include <random>
#include <vector>

#include "mimic/rig/skeleton.h"
#include "mimic/devices/sample.h"
#include "mimic/solver/body_solver.h"
#include "mimic/solver/sensor_layout.h"

namespace mimic::solver::testing {

// Mounts of a standard layout with the instructed placements and, if `tilt_rad` > 0, a random
// rotation of up to that angle (a strap never sits square).
inline std::vector<SensorMount> mounts_for(const SensorLayout& layout, float tilt_rad, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<SensorMount> out;
  for (const auto& b : layout.bindings) {
    SensorMount m{b.sensor, b.segment, {}};
    m.segment_from_sensor.translation = b.placement_m;
    if (tilt_rad > 0) {
      glm::vec3 axis(u(rng), u(rng), u(rng));
      if (glm::length(axis) < 1e-3f) axis = {1, 0, 0};
      m.segment_from_sensor.rotation = glm::angleAxis(tilt_rad * u(rng), glm::normalize(axis));
    }
    out.push_back(m);
  }
  return out;
}

inline void sense(const rig::Skeleton& s, const rig::Pose& pose, const std::vector<SensorMount>& mounts,
                  std::vector<devices::SensorSample>& out, std::mt19937_64* noise = nullptr, float noise_m = 0,
                  float noise_rad = 0, double t_s = 0) {
  std::vector<rig::RigidTransform> w(s.joint_count());
  rig::forward_kinematics(s, pose, w);
  out.clear();
  std::normal_distribution<float> n(0.0f, 1.0f);
  for (const auto& m : mounts) {
    const rig::RigidTransform ws = w[s.find_joint(m.segment)] * m.segment_from_sensor;
    devices::SensorSample smp;
    smp.sensor = m.sensor;
    smp.device_time_s = smp.host_time_s = t_s;
    smp.position_m = ws.translation;
    smp.orientation = ws.rotation;
    if (noise) {
      smp.position_m += noise_m * glm::vec3(n(*noise), n(*noise), n(*noise));
      const glm::vec3 rv = noise_rad * glm::vec3(n(*noise), n(*noise), n(*noise));
      if (glm::length(rv) > 0) smp.orientation = smp.orientation * glm::angleAxis(glm::length(rv), glm::normalize(rv));
    }
    out.push_back(smp);
  }
}

// DOFs drawn inside `fraction` of their limits around the relaxed value; the root turned and
// moved somewhere in a room.
inline rig::Pose random_pose(const rig::Skeleton& s, std::mt19937_64& rng, float fraction) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  rig::Pose p = s.zero_pose();
  for (int d = 0; d < s.dof_count(); ++d) {
    const auto& f = s.dof(d);
    const float lo = f.rest_rad + fraction * (f.min_rad - f.rest_rad);
    const float hi = f.rest_rad + fraction * (f.max_rad - f.rest_rad);
    p.dof_rad[d] = lo + (hi - lo) * u(rng);
  }
  p.root_position_m = {4.0f * u(rng) - 2.0f, 0.8f + 0.2f * u(rng), 4.0f * u(rng) - 2.0f};
  p.root_orientation =
      glm::angleAxis(6.28f * u(rng), glm::vec3(0, 1, 0)) * glm::angleAxis(0.3f * (u(rng) - 0.5f), glm::vec3(1, 0, 0));
  return p;
}

}  // namespace mimic::solver::testing
