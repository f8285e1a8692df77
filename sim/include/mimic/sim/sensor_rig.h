// A virtual body wearing virtual 6-DOF sensors: the body follows a Motion (built-in or BVH), each
// sensor rides on one skeleton segment at a mounting offset, and the rig turns the true sensor
// poses into tracker samples with the faults real trackers have (noise, a slowly drifting bias,
// latency, dropouts), deterministically from one seed.
//
// Frames. The motion's world frame is Mimic's (metres, +Y up, body faces +Z). A sensor's true
// pose is world_from_sensor = world_from_joint[segment] · segment_from_sensor. Samples are given
// in the tracker's reference frame: reference_from_sensor = inverse(world_from_reference) ·
// world_from_sensor. world_from_reference defaults to identity (the tracker's transmitter at
// Mimic's world origin with Mimic's axes).
//
// Time. Tick k is measured at device time t_k = k / rate_hz (the motion is sampled at t_k) and
// reaches the host at host_time = t_k + latency_s (plus the host_time_offset given to step()).
//
// Faults, per sensor and tick, in this order:
//   bias     random walk: every tick the position bias moves by N(0, σ²·dt) per axis with
//            σ = bias_walk_mm_per_sqrt_s, the orientation bias by a rotation vector with
//            N(0, σ²·dt) per axis, σ = bias_walk_deg_per_sqrt_s (in the sensor frame);
//   noise    white: position N(0, position_noise_mm²) per axis in the reference frame,
//            orientation a rotation vector with N(0, orientation_noise_deg²) per axis in the
//            sensor frame;
//   dropout  while not already in one, a burst starts with probability dropout_probability and
//            lasts dropout_burst ticks (this one included). A dropped tick still yields a sample,
//            flagged kSampleStale (kSampleValid cleared), repeating the last good measured pose
//            (identity before the first good one): this is what a driver reports for a sensor
//            that fell silent.
//   measured = (reference_from_sensor_true with biased, noisy position) · R(bias) · R(noise).
//
// Determinism. Sensor i draws only from its own mt19937_64 seeded from (seed, i) through
// splitmix64, and Gaussians come from a Box–Muller transform on raw 64-bit draws (not std::
// distributions, whose output differs between standard libraries). Every tick draws the same
// number of values whatever the configuration, so e.g. enabling dropouts leaves the noise of the
// surviving samples unchanged.
//
// Allocation happens in create() only; step() never allocates or throws.
#pragma once

#include <cstdint>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mimic/rig/motion.h"
#include "mimic/rig/skeleton.h"
#include "mimic/rig/transform.h"
#include "mimic/core/result.h"
#include "mimic/devices/sample.h"

namespace mimic::sim {

struct SensorMount {
  std::string name;                         // e.g. "head", "l_hand"
  std::string segment;                      // skeleton joint whose frame carries the sensor
  rig::RigidTransform segment_from_sensor;  // mounting offset in the segment (joint) frame
};

// Named layouts on Mimic's skeleton (joint names as in default_skeleton_desc()); sensor id =
// index in the list:
//   "3"   head, l_hand, r_hand
//   "6"   "3" + pelvis, l_foot, r_foot
//   "11"  "6" + l_upper_arm, r_upper_arm, l_thigh, r_thigh, chest
//   "all" one sensor per joint, named after it, at the middle of its link, unrotated.
// Segments: head → head, hands → l_/r_wrist (back of the hand), pelvis → pelvis (sacrum),
// feet → l_/r_ankle (instep), upper arms → l_/r_shoulder (outer side), thighs → l_/r_hip
// (front), chest → spine_upper (sternum). Fails (not_found) on an unknown layout name or when a
// segment is missing from the skeleton.
Result<std::vector<SensorMount>> make_layout(std::string_view name, const rig::Skeleton& skeleton);
std::vector<std::string> layout_names();

struct RigConfig {
  std::vector<SensorMount> sensors;
  double rate_hz = 100.0;
  double position_noise_mm = 0.0;         // std dev per axis
  double orientation_noise_deg = 0.0;     // std dev per rotation-vector axis
  double bias_walk_mm_per_sqrt_s = 0.0;   // random-walk drift of the position bias
  double bias_walk_deg_per_sqrt_s = 0.0;  // random-walk drift of the orientation bias
  double latency_s = 0.0;                 // host_time − device_time
  double dropout_probability = 0.0;       // chance per tick that a dropout burst starts
  int dropout_burst = 1;                  // ticks per burst (≥ 1)
  uint64_t seed = 1;
  rig::RigidTransform world_from_reference;  // identity: the tracker frame is Mimic's world
};

// The deterministic sample engine of one sensor (exposed for tests and for virtual devices that
// want the same noise model).
class SensorRandom {
 public:
  SensorRandom() = default;
  SensorRandom(uint64_t seed, uint64_t sensor_id) { reseed(seed, sensor_id); }
  void reseed(uint64_t seed, uint64_t sensor_id);
  uint64_t next_u64() { return engine_(); }
  double uniform();   // in (0, 1), 53 bits
  double gaussian();  // N(0, 1); consumes exactly two raw draws

