#include "mimic/sim/sensor_rig.h"

#include <cmath>

namespace mimic::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

uint64_t splitmix64(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

rig::RigidTransform at(glm::vec3 translation_m) {
  rig::RigidTransform t;
  t.translation = translation_m;
  return t;
}

SensorMount mount(std::string name, std::string segment, glm::vec3 translation_m) {
  return SensorMount{std::move(name), std::move(segment), at(translation_m)};
}

glm::vec3 mirror(glm::vec3 p) { return {-p.x, p.y, p.z}; }

// Where a strap-on sensor sits on an average adult, in the segment frames of the zero posture
// (T-pose, palms down): the back of the hand is +Y, the front of the body +Z.
void add_pair(std::vector<SensorMount>& out, const std::string& part, const std::string& joint, glm::vec3 left_m) {
  out.push_back(mount("l_" + part, "l_" + joint, left_m));
  out.push_back(mount("r_" + part, "r_" + joint, mirror(left_m)));
}

}  // namespace

void SensorRandom::reseed(uint64_t seed, uint64_t sensor_id) {
  // Two splitmix64 rounds over (seed, id) decorrelate neighbouring seeds and sensors before
  // the Mersenne Twister sees them.
  uint64_t s = seed;
  const uint64_t a = splitmix64(s);
  s ^= sensor_id * 0xD1B54A32D192ED03ull;
  const uint64_t b = splitmix64(s);
  engine_.seed(a ^ (b << 1) ^ sensor_id);
}

double SensorRandom::uniform() { return (static_cast<double>(engine_() >> 11) + 0.5) * 0x1.0p-53; }

