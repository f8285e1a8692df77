// pose_to_match: limb directions of a skeleton set to those of a reference body's joints.
#include <algorithm>
#include <array>
#include <cmath>

#include <glm/gtc/quaternion.hpp>

#include "mimic/avatar/measure.h"

namespace mimic::avatar {

namespace {

// One limb chain: an upper joint (shoulder/hip) whose link runs to the lower joint
// (elbow/knee), whose link runs to the end joint (wrist/ankle).
struct Chain {
  int upper = -1, lower = -1, end = -1;
  glm::dvec3 dir_upper{0}, dir_lower{0};  // target world directions (unit)
};

glm::dquat local_rotation(const rig::Skeleton& s, int j, const std::vector<double>& dof) {
  glm::dquat r(1, 0, 0, 0);
  for (int i = s.dof_begin(j); i < s.dof_end(j); ++i)
    r = r * glm::angleAxis(dof[static_cast<size_t>(i)], glm::dvec3(s.dof(i).axis));
  return r;
}

// Residuals: world link directions minus targets, plus a light pull toward zero so the
// redundant twist stays near its neutral value.
constexpr double kRegularisation = 0.02;

void residuals(const rig::Skeleton& s, const Chain& c, const glm::dquat& world_from_parent,
               const std::vector<double>& dof, double* r) {
  const glm::dquat wu = world_from_parent * local_rotation(s, c.upper, dof);
  const glm::dquat wl = wu * local_rotation(s, c.lower, dof);
  const glm::dvec3 d1 = glm::normalize(wu * glm::dvec3(s.offset_m(c.lower)));
  const glm::dvec3 d2 = glm::normalize(wl * glm::dvec3(s.offset_m(c.end)));
  for (int k = 0; k < 3; ++k) {
    r[k] = d1[k] - c.dir_upper[k];
    r[3 + k] = d2[k] - c.dir_lower[k];
  }
  int n = 6;
  for (int j : {c.upper, c.lower})
    for (int i = s.dof_begin(j); i < s.dof_end(j); ++i) r[n++] = kRegularisation * dof[static_cast<size_t>(i)];
}

double solve_chain(const rig::Skeleton& s, const Chain& c, const glm::dquat& world_from_parent,
                   std::vector<double>& dof) {
  std::vector<int> vars;
  for (int j : {c.upper, c.lower})
    for (int i = s.dof_begin(j); i < s.dof_end(j); ++i) vars.push_back(i);
  const size_t nv = vars.size(), nr = 6 + nv;
  std::vector<double> r(nr), r2(nr), jac(nr * nv);
  auto cost = [&](const std::vector<double>& x, std::vector<double>& out) {
    residuals(s, c, world_from_parent, x, out.data());
    double e = 0;
    for (double v : out) e += v * v;
    return e;
  };
  auto clamp = [&](std::vector<double>& x) {
    for (int i : vars)
      x[static_cast<size_t>(i)] =
          std::clamp(x[static_cast<size_t>(i)], double(s.dof(i).min_rad), double(s.dof(i).max_rad));
  };
  double e = cost(dof, r), lambda = 1e-3;
  for (int iter = 0; iter < 200 && e > 1e-14; ++iter) {
    const double h = 1e-6;
    for (size_t v = 0; v < nv; ++v) {
      std::vector<double> x = dof;
      x[static_cast<size_t>(vars[v])] += h;
      residuals(s, c, world_from_parent, x, r2.data());
      for (size_t k = 0; k < nr; ++k) jac[k * nv + v] = (r2[k] - r[k]) / h;
    }
    // (JᵀJ + λ diag) δ = −Jᵀr, solved by Gaussian elimination (at most 5 unknowns).
    std::vector<double> a(nv * nv, 0), b(nv, 0);
    for (size_t k = 0; k < nr; ++k)
      for (size_t p = 0; p < nv; ++p) {
        b[p] -= jac[k * nv + p] * r[k];
        for (size_t q = 0; q < nv; ++q) a[p * nv + q] += jac[k * nv + p] * jac[k * nv + q];
      }
    for (size_t p = 0; p < nv; ++p) a[p * nv + p] *= 1 + lambda, a[p * nv + p] += 1e-12;
    for (size_t p = 0; p < nv; ++p) {
      size_t piv = p;
      for (size_t q = p + 1; q < nv; ++q)
        if (std::abs(a[q * nv + p]) > std::abs(a[piv * nv + p])) piv = q;
      for (size_t q = 0; q < nv; ++q) std::swap(a[p * nv + q], a[piv * nv + q]);
      std::swap(b[p], b[piv]);
      for (size_t q = p + 1; q < nv; ++q) {
        const double f = a[q * nv + p] / a[p * nv + p];
        for (size_t k = p; k < nv; ++k) a[q * nv + k] -= f * a[p * nv + k];
        b[q] -= f * b[p];
      }
    }
    std::vector<double> delta(nv);
    for (size_t p = nv; p-- > 0;) {
      double sum = b[p];
      for (size_t q = p + 1; q < nv; ++q) sum -= a[p * nv + q] * delta[q];
      delta[p] = sum / a[p * nv + p];
    }
    std::vector<double> x = dof;
    for (size_t v = 0; v < nv; ++v) x[static_cast<size_t>(vars[v])] += delta[v];
    clamp(x);
    const double e2 = cost(x, r2);
    if (e2 < e) {
      dof = x;
      e = e2;
      r = r2;
      lambda = std::max(lambda * 0.3, 1e-9);
    } else {
      lambda *= 10;
      if (lambda > 1e8) break;
    }
  }
  return e;
}

}  // namespace

rig::Pose pose_to_match(const rig::Skeleton& s, const BodyLandmarks& lm) {
  rig::Pose pose = s.zero_pose();
  pose.root_position_m = lm.pelvis_m;
  std::vector<rig::RigidTransform> world(s.joint_count());
  rig::forward_kinematics(s, pose, world);
  std::vector<double> dof(pose.dof_rad.begin(), pose.dof_rad.end());

  auto unit = [](glm::vec3 v) { return glm::normalize(glm::dvec3(v)); };
  for (auto [side, limb] : {std::pair{"l_", &lm.left}, std::pair{"r_", &lm.right}}) {
    const std::string p(side);
    const Chain chains[2] = {{s.find_joint(p + "shoulder"), s.find_joint(p + "elbow"), s.find_joint(p + "wrist"),
                              unit(limb->elbow_m - limb->shoulder_m), unit(limb->wrist_m - limb->elbow_m)},
                             {s.find_joint(p + "hip"), s.find_joint(p + "knee"), s.find_joint(p + "ankle"),
                              unit(limb->knee_m - limb->hip_m), unit(limb->ankle_m - limb->knee_m)}};
    for (const Chain& c : chains) {
      if (c.upper < 0 || c.lower < 0 || c.end < 0 || s.parent(c.lower) != c.upper || s.parent(c.end) != c.lower)
        continue;
      if (!std::isfinite(c.dir_upper.x) || !std::isfinite(c.dir_lower.x)) continue;
      const glm::dquat world_from_parent = glm::dquat(world[s.parent(c.upper)].rotation);
      // A few starts, since the shoulder's twist and the elbow's bend trade off.
      std::vector<double> best = dof;
      double best_e = 1e300;
      for (double twist : {0.0, 1.2, -1.2, 2.4, -2.4}) {
        for (double lift : {0.0, 0.8, -0.8}) {
          std::vector<double> x = dof;
          const int first = s.dof_begin(c.upper), count = s.dof_end(c.upper) - first;
          if (count >= 2) x[static_cast<size_t>(first + 1)] = lift;
          if (count >= 3) x[static_cast<size_t>(first + 2)] = twist;
          for (int j : {c.upper, c.lower})
            for (int i = s.dof_begin(j); i < s.dof_end(j); ++i)
              x[static_cast<size_t>(i)] =
                  std::clamp(x[static_cast<size_t>(i)], double(s.dof(i).min_rad), double(s.dof(i).max_rad));
          const double e = solve_chain(s, c, world_from_parent, x);
          if (e < best_e - 1e-12) {
            best_e = e;
            best = x;
          }
        }
      }
      dof = best;
    }
  }
  for (size_t i = 0; i < dof.size(); ++i) pose.dof_rad[i] = static_cast<float>(dof[i]);
  return pose;
}

}  // namespace mimic::avatar
