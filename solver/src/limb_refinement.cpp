#include "mimic/solver/limb_refinement.h"

#include <cmath>

#include "small_linalg.h"

namespace mimic::solver {

namespace {

using Mat3 = detail::SquareMatrix<3>;

}  // namespace

LimbLengthEstimator::LimbLengthEstimator(const SolverModel& model, LimbRefinementOptions options) : options_(options) {
  for (int c = 0; c < 4; ++c) {
    const auto& ch = model.chains_[c];
    int upper = -1, mid = -1, end = -1;
    for (size_t i = 0; i < model.mount_joint_.size(); ++i) {
      if (model.mount_joint_[i] == ch.upper) upper = static_cast<int>(i);
      if (model.mount_joint_[i] == ch.mid) mid = static_cast<int>(i);
      if (model.mount_joint_[i] == ch.end) end = static_cast<int>(i);
    }
    // With a sensor on the middle segment too, the joint centres (joint_centres.h) see more.
    if (upper >= 0 && end >= 0 && mid < 0) chains_[c].upper_slot = upper, chains_[c].end_slot = end;
  }
}

int LimbLengthEstimator::observable_count() const {
  int n = 0;
  for (int c = 0; c < 4; ++c) n += observable(c) ? 1 : 0;
  return n;
}

void LimbLengthEstimator::reset() {
  for (auto& c : chains_) c.m = Moments{};
}

void LimbLengthEstimator::add(std::span<const devices::SensorSample> samples, const SolverModel& model) {
  constexpr uint32_t kUsable = devices::kSampleValid;
  constexpr uint32_t kSkip = devices::kSampleStale | devices::kSampleOutlier;
  auto find = [&](int slot) -> const devices::SensorSample* {
    const uint16_t id = model.mounts_[static_cast<size_t>(slot)].sensor;
    for (const auto& s : samples)
      if (s.sensor == id && (s.flags & kUsable) && !(s.flags & kSkip)) return &s;
    return nullptr;
  };
  for (auto& ch : chains_) {
    if (ch.upper_slot < 0) continue;
    const devices::SensorSample* u = find(ch.upper_slot);
    const devices::SensorSample* e = find(ch.end_slot);
    if (!u || !e) continue;
    // In the upper sensor's frame, which no refinement of the model moves.
    const rig::RigidTransform world_from_upper_sensor{u->orientation, u->position_m};
    const glm::vec3 end_world =
        rig::RigidTransform{e->orientation, e->position_m}.apply(model.sensor_from_segment_[ch.end_slot].translation);
    const glm::vec3 xf = world_from_upper_sensor.inverse().apply(end_world);
    if (!std::isfinite(xf.x) || !std::isfinite(xf.y) || !std::isfinite(xf.z)) continue;
    const double x = xf.x, y = xf.y, z = xf.z, r2 = x * x + y * y + z * z;
    Moments& m = ch.m;
    ++m.n;
    m.s1[0] += x, m.s1[1] += y, m.s1[2] += z;
    m.s2[0] += x * x, m.s2[1] += x * y, m.s2[2] += x * z, m.s2[3] += y * y, m.s2[4] += y * z, m.s2[5] += z * z;
    m.s3[0] += x * r2, m.s3[1] += y * r2, m.s3[2] += z * r2;
    m.s4 += r2;
  }
}

LimbFit LimbLengthEstimator::fit(int chain, const SolverModel& model) const {
  LimbFit out;
  if (!observable(chain)) return out;
  const Moments& m = chains_[chain].m;
  out.samples = m.n;
  if (m.n < std::max(options_.min_samples, 4)) return out;
  const double n = m.n;
  const std::array<double, 3> mu = {m.s1[0] / n, m.s1[1] / n, m.s1[2] / n};
  const Mat3 s2 = {{{m.s2[0], m.s2[1], m.s2[2]}, {m.s2[1], m.s2[3], m.s2[4]}, {m.s2[2], m.s2[4], m.s2[5]}}};
  Mat3 cov;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) cov[i][j] = s2[i][j] / n - mu[i] * mu[j];
  detail::Vector<3> w;
  Mat3 v;
  detail::symmetric_eigen<3>(cov, w, v);
  out.arc_spread_m = static_cast<float>(std::sqrt(std::max(0.0, w[1])));
  out.off_plane_m = static_cast<float>(std::sqrt(std::max(0.0, w[2])));
  // Kåsa circle fit in the plane: centre k = μ + a·e1 + b·e2, rows (2 e1·x, 2 e2·x, 1) against
  // |x|² − 2 x·μ, all sums taken from the moments.
  auto dot3 = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  };
  auto mul = [&](const std::array<double, 3>& a) {
    return std::array<double, 3>{dot3(s2[0], a), dot3(s2[1], a), dot3(s2[2], a)};
  };
  const std::array<double, 3> e1 = {v[0][0], v[1][0], v[2][0]}, e2 = {v[0][1], v[1][1], v[2][1]};
  const std::array<double, 3> s2e1 = mul(e1), s2e2 = mul(e2), s2mu = mul(mu);
  Mat3 a = {{{4 * dot3(e1, s2e1), 4 * dot3(e1, s2e2), 2 * dot3(e1, m.s1)},
             {4 * dot3(e2, s2e1), 4 * dot3(e2, s2e2), 2 * dot3(e2, m.s1)},
             {2 * dot3(e1, m.s1), 2 * dot3(e2, m.s1), n}}};
  const std::array<double, 3> b = {2 * dot3(e1, m.s3) - 4 * dot3(e1, s2mu), 2 * dot3(e2, m.s3) - 4 * dot3(e2, s2mu),
                                   m.s4 - 2 * dot3(m.s1, mu)};
  detail::Vector<3> sol{};
  if (!detail::solve_linear<3>(a, b, sol)) return out;
  std::array<double, 3> k;
  for (int i = 0; i < 3; ++i) k[i] = mu[i] + sol[0] * e1[i] + sol[1] * e2[i];
  const double r2 = sol[2] + dot3(k, k);
  if (!(r2 > 0)) return out;
  // The upper joint is the upper segment's origin.
  const glm::vec3 o = model.sensor_from_segment_[chains_[chain].upper_slot].translation;
  const std::array<double, 3> ko = {k[0] - o.x, k[1] - o.y, k[2] - o.z};
  out.upper_m = static_cast<float>(std::sqrt(dot3(ko, ko)));
  out.lower_m = static_cast<float>(std::sqrt(r2));
  out.valid = out.arc_spread_m >= options_.min_arc_spread_m && out.off_plane_m <= options_.max_off_plane_m &&
              out.arc_spread_m >= options_.min_plane_ratio * out.off_plane_m && out.upper_m >= options_.min_link_m &&
              out.upper_m <= options_.max_link_m && out.lower_m >= options_.min_link_m &&
              out.lower_m <= options_.max_link_m;
  return out;
}

int LimbLengthEstimator::refine(SolverModel& model) const {
  int changed = 0;
  for (int c = 0; c < 4; ++c) {
    const LimbFit f = fit(c, model);
    if (f.valid && model.set_chain_lengths(c, f.upper_m, f.lower_m)) ++changed;
  }
  return changed;
}

}  // namespace mimic::solver
