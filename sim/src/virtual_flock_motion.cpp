// The virtual Flock's built-in motion: the default skeleton with every DOF on its own sinusoid,
// sensors on well-separated joints, seen from a transmitter behind the performer.
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "mimic/rig/skeleton.h"
#include "mimic/sim/virtual_flock.h"

namespace mimic::sim {

namespace {

constexpr double kTwoPi = 6.283185307179586;
constexpr const char* kSensorJoints[] = {"pelvis",      "head",       "l_wrist",    "r_wrist", "l_ankle",
                                         "r_ankle",     "l_elbow",    "r_elbow",    "l_knee",  "r_knee",
                                         "spine_upper", "l_shoulder", "r_shoulder", "neck"};

struct MotionState {
  rig::Skeleton skeleton;
  rig::Pose pose;
  std::vector<rig::RigidTransform> world_from_joint;
  std::vector<double> freq_hz, phase_rad, amp_rad, mid_rad;
  std::vector<int> sensor_joint;
  double last_t = -1;
  float root_height_m = 0;
  glm::vec3 transmitter_m{0.0f, 1.0f, -0.5f};
};

}  // namespace

FlockSampleProvider make_builtin_flock_motion(uint64_t seed) {
  auto st = std::make_shared<MotionState>();
  auto built = rig::Skeleton::build(rig::default_skeleton_desc());
  if (!built) return [](double, int, devices::SensorSample&) {};
  st->skeleton = std::move(*built);
  st->pose = st->skeleton.zero_pose();
  st->world_from_joint.resize(static_cast<size_t>(st->skeleton.joint_count()));
  st->root_height_m = rig::standing_root_height_m(st->skeleton);
  std::mt19937_64 rng(seed);
  // Raw engine output, not std:: distributions, so the motion is the same on every library.
  auto unit = [&rng] { return static_cast<double>(rng() >> 11) / 9007199254740992.0; };
  for (const auto& d : st->skeleton.dofs()) {
    st->freq_hz.push_back(0.2 + 0.5 * unit());
    st->phase_rad.push_back(kTwoPi * unit());
    const double lo = d.min_rad, hi = d.max_rad;
    st->mid_rad.push_back(0.5 * (std::clamp(0.0, lo, hi) + 0.5 * (lo + hi)));  // between relaxed and centre
    st->amp_rad.push_back(0.2 * (hi - lo) * 0.5);
  }
  for (const char* name : kSensorJoints) st->sensor_joint.push_back(st->skeleton.find_joint(name));

  return [st](double t_s, int bird, devices::SensorSample& out) {
    if (t_s != st->last_t) {
      for (size_t i = 0; i < st->freq_hz.size(); ++i) {
        const double v = st->mid_rad[i] + st->amp_rad[i] * std::sin(kTwoPi * st->freq_hz[i] * t_s + st->phase_rad[i]);
        const auto& d = st->skeleton.dof(static_cast<int>(i));
        st->pose.dof_rad[i] = static_cast<float>(std::clamp(v, double(d.min_rad), double(d.max_rad)));
      }
      st->pose.root_position_m =
          glm::vec3(0.05f * static_cast<float>(std::sin(kTwoPi * 0.3 * t_s)), st->root_height_m, 0.0f);
      rig::forward_kinematics(st->skeleton, st->pose, st->world_from_joint);
      st->last_t = t_s;
    }
    const size_t n = std::size(kSensorJoints);
    const int j = st->sensor_joint[static_cast<size_t>(bird) % n];
    if (j < 0) return;
    const auto& x = st->world_from_joint[static_cast<size_t>(j)];
    out.position_m = x.translation - st->transmitter_m;
    out.orientation = x.rotation;
  };
}

}  // namespace mimic::sim
