#include "mimic/solver/joint_centres.h"

#include <algorithm>
#include <cmath>

#include "small_linalg.h"

namespace mimic::solver {

namespace {

using rig::RigidTransform;

int find_sensor(const Calibration& cal, const std::string& segment) {
  for (size_t i = 0; i < cal.sensors.size(); ++i)
    if (cal.sensors[i].segment == segment) return static_cast<int>(i);
  return -1;
}

// Shortest rotation taking unit vector `from` onto unit vector `to`.
glm::quat rotation_between(glm::vec3 from, glm::vec3 to) {
  const float c = glm::dot(from, to);
  if (c > 1.0f - 1e-7f) return glm::quat(1, 0, 0, 0);
  if (c < -1.0f + 1e-6f) {
    glm::vec3 axis = glm::cross(from, glm::vec3(1, 0, 0));
    if (glm::length(axis) < 1e-3f) axis = glm::cross(from, glm::vec3(0, 1, 0));
    return glm::angleAxis(3.14159265f, glm::normalize(axis));
  }
  const glm::vec3 axis = glm::cross(from, to);
  return glm::normalize(glm::quat(1.0f + c, axis.x, axis.y, axis.z));
}

}  // namespace

JointCentreEstimator::JointCentreEstimator(const Calibration& cal, JointCentreOptions options) : options_(options) {
  auto skeleton = rig::Skeleton::build(cal.skeleton);
  if (!skeleton) return;
  const rig::Skeleton& s = *skeleton;
  int max_id = -1;
  for (const auto& sc : cal.sensors) max_id = std::max(max_id, int{sc.sensor});
  slot_of_sensor_.assign(static_cast<size_t>(max_id + 1), -1);
  for (size_t i = 0; i < cal.sensors.size(); ++i) slot_of_sensor_[cal.sensors[i].sensor] = static_cast<int>(i);
  latest_.assign(cal.sensors.size(), nullptr);
  for (int j = 1; j < s.joint_count(); ++j) {
    const int child = find_sensor(cal, s.joint_name(j));
    const int parent = find_sensor(cal, s.joint_name(s.parent(j)));
    if (child < 0 || parent < 0) continue;
    Pair p;
    p.joint = j;
    p.parent_sensor = cal.sensors[parent].sensor;
    p.child_sensor = cal.sensors[child].sensor;
    // The calibrated centre: the child segment's origin, the parent's offset point.
    p.prior_parent = glm::dvec3(cal.sensors[parent].segment_from_sensor.inverse().apply(s.offset_m(j)));
    p.prior_child = glm::dvec3(cal.sensors[child].segment_from_sensor.inverse().translation);
    pairs_.push_back(p);
  }
}

void JointCentreEstimator::add(std::span<const devices::SensorSample> samples) {
  if (pairs_.empty()) return;
  std::fill(latest_.begin(), latest_.end(), nullptr);
  constexpr uint32_t kSkip = devices::kSampleStale | devices::kSampleOutlier;
  for (const auto& smp : samples) {
    if (!(smp.flags & devices::kSampleValid) || (smp.flags & kSkip)) continue;
    if (smp.sensor >= slot_of_sensor_.size() || slot_of_sensor_[smp.sensor] < 0) continue;
    if (!std::isfinite(smp.position_m.x + smp.position_m.y + smp.position_m.z + smp.orientation.w + smp.orientation.x +
                       smp.orientation.y + smp.orientation.z))
      continue;
    latest_[static_cast<size_t>(slot_of_sensor_[smp.sensor])] = &smp;
  }
  for (Pair& p : pairs_) {
    const devices::SensorSample* a = latest_[static_cast<size_t>(slot_of_sensor_[p.parent_sensor])];
    const devices::SensorSample* b = latest_[static_cast<size_t>(slot_of_sensor_[p.child_sensor])];
    if (!a || !b) continue;
    const glm::dmat3 rp = glm::mat3_cast(glm::normalize(a->orientation));
    const glm::dmat3 rc = glm::mat3_cast(glm::normalize(b->orientation));
    const glm::dvec3 d = glm::dvec3(b->position_m) - glm::dvec3(a->position_m);
    ++p.n;
    p.sum_pt_c += glm::transpose(rp) * rc;
    p.sum_pt_b += glm::transpose(rp) * d;
    p.sum_ct_b += glm::transpose(rc) * d;
    p.sum_bb += glm::dot(d, d);
  }
}

std::vector<JointCentreFit> JointCentreEstimator::fits() const {
  std::vector<JointCentreFit> out;
  for (const Pair& p : pairs_) {
    if (p.n < options_.min_samples) continue;
    // Rows [R_p, −R_c]·(c_p, c_c) = p_c − p_p; normal matrix [[n I, −M], [−Mᵀ, n I]], M = Σ R_pᵀR_c.
    detail::SquareMatrix<6> a{};
    detail::Vector<6> g{}, x{};
    const double n = p.n, lambda = options_.prior_weight;
    for (int i = 0; i < 3; ++i) {
      a[i][i] = a[i + 3][i + 3] = n + lambda;
      for (int k = 0; k < 3; ++k) {
        a[i][k + 3] = -p.sum_pt_c[k][i];  // glm is column-major: m[col][row]
        a[k + 3][i] = -p.sum_pt_c[k][i];
      }
      g[i] = p.sum_pt_b[i] + lambda * p.prior_parent[i];
      g[i + 3] = -p.sum_ct_b[i] + lambda * p.prior_child[i];
    }
    if (!detail::solve_linear<6>(a, g, x)) continue;
    JointCentreFit f;
    f.joint = p.joint;
    f.samples = p.n;
    f.in_parent_sensor = glm::vec3(x[0], x[1], x[2]);
    f.in_child_sensor = glm::vec3(x[3], x[4], x[5]);
    // Σ|r|² = xᵀ N x − 2 xᵀ g0 + Σ|b|² with N, g0 the unregularised normal equations.
    double xnx = 0, xg = 0;
    for (int i = 0; i < 6; ++i) {
      double row = 0;
      for (int k = 0; k < 6; ++k) row += (i == k ? a[i][k] - lambda : a[i][k]) * x[k];
      xnx += x[i] * row;
    }
    for (int i = 0; i < 3; ++i) xg += x[i] * p.sum_pt_b[i] - x[i + 3] * p.sum_ct_b[i];
    f.rms_m = static_cast<float>(std::sqrt(std::max(0.0, (xnx - 2 * xg + p.sum_bb) / n)));
    detail::SquareMatrix<6> unit = a;
    for (int i = 0; i < 6; ++i)
      for (int k = 0; k < 6; ++k) unit[i][k] = (i == k ? a[i][k] - lambda : a[i][k]) / n;
    detail::Vector<6> w;
    detail::SquareMatrix<6> v;
    detail::symmetric_eigen<6>(unit, w, v);
    f.min_excitation = static_cast<float>(std::max(0.0, w[5]));
    out.push_back(f);
  }
  return out;
}

Result<Calibration> JointCentreEstimator::refine(const Calibration& cal, int* changed) const {
  auto built = rig::Skeleton::build(cal.skeleton);
  if (!built) return tl::unexpected(built.error());
  const rig::Skeleton& s = *built;
  const int n = s.joint_count();
  std::vector<int> desc_of(n, -1);  // skeleton joint → SkeletonDesc entry
  for (size_t i = 0; i < cal.skeleton.joints.size(); ++i)
    desc_of[s.find_joint(cal.skeleton.joints[i].name)] = static_cast<int>(i);
  std::vector<uint8_t> has(n, 0);
  std::vector<glm::vec3> in_parent(n), in_child(n);
  const auto found = fits();
  for (const auto& f : found)
    has[f.joint] = 1, in_parent[f.joint] = f.in_parent_sensor, in_child[f.joint] = f.in_child_sensor;
  if (changed) *changed = static_cast<int>(found.size());
  Calibration out = cal;
  if (found.empty()) return out;

  std::vector<std::vector<int>> children(n);
  for (int j = 1; j < n; ++j) children[s.parent(j)].push_back(j);
  for (int seg = 0; seg < n; ++seg) {
    const int sensor = find_sensor(cal, s.joint_name(seg));
    if (sensor < 0) continue;
    bool touched = has[seg];
    for (int k : children[seg]) touched = touched || has[k];
    if (!touched) continue;
    const RigidTransform segment_from_sensor = cal.sensors[sensor].segment_from_sensor;
    const RigidTransform sensor_from_segment = segment_from_sensor.inverse();
    // Where the segment's joints are, in its sensor's frame.
    glm::vec3 origin = has[seg] ? in_child[seg] : sensor_from_segment.translation;
    if (seg == 0)  // the root sits on a child drawn at its origin (the lower back), if measured
      for (int k : children[seg])
        if (has[k] && glm::length(s.offset_m(k)) < 1e-4f) origin = in_parent[k];
    std::vector<glm::vec3> ends;
    for (int k : children[seg]) ends.push_back(has[k] ? in_parent[k] : sensor_from_segment.apply(s.offset_m(k)));
    glm::quat rot = segment_from_sensor.rotation;
    if (children[seg].size() == 1) {
      // Turn the frame so that the link lies along the skeleton's axis for it.
      const glm::vec3 axis = s.offset_m(children[seg][0]);
      const glm::vec3 link = rot * (ends[0] - origin);
      if (glm::length(axis) > 0.01f && glm::length(link) > 0.01f)
        rot = glm::conjugate(rotation_between(glm::normalize(axis), glm::normalize(link))) * rot;
    }
    out.sensors[sensor].segment_from_sensor = RigidTransform{rot, -(rot * origin)};
    for (size_t c = 0; c < children[seg].size(); ++c) {
      const int k = children[seg][c];
      auto& jd = out.skeleton.joints[desc_of[k]];
      jd.offset_m = rot * (ends[c] - origin);
    }
    if (children[seg].size() == 1)
      out.skeleton.joints[desc_of[seg]].tip_m = out.skeleton.joints[desc_of[children[seg][0]]].offset_m;
  }
  return out;
}

}  // namespace mimic::solver
