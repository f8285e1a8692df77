#include "mimic/solver/pose_error.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "mimic/core/percentile.h"

namespace mimic::solver {

bool is_end_effector(std::string_view joint) {
  return joint == "head" || joint == "l_wrist" || joint == "r_wrist" || joint == "l_ankle" || joint == "r_ankle";
}

PoseErrorAccumulator::PoseErrorAccumulator(const rig::Skeleton& truth, const rig::Skeleton& solved) {
  for (int j = 0; j < truth.joint_count(); ++j) {
    const std::string& name = truth.joint_name(j);
    if (name.find("toes") != std::string::npos) continue;
    const int k = solved.find_joint(name);
    if (k < 0) continue;
    const bool ee = is_end_effector(name);
    pairs_.push_back(Pair{j, k, ee});
    names_.push_back(name);
    end_effectors_ += ee ? 1 : 0;
  }
  joint_sum_.assign(pairs_.size(), 0.0);
  joint_jitter_sum_.assign(pairs_.size(), 0.0);
}

void PoseErrorAccumulator::add(std::span<const rig::RigidTransform> truth_world,
                               std::span<const rig::RigidTransform> solved_world, double solve_us) {
  const size_t n = pairs_.size();
  double pos = 0, rot = 0, ee = 0;
  std::vector<glm::vec3> solved_now(n), truth_now(n);
  for (size_t i = 0; i < n; ++i) {
    const auto& t = truth_world[pairs_[i].truth];
    const auto& s = solved_world[pairs_[i].solved];
    const double e = glm::length(glm::dvec3(s.translation) - glm::dvec3(t.translation));
    pos += e;
    joint_sum_[i] += e;
    if (pairs_[i].end_effector) {
      ee += e;
      ee_max_ = std::max(ee_max_, e);
    }
    const glm::dquat d = glm::dquat(s.rotation) * glm::conjugate(glm::dquat(t.rotation));
    rot += 2.0 * std::asin(std::min(1.0, glm::length(glm::dvec3(d.x, d.y, d.z))));
    solved_now[i] = s.translation;
    truth_now[i] = t.translation;
  }
  if (n > 0) {
    pos_sum_ += pos / static_cast<double>(n);
    rot_sum_ += rot / static_cast<double>(n);
  }
  if (end_effectors_ > 0) ee_sum_ += ee / end_effectors_;
  if (frames_ >= 2) {
    for (size_t i = 0; i < n; ++i) {
      const double j =
          glm::length(glm::dvec3(solved_now[i]) - 2.0 * glm::dvec3(prev_solved_[i]) + glm::dvec3(prev2_solved_[i]));
      jitter_sum_ += j;
      joint_jitter_sum_[i] += j;
      jitter_truth_sum_ +=
          glm::length(glm::dvec3(truth_now[i]) - 2.0 * glm::dvec3(prev_truth_[i]) + glm::dvec3(prev2_truth_[i]));
    }
    jitter_terms_ += static_cast<long>(n);
  }
  if (rate_hz_ > 0) {
    solved_track_.insert(solved_track_.end(), solved_now.begin(), solved_now.end());
    truth_track_.insert(truth_track_.end(), truth_now.begin(), truth_now.end());
  }
  prev2_solved_ = frames_ >= 1 ? prev_solved_ : solved_now;
  prev2_truth_ = frames_ >= 1 ? prev_truth_ : truth_now;
  prev_solved_ = std::move(solved_now);
  prev_truth_ = std::move(truth_now);
  if (solve_us >= 0) solve_us_.push_back(solve_us);
  ++frames_;
}

PoseErrorReport PoseErrorAccumulator::report() const {
  PoseErrorReport r;
  r.frames = frames_;
  r.joints = static_cast<int>(pairs_.size());
  r.joint_names = names_;
  if (frames_ > 0) {
    r.mpjpe_cm = 100.0 * pos_sum_ / frames_;
    r.mpjre_deg = rot_sum_ / frames_ * 180.0 / 3.14159265358979;
    r.end_effector_mm = 1000.0 * ee_sum_ / frames_;
    r.end_effector_max_mm = 1000.0 * ee_max_;
    for (double v : joint_sum_) r.joint_mpjpe_cm.push_back(100.0 * v / frames_);
    for (double v : joint_jitter_sum_) r.joint_jitter_mm.push_back(frames_ > 2 ? 1000.0 * v / (frames_ - 2) : 0.0);
  }
  if (jitter_terms_ > 0) {
    r.jitter_mm = 1000.0 * jitter_sum_ / static_cast<double>(jitter_terms_);
    r.jitter_truth_mm = 1000.0 * jitter_truth_sum_ / static_cast<double>(jitter_terms_);
  }
  const size_t n = pairs_.size();
  if (rate_hz_ > 0 && n > 0 && frames_ > 20) {
    // Error against the truth `shift` samples earlier, for each shift; the best, refined.
    constexpr int kMin = -2, kMax = 6;
    std::array<double, kMax - kMin + 1> err{};
    for (int sh = kMin; sh <= kMax; ++sh) {
      double sum = 0;
      long terms = 0;
      for (int f = std::max(0, sh); f < frames_ + std::min(0, sh); ++f)
        for (size_t i = 0; i < n; ++i, ++terms)
          sum += glm::length(glm::dvec3(solved_track_[f * n + i]) - glm::dvec3(truth_track_[(f - sh) * n + i]));
      err[sh - kMin] = sum / static_cast<double>(std::max(1L, terms));
    }
    const int best = static_cast<int>(std::min_element(err.begin(), err.end()) - err.begin());
    double shift = best + kMin;
    if (best > 0 && best + 1 < static_cast<int>(err.size())) {
      const double a = err[best - 1], b = err[best], c = err[best + 1];
      const double d = a - 2 * b + c;
      if (d > 0) shift += 0.5 * (a - c) / d;
    }
    r.lag_ms = 1000.0 * shift / rate_hz_;
  }
  if (!solve_us_.empty()) {
    std::vector<double> t = solve_us_;
    r.solve_us_p50 = percentile_in_place(t, 0.50);
    r.solve_us_p99 = percentile_in_place(t, 0.99);
    r.solve_us_max = percentile_in_place(t, 1.0);
  }
  return r;
}

}  // namespace mimic::solver