 private:
  std::mt19937_64 engine_;
};

class SensorRig {
 public:
  // The motion is shared (sample() is const). Fails on an empty layout, an unknown segment, a
  // non-positive rate, negative noise or latency, a probability outside [0, 1], a burst < 1.
  static Result<SensorRig> create(std::shared_ptr<const rig::Motion> motion, RigConfig config);

  const RigConfig& config() const { return config_; }
  const rig::Motion& motion() const { return *motion_; }
  int sensor_count() const { return static_cast<int>(config_.sensors.size()); }
  double period_s() const { return 1.0 / config_.rate_hz; }

  uint64_t ticks() const { return tick_; }  // ticks stepped so far
  double next_device_time_s() const { return static_cast<double>(tick_) / config_.rate_hz; }
  // Host time of the next tick's samples, before any offset: next_device_time_s() + latency_s.
  double next_host_time_s() const { return next_device_time_s() + config_.latency_s; }

  // Measures the next tick: writes sensor_count() samples (sensor i to out[i]; out.size() must
  // be at least sensor_count()) with host_time = t_k + latency_s + host_time_offset_s, and
  // updates the ground truth. Returns the device time t_k. Never allocates.
  double step(std::span<devices::SensorSample> out, double host_time_offset_s = 0.0);

  // Back to tick 0 with fresh random streams: the same samples come out again.
  void reset();

  // Ground truth of the last step(): the body's pose and each sensor's true pose.
  const rig::Pose& true_pose() const { return pose_; }
  std::span<const rig::RigidTransform> true_world_from_joint() const { return world_from_joint_; }
  const rig::RigidTransform& true_world_from_sensor(int i) const { return world_from_sensor_[i]; }
  const rig::RigidTransform& true_reference_from_sensor(int i) const { return reference_from_sensor_[i]; }
  int segment_joint(int i) const { return segment_joint_[i]; }

 private:
  struct SensorState {
    SensorRandom random;
    glm::dvec3 position_bias_m{0.0};
    glm::dvec3 rotation_bias_rad{0.0};  // rotation vector, sensor frame
    int dropout_left = 0;
    devices::SensorSample last_good;
    bool have_good = false;
  };

  SensorRig() = default;

  std::shared_ptr<const rig::Motion> motion_;
  RigConfig config_;
  std::vector<int> segment_joint_;
  rig::RigidTransform reference_from_world_;
  uint64_t tick_ = 0;
  rig::Pose pose_;
  std::vector<rig::RigidTransform> world_from_joint_;
  std::vector<rig::RigidTransform> world_from_sensor_;
  std::vector<rig::RigidTransform> reference_from_sensor_;
  std::vector<SensorState> state_;
};

// Rotation by a rotation vector (axis · angle, radians); identity for a zero vector.
glm::quat quat_from_rotation_vector(const glm::dvec3& v_rad);

}  // namespace mimic::sim
