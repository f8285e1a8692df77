#include "mimic/solver/gait_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace mimic::solver {

namespace {

glm::vec2 horizontal(const glm::vec3& p) { return {p.x, p.z}; }

// Planted flags of one foot's ankle track: slow horizontally and near its lowest.
std::vector<uint8_t> planted_frames(const std::vector<glm::vec3>& ankle, double rate_hz, const GaitOptions& o) {
  const size_t n = ankle.size();
  std::vector<uint8_t> planted(n, 0);
  if (n < 2) return planted;
  float low = std::numeric_limits<float>::max();
  for (const auto& p : ankle) low = std::min(low, p.y);
  for (size_t i = 0; i < n; ++i) {
    // Central difference (one-sided at the ends) so a single noisy sample does not split a stance.
    const size_t a = i > 0 ? i - 1 : i, b = i + 1 < n ? i + 1 : i;
    const double speed = glm::length(ankle[b] - ankle[a]) * rate_hz / static_cast<double>(b - a);
    planted[i] = speed < o.planted_speed_mps && ankle[i].y < low + o.planted_height_m;
  }
  return planted;
}

struct Stance {
  size_t begin, end;  // [begin, end)
};

std::vector<Stance> stances(const std::vector<uint8_t>& planted, int min_frames) {
  std::vector<Stance> out;
  size_t i = 0;
  while (i < planted.size()) {
    if (!planted[i]) {
      ++i;
      continue;
    }
    size_t j = i;
    while (j < planted.size() && planted[j]) ++j;
    if (static_cast<int>(j - i) >= min_frames) out.push_back({i, j});
    i = j;
  }
  return out;
}

// Stances reached after a swing of at least min_step_m: the steps.
int count_steps(const std::vector<glm::vec3>& ankle, const std::vector<Stance>& st, float min_step_m) {
  int steps = 0;
  for (size_t k = 1; k < st.size(); ++k)
    if (glm::length(horizontal(ankle[st[k].begin]) - horizontal(ankle[st[k - 1].end - 1])) >= min_step_m) ++steps;
  return steps;
}

}  // namespace

GaitAccumulator::GaitAccumulator(const rig::Skeleton& truth, const rig::Skeleton& solved, double rate_hz,
                                 GaitOptions options)
    : rate_hz_(rate_hz), options_(options) {
  for (const char* name : {"l_hip", "r_hip", "l_knee", "r_knee", "l_ankle", "r_ankle"}) {
    const int t = truth.find_joint(name), s = solved.find_joint(name);
    if (t >= 0 && s >= 0) lower_pairs_.push_back({t, s});
  }
  for (const char* side : {"l_", "r_"}) {
    Foot f;
    f.truth_ankle = truth.find_joint(std::string(side) + "ankle");
    f.solved_ankle = solved.find_joint(std::string(side) + "ankle");
    f.truth_toes = truth.find_joint(std::string(side) + "toes");
    f.solved_toes = solved.find_joint(std::string(side) + "toes");
    if (f.truth_ankle < 0 || f.solved_ankle < 0) continue;
    if (f.truth_toes >= 0) f.truth_tip = truth.tip_m(f.truth_toes);
    if (f.solved_toes >= 0) f.solved_tip = solved.tip_m(f.solved_toes);
    feet_.push_back(f);
  }
  truth_ankle_.resize(feet_.size());
  solved_ankle_.resize(feet_.size());
}

void GaitAccumulator::add(std::span<const rig::RigidTransform> truth_world,
                          std::span<const rig::RigidTransform> solved_world) {
  if (!lower_pairs_.empty()) {
    double sum = 0;
    for (const auto& [t, s] : lower_pairs_)
      sum += glm::length(glm::dvec3(solved_world[s].translation) - glm::dvec3(truth_world[t].translation));
    lower_sum_ += sum / static_cast<double>(lower_pairs_.size());
    ++lower_n_;
  }
  float truth_low = std::numeric_limits<float>::max(), solved_low = std::numeric_limits<float>::max();
  for (size_t k = 0; k < feet_.size(); ++k) {
    const Foot& f = feet_[k];
    truth_ankle_[k].push_back(truth_world[f.truth_ankle].translation);
    solved_ankle_[k].push_back(solved_world[f.solved_ankle].translation);
    truth_low = std::min(truth_low, truth_world[f.truth_ankle].translation.y);
    solved_low = std::min(solved_low, solved_world[f.solved_ankle].translation.y);
    if (f.truth_toes >= 0) {
      truth_low = std::min(truth_low, truth_world[f.truth_toes].translation.y);
      truth_low = std::min(truth_low, truth_world[f.truth_toes].apply(f.truth_tip).y);
    }
    if (f.solved_toes >= 0) {
      solved_low = std::min(solved_low, solved_world[f.solved_toes].translation.y);
      solved_low = std::min(solved_low, solved_world[f.solved_toes].apply(f.solved_tip).y);
    }
  }
  truth_low_y_.push_back(truth_low);
  solved_low_y_.push_back(solved_low);
}

GaitReport GaitAccumulator::report() const {
  GaitReport r;
  if (lower_n_ > 0) r.lower_body_mpjpe_cm = 100.0 * lower_sum_ / static_cast<double>(lower_n_);
  if (!truth_low_y_.empty()) {
    const float floor_y = *std::min_element(truth_low_y_.begin(), truth_low_y_.end());
    float deepest = 0;
    for (float y : solved_low_y_) deepest = std::max(deepest, floor_y - y);
    r.floor_penetration_mm = 1000.0 * deepest;
  }
  auto largest_move_mm = [](const std::vector<glm::vec3>& path) {
    float most = 0;
    for (size_t i = 1; i < path.size(); ++i) most = std::max(most, glm::length(path[i] - path[i - 1]));
    return 1000.0 * most;
  };
  for (size_t k = 0; k < feet_.size(); ++k) {
    r.largest_ankle_move_mm = std::max(r.largest_ankle_move_mm, largest_move_mm(solved_ankle_[k]));
    r.largest_ankle_move_truth_mm = std::max(r.largest_ankle_move_truth_mm, largest_move_mm(truth_ankle_[k]));
  }
  double skate_sum = 0;
  for (size_t k = 0; k < feet_.size(); ++k) {
    const auto& truth = truth_ankle_[k];
    const auto& solved = solved_ankle_[k];
    const auto truth_st = stances(planted_frames(truth, rate_hz_, options_), options_.min_stance_frames);
    const auto solved_st = stances(planted_frames(solved, rate_hz_, options_), options_.min_stance_frames);
    r.steps_truth += count_steps(truth, truth_st, options_.min_step_m);
    r.steps_solved += count_steps(solved, solved_st, options_.min_step_m);
    for (const auto& st : truth_st) {
      float slide = 0;
      for (size_t i = st.begin; i < st.end; ++i) {
        const glm::vec2 d = (horizontal(solved[i]) - horizontal(solved[st.begin])) -
                            (horizontal(truth[i]) - horizontal(truth[st.begin]));
        slide = std::max(slide, glm::length(d));
      }
      skate_sum += slide;
      ++r.stances_truth;
    }
  }
  if (r.stances_truth > 0) r.foot_skate_mm = 1000.0 * skate_sum / r.stances_truth;
  return r;
}

}  // namespace mimic::solver
