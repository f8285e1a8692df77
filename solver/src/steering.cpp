#include "mimic/solver/steering.h"

#include <algorithm>
#include <cmath>

namespace mimic::solver {

float Steering::shape(float x) const {
  if (!std::isfinite(x)) return 0.0f;
  const float a = std::min(1.0f, std::abs(x));
  const float dz = std::clamp(config_.dead_zone, 0.0f, 0.99f);
  if (a <= dz) return 0.0f;
  const float t = (a - dz) / (1.0f - dz);
  return std::copysign(std::pow(t, std::max(0.1f, config_.exponent)), x);
}

SteeringEvents Steering::update(const devices::InputFrame& in, double dt_s) {
  SteeringEvents ev;
  const uint32_t pressed = in.buttons & ~buttons_;
  buttons_ = in.buttons;
  auto bit = [](int button) { return button >= 1 && button <= 32 ? (1u << (button - 1)) : 0u; };
  if (pressed & bit(config_.recalibrate_button)) ev.recalibrate = true;
  if (pressed & bit(config_.reset_button)) {
    reset();
    ev.reset = true;
    return ev;
  }
  const float dt = static_cast<float>(std::clamp(std::isfinite(dt_s) ? dt_s : 0.0, 0.0, 0.1));
  heading_rad_ += glm::radians(config_.max_turn_deg_s) * shape(in.rotation.y) * dt;
  heading_rad_ = std::remainder(heading_rad_, 6.2831853f);
  // Body frame: forward +Z, left +X. The cap: right +X, toward the user +Z.
  const glm::vec3 v_body(-shape(in.translation.x), config_.vertical ? shape(in.translation.y) : 0.0f,
                         -shape(in.translation.z));
  offset_m_ += glm::angleAxis(heading_rad_, glm::vec3(0, 1, 0)) * v_body * (config_.max_speed_m_s * dt);
  return ev;
}

void Steering::apply(rig::Pose& pose) {
  if (!pivot_set_) {
    pivot_m_ = glm::vec3(pose.root_position_m.x, 0.0f, pose.root_position_m.z);
    pivot_set_ = true;
  }
  const glm::quat turn = glm::angleAxis(heading_rad_, glm::vec3(0, 1, 0));
  pose.root_position_m = pivot_m_ + offset_m_ + turn * (pose.root_position_m - pivot_m_);
  pose.root_orientation = glm::normalize(turn * pose.root_orientation);
}

void Steering::reset() {
  heading_rad_ = 0;
  offset_m_ = glm::vec3(0.0f);
  pivot_set_ = false;
}

}  // namespace mimic::solver