double SensorRandom::gaussian() {
  const double u1 = uniform();
  const double u2 = uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

glm::quat quat_from_rotation_vector(const glm::dvec3& v_rad) {
  const double angle = std::sqrt(v_rad.x * v_rad.x + v_rad.y * v_rad.y + v_rad.z * v_rad.z);
  if (angle == 0.0) return glm::quat(1.0f, 0.0f, 0.0f, 0.0f);
  const double s = std::sin(0.5 * angle) / angle;
  return glm::quat(static_cast<float>(std::cos(0.5 * angle)), static_cast<float>(v_rad.x * s),
                   static_cast<float>(v_rad.y * s), static_cast<float>(v_rad.z * s));
}

std::vector<std::string> layout_names() { return {"3", "6", "11", "all"}; }

Result<std::vector<SensorMount>> make_layout(std::string_view name, const rig::Skeleton& skeleton) {
  std::vector<SensorMount> out;
  if (name == "all") {
    for (int j = 0; j < skeleton.joint_count(); ++j)
      out.push_back(mount(skeleton.joint_name(j), skeleton.joint_name(j), 0.5f * skeleton.tip_m(j)));
  } else if (name == "3" || name == "6" || name == "11") {
    out.push_back(mount("head", "head", {0.0f, 0.160f, -0.020f}));
    add_pair(out, "hand", "wrist", {0.080f, 0.030f, 0.0f});
    if (name != "3") {
      out.push_back(mount("pelvis", "pelvis", {0.0f, 0.020f, -0.120f}));
      add_pair(out, "foot", "ankle", {0.0f, -0.010f, 0.080f});
    }
    if (name == "11") {
      add_pair(out, "upper_arm", "shoulder", {0.120f, 0.050f, 0.0f});
      add_pair(out, "thigh", "hip", {0.0f, -0.200f, 0.080f});
      out.push_back(mount("chest", "spine_upper", {0.0f, 0.100f, 0.110f}));
    }
  } else {
    return fail(Errc::not_found, "unknown sensor layout '" + std::string(name) + "' (known: 3, 6, 11, all)");
  }
  for (const auto& m : out)
    if (skeleton.find_joint(m.segment) < 0)
      return fail(Errc::not_found, "sensor layout '" + std::string(name) + "': the skeleton has no segment '" +
                                       m.segment + "' for sensor '" + m.name + "'");
  return out;
}

Result<SensorRig> SensorRig::create(std::shared_ptr<const rig::Motion> motion, RigConfig config) {
  if (!motion) return fail(Errc::invalid_argument, "sensor rig: no motion");
  if (config.sensors.empty()) return fail(Errc::invalid_argument, "sensor rig: no sensors");
  if (config.sensors.size() > 65535) return fail(Errc::out_of_range, "sensor rig: more than 65535 sensors");
  if (!(config.rate_hz > 0.0) || !std::isfinite(config.rate_hz))
    return fail(Errc::out_of_range, "sensor rig: rate must be positive, got " + std::to_string(config.rate_hz));
  auto non_negative = [](double v) { return v >= 0.0 && std::isfinite(v); };
  if (!non_negative(config.position_noise_mm) || !non_negative(config.orientation_noise_deg) ||
      !non_negative(config.bias_walk_mm_per_sqrt_s) || !non_negative(config.bias_walk_deg_per_sqrt_s))
    return fail(Errc::out_of_range, "sensor rig: noise and bias drift must be finite and non-negative");
  if (!non_negative(config.latency_s))
    return fail(Errc::out_of_range, "sensor rig: latency must be finite and non-negative");
  if (!(config.dropout_probability >= 0.0 && config.dropout_probability <= 1.0))
    return fail(Errc::out_of_range, "sensor rig: dropout probability must lie in [0, 1]");
  if (config.dropout_burst < 1) return fail(Errc::out_of_range, "sensor rig: dropout burst must be at least 1 tick");

  const rig::Skeleton& skeleton = motion->skeleton();
  SensorRig rig;
  for (const auto& m : config.sensors) {
    const int j = skeleton.find_joint(m.segment);
    if (j < 0) return fail(Errc::not_found, "sensor '" + m.name + "': the skeleton has no segment '" + m.segment + "'");
    rig.segment_joint_.push_back(j);
  }
  rig.motion_ = std::move(motion);
  rig.config_ = std::move(config);
  rig.reference_from_world_ = rig.config_.world_from_reference.inverse();
  rig.pose_ = skeleton.zero_pose();
  rig.world_from_joint_.resize(skeleton.joint_count());
  const size_t n = rig.config_.sensors.size();
  rig.world_from_sensor_.resize(n);
  rig.reference_from_sensor_.resize(n);
  rig.state_.resize(n);
  rig.reset();
  return rig;
}

void SensorRig::reset() {
  tick_ = 0;
  for (size_t i = 0; i < state_.size(); ++i) {
    SensorState& s = state_[i];
    s.random.reseed(config_.seed, i);
    s.position_bias_m = glm::dvec3(0.0);
    s.rotation_bias_rad = glm::dvec3(0.0);
    s.dropout_left = 0;
    s.last_good = devices::SensorSample{};
    s.have_good = false;
  }
}

double SensorRig::step(std::span<devices::SensorSample> out, double host_time_offset_s) {
  const double t = static_cast<double>(tick_) / config_.rate_hz;
  const double dt = 1.0 / config_.rate_hz;
  ++tick_;
  motion_->sample(t, pose_);
  rig::forward_kinematics(motion_->skeleton(), pose_, world_from_joint_);

  const double bias_pos_step_m = config_.bias_walk_mm_per_sqrt_s * 1e-3 * std::sqrt(dt);
  const double bias_rot_step_rad = config_.bias_walk_deg_per_sqrt_s * kDegToRad * std::sqrt(dt);
  const double noise_pos_m = config_.position_noise_mm * 1e-3;
  const double noise_rot_rad = config_.orientation_noise_deg * kDegToRad;
  const double host_time = t + config_.latency_s + host_time_offset_s;

  for (size_t i = 0; i < state_.size(); ++i) {
    SensorState& s = state_[i];
    const rig::RigidTransform world_from_sensor =
        world_from_joint_[segment_joint_[i]] * config_.sensors[i].segment_from_sensor;
    world_from_sensor_[i] = world_from_sensor;
    const rig::RigidTransform truth = reference_from_world_ * world_from_sensor;
    reference_from_sensor_[i] = truth;

    // Fixed draw order and count: dropout, bias (position, rotation), noise (position, rotation).
    SensorRandom& r = s.random;
    const double u = r.uniform();
    glm::dvec3 g[4];
    for (auto& v : g) {
      v.x = r.gaussian();
      v.y = r.gaussian();
      v.z = r.gaussian();
    }
    s.position_bias_m += bias_pos_step_m * g[0];
    s.rotation_bias_rad += bias_rot_step_rad * g[1];

    if (s.dropout_left == 0 && config_.dropout_probability > 0.0 && u < config_.dropout_probability)
      s.dropout_left = config_.dropout_burst;

    devices::SensorSample& o = out[i];
    if (s.dropout_left > 0) {
      --s.dropout_left;
      o = s.last_good;
      o.flags = devices::kSampleStale;
    } else {
      const glm::dvec3 p = glm::dvec3(truth.translation) + s.position_bias_m + noise_pos_m * g[2];
      glm::quat q = truth.rotation;
      if (s.rotation_bias_rad != glm::dvec3(0.0) || noise_rot_rad > 0.0)
        q = glm::normalize(q * quat_from_rotation_vector(s.rotation_bias_rad) *
                           quat_from_rotation_vector(noise_rot_rad * g[3]));
      o = devices::SensorSample{};
      o.position_m = glm::vec3(p);
      o.orientation = q;
      o.flags = devices::kSampleValid;
      s.last_good = o;
      s.have_good = true;
    }
    o.sensor = static_cast<uint16_t>(i);
    o.device_time_s = t;
    o.host_time_s = host_time;
    o.buttons = 0;
  }
  return t;
}

}  // namespace mimic::sim
