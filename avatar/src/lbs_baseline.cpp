#include "mimic/avatar/lbs_baseline.h"

namespace mimic::avatar {

LinearBlendBaseline::LinearBlendBaseline(const Skeleton& s, std::span<const glm::vec3> rest) {
  std::vector<RigidTransform> rest_w(s.joint_count());
  forward_kinematics(s, s.zero_pose(), rest_w);
  binds_.reserve(rest.size());
  for (const glm::vec3& v : rest) {
    int best[2] = {0, 0};
    float d[2] = {1e9f, 1e9f};
    for (int j = 0; j < s.joint_count(); ++j) {
      const glm::vec3 mid = rest_w[j].apply(0.5f * s.tip_m(j));  // the middle of the joint's link
      const float dd = glm::distance(v, mid);
      if (dd < d[0]) {
        d[1] = d[0], best[1] = best[0];
        d[0] = dd, best[0] = j;
      } else if (dd < d[1]) {
        d[1] = dd, best[1] = j;
      }
    }
    const float w0 = d[0] + d[1] > 0 ? d[1] / (d[0] + d[1]) : 1.0f;
    binds_.push_back({best[0], best[1], w0, rest_w[best[0]].inverse().apply(v), rest_w[best[1]].inverse().apply(v)});
  }
}

void LinearBlendBaseline::deform(std::span<const RigidTransform> w, std::span<glm::vec3> out) const {
  for (size_t k = 0; k < binds_.size() && k < out.size(); ++k) {
    const Bind& b = binds_[k];
    out[k] = b.w0 * w[b.j0].apply(b.l0) + (1.0f - b.w0) * w[b.j1].apply(b.l1);
  }
}

}  // namespace mimic::avatar
