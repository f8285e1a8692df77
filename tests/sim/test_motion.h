// A small procedural motion for the sim tests: every DOF swings on its own sine within a third
// of its range, and the root walks forward while turning, so every segment moves and rotates.
// Kept here (not the product's built-in motions) so golden data does not change when those are
// retuned.
#pragma once

#include <cmath>
#include <memory>
#include <string>

#include "mimic/rig/motion.h"
#include "mimic/rig/skeleton.h"

namespace mimic::test {

class SwingMotion final : public rig::Motion {
 public:
  explicit SwingMotion(rig::Skeleton skeleton) : skeleton_(std::move(skeleton)) {}
  const rig::Skeleton& skeleton() const override { return skeleton_; }
  double duration_s() const override { return 4.0; }
  bool loops() const override { return true; }
  void sample(double t_s, rig::Pose& out) const override {
    out.dof_rad.resize(static_cast<size_t>(skeleton_.dof_count()));  // no-op after the first call
    for (int i = 0; i < skeleton_.dof_count(); ++i) {
      const auto& d = skeleton_.dof(i);
      const double mid = 0.5 * (d.min_rad + d.max_rad);
      const double amp = (d.max_rad - d.min_rad) / 6.0;
      out.dof_rad[i] = static_cast<float>(mid + amp * std::sin(2.0 * 3.14159265358979 * t_s / 4.0 * (1 + i % 3) + i));
    }
    const double a = 0.3 * std::sin(t_s);
    out.root_position_m = {static_cast<float>(0.1 * std::sin(t_s)), 0.9f, static_cast<float>(0.5 * t_s)};
    out.root_orientation = glm::angleAxis(static_cast<float>(a), glm::vec3(0, 1, 0));
  }
  std::string name() const override { return "swing"; }

 private:
  rig::Skeleton skeleton_;
};

inline std::shared_ptr<const rig::Motion> swing_motion() {
  return std::make_shared<SwingMotion>(rig::Skeleton::build(rig::default_skeleton_desc()).value());
}

}  // namespace mimic::test
